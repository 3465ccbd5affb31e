"""DynamicController, gains_from_poles, lqr_gains: mathematics against independent computations."""

from __future__ import annotations

import itertools
import math

import casadi as ca
import numpy as np
import pytest
from scipy import linalg

import fl_design as fl
from fl_design import errors


# --- construction and validation -------------------------------------------------------------
def test_paper_trms_setting_is_normalized():
    ctrl = fl.DynamicController((2, 4), 3e-4, ki=1e-3, estimate_limits=(None, 0.05))
    assert ctrl.rho == 2
    assert ctrl.gains == (2.0, 4.0)
    assert (ctrl.gamma, ctrl.ki, ctrl.u0, ctrl.u_start, ctrl.u_range) == (3e-4, 1e-3, None, 0.0, None)
    assert ctrl.estimate_ranges == (None, (-0.05, 0.05))
    assert fl.DynamicController((1, 3, 3), 1.0).estimate_ranges == (None, None, None)
    assert fl.DynamicController((2, 4), 1.0, u_limits=2).u_range == (-2.0, 2.0)


@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        ({"gains": (-3, 2)}, errors.HurwitzError, r"\[-3.0, 2.0\] give s\^2 \+ 2 s - 3 .*: 1;"),
        ({"gains": (1, -1)}, errors.HurwitzError, r"not in the open left half-plane"),
        ({"gains": (0, 1)}, errors.ParameterError, r"gains"),
        ({"gains": (1, 0.1, 0.1)}, errors.HurwitzError, r"roots"),  # positive, not Hurwitz
        ({"gains": ()}, errors.DimensionError, r"at least one"),
        ({"gains": 2.0}, errors.DimensionError, r"gains must be a sequence"),
        ({"gains": (1, float("nan"))}, errors.ParameterError, r"gains must be finite"),
        ({"gamma": 0.0}, errors.ParameterError, r"gamma must be nonzero .*sign.* b\), got 0.0"),
        ({"gamma": float("nan")}, errors.ParameterError, r"gamma must be finite"),
        ({"gamma": float("inf")}, errors.ParameterError, r"gamma must be finite"),
        ({"ki": -1e-3}, errors.ParameterError, r"ki must be >= 0, got -0.001"),
        ({"ki": float("nan")}, errors.ParameterError, r"ki must be finite"),
        ({"u_limits": (1, -1)}, errors.ParameterError, r"u_limits must satisfy lo < hi"),
        ({"u_limits": (0, 1, 2)}, errors.DimensionError, r"u_limits"),
        ({"u_limits": (0.5, 1), "u0": 0.0}, errors.ParameterError, r"u0=0.0 must lie inside"),
        ({"u0": float("nan")}, errors.ParameterError, r"u0 must be finite"),
        ({"estimate_limits": (0.1, 0.05)}, errors.ParameterError, r"estimate_limits\[0\].*xhat_1"),
        ({"estimate_limits": ((-1, 1), None)}, errors.ParameterError, r"clamp xhat_1"),
        ({"estimate_limits": (None,)}, errors.DimensionError, r"rho = 2 entries"),
        ({"estimate_limits": (None, None, 1)}, errors.DimensionError, r"got 3"),
        ({"estimate_limits": 0.05}, errors.DimensionError, r"sequence of 2 entries"),
        ({"estimate_limits": (None, (0.1, -0.1))}, errors.ParameterError, r"estimate_limits\[1\]"),
        ({"estimate_limits": (None, -0.1)}, errors.ParameterError, r"estimate_limits\[1\] must"),
        ({"estimate_limits": (None, float("nan"))}, errors.ParameterError, r"finite"),
    ],
)
def test_bad_inputs_are_named(kwargs, error, match):
    args = {"gains": (2, 4), "gamma": 3e-4} | kwargs
    with pytest.raises(error, match=match):
        fl.DynamicController(**args)


def test_options_are_keyword_only_and_replace_revalidates():
    with pytest.raises(TypeError):
        fl.DynamicController((2, 4), 3e-4, 1e-3)  # ki must be named
    ctrl = fl.DynamicController((2, 4), 3e-4, estimate_limits=(None, (-1, 2)), u_limits=(-1, 1))
    assert ctrl.replace(gamma=1e-2).gamma == 1e-2
    assert ctrl.replace(gamma=1e-2).estimate_limits == ctrl.estimate_ranges
    assert ctrl.replace(gamma=-1.0).gamma == -1.0  # the sign of b decides (a run checks it)
    with pytest.raises(errors.ParameterError, match="gamma must be nonzero"):
        ctrl.replace(gamma=0.0)
    assert "gains=(2, 4)" in repr(ctrl) and "u_limits=(-1, 1)" in repr(ctrl)


# --- the symbolic law against the written equations ------------------------------------------
def _law_numpy(ctrl, xhat_ext, r, u_prev, z_prev, ready, gamma, T):
    """Steps 2-5 of DESIGN.md, written out independently."""
    x = np.array(xhat_ext, dtype=float)
    for i in range(1, ctrl.rho):
        lim = ctrl.estimate_ranges[i]
        if lim is not None:
            x[i] = min(max(x[i], lim[0]), lim[1])
    if not ready:
        return u_prev, z_prev, x
    z = z_prev + T * (x[0] - r)
    v = -ctrl.gains[0] * (x[0] - r) - sum(ctrl.gains[i] * x[i] for i in range(1, ctrl.rho))
    v -= ctrl.ki * z
    u = u_prev + gamma * (v - x[ctrl.rho])
    if ctrl.u_range is not None:
        u = min(max(u, ctrl.u_range[0]), ctrl.u_range[1])
        push = -gamma * ctrl.ki * (x[0] - r)  # conditional integration (anti-windup)
        if ctrl.antiwindup and ((u >= ctrl.u_range[1] and push > 0)
                                or (u <= ctrl.u_range[0] and push < 0)):
            z = z_prev
    return u, z, x


@pytest.mark.parametrize("antiwindup", [True, False])
@pytest.mark.parametrize("rho", [1, 2, 3])
def test_symbolic_law_matches_the_equations(rho, antiwindup):
    rng = np.random.default_rng(rho)
    gains = fl.gains_from_poles([-1.0 - 0.5 * i for i in range(rho)])
    limits = (None,) + tuple((-0.3, 0.4) for _ in range(rho - 1))
    ctrl = fl.DynamicController(gains, 0.7, ki=0.3, u_limits=(-0.5, 0.8), estimate_limits=limits,
                                antiwindup=antiwindup)
    xs = ca.SX.sym("x", rho + 1)
    r, up, zp, ready, gamma = (ca.SX.sym(n) for n in ("r", "up", "zp", "ready", "gamma"))
    f = ca.Function("law", [xs, r, up, zp, ready, gamma],
                    list(ctrl.symbolic_law(xs, r, up, zp, ready, gamma, 0.01)))
    hit_lo = hit_hi = hit_clamp = False
    for _ in range(200):
        args = (rng.normal(size=rho + 1), rng.normal(), rng.uniform(-0.5, 0.8), rng.normal(),
                float(rng.integers(0, 2)), rng.uniform(0.1, 2.0))
        u, z, xc = (np.asarray(o, dtype=float).ravel() for o in f(*args))
        u_ref, z_ref, x_ref = _law_numpy(ctrl, *args[:5], args[5], 0.01)
        np.testing.assert_allclose([u[0], z[0]], [u_ref, z_ref], rtol=0, atol=1e-14)
        np.testing.assert_allclose(xc, x_ref, rtol=0, atol=0)
        hit_lo |= u[0] == -0.5
        hit_hi |= u[0] == 0.8
        hit_clamp |= rho > 1 and not np.array_equal(xc, args[0])
    assert hit_lo and hit_hi and (hit_clamp or rho == 1)


def test_symbolic_law_rejects_wrong_estimate_length():
    ctrl = fl.DynamicController((2, 4), 1.0)
    with pytest.raises(errors.DimensionError, match=r"rho \+ 1 = 3 entries, got 2"):
        ctrl.symbolic_law(ca.SX.sym("x", 2), 0, 0, 0, 1, 1.0, 1e-3)


# --- gains_from_poles ------------------------------------------------------------------------
def _expanded(poles):
    """Coefficients of prod (s - p) by elementary symmetric polynomials (independent of np.poly)."""
    n = len(poles)
    e = [sum(math.prod(c) for c in itertools.combinations(poles, j)) for j in range(n + 1)]
    return [((-1) ** j * e[j]).real for j in range(n + 1)]  # s^n, s^(n-1), ..., s^0


@pytest.mark.parametrize(
    "poles",
    [[-2.0], [-1.0, -2.0], [-1 + 2j, -1 - 2j], [-3.0, -1 + 1j, -1 - 1j], [-0.5, -4.0, -7.0, -9.0],
     [-2 + 1j, -2 - 1j, -5 + 3j, -5 - 3j, -0.1]],
)
def test_gains_from_poles_matches_numpy_poly_and_expansion(poles):
    k = fl.gains_from_poles(poles)
    c = np.poly(poles).real
    np.testing.assert_allclose(k, c[:0:-1], rtol=1e-13)
    np.testing.assert_allclose(k, _expanded(poles)[:0:-1], rtol=1e-12)
    np.testing.assert_allclose(np.sort_complex(np.roots([1.0, *k[::-1]])), np.sort_complex(poles),
                               rtol=1e-6)


@pytest.mark.parametrize("rho", [1, 2, 3, 4, 6])
def test_gains_from_poles_repeated_pole_is_binomial(rho):
    lam = 2.5
    k = fl.gains_from_poles([-lam] * rho)
    # (s + lam)^rho: coefficient of s^(i-1) is C(rho, i-1) lam^(rho-i+1)
    expected = [math.comb(rho, i - 1) * lam ** (rho - i + 1) for i in range(1, rho + 1)]
    np.testing.assert_allclose(k, expected, rtol=1e-14)
    fl.DynamicController(k, 1.0)  # accepted as Hurwitz


@pytest.mark.parametrize(
    "poles, error, match",
    [
        ([-1.0, 0.0], errors.HurwitzError, r"negative real parts \(roots in the open left half-plane\), got \[0j\]"),
        ([-1.0, 2.0], errors.HurwitzError, r"negative real parts"),
        ([1j, -1j], errors.HurwitzError, r"negative real parts"),
        ([-1 + 1j, -2.0], errors.ParameterError, r"conjugate pairs: \(-1\+1j\)"),
        ([-1 + 1j, -1 + 1j], errors.ParameterError, r"conjugate pairs"),
        ([], errors.DimensionError, r"non-empty"),
        ([-1.0, float("nan")], errors.ParameterError, r"poles must be finite"),
        (["a"], errors.ParameterError, r"sequence of numbers"),
    ],
)
def test_gains_from_poles_bad_inputs(poles, error, match):
    with pytest.raises(error, match=match):
        fl.gains_from_poles(poles)


# --- lqr_gains -------------------------------------------------------------------------------
def _brunovsky(rho):
    B = np.zeros((rho, 1))
    B[-1] = 1.0
    return np.eye(rho, k=1), B


@pytest.mark.parametrize(
    "rho, Q, R",
    [(1, None, 1.0), (2, None, 1.0), (2, [10.0, 1.0], 0.1), (3, None, 2.0),
     (3, np.array([[2.0, 0.5, 0.0], [0.5, 1.0, 0.0], [0.0, 0.0, 0.3]]), 1.0), (4, [1, 0, 0, 0], 1)],
)
def test_lqr_gains_solve_the_riccati_equation(rho, Q, R):
    k = np.array(fl.lqr_gains(rho, Q=Q, R=R))
    A, B = _brunovsky(rho)
    Qm = np.eye(rho) if Q is None else (np.diag(Q) if np.ndim(Q) == 1 else np.asarray(Q))
    P = linalg.solve_continuous_are(A, B, Qm, np.array([[R]]))
    np.testing.assert_allclose(k, (B.T @ P).ravel() / R, rtol=1e-10)
    assert np.all(np.linalg.eigvals(A - B @ k[None, :]).real < 0)
    # P really solves the CARE
    res = A.T @ P + P @ A - P @ B @ B.T @ P / R + Qm
    assert np.abs(res).max() < 1e-9 * max(1.0, np.abs(P).max())
    fl.DynamicController(tuple(k), 1.0)


def test_lqr_double_integrator_closed_form():
    # Q = diag(q1, q2), R = 1: k_1 = sqrt(q1), k_2 = sqrt(q2 + 2 sqrt(q1))
    q1, q2 = 9.0, 2.0
    np.testing.assert_allclose(fl.lqr_gains(2, Q=[q1, q2]), [3.0, math.sqrt(q2 + 6.0)], rtol=1e-12)


@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        ({"rho": 0}, errors.ParameterError, r"rho must be >= 1"),
        ({"rho": 2.0}, errors.ParameterError, r"rho must be an integer"),
        ({"rho": 2, "R": 0.0}, errors.ParameterError, r"R must be > 0"),
        ({"rho": 2, "R": float("nan")}, errors.ParameterError, r"R must be finite"),
        ({"rho": 2, "Q": [1.0]}, errors.DimensionError, r"Q must have length 2"),
        ({"rho": 2, "Q": np.ones((3, 3))}, errors.DimensionError, r"\(2, 2\) matrix"),
        ({"rho": 2, "Q": [[1.0, 1.0], [0.0, 1.0]]}, errors.ParameterError, r"symmetric"),
        ({"rho": 2, "Q": [-1.0, 1.0]}, errors.ParameterError, r"positive semidefinite"),
        ({"rho": 2, "Q": [[1, np.nan], [np.nan, 1]]}, errors.ParameterError, r"Q must be finite"),
        ({"rho": 2, "Q": [0.0, 0.0]}, errors.ComputationError, r"LQR"),
    ],
)
def test_lqr_gains_bad_inputs(kwargs, error, match):
    with pytest.raises(error, match=match):
        fl.lqr_gains(**kwargs)


def test_antiwindup_is_a_bool_and_on_by_default():
    assert fl.DynamicController((2, 4), 1e-3).antiwindup is True
    assert "antiwindup=False" in repr(fl.DynamicController((2, 4), 1e-3, antiwindup=False))
    with pytest.raises(errors.ParameterError, match="antiwindup must be True or False, got 1"):
        fl.DynamicController((2, 4), 1e-3, antiwindup=1)
