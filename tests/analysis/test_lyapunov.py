"""certify_lyapunov / synthesize_gains against closed forms and independent linear algebra."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import scipy.linalg

import fl_design as fl
from fl_design.errors import DimensionError, HurwitzError, ParameterError
from tests.oracles import chain_zoh_closed_form


def _kron_lyapunov(Ac, Q):
    """P from the Kronecker form (I (x) A^T + A^T (x) I) vec(P) = -vec(Q)."""
    n = Ac.shape[0]
    K = np.kron(np.eye(n), Ac.T) + np.kron(Ac.T, np.eye(n))
    return np.linalg.solve(K, -Q.reshape(-1)).reshape(n, n)


@pytest.mark.parametrize("gains,Q", [((2.0, 4.0), None), ((6.0, 11.0, 6.0), np.diag([1, 2, 3.0])),
                                     ((1.0, 4.0, 6.0, 4.0), None)])
def test_P_x_solves_the_lyapunov_equation_and_the_lmi(gains, Q):
    c = fl.certify_lyapunov(gains, Q)
    rho = len(gains)
    Ac = np.eye(rho, k=1)
    Ac[-1] = -np.asarray(gains)
    Qm = np.eye(rho) if Q is None else Q
    np.testing.assert_allclose(c.P_x, _kron_lyapunov(Ac, Qm), rtol=1e-10, atol=1e-12)
    assert np.linalg.eigvalsh(c.P_x)[0] > 0
    np.testing.assert_allclose(c.P_lmi, c.P_x, rtol=1e-5, atol=1e-6)
    assert c.lambda_x == np.linalg.eigvalsh(Qm)[0] / 2 and c.certified


def test_rho_one_closed_form():
    c = fl.certify_lyapunov((3.0,), [[2.0]], T=0.01)
    assert c.P_x[0, 0] == pytest.approx(2.0 / (2 * 3.0), rel=1e-14)
    # M_T = 1 - 3 T exactly: (M^2 - 1) P = -lambda_min(Q) T + H T^2 with H = 9 P
    assert c.H == pytest.approx(9.0 * c.P_x[0, 0], rel=1e-9)
    assert c.T_bound == pytest.approx(min(0.01, 1.0 / c.H), rel=1e-12)


def test_decrease_along_the_approximate_model():
    gains, T = (2.0, 4.0), 0.05
    c = fl.certify_lyapunov(gains, T=T)
    lam_q = 2 * c.lambda_x
    rng = np.random.default_rng(0)
    for t in (T, T / 3, T / 10):
        Phi, Gam = chain_zoh_closed_form(2, t)
        M = Phi - np.outer(Gam, gains)
        for x in rng.standard_normal((20, 2)):
            dV = (M @ x) @ c.P_x @ (M @ x) - x @ c.P_x @ x
            assert dV <= -lam_q * t * (x @ x) + c.H * t * t * (x @ x) + 1e-15
            if t <= c.T_bound:
                assert dV <= -c.lambda_x * t * (x @ x)
    assert c.decrease_holds
    json.dumps(c.to_dict(), allow_nan=False)


def test_large_T_breaks_the_decrease():
    c = fl.certify_lyapunov((2.0, 4.0), T=2.0)
    assert c.decrease_holds is False and not c.certified and c.T_bound < 2.0


@pytest.mark.parametrize("rho,decay", [(r, d) for r in range(1, 7) for d in (0.5, 2.0, 4.0)])
def test_synthesized_gains_meet_the_decay(rho, decay):
    s = fl.synthesize_gains(rho, decay=decay)
    assert s.certified
    roots = np.roots(np.concatenate([[1.0], np.asarray(s.gains)[::-1]]))
    assert np.max(roots.real) <= -decay
    assert np.min(roots.real) >= -1.1 * decay  # no pole much faster than asked
    np.testing.assert_allclose(np.asarray(s.gains)[::-1], np.poly([-1.02 * decay] * rho)[1:],
                               rtol=1e-12)
    A = np.eye(rho, k=1)
    A[-1] -= s.gains
    if rho > 4:  # P's condition number (~1e28 at rho = 6) is beyond a check in these coordinates
        return
    A += decay * np.eye(rho)  # the stored P > 0 proves the decay (Jacobi-scaled check)
    J = np.diag(1.0 / np.sqrt(np.diag(s.P)))
    assert np.linalg.eigvalsh(J @ s.P @ J)[0] > 0
    assert np.linalg.eigvalsh(J @ (A.T @ s.P + s.P @ A) @ J)[-1] < 0
    fl.DynamicController(s.gains, 1e-3)  # accepted as Hurwitz gains


def test_paper_decay_gives_slow_small_gains():
    """rho = 2, decay 0.5: no pole faster than ~-5 (the LMI gave a pole at -145 rad/s)."""
    s = fl.synthesize_gains(2, decay=0.5)
    assert s.certified and max(s.gains) < 2.0 and np.min(s.eigenvalues.real) > -5.0


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_all_poles_at_minus_decay_are_the_smallest_gains(seed):
    """Any polynomial with roots of real part <= -d has coefficients >= those of (s + d)^rho."""
    rng = np.random.default_rng(seed)
    d, rho = 0.7, 4
    floor = np.poly([-d] * rho)
    for _ in range(200):
        re = -d - rng.exponential(1.0, 2)
        im = rng.normal(0.0, 2.0, 2)
        roots = np.concatenate([re + 1j * im, re - 1j * im])
        assert np.all(np.poly(roots).real >= floor * (1 - 1e-12))


def test_gains_above_max_gain_are_not_certified():
    s = fl.synthesize_gains(3, decay=50.0)
    assert not s.certified and "max_gain" in s.solver_status
    with pytest.raises(ParameterError, match="decay"):
        fl.synthesize_gains(2, decay=-1.0)


@pytest.mark.parametrize("Q,err,match", [
    ([[1.0, 0.5], [0.0, 1.0]], ParameterError, "symmetric"),
    ([[1.0, 0.0], [0.0, -1.0]], ParameterError, "positive definite"),
    (np.eye(3), DimensionError, "2x2"),
    ([[1.0, math.nan], [math.nan, 1.0]], ParameterError, "finite"),
])
def test_bad_Q(Q, err, match):
    with pytest.raises(err, match=match):
        fl.certify_lyapunov((2.0, 4.0), Q)


def test_bad_gains():
    with pytest.raises(HurwitzError):
        fl.certify_lyapunov((2.0, -4.0))


@pytest.mark.parametrize("gamma,alpha", [(3e-4, 0.02), (3e-3, 1.0)])
def test_theorem1_constants_bound_the_decrease(gamma, alpha):
    """Vbar(F) - Vbar <= -lambda_x h|x|^2 - lambda_u e^2 + H h^2 (|x|^2 + e^2) on random states,
    the loop stepped independently (closed-form ZOH of the chain, e_u = K x - b u)."""
    from fl_design.analysis import theorem1_constants

    c = theorem1_constants((2.0, 4.0), gamma, (3.6, 6.8), alpha=alpha)
    assert c.lambda_x == 0.5 and 0 < c.eps_star < np.inf
    assert c.lambda_u == pytest.approx(min(1 - (1 - b * gamma) ** 2 for b in (3.6, 6.8)) / 4)
    P = scipy.linalg.solve_continuous_lyapunov(np.array([[0.0, 1.0], [-2.0, -4.0]]).T,
                                               -np.eye(2))
    K = -np.array([2.0, 4.0])
    rng = np.random.default_rng(5)
    for h in np.geomspace(1e-7, alpha, 15):
        Phi, Gam = chain_zoh_closed_form(2, h)
        for b in (3.6, 5.0, 6.8):
            for _ in range(20):
                x, e = rng.normal(size=2), rng.normal()
                u = (K @ x - e) / b
                x1 = Phi @ x + Gam * b * u
                u1 = u + gamma * e
                e1 = K @ x1 - b * u1
                dV = x1 @ P @ x1 + e1 ** 2 / 2 - x @ P @ x - e ** 2 / 2
                bound = (-c.lambda_x * h * (x @ x) - c.lambda_u * e ** 2
                         + c.H * h ** 2 * (x @ x + e ** 2))
                assert dV <= bound + 1e-12 * (x @ x + e ** 2), (h, b)
