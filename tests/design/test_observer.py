"""EHGO: the mathematics against independent computations (scipy, closed forms, fitted slopes)."""

from __future__ import annotations

import math
import warnings

import casadi
import numpy as np
import pytest
import scipy.linalg as sla
import scipy.signal as sig
from hypothesis import given, settings
from hypothesis import strategies as st

import fl_design as fl
from fl_design.errors import (
    DimensionError,
    HurwitzError,
    MissingDependencyError,
    ParameterError,
    UnstableDiscretizationWarning,
)

U = np.finfo(float).eps


def companion(coeffs):
    """F of eps q' = F q + L y, built independently of the module."""
    n = len(coeffs)
    F = np.zeros((n, n))
    F[:, 0] = -np.asarray(coeffs, dtype=float)
    F[np.arange(n - 1), np.arange(1, n)] = 1.0
    return F


def freq_resp(A, B, C, D, z):
    n = A.shape[0]
    return np.array([C @ np.linalg.solve(zk * np.eye(n) - A, B)[:, 0] + D[:, 0] for zk in z])


def unscaled_error_bound(obs):
    """First-order bound on the error of scipy's bilinear discretization of the UNSCALED observer,
    measured in the scaled coordinates q = D xhat (2-norm).

    cont2discrete solves (I - T/2 A_u) X = R by LU with partial pivoting: backward error
    |E| <= gamma_n P|L||U|, gamma_n ~ n u (Higham, Thm 9.4), in the badly scaled coordinates.
    Mapped by the exact similarity D, that perturbation is D E D^-1; the forward error is then
    at most ||(I - alpha F/2)^-1|| (||D E D^-1|| (1 + ||X_s||) + gamma_n ||D |R| D^-1||).
    Our own scaled computation adds gamma_n cond(I - alpha F/2).
    """
    n, d, T = obs.state_size, obs.scaling, obs.T
    Ac, H = obs.continuous().A, obs.continuous().B
    ima = np.eye(n) - T / 2 * Ac
    P, L, Uf = sla.lu(ima)
    Es = d[:, None] * (P @ np.abs(L) @ np.abs(Uf)) / d[None, :]
    rhs = np.abs(np.hstack([np.eye(n) + T / 2 * Ac, T * H]))
    Rs = d[:, None] * rhs / np.r_[d, 1.0][None, :]
    Ms = np.eye(n) - obs.alpha / 2 * companion(obs.alphas)
    gam = 3 * n * U
    Xs = np.linalg.norm(np.hstack(obs.matrices[:2]), 2)
    return gam * np.linalg.norm(np.linalg.inv(Ms), 2) * (
        np.linalg.norm(Es, 2) * (1 + Xs) + np.linalg.norm(Rs, 2)
    ) + gam * np.linalg.cond(Ms)


# --- transfer functions ------------------------------------------------------------------------
@pytest.mark.parametrize("rho", [1, 2, 3, 4])
@pytest.mark.parametrize("alpha", np.logspace(-4, 3, 8))
def test_bilinear_equals_unscaled_cont2discrete(rho, alpha):
    T = 1e-3
    obs = fl.EHGO(rho, T / alpha, T)
    d = obs.scaling
    with warnings.catch_warnings():  # scipy rightly warns that the unscaled matrix is ill-conditioned
        warnings.simplefilter("ignore", sla.LinAlgWarning)
        Au, Bu, Cu, Du, _ = sig.cont2discrete(tuple(obs.continuous()), T, method="bilinear")
    # the same realization in scaled coordinates q = D xhat (an exact diagonal similarity)
    ref = (d[:, None] * Au / d[None, :], d[:, None] * Bu, d[:, None] * Cu / d[None, :], d[:, None] * Du)
    delta = unscaled_error_bound(obs)
    for ours, theirs in zip(obs.matrices, ref):
        assert np.linalg.norm(ours - theirs, 2) <= delta
    # frequency responses y -> q up to the Nyquist frequency, around the observer bandwidth
    w = np.logspace(-2, 2, 9) / obs.eps
    w = w[w * T < 3.0] if np.sum(w * T < 3.0) >= 3 else np.linspace(0.1, 3.0, 9) / T
    z = np.exp(1j * w * T)
    G, Gref = freq_resp(*obs.matrices, z), freq_resp(*ref, z)
    A, B, C, _ = obs.matrices
    for k, zk in enumerate(z):  # first-order propagation of a matrix error delta through G(z)
        r = np.linalg.norm(np.linalg.inv(zk * np.eye(rho + 1) - A), 2)
        nb, nc = np.linalg.norm(B, 2), np.linalg.norm(C, 2)
        tol = delta * (nc * r * r * nb + r * nb + nc * r + 1) + 10 * U * (1 + nc * r * nb)
        assert np.linalg.norm(G[k] - Gref[k]) <= tol
        assert tol < 1e-2 * np.linalg.norm(Gref[k])  # normwise first-order bound: pessimistic, not vacuous


@pytest.mark.parametrize("method", ["forward_euler", "backward_euler", "zoh"])
def test_other_methods_equal_unscaled_cont2discrete(method):
    T, eps = 1e-3, 0.02
    obs = fl.EHGO(3, eps, T, coeffs=(10, 35, 50, 24), method=method)
    d = obs.scaling
    scipy_name = {"forward_euler": "euler", "backward_euler": "backward_diff", "zoh": "zoh"}[method]
    Au, Bu, Cu, Du, _ = sig.cont2discrete(tuple(obs.continuous()), T, method=scipy_name)
    z = np.exp(1j * np.linspace(0.01, 3.0, 7))
    np.testing.assert_allclose(
        freq_resp(*obs.matrices, z), freq_resp(Au, Bu, d[:, None] * Cu, d[:, None] * Du, z),
        rtol=1e-9, atol=1e-12,
    )


def test_default_coeffs_are_binomial_and_continuous_gains():
    obs = fl.EHGO(3, 0.1, 1e-3)
    assert obs.alphas == (4.0, 6.0, 4.0, 1.0)
    np.testing.assert_allclose(np.poly(-np.ones(4))[1:], obs.alphas)
    np.testing.assert_allclose(obs.gains, [4 / 0.1, 6 / 0.01, 4 / 1e-3, 1 / 1e-4])
    np.testing.assert_allclose(obs.alpha, 1e-2)
    np.testing.assert_allclose(obs.unscaling, 1 / np.array([1, 0.1, 0.01, 0.001]))
    Ac, H, Cc, Dc = obs.continuous()
    np.testing.assert_allclose(np.sort(np.linalg.eigvals(Ac * 0.1).real), -np.ones(4), atol=1e-3)
    assert Cc.shape == (4, 4) and Dc.shape == (4, 1) and H.shape == (4, 1)


# --- stability of the discretization -----------------------------------------------------------
@st.composite
def hurwitz_poles(draw):
    rho = draw(st.integers(1, 6))
    n_pairs = draw(st.integers(0, (rho + 1) // 2))
    mag = st.floats(math.log(0.2), math.log(5.0))
    poles = []
    for _ in range(n_pairs):
        re, im = -math.exp(draw(mag)), math.exp(draw(mag))
        poles += [complex(re, im), complex(re, -im)]
    poles += [-math.exp(draw(mag)) for _ in range(rho + 1 - 2 * n_pairs)]
    return rho, poles


@settings(max_examples=80, deadline=None, derandomize=True)
@given(hurwitz_poles(), st.floats(-4.0, 4.0), st.sampled_from(["bilinear", "backward_euler", "zoh"]))
def test_a_stable_methods_are_schur_for_every_alpha(rp, log_alpha, method):
    rho, poles = rp
    T = 1e-3
    obs = fl.EHGO.from_poles(rho, T / 10.0**log_alpha, T, poles, method=method)
    np.testing.assert_allclose(obs.alphas, np.real(np.poly(poles))[1:], rtol=1e-12)
    A = obs.matrices.A
    # independent certificate: the discrete Lyapunov equation A^T P A - P = -I has P > 0
    P = sla.solve_discrete_lyapunov(A.T, np.eye(rho + 1))
    np.linalg.cholesky((P + P.T) / 2)
    assert obs.is_schur and obs.spectral_radius < 1


def test_forward_euler_limit_against_eigenvalues():
    coeffs = (6.0, 11.0, 6.0)  # roots -1, -2, -3
    lam = np.linalg.eigvals(companion(coeffs))
    amax = np.min(-2 * lam.real / np.abs(lam) ** 2)
    np.testing.assert_allclose(amax, 2 / 3)
    T = 1e-3
    ok = fl.EHGO(2, T / (0.999 * amax), T, coeffs=coeffs, method="forward_euler")
    np.testing.assert_allclose(ok.alpha_max, amax)
    assert np.max(np.abs(np.linalg.eigvals(ok.matrices.A))) < 1 and ok.is_schur
    eps_bad = T / (1.001 * amax)
    with pytest.raises(ParameterError, match=r"alpha_max = 0\.666667.*eps_min"):
        fl.EHGO(2, eps_bad, T, coeffs=coeffs, method="forward_euler")
    with pytest.warns(UnstableDiscretizationWarning, match="forward_euler"):
        bad = fl.EHGO(2, eps_bad, T, coeffs=coeffs, method="forward_euler", allow_unstable=True)
    assert np.max(np.abs(np.linalg.eigvals(bad.matrices.A))) > 1 and not bad.is_schur


def test_forward_euler_default_coeffs_limit_is_two():
    assert fl.EHGO(6, 1.0, 1.99, method="forward_euler").is_schur
    with pytest.raises(ParameterError, match="alpha_max = 2"):
        fl.EHGO(6, 1.0, 2.0, method="forward_euler")


# --- estimation error O(eps) -------------------------------------------------------------------
@pytest.mark.parametrize("method", ["bilinear", "backward_euler"])
def test_estimation_error_is_order_eps(method):
    """y = sin t + 0.5 sin 2.3 t, rho = 2: xhat -> (y, y', y'' = sigma) with error O(eps)."""
    alpha = 0.1
    eps_list = np.array([0.08, 0.04, 0.02, 0.01])
    errs = []
    for eps in eps_list:
        obs = fl.EHGO(2, eps, alpha * eps, method=method)
        t = np.arange(0.0, 8.0, obs.T)
        truth = np.stack([np.sin(t) + 0.5 * np.sin(2.3 * t),
                          np.cos(t) + 1.15 * np.cos(2.3 * t),
                          -np.sin(t) - 0.5 * 2.3**2 * np.sin(2.3 * t)], axis=1)
        xhat = obs.filter(truth[:, 0])
        steady = t >= 4.0  # transients exp(-t/eps) long gone
        errs.append(np.max(np.abs(xhat[steady] - truth[steady]), axis=0))
    errs = np.array(errs)
    slopes = [np.polyfit(np.log(eps_list), np.log(errs[:, i]), 1)[0] for i in range(3)]
    assert min(slopes) >= 0.8, slopes


# --- protocol --------------------------------------------------------------------------------
def _run_symbolic(obs_graph, p, y):
    n = obs_graph.state_size
    xi, ys = casadi.SX.sym("xi", n), casadi.SX.sym("y")
    ps = casadi.SX.sym("p", p.size)
    xhat, xi_next, ready = obs_graph.symbolic_update(xi, ys, ps)
    f = casadi.Function("f", [xi, ys, ps], [xhat, xi_next, ready])
    x, out = obs_graph.initial_state(), []
    for yk in y:
        xh, x, r = f(x, yk, p)
        assert float(r) == 1.0
        out.append(np.asarray(xh).ravel())
    return np.array(out)


def test_symbolic_update_equals_filter():
    obs = fl.EHGO(3, 0.02, 1e-3, coeffs=(10, 35, 50, 24))
    y = np.sin(np.arange(600) * 1e-3) + 0.01 * np.random.default_rng(1).standard_normal(600)
    ref = obs.filter(y)
    scale = np.max(np.abs(ref), axis=0)  # each component relative to its own size
    np.testing.assert_allclose(_run_symbolic(obs, obs.parameter_vector(), y) / scale, ref / scale,
                               rtol=0, atol=1e-11)
    # xi = 0: the first estimate is D^-1 D_d y_0
    np.testing.assert_allclose(ref[0], obs.unscaling * obs.matrices.D[:, 0] * y[0])


def test_parameter_vector_of_another_eps_reproduces_that_observer():
    obs1 = fl.EHGO(2, 0.05, 1e-3, coeffs=(6, 11, 6))
    obs2 = obs1.replace(eps=0.01)
    assert obs2 == fl.EHGO(2, 0.01, 1e-3, coeffs=(6, 11, 6))
    y = np.cos(np.arange(400) * 2e-3)
    ref = obs2.filter(y)
    scale = np.max(np.abs(ref), axis=0)
    np.testing.assert_allclose(_run_symbolic(obs1, obs2.parameter_vector(), y) / scale, ref / scale,
                               rtol=0, atol=1e-11)


def test_filter_initial_state_and_to_statespace():
    obs = fl.EHGO(2, 0.05, 1e-3)
    y = np.random.default_rng(2).standard_normal(300)
    xi0 = np.array([0.1, -0.2, 0.3])
    # independent reference: scipy.signal.dlsim on the unscaled-output realization
    C, D = obs.output_matrices()
    _, ref, _ = sig.dlsim((obs.matrices.A, obs.matrices.B, C, D, obs.T), y, x0=xi0)
    np.testing.assert_allclose(obs.filter(y, xi0=xi0), ref, rtol=1e-10, atol=1e-10)
    sys = obs.to_statespace()
    np.testing.assert_allclose(sys.C, C)
    np.testing.assert_allclose(sys.D, D)
    assert sys.dt == obs.T and obs.flops_per_step == 2 * 9 + 2 * 3


def test_to_statespace_without_control(monkeypatch):
    monkeypatch.setitem(__import__("sys").modules, "control", None)
    with pytest.raises(MissingDependencyError, match=r"pip install fl_design\[control\]"):
        fl.EHGO(2, 0.05, 1e-3).to_statespace()


def test_replace_and_from_poles():
    obs = fl.EHGO(2, 0.05, 1e-3)
    assert obs.replace(rho=3).alphas == (4.0, 6.0, 4.0, 1.0)
    assert obs.replace(T=2e-3).alpha == pytest.approx(0.04)
    with pytest.raises(ParameterError, match="valid fields"):
        obs.replace(gamma=1.0)
    assert fl.EHGO.from_poles(2, 0.05, 1e-3, [-1, -2, -3]).coeffs == (6.0, 11.0, 6.0)
    pair = fl.EHGO.from_poles(1, 0.05, 1e-3, [-1 + 2j, -1 - 2j])
    assert pair.coeffs == pytest.approx((2.0, 5.0))
    with pytest.raises(ParameterError, match="conjugate pairs"):
        fl.EHGO.from_poles(2, 0.05, 1e-3, [-1 + 2j, -1 - 1j, -2])
    with pytest.raises(DimensionError, match="rho\\+1 = 3"):
        fl.EHGO.from_poles(2, 0.05, 1e-3, [-1, -2])
    with pytest.raises(HurwitzError, match="open left half-plane"):
        fl.EHGO.from_poles(2, 0.05, 1e-3, [-1, -2, 0.5])


# --- bad inputs --------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        ({"coeffs": (1, -1, 1)}, HurwitzError, "not in the open left half-plane"),
        ({"coeffs": (3, 3)}, DimensionError, "length 3"),
        ({"coeffs": (3, 3, 1, 1)}, DimensionError, "length 3"),
        ({"coeffs": (3, np.nan, 1)}, ParameterError, "finite"),
        ({"eps": 0.0}, ParameterError, "eps must be > 0"),
        ({"eps": -0.1}, ParameterError, "eps must be > 0"),
        ({"eps": np.nan}, ParameterError, "eps must be finite"),
        ({"T": 0.0}, ParameterError, "T must be > 0"),
        ({"T": np.inf}, ParameterError, "T must be finite"),
        ({"rho": 0}, ParameterError, "rho must be >= 1"),
        ({"rho": 7}, ParameterError, "rho must be <= 6"),
        ({"rho": 2.0}, ParameterError, "rho must be an integer"),
        ({"method": "tustin"}, ParameterError, "valid methods: 'bilinear'"),
    ],
)
def test_bad_inputs(kwargs, error, match):
    args = {"rho": 2, "eps": 0.05, "T": 1e-3} | kwargs
    with pytest.raises(error, match=match):
        fl.EHGO(**args)


def test_symbolic_update_wrong_parameter_length():
    obs = fl.EHGO(2, 0.05, 1e-3)
    with pytest.raises(DimensionError, match="p must be a vector of length 27"):
        obs.symbolic_update(casadi.SX.sym("xi", 3), casadi.SX.sym("y"), casadi.SX.sym("p", 5))


@pytest.mark.parametrize("rho", [1, 2, 3, 4, 6])
@pytest.mark.parametrize("alpha", np.logspace(-4, 3, 8))
def test_bilinear_is_the_continuous_observer_at_the_tustin_frequency(rho, alpha):
    """Closed form: G_d(z) = G_c(s) with s = (2/T)(z-1)/(z+1); in scaled coordinates
    G_c = (eps s I - F)^-1 L, well conditioned for every alpha, so the tolerance is tight."""
    T = 1e-3
    obs = fl.EHGO(rho, T / alpha, T)
    n = rho + 1
    F = companion(obs.alphas)
    L = np.asarray(obs.alphas, dtype=float)
    w = np.logspace(-2, 2, 9) / obs.eps
    w = w[w * T < 3.0]
    if w.size < 3:
        w = np.linspace(0.1, 3.0, 9) / T
    z = np.exp(1j * w * T)
    Gd = freq_resp(*obs.matrices, z)
    eps_s = (2.0 / obs.alpha) * (z - 1.0) / (z + 1.0)
    Gc = np.array([np.linalg.solve(es * np.eye(n) - F, L) for es in eps_s])
    np.testing.assert_allclose(Gd, Gc, rtol=1e-8, atol=1e-12 * np.abs(Gc).max())
