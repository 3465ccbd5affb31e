"""A plant as a user brings it: a bumpless observer start, either sign of b (issue 10)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal
import sympy as sp

import fl_design as fl
from fl_design import errors

T = 1e-3


def _pendulum_at(theta0: float):
    """The library pendulum held at ``theta0`` (its output is ``theta0`` at rest)."""
    th, om, u = sp.symbols("theta omega u")
    rhs = [om, -9.81 * sp.sin(th) - 0.5 * om + u]
    return fl.Plant.from_ode([th, om], u, rhs, th, operating_point={"theta": theta0},
                             region={"theta": (-1, 1), "omega": (-10, 10)}, input_range=20)


def _negative_b_plant():
    """``x1' = x2, x2' = -x1 - x2 - u``: b = -1 in natural coordinates."""
    x1, x2, u = sp.symbols("x1 x2 u")
    return fl.Plant.from_ode([x1, x2], u, [x2, -x1 - x2 - u], x1, name="neg_b",
                             region={"x1": (-1, 1), "x2": (-5, 5)}, input_range=20)


# --- item 3: the bumpless observer start -----------------------------------------------------
@pytest.mark.parametrize("method", ["bilinear", "forward_euler", "backward_euler", "zoh"])
@pytest.mark.parametrize("realization", ["direct", "delta"])
def test_ehgo_start_is_the_rest_state_of_the_first_measurement(method, realization):
    obs = fl.EHGO(3, 0.02, T, method=method, realization=realization)
    y0 = -0.05
    xi = obs.initial_state(y0=y0)
    A, B, _, _ = scipy.signal.cont2discrete(  # independent discretization of eps q' = F q + L y
        (np.eye(4, k=1) - np.outer(obs.alphas, [1, 0, 0, 0]), np.array(obs.alphas)[:, None],
         np.eye(4), np.zeros((4, 1))), obs.alpha,
        method={"bilinear": "bilinear", "forward_euler": "euler",
                "backward_euler": "backward_diff", "zoh": "zoh"}[method])[:4]
    np.testing.assert_allclose(A @ xi + B[:, 0] * y0, xi, atol=1e-15)  # a fixed point
    xhat, xi_next, _ = obs.symbolic_update(xi, y0, obs.parameter_vector())
    np.testing.assert_allclose(xhat.full().ravel(), [y0, 0, 0, 0], atol=1e-10)
    np.testing.assert_allclose(xi_next.full().ravel(), xi, atol=1e-15)


def test_a_plant_at_rest_away_from_zero_no_longer_peaks():
    """Output -0.05 at rest: the old start (xi = 0) kicked the loop; the bumpless one does not."""
    plant = _pendulum_at(-0.05)
    design = fl.presets.pendulum_design(eps=0.003)
    y0 = float(plant.casadi().h(plant.x_op))
    obs = design.estimator  # before: xi = 0, first estimate D^-1 D_d y0 (closed form below)
    D_d = scipy.signal.cont2discrete((np.eye(3, k=1) - np.outer(obs.alphas, [1, 0, 0]),
                                      np.array(obs.alphas)[:, None], np.eye(3), np.zeros((3, 1))),
                                     obs.alpha, method="bilinear")[3][:, 0]
    legacy = design.run([y0], state0=design.initial_state(y0=0.0)).xhat[0]
    np.testing.assert_allclose(legacy, D_d * y0 / obs.eps ** np.arange(3), rtol=1e-9)
    assert legacy[2] == pytest.approx(-583.09, rel=1e-4)
    before = fl.simulate(plant, design, fl.Scenario(-0.05, 5.0, initial_estimate=legacy))
    after = fl.simulate(plant, design, fl.Scenario(-0.05, 5.0))
    assert before.sigmahat[0] == pytest.approx(legacy[2], rel=1e-9)
    assert np.max(np.abs(before.y + 0.05)) > 0.05  # the kick doubles the output's offset
    assert abs(after.sigmahat[0]) < 1e-9 and after.xhat[0, 0] == pytest.approx(y0, abs=1e-15)
    assert after.u[0] == pytest.approx(plant.u_eq, abs=1e-9)  # bumpless input: u_eq
    assert plant.u_eq == pytest.approx(9.81 * np.sin(-0.05), rel=1e-12)
    assert after.status == "converged" and np.max(np.abs(after.y + 0.05)) < 1e-9


def test_initial_estimate_overrides_the_start_and_is_checked():
    plant = fl.plants.pendulum()
    est = [0.02, 0.3, -1.5]
    for realization in ("direct", "delta"):
        d = fl.Design(estimator=fl.EHGO(2, 0.02, T, realization=realization),
                      controller=fl.DynamicController((2, 4), 1e-2))
        resp = fl.simulate(plant, d, fl.Scenario(0.0, 0.01, initial_estimate=est))
        np.testing.assert_allclose([*resp.xhat[0], resp.sigmahat[0]], est, rtol=1e-9, atol=1e-12)
    with pytest.raises(errors.DimensionError, match=r"initial_estimate=\[0.1, 0.0\] has 2 entries.*"
                                                    r"rho \+ 1 = 3"):
        fl.simulate(plant, d, fl.Scenario(0.0, 0.01, initial_estimate=[0.1, 0.0]))
    with pytest.raises(errors.DimensionError, match="rho \\+ 1 = 3 entries"):
        d.initial_state(estimate=[0.1])


def test_initial_estimate_in_a_sweep_follows_each_eps():
    plant, d = fl.plants.pendulum(), fl.presets.pendulum_design()
    from fl_design.sim._grid import parameter_columns
    from fl_design.sim._run import prepare_run

    run = prepare_run(plant, d, fl.Scenario(0.0, 0.01, initial_estimate=[0.0, 0.1, 2.0]))
    P = parameter_columns(d, [0.01, 0.05], [1e-2, 2e-2])
    S = run.loop.layout.unpack(run.initial_accumulator(P))["s"]
    for j, eps in enumerate([0.01, 0.01, 0.05, 0.05]):
        dj = d.replace(eps=eps)
        out = dj.run([0.0], state0=S[:, j]).xhat[0]
        np.testing.assert_allclose(out, [0.0, 0.1, 2.0], atol=1e-9)


def test_least_squares_window_starts_full_at_the_first_measurement():
    est = fl.LeastSquaresEstimator(2, T, window=9)
    d = fl.Design(estimator=est, controller=fl.DynamicController((2, 4), 1e-2))
    out = d.run([0.3, 0.3], state0=d.initial_state(y0=0.3))
    np.testing.assert_allclose(out.xhat, [[0.3, 0, 0]] * 2, atol=1e-9)
    assert out.u[0] != 0.0  # ready at the first sample: the controller acts at once
    poly = [0.1, -0.4, 3.0]  # y(t) = 0.1 - 0.4 t + 1.5 t^2 before the start; y(0) = 0.1
    first = d.run([0.1], state0=d.initial_state(estimate=poly)).xhat[0]
    np.testing.assert_allclose(first, poly, rtol=1e-7)


# --- item 2: either sign of b -----------------------------------------------------------------
def test_negative_b_takes_a_negative_gamma():
    plant = _negative_b_plant()
    assert plant.b_bounds() == (-1.0, -1.0)
    good = fl.presets.pendulum_design(gamma=-1e-2)
    resp = fl.simulate(plant, good, fl.Scenario(0.1, 10.0))
    assert resp.status == "converged" and resp.y[-1] == pytest.approx(0.1, abs=1e-3)
    with pytest.raises(errors.ParameterError,
                       match=r"gamma=0.01 has the sign opposite to b on plant 'neg_b' "
                             r"\(b in \[-1, -1\] over the region\).*gamma < 0"):
        fl.simulate(plant, fl.presets.pendulum_design(gamma=1e-2), fl.Scenario(0.1, 1.0))
    with pytest.raises(errors.ParameterError, match=r"gamma=-0.01 has the sign opposite to b.*> 0"):
        fl.simulate(fl.plants.pendulum(), good, fl.Scenario(0.1, 1.0))


def test_sweep_gammas_follow_the_sign_of_b():
    plant, d = _negative_b_plant(), fl.presets.pendulum_design(gamma=-1e-2)
    kw = {"eps": [0.02, 0.5], "kernel": fl.Kernel(compiled=False), "progress": False}
    sc = fl.Scenario(0.1, 3.0)
    mags = fl.sweep(plant, d, sc, gamma=[5e-3, 1e-2], **kw)
    signed = fl.sweep(plant, d, sc, gamma=[-1e-2, -5e-3], **kw)
    np.testing.assert_array_equal(mags.status[:, ::-1], signed.status)
    assert mags.gamma.tolist() == [5e-3, 1e-2] and signed.gamma.tolist() == [-1e-2, -5e-3]
    one = fl.simulate(plant, d.replace(eps=0.02, gamma=-5e-3), sc)
    assert mags.metrics["overshoot"][0, 0] == pytest.approx(one.metrics["overshoot"], rel=1e-9)
    with pytest.raises(errors.ParameterError, match="gamma=-0.01 has the sign opposite to b"):
        fl.sweep(fl.plants.pendulum(), d, sc, gamma=[-1e-2], **kw)
    with pytest.raises(errors.ParameterError, match=r"gamma values must be finite and > 0 "
                                                    r"\(or all < 0"):
        fl.sweep(plant, d, sc, gamma=[-1e-2, 1e-2], **kw)


# --- item 6: unmodeled dynamics on purpose ----------------------------------------------------
def _pendulum_with_motor(Tm: float):
    """The library pendulum driven through a first-order actuator ``Tm tau' = u - tau`` (rho 3)."""
    th, om, tau, u = sp.symbols("theta omega tau u", real=True)
    return fl.Plant.from_ode([th, om, tau], u, [om, -9.81 * sp.sin(th) - 0.5 * om + tau,
                                                 (u - tau) / Tm], th, name="pendulum_motor",
                             region={"theta": (-3.2, 3.2), "omega": (-10, 10), "tau": (-20, 20)},
                             input_range=20)


def test_unmodeled_actuator_needs_the_opt_in_and_shrinks_eps_star():
    d, sc = fl.presets.pendulum_design(), fl.Scenario(0.1, 10.0)
    lagged = _pendulum_with_motor(0.05)
    with pytest.raises(errors.DesignMismatchError, match="allow_unmodeled=True"):
        fl.simulate(lagged, d, sc)
    with pytest.warns(errors.UnmodeledDynamicsWarning, match="1 order"):
        resp = fl.simulate(lagged, d, sc.replace(duration=20.0), allow_unmodeled=True)
    assert resp.status == "converged"  # slower than the static pendulum (10 s: converging)
    th, om, tau = resp.x.T  # the design's truth: y, y' and sigma = L_f^2 h (no input term)
    np.testing.assert_allclose(resp.coords, np.c_[th, om], rtol=0, atol=0)
    np.testing.assert_allclose(resp.sigma, -9.81 * np.sin(th) - 0.5 * om + tau, atol=1e-12)
    kw = {"eps_range": (0.002, 2.0), "rtol": 0.01}
    static = fl.estimate_eps_star(fl.plants.pendulum(), d, sc, **kw)
    with pytest.warns(errors.UnmodeledDynamicsWarning):
        slow = [fl.estimate_eps_star(_pendulum_with_motor(Tm), d, sc, allow_unmodeled=True, **kw)
                for Tm in (0.01, 0.05)]
    assert static.converged and all(e.converged for e in slow)
    # measured: 0.0428 (static), 0.0381 (Tm = 10 ms), 0.0261 (Tm = 50 ms)
    assert static.bracket[0] > slow[0].bracket[1] and slow[0].bracket[0] > slow[1].bracket[1]
    assert slow[1].eps_star < 0.7 * static.eps_star
