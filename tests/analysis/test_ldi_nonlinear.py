"""The nonlinear (LDI) certificate with the interval ZOH model and its region search.

Oracles: SciPy ``expm`` of random piecewise-constant matrices inside the box (the Metzler
enclosure), the test oracle's surrogate loop matrix (tests/oracles.py), and the loop's own
nonlinear sample function (ClosedLoop.sample) iterated from the covered set's boundary.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

import fl_design as fl
from fl_design.analysis._ldi import _metzler_box
from fl_design.analysis._plant_bounds import plant_bounds
from fl_design.analysis._region import nonlinear_region
from fl_design.errors import ParameterError
from tests.oracles import surrogate_loop_matrix

T = 1e-3


def _X(a, b):
    return np.array([[0.0, 1.0, 0.0], [0.0, a, b], [0.0, 0.0, 0.0]])


def _random_sample_map(rng, a_rng, b_rng, pieces):
    """The transition over one sample of a piecewise-constant X(t) inside the box."""
    cuts = np.sort(rng.uniform(0.0, T, pieces - 1))
    dts = np.diff(np.concatenate([[0.0], cuts, [T]]))
    Psi = np.eye(3)
    for dt in dts:
        a, b = rng.uniform(*a_rng), rng.uniform(*b_rng)
        if rng.random() < 0.5:  # bang-bang as well as interior values
            a, b = a_rng[rng.integers(2)], b_rng[rng.integers(2)]
        Psi = scipy.linalg.expm(dt * _X(a, b)) @ Psi
    return Psi


def test_metzler_box_encloses_every_time_varying_sample_map():
    a_rng, b_rng = (-505.0, -5.0), (3.6, 6.8)
    lo, hi = _metzler_box(np.stack([_X(a, b) for a in a_rng for b in b_rng]), T)
    rng = np.random.default_rng(3)
    maps = [_random_sample_map(rng, a_rng, b_rng, int(rng.integers(1, 12)))
            for _ in range(120)]
    for Psi in maps:
        assert np.all(lo <= Psi) and np.all(Psi <= hi)
    # the box is not loose: the frozen ends reach its corners (the map at a constant vertex)
    assert np.allclose(lo, scipy.linalg.expm(T * _X(-505.0, 3.6)), rtol=1e-12, atol=0)
    # the first-order model of the old certificate does not enclose them (what failed before)
    Xc = 0.5 * (_X(-505.0, 3.6) + _X(-5.0, 6.8))
    first = scipy.linalg.expm(T * Xc) + T * (_X(-5.0, 3.6) - Xc)
    assert not np.all(first <= hi + 1e-3)  # its (1,1) entry exceeds every real map's
    # a negative off-diagonal entry (the pendulum's -g cos theta) is not Metzler: None
    assert _metzler_box(np.stack([chain for chain in (
        np.array([[0.0, 1.0, 0.0], [-9.8, -0.1, 1.0], [0.0, 0.0, 0.0]]),)]), T) is None


def test_trms_narrow_friction_slope_is_certified_and_the_p_contracts_every_sample_map():
    design = fl.presets.paper_design()
    pb = plant_bounds(fl.plants.trms_yaw(), T=design.T)
    c = fl.certify_eps(design, pb, a_jacobian_bounds=[(0.0, 0.0), (-6.0, -5.0)], search=False)
    assert c.certified and c.covers == "nonlinear" and "interval ZOH model" in c.point.reason
    P = c.point.lyapunov[0][0]
    # independent loop matrices (oracle) with random time-varying sample maps of the box
    base = surrogate_loop_matrix(design.estimator, (2.0, 4.0), design.controller.gamma,
                                 design.controller.ki, 1.0)
    rng = np.random.default_rng(7)
    worst = 0.0
    for _ in range(200):
        Psi = _random_sample_map(rng, (-6.0, -5.0), (3.6, 6.8), int(rng.integers(1, 6)))
        M = base.copy()
        M[:2] = np.hstack([Psi[:2, :2], np.zeros((2, 5))]) + np.outer(Psi[:2, 2], base[5])
        lam = scipy.linalg.eigh(M.T @ P @ M, P, eigvals_only=True)[-1]
        worst = max(worst, lam)
    assert worst < 1.0


def test_trms_whole_region_says_why_not():
    design = fl.presets.paper_design()
    pb = plant_bounds(fl.plants.trms_yaw(), T=design.T)
    assert pb.a_jacobian_bounds[1][0] == pytest.approx(-505.0)
    c = fl.certify_eps(design, pb, a_jacobian_bounds="plant", search=False)
    why = c.point.reason
    # every corner is Schur, but a member of the class (the slope switching between its corner
    # plants -505 and -5) grows: no certificate can exist, none is solved for
    assert not c.certified and "a member of the class grows" in why
    assert "(0, -505)" in why and "(0, -5)" in why and "no certificate exists" in why


def _loop_state(design, keep, x, s, s_eq):
    return np.concatenate([x, s - s_eq])[keep]


@pytest.mark.parametrize("which", ["trms", "pendulum"])
def test_covered_set_boundary_runs_stay_decrease_v_and_converge(which):
    """Start the nonlinear loop (its own sample function) on the boundary of the covered set,
    observer at rest at the first measurement: V decreases at every sample at least at the
    certificate's rate, the plant stays in the certified region, the input inside its range."""
    from fl_design.analysis._surrogate import SurrogateLoop
    from fl_design.sim import ClosedLoop
    from fl_design.sim.kernel._loop import default_substeps

    if which == "trms":
        design, plant, n_steps = fl.presets.paper_design(), fl.plants.trms_yaw(), 2000
    else:
        design, plant, n_steps = fl.presets.pendulum_design(), fl.plants.pendulum(), 8000
    r = nonlinear_region(design, plant, steps=4)
    assert r.certified and r.covered is not None and r.covered.level > 0
    assert "nonlinear: certified in region" in r.words()
    q = r.q  # the contraction of V's P, re-checked in NumPy
    assert 0.0 < q < 1.0
    cs, keep = r.covered, SurrogateLoop(design).keep
    loop = ClosedLoop(plant, design, substeps=default_substeps(plant, design.T))
    p = design.parameter_vector()
    s_eq = design.initial_state(y0=0.0, u0=0.0)
    box = {n: (lo, hi) for n, lo, hi in r.region}
    names = [str(v) for v in plant.states]
    ext = dict(r.start_extents)
    for direction in ((1.0, 0.0), (0.0, 1.0), (0.7, -0.7), (-0.5, 1.0)):
        d0 = np.array([direction[0] * ext[names[0]], direction[1] * ext[names[1]]])
        # on the boundary: scale the start to V = level (V is quadratic in the start)
        X0 = _loop_state(design, keep, d0, design.initial_state(y0=d0[0], u0=0.0), s_eq)
        d0 = d0 * np.sqrt(cs.level / (X0 @ cs.P @ X0)) * (1 - 1e-9)
        x, s = d0.copy(), design.initial_state(y0=d0[0], u0=0.0)
        X = _loop_state(design, keep, x, s, s_eq)
        V0 = Vk = X @ cs.P @ X
        assert V0 == pytest.approx(cs.level, rel=1e-6)
        for _ in range(n_steps):
            xn, sn = loop.sample(x, s, 0.0, 0.0, 0.0, p)[:2]
            x, s = np.asarray(xn, float).ravel(), np.asarray(sn, float).ravel()
            X = _loop_state(design, keep, x, s, s_eq)
            Vn = X @ cs.P @ X
            assert Vn <= q * q * Vk * (1 + 1e-9) + 1e-30, (which, direction)
            for name, v in zip(names, x):
                assert box[name][0] <= v <= box[name][1]
            assert r.input_range[0] <= s[design.state_layout["u"]][0] <= r.input_range[1]
            Vk = Vn
        assert Vk <= q ** (2 * n_steps) * V0 * (1 + 1e-6)
        if which == "pendulum":  # fast enough to see convergence
            assert Vk < 1e-3 * V0


def test_internal_dynamics_are_refused_with_what_is_needed():
    plant = fl.plants.cart_pendulum()
    design = fl.Design(estimator=fl.EHGO(rho=2, eps=0.01, T=1e-3),
                       controller=fl.DynamicController((2, 4), 1e-2))
    with pytest.raises(ParameterError, match=r"rho = 2 < n = 4.*eta' = q\(xi, eta\)"):
        nonlinear_region(design, plant)
    lag = fl.plants.trms_yaw(motor_lag=True)  # rho = n = 3, xi = (phi, phi', phi'') != x
    with pytest.raises(ParameterError, match=r"are not its states.*region given in xi"):
        nonlinear_region(fl.presets.trms_lag_design(), lag)
    with pytest.raises(ParameterError, match="s_min"):
        nonlinear_region(fl.presets.pendulum_design(), fl.plants.pendulum(), s_min=2.0)
