"""The loop's equilibrium: F(X) = X checked through ClosedLoop.sample, the Jacobian against
finite differences, the simulation fallback, and the error when neither finds one."""

from __future__ import annotations

import json

import numpy as np
import pytest

import fl_design as fl
from fl_design.errors import ComputationError
from fl_design.sim import ClosedLoop
from fl_design.sim import _loop_jacobian as L
from fl_design.sim.kernel._loop import default_substeps
from tests.oracles import fd_jacobian, sample_map

UNIT = np.finfo(float).eps


def _one_sample(plant, design, lin):
    """``F(X_eq)`` by one call of the loop's own sample function (not the linearizer's)."""
    loop = ClosedLoop(plant, design, substeps=default_substeps(plant, design.T))
    F = sample_map(loop, lin.r, design.parameter_vector())
    return loop, F(np.concatenate([lin.x_eq, lin.s_eq]))


def _rho3_design():
    return fl.Design(estimator=fl.EHGO(rho=3, eps=0.02, T=1e-3),
                     controller=fl.DynamicController((1.0, 3.0, 3.0), 1e-3, ki=1e-3))


CASES = [
    ("trms", fl.plants.trms_yaw, lambda: fl.presets.paper_design(), 0.3),
    ("trms", fl.plants.trms_yaw, lambda: fl.presets.paper_design(), 0.5),
    ("trms", fl.plants.trms_yaw, lambda: fl.presets.paper_design(), 1.0),
    # an absolute 1e-13 tolerance stopped Newton here (max|F(X) - X| = 8.9e-13 at |X| ~ 2)
    ("trms-fast", fl.plants.trms_yaw,
     lambda: fl.presets.paper_design(eps=0.0017782794100389228, gamma=0.03), 2.0),
    ("pendulum", fl.plants.pendulum, lambda: fl.presets.pendulum_design(ki=0.5), 0.3),
    ("motor lag", lambda: fl.plants.trms_yaw(motor_lag=True), _rho3_design, 0.5),
]


@pytest.mark.parametrize("name, make_plant, make_design, r", CASES,
                         ids=[f"{c[0]}-r{c[3]}" for c in CASES])
def test_equilibrium_is_a_fixed_point_and_eigenvalues_match_finite_differences(
        name, make_plant, make_design, r):
    plant, design = make_plant(), make_design()
    lin = fl.sampled_linearization(plant, design, r=r)
    assert lin.equilibrium_source == "newton"
    X = np.concatenate([lin.x_eq, lin.s_eq])
    loop, FX = _one_sample(plant, design, lin)
    # F(X) = X to the stated per-component tolerance, recomputed here from its formula
    tol = 16 * UNIT * ((np.abs(lin.matrix) + np.eye(X.size)) @ np.maximum(1.0, np.abs(X)))
    np.testing.assert_allclose(lin.tolerance, tol, rtol=1e-12)
    assert np.all(np.abs(FX - X) <= tol)
    assert lin.residual == pytest.approx(np.max(np.abs(FX - X)), abs=2 * UNIT * X.size)
    assert plant.casadi().h(lin.x_eq) == pytest.approx(r, abs=1e-9)
    # the Jacobian and the loop's eigenvalues against central differences of the sample map
    M = fd_jacobian(loop, X, r, design.parameter_vector())
    np.testing.assert_allclose(lin.matrix, M, rtol=0, atol=1e-6 * np.abs(M).max())
    keep = [i for i, s in enumerate(lin.state_names) if s not in lin.decoupled]
    fd_radius = np.max(np.abs(np.linalg.eigvals(M[np.ix_(keep, keep)])))
    assert lin.spectral_radius == pytest.approx(fd_radius, abs=1e-8)
    json.dumps(lin.to_dict(), allow_nan=False)


def test_simulation_fallback_when_newton_is_capped(monkeypatch):
    """No Newton step from the operating point: the state a simulation settles to, polished,
    is the same fixed point, reported as such."""
    plant, design, r = fl.plants.trms_yaw(), fl.presets.paper_design(), 0.5
    newton = fl.sampled_linearization(plant, design, r=r)
    monkeypatch.setattr(L, "NEWTON_ITERATIONS", 0)
    sim = fl.sampled_linearization(plant, design, r=r)
    assert (newton.equilibrium_source, sim.equilibrium_source) == ("newton", "simulation")
    X = np.concatenate([sim.x_eq, sim.s_eq])
    _, FX = _one_sample(plant, design, sim)
    assert np.all(np.abs(FX - X) <= sim.tolerance)
    np.testing.assert_allclose(X, np.concatenate([newton.x_eq, newton.s_eq]), rtol=0,
                               atol=1e-9)
    assert sim.spectral_radius == pytest.approx(newton.spectral_radius, abs=1e-12)
    assert sim.to_dict()["equilibrium_source"] == "simulation"


@pytest.mark.parametrize("theta0", [3.3, 50.0])
def test_newton_from_far_away_ends_at_the_same_equilibrium(theta0):
    """Newton started beyond the pendulum's top (the line search keeps it on course)."""
    plant, design = fl.plants.pendulum(), fl.presets.pendulum_design(ki=0.5)
    loop = ClosedLoop(plant, design, substeps=default_substeps(plant, design.T))
    lin = L.LoopLinearizer(loop)
    ref = lin(0.3, design.parameter_vector())
    far = lin.start()
    far[0] = theta0
    res = lin(0.3, design.parameter_vector(), start=far)
    assert res.equilibrium_source == "newton"
    np.testing.assert_allclose(res.x_eq, ref.x_eq, atol=1e-9)


def test_no_equilibrium_names_the_reference_the_residuals_and_what_to_try():
    """A reference the saturated input cannot hold: Newton and the simulation both fail; the
    simulation's output sits at asin(1 / 9.81), where u = 1 balances gravity."""
    design = fl.Design(estimator=fl.EHGO(rho=2, eps=0.02, T=1e-3),
                       controller=fl.DynamicController((2, 4), 1e-2, ki=0.5,
                                                       u_limits=(-1.0, 1.0)))
    with pytest.raises(ComputationError) as info:
        fl.sampled_linearization(fl.plants.pendulum(), design, r=0.5)
    msg = str(info.value)
    assert "no closed-loop equilibrium found for r=0.5" in msg
    assert "Newton's method from the operating point stopped with max|F(X) - X| = " in msg
    assert f"output y = {np.arcsin(1 / 9.81):.6g} for the reference 0.5" in msg
    assert "run fl.simulate at this reference" in msg
