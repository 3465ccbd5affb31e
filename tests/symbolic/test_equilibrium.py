"""Operating points away from the origin: equilibria solved, checked against SciPy fsolve."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.optimize
import sympy as sp

import fl_design as fl
from fl_design import errors


def _beam_like():
    """``x1' = x2, x2' = x3 - sin(x1), x3' = -x3 + u``, y = x1 (rho = 3, equilibrium off 0)."""
    x1, x2, x3, u = sp.symbols("x1 x2 x3 u")
    return [x1, x2, x3], u, [x2, x3 - sp.sin(x1), -x3 + u + 0.2], x1


def test_output_operating_point_solves_states_and_input():
    states, u, rhs, y = _beam_like()
    plant = fl.Plant.from_ode(states, u, rhs, y, operating_point={"y": 0.4},
                              region={"x1": (-1, 1), "x2": (-1, 1), "x3": (-2, 2)})
    f = sp.lambdify([[*states, u]], rhs)
    ref = scipy.optimize.fsolve(lambda z: f(np.r_[0.4, z]), [0.1, 0.1, 0.1], xtol=1e-14)
    np.testing.assert_allclose(plant.x_op, [0.4, *ref[:2]], atol=1e-12)
    assert plant.u_eq == pytest.approx(ref[2], abs=1e-12)
    assert plant.u_eq == pytest.approx(np.sin(0.4) - 0.2, abs=1e-12)  # closed form
    eq = plant.equilibrium(y=-0.3)
    np.testing.assert_allclose(eq.x, [-0.3, 0.0, np.sin(-0.3)], atol=1e-12)
    assert eq.u == pytest.approx(np.sin(-0.3) - 0.2, abs=1e-12) and eq.y == -0.3
    held = plant.equilibrium(x3=0.5)  # a state held instead: x1 = asin(0.5)
    np.testing.assert_allclose(held.x, [np.arcsin(0.5), 0.0, 0.5], atol=1e-12)


def test_partial_state_operating_point_and_the_run_starts_there():
    plant = fl.Plant.from_ode(*_beam_like()[:3], _beam_like()[3], operating_point={"x1": 0.2},
                              region={"x1": (-1, 1), "x2": (-1, 1), "x3": (-2, 2)})
    np.testing.assert_allclose(plant.x_op, [0.2, 0.0, np.sin(0.2)], atol=1e-12)
    from fl_design.sim._run import prepare_run

    d = fl.Design(estimator=fl.EHGO(3, 0.05, 1e-3), controller=fl.DynamicController((1, 3, 3), 0.1))
    run = prepare_run(plant, d, fl.Scenario(0.2, 0.01))
    np.testing.assert_array_equal(run.x0, plant.x_op)
    assert run.u0 == plant.u_eq and run.s0[0] == pytest.approx(0.2, abs=1e-15)


def test_no_or_several_equilibria_are_named():
    states, u, rhs, y = _beam_like()
    region = {"x1": (-1, 1), "x2": (-1, 1), "x3": (-0.5, 0.5)}
    with pytest.raises(errors.PlantDefinitionError,  # x3 = sin(0.9) = 0.783327 > 0.5
                       match=r"the equilibrium has x3=0.783327, outside the region \[-0.5, 0.5\]"):
        fl.Plant.from_ode(states, u, rhs, y, operating_point={"y": 0.9}, region=region)
    x1, x2, v = sp.symbols("x1 x2 v")
    with pytest.raises(errors.PlantDefinitionError,
                       match=r"no equilibrium f\(x, u\) = 0 with y=0.1 inside its region.*"
                             r"solved for x1, x2, u by least squares from 17 starts"):
        fl.Plant.from_ode([x1, x2], v, [x2, v**2 + 1], x1, operating_point={"y": 0.1})
    x1, x2, v = sp.symbols("x1 x2 v")  # holding y = x2 = 0 leaves x1 = +-0.5
    two = {"states": [x1, x2], "input": v, "rhs": [x2 - (x1**2 - 0.25), v], "output": x2}
    with pytest.raises(errors.PlantDefinitionError,
                       match=r"2 equilibria with y=0 in its region \(x1, x2, u = -0.5, 0, 0; 0.5, 0, 0\)"):
        fl.Plant(**two, region={"x1": (-1, 1)}, operating_point={"y": 0.0})
    one = fl.Plant(**two, region={"x1": (0, 1)}, operating_point={"y": 0.0})
    np.testing.assert_allclose(one.x_op, [0.5, 0.0], atol=1e-12)


def test_operating_point_outside_the_region_is_refused():
    states, u, rhs, y = _beam_like()
    with pytest.raises(errors.PlantDefinitionError,
                       match=r"the operating point x1=1.5 lies outside the region \[-1, 1\] of x1"):
        fl.Plant.from_ode(states, u, rhs, y, operating_point={"x1": 1.5},
                          region={"x1": (-1, 1)})


@pytest.mark.parametrize("name,dy", [("trms_yaw", 0.3), ("pendulum", 0.2), ("maglev", 0.001),
                                     ("flexible_joint", 0.3)])
def test_newton_first_gives_the_least_squares_equilibrium(monkeypatch, name, dy):
    """Newton's method from each start (issue 33: the TRMS's 17 bounded least squares took
    0.26 s) finds the equilibrium the least-squares path finds, to round-off."""
    from fl_design.symbolic import _equilibrium

    plant = getattr(fl.plants, name)()
    y = float(plant.casadi().h(plant.x_op)) + dy
    fast = plant.equilibrium(y=y)
    monkeypatch.setattr(_equilibrium, "NEWTON_STEPS", 0)  # straight to least squares
    slow = plant.equilibrium(y=y)
    np.testing.assert_allclose(fast.x, slow.x, rtol=1e-12, atol=1e-14)
    assert fast.u == pytest.approx(slow.u, rel=1e-12, abs=1e-14)
    # and it is an equilibrium: f(x, u) = 0, h(x) = y
    f = plant.casadi()
    assert np.max(np.abs(np.asarray(f.f(fast.x, fast.u), float))) < 1e-9
    assert float(f.h(fast.x)) == pytest.approx(y, abs=1e-12)
