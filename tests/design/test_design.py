"""Design: the loop step against a hand-written NumPy loop of DESIGN.md's normative order."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

import fl_design as fl
from fl_design import errors

T = 1e-3


# --- the normative loop, written out by hand ----------------------------------------------------
def _clamp(x, lim):
    return x if lim is None else min(max(x, lim[0]), lim[1])


def _controller_part(ctrl, xhat, r, u_prev, z_prev):
    """Steps 2-5 of the normative loop for one sample (xhat = [xhat_1..xhat_rho, sigmahat])."""
    rho = ctrl.rho
    x = np.array(xhat, dtype=float)
    for i in range(1, rho):  # step 2: clamp xhat_2..xhat_rho
        x[i] = _clamp(x[i], ctrl.estimate_ranges[i])
    z = z_prev + T * (x[0] - r)  # step 3
    v = -ctrl.gains[0] * (x[0] - r)  # step 4
    for i in range(1, rho):
        v -= ctrl.gains[i] * x[i]
    v -= ctrl.ki * z
    u = _clamp(u_prev + ctrl.gamma * (v - x[rho]), ctrl.u_range)  # step 5
    if ctrl.antiwindup and ctrl.u_range is not None:  # conditional integration
        push = -ctrl.gamma * ctrl.ki * (x[0] - r)
        if (u >= ctrl.u_range[1] and push > 0) or (u <= ctrl.u_range[0] and push < 0):
            z = z_prev
    return u, z, x


def _ehgo_loop(obs, ctrl, ys, rs):
    """Steps 1-7 with the EHGO's own discrete matrices (A_d, B_d, C_d, D_d)."""
    Ad, Bd, Cd, Dd = _ehgo_output_matrices(obs)
    xi = np.asarray(obs.initial_state(), dtype=float)
    u, z = ctrl.u0, 0.0
    us, xhats = [], []
    for y, r in zip(ys, rs):
        xhat = Cd @ xi + Dd.ravel() * y  # step 1
        u, z, xc = _controller_part(ctrl, xhat, r, u, z)  # steps 2-5 (6: u applied)
        xi = Ad @ xi + Bd.ravel() * y  # step 7
        us.append(u)
        xhats.append(xc)
    return np.array(us), np.array(xhats), np.concatenate([xi, [u, z]])


def _ehgo_output_matrices(obs):
    """(A_d, B_d, D^-1 C_d, D^-1 D_d): xhat = D^-1 (C_d xi + D_d y), D = diag(1, eps, ..)."""
    Ad, Bd, Cd, Dd = (np.asarray(m, dtype=float) for m in obs.matrices)
    Dinv = np.diag([obs.eps ** -i for i in range(obs.rho + 1)])
    return Ad, Bd, Dinv @ Cd, Dinv @ Dd


def _signal(n, *, seed):
    """A reference-tracking-like measurement: steps, a ramp and a little noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * T
    y = 0.3 * (t > 0.02) + 0.5 * np.sin(7.0 * t) + 0.02 * rng.standard_normal(n)
    r = np.where(t < 0.1, 0.3, -0.2)
    return y, r


def _assert_close(actual, expected, *, tol=1e-12):
    actual, expected = np.asarray(actual, float), np.asarray(expected, float)
    scale = max(1.0, float(np.abs(expected).max()))
    np.testing.assert_allclose(actual, expected, rtol=0, atol=tol * scale)


EHGO_CASES = {
    2: {"eps": 0.01, "gains": (2.0, 4.0), "gamma": 0.05, "ki": 5.0, "u_limits": (-0.4, 0.6),
            "estimate_limits": (None, 3.0)},
    3: {"eps": 0.02, "gains": (1.0, 3.0, 3.0), "gamma": 0.01, "ki": 2.0, "u_limits": (-0.3, 0.3),
            "estimate_limits": (None, (-2.0, 2.5), 20.0)},
}


def _ehgo_design(rho, **over):
    case = EHGO_CASES[rho] | over
    obs = fl.EHGO(rho=rho, eps=case["eps"], T=T)
    ctrl = fl.DynamicController(case["gains"], case["gamma"], ki=case["ki"],
                                u_limits=case["u_limits"],
                                estimate_limits=case["estimate_limits"], u0=0.1)
    return fl.Design(estimator=obs, controller=ctrl)


@pytest.mark.parametrize("rho", [2, 3])
def test_ehgo_design_follows_the_normative_order(rho):
    design = _ehgo_design(rho)
    ys, rs = _signal(400, seed=rho)
    u_ref, xhat_ref, state_ref = _ehgo_loop(design.estimator, design.controller, ys, rs)
    lo, hi = design.controller.u_range
    assert np.any(u_ref == lo) and np.any(u_ref == hi), "both input limits must be exercised"
    raw = _ehgo_loop(design.estimator, design.controller.replace(estimate_limits=None), ys, rs)[1]
    assert np.any(raw[:, 1] != xhat_ref[:, 1]), "the estimate limit must be exercised"
    assert np.any(np.abs(xhat_ref[:, 0] - rs) > 0.1) and design.controller.ki > 0

    out = design.run(ys, rs)
    _assert_close(out.u, u_ref)
    _assert_close(out.xhat, xhat_ref)
    _assert_close(out.state[-1], state_ref)
    # the plain step function, called sample by sample, gives the same numbers
    state = design.initial_state()
    for k in range(60):
        state, u = design.step(state, ys[k], rs[k])
        _assert_close(float(u), u_ref[k])
    _assert_close(np.asarray(state).ravel(), out.state[60])


def _ls_loop(est, ctrl, ys, rs):
    """Steps 1-7 with an independent polynomial fit (numpy Polynomial.fit) for step 1."""
    N, rho = est.window, est.rho
    u, z = ctrl.u0, 0.0
    us, xhats = [], []
    t = (np.arange(N) - (N - 1)) * T  # oldest first, current sample at t = 0
    for k, (y, r) in enumerate(zip(ys, rs)):
        if k + 1 < N:  # window not full: steps 2-5 skipped, u and z stay at their values
            us.append(u)
            xhats.append(None)
            continue
        fit = np.polynomial.Polynomial.fit(t, ys[k + 1 - N : k + 1], est.fit_degree)
        xhat = [fit.deriv(i)(0.0) if i else fit(0.0) for i in range(rho + 1)]
        u, z, xc = _controller_part(ctrl, xhat, r, u, z)
        us.append(u)
        xhats.append(xc)
    return np.array(us), xhats, z


@pytest.mark.parametrize("window, degree", [(9, None), (26, 3)])
def test_least_squares_design_holds_until_the_window_is_full(window, degree):
    est = fl.LeastSquaresEstimator(rho=2, T=T, window=window, degree=degree)
    ctrl = fl.DynamicController((2.0, 4.0), 2e-4, ki=3.0, u_limits=(-0.2, 0.25), u0=0.05,
                                estimate_limits=(None, 0.4))
    design = fl.Design(estimator=est, controller=ctrl)
    t = np.arange(300) * T
    ys = 0.3 * np.sin(30.0 * t) + 0.1 + 1e-3 * np.random.default_rng(window).standard_normal(300)
    rs = np.where(t < 0.15, 0.3, -2.0)
    u_ref, xhat_ref, z_ref = _ls_loop(est, ctrl, ys, rs)
    out = design.run(ys, rs)
    lay = design.state_layout
    held = slice(0, window - 1)
    np.testing.assert_array_equal(out.u[held], ctrl.u0)
    np.testing.assert_array_equal(out.state[1:window, lay["z"]].ravel(), 0.0)
    assert out.u[window - 1] != ctrl.u0  # acts at the first full window
    _assert_close(out.u, u_ref)
    _assert_close(out.xhat[window - 1 :], np.array(xhat_ref[window - 1 :]))
    _assert_close(out.state[-1, lay["z"]], z_ref)
    assert np.any(u_ref == -0.2) and np.any(u_ref == 0.25)
    raw = np.array([np.polynomial.Polynomial.fit((np.arange(window) - window + 1) * T,
                                                 ys[k + 1 - window : k + 1], est.fit_degree)
                    .deriv()(0.0) for k in range(window - 1, 300)])
    assert np.any(np.abs(raw) > 0.4), "the estimate limit must be exercised"


def test_replace_eps_is_refused_for_the_least_squares_estimator():
    design = fl.Design(estimator=fl.LeastSquaresEstimator(rho=2, T=T, window=9),
                       controller=fl.DynamicController((2, 4), 3e-4))
    with pytest.raises(errors.ParameterError, match=r"eps=0.01 cannot be set.*no eps"):
        design.replace(eps=0.01)
    assert design.replace(gamma=1e-3).controller.gamma == 1e-3


def test_step_equals_parametric_step_with_the_design_parameters():
    design = _ehgo_design(3)
    rng = np.random.default_rng(0)
    p = design.parameter_vector()
    for _ in range(20):
        state = rng.normal(size=design.state_size)
        y, r = rng.normal(size=2)
        sn, u = design.step(state, y, r)
        sn_p, u_p, _ = design.parametric_step(state, y, r, p)
        _assert_close(sn, sn_p, tol=1e-14)
        _assert_close(u, u_p, tol=1e-14)


def test_function_signatures_follow_the_contract():
    design = _ehgo_design(2)
    f, g = design.parametric_step, design.step
    assert f.name() == "fl_step_p" and g.name() == "fl_step"
    assert f.name_in() == ["state", "y", "r", "p"]
    assert f.name_out() == ["state_next", "u", "xhat"]
    assert g.name_in() == ["state", "y", "r"] and g.name_out() == ["state_next", "u"]
    n, m = design.state_size, design.parameter_vector().size
    assert [f.size_in(i) for i in range(4)] == [(n, 1), (1, 1), (1, 1), (m, 1)]
    assert [f.size_out(i) for i in range(3)] == [(n, 1), (1, 1), (3, 1)]
    assert design.parametric_step is f and design.step is g  # built once


def test_state_layout_initial_state_and_parameters():
    design = _ehgo_design(2)
    obs, ctrl = design.estimator, design.controller
    m = obs.state_size
    assert design.state_size == m + 2
    lay = design.state_layout
    assert lay == {"estimator": slice(0, m), "u": slice(m, m + 1), "z": slice(m + 1, m + 2)}
    x0 = design.initial_state()
    np.testing.assert_array_equal(x0[lay["estimator"]], obs.initial_state())
    assert x0[lay["u"]][0] == ctrl.u0 and x0[lay["z"]][0] == 0.0
    np.testing.assert_array_equal(design.parameter_vector(),
                                  np.r_[obs.parameter_vector(), ctrl.gamma])
    assert (design.rho, design.T) == (2, T)


def test_replace_eps_equals_a_design_built_from_scratch():
    design = _ehgo_design(2)
    new = design.replace(eps=0.003, gamma=0.02)
    scratch = fl.Design(estimator=fl.EHGO(rho=2, eps=0.003, T=T),
                        controller=design.controller.replace(gamma=0.02))
    np.testing.assert_array_equal(new.parameter_vector(), scratch.parameter_vector())
    ys, rs = _signal(200, seed=5)
    a, b = new.run(ys, rs), scratch.run(ys, rs)
    np.testing.assert_array_equal(a.u, b.u)
    np.testing.assert_array_equal(a.state, b.state)
    assert design.estimator.eps == EHGO_CASES[2]["eps"]  # the original is unchanged
    # and the original graph evaluated with the new parameters agrees too (what sweeps do)
    state = scratch.initial_state()
    for k in range(50):
        state, u, _ = design.parametric_step(state, ys[k], rs[k], scratch.parameter_vector())
        _assert_close(float(u), b.u[k])


def test_estimate_limits_reduce_peaking():
    """y jumps 0 -> 1 at k = 0: with small eps the EHGO's xhat_2 peaks like 1/eps."""
    ys = np.ones(300)
    free = _ehgo_design(2, eps=2e-3, estimate_limits=None, u_limits=None, ki=0.0)
    limited = _ehgo_design(2, eps=2e-3, estimate_limits=(None, 5.0), u_limits=None, ki=0.0)
    out_free, out_lim = free.run(ys, 0.0), limited.run(ys, 0.0)
    assert np.max(np.abs(out_free.xhat[:, 1])) > 50.0  # peaking ~ 1/eps
    assert np.max(np.abs(out_lim.xhat[:, 1])) <= 5.0
    assert np.max(np.abs(out_lim.u)) < np.max(np.abs(out_free.u))


def test_saturation_is_respected_and_is_the_controller_state():
    design = _ehgo_design(2, gamma=10.0)
    ys, rs = _signal(300, seed=3)
    out = design.run(ys, rs)
    lo, hi = design.controller.u_range
    assert np.all(out.u >= lo) and np.all(out.u <= hi)
    assert np.any(out.u == lo) and np.any(out.u == hi)
    np.testing.assert_array_equal(out.state[1:, design.state_layout["u"]].ravel(), out.u)


def test_run_accepts_a_scalar_reference_and_an_initial_state():
    design = _ehgo_design(2)
    ys = np.linspace(0.0, 1.0, 50)
    a = design.run(ys, 0.25)
    b = design.run(ys, np.full(50, 0.25))
    np.testing.assert_array_equal(a.u, b.u)
    c = design.run(ys[25:], 0.25, state0=a.state[25])
    np.testing.assert_array_equal(c.u, a.u[25:])
    assert set(a.to_dict()) == {"u", "xhat", "state"}


@pytest.mark.parametrize(
    "args, kwargs, error, match",
    [
        (([],), {}, errors.DimensionError, r"at least one sample"),
        (([[0.0, 1.0]],), {}, errors.DimensionError, r"y_sequence must be one-dimensional"),
        (([0.0, np.nan],), {}, errors.ParameterError, r"y_sequence must be finite"),
        (([0.0, 1.0], [0.0]), {}, errors.DimensionError, r"r_sequence must have length 2"),
        (([0.0, 1.0], np.inf), {}, errors.ParameterError, r"r_sequence must be finite"),
        (([0.0],), {"state0": [0.0]}, errors.DimensionError, r"state0 must have length 5"),
    ],
)
def test_run_bad_inputs(args, kwargs, error, match):
    with pytest.raises(error, match=match):
        _ehgo_design(2).run(*args, **kwargs)


def test_rho_mismatch_names_both():
    with pytest.raises(errors.DesignMismatchError, match=r"estimator rho=3.*controller rho=2"):
        fl.Design(estimator=fl.EHGO(rho=3, eps=0.05, T=T),
                  controller=fl.DynamicController((2, 4), 1e-3))


def test_estimator_must_be_an_estimator():
    with pytest.raises(errors.ParameterError, match=r"estimator must be an fl_design estimator"):
        fl.Design(estimator=object(), controller=fl.DynamicController((2, 4), 1e-3))

    class Incomplete(fl.design.Estimator):  # declares nothing: cannot even be built
        pass

    with pytest.raises(TypeError, match="abstract"):
        Incomplete()
    with pytest.raises(errors.ParameterError, match=r"controller must be a fl.DynamicController"):
        fl.Design(estimator=fl.EHGO(rho=2, eps=0.05, T=T), controller=(2, 4))


def test_pickles_and_describes():
    design = _ehgo_design(3)
    back = pickle.loads(pickle.dumps(design))
    assert back == design
    x0 = design.initial_state()
    np.testing.assert_array_equal(np.asarray(back.step(x0, 0.2, 0.1)[0]),
                                  np.asarray(design.step(x0, 0.2, 0.1)[0]))
    text = design.describe()
    assert "rho = 3" in text and "DynamicController(gains=(1, 3, 3)" in text
    assert repr(design).startswith("Design(estimator=")


def test_design_replace_refuses_unknown_names():
    with pytest.raises(errors.ParameterError, match=r"takes eps and gamma only, got \['foo'\]"):
        _ehgo_design(2).replace(foo=1)
