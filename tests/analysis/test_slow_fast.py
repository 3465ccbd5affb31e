"""Certificates of rho = 3 and 4 classes in slow-fast coordinates (issue 33: 0 of 12 gains
were certified, Clarabel failing numerically on the loop's own coordinates).

Each certificate is re-checked independently of the package's re-check: in the loop's own
coordinates, with the loop matrix ``M(b)`` at the ends of each piece and Cholesky
factorizations in 60-digit arithmetic (mpmath), and its eps compared with the frozen-b
eigenvalue boundary (the refutation)."""

import itertools

import mpmath
import numpy as np
import pytest
import scipy.linalg

import fl_design as fl
from fl_design.analysis._certify import _Loop
from fl_design.analysis._slow_fast import slow_fast_coordinates
from fl_design.analysis._surrogate import delta

T = 1e-3


def _design(rho: int, gamma: float):
    gains = fl.synthesize_gains(rho, decay=1.0).gains
    return fl.Design(estimator=fl.EHGO(rho, 10 * T, T),
                     controller=fl.DynamicController(gains, gamma))


def _lyapunov_mp(P, M) -> tuple[bool, bool]:
    """``P > 0`` and ``P - M^T P M > 0`` for the float matrices ``P`` and ``M``, the products
    and Cholesky factorizations in 60 digits (no float rounding decides)."""
    out = []
    with mpmath.workdps(60):
        Pm, Mm = mpmath.matrix(P.tolist()), mpmath.matrix(M.tolist())
        Pm = (Pm + Pm.T) / 2
        for A in (Pm, Pm - Mm.T * Pm * Mm):
            try:
                mpmath.cholesky((A + A.T) / 2)
                out.append(True)
            except ValueError:
                out.append(False)
    return tuple(out)


@pytest.mark.parametrize(("rho", "b_max"), [(3, 5.0), (4, 2.0)])
def test_slow_fast_coordinates_are_a_similarity_that_decouples(rho, b_max):
    L = _Loop(_design(rho, 0.5 / b_max), (1.0, b_max), None, 41, 8)
    M0, M1 = L.loop.parts(0.005, 0.02)
    D = [delta(M0 + b * M1, T) for b in (1.0, b_max)]
    E, K, err, S = slow_fast_coordinates(D, rho)
    assert S == list(range(rho))  # x slow; u and the observer fast at this gain
    for Dv, Ev in zip(D, E):  # the same spectrum as the loop's own delta: its eigenvalues
        # in 40 digits (in float64 the near-repeated slow cluster is off by ~1e-5)
        with mpmath.workdps(40):
            ref = np.array([complex(z) for z in mpmath.eig(mpmath.matrix(Dv.tolist()))[0]])
        got = scipy.linalg.eigvals(Ev)
        for z in ref:
            assert np.min(np.abs(got - z)) <= 1e-7 * abs(z)
        # and E = K D K^-1 (K maps the loop's coordinates to the new ones)
        assert np.linalg.norm(K @ Dv @ np.linalg.inv(K) - Ev, 2) <= 1e-6 * np.linalg.norm(Ev, 2)
    # the rounding bound of the similarity (cond ~1e5 at rho = 4) stays far below the LMI
    # margins (~1e-5 relative)
    assert 0.0 < err < 1e-6 * np.linalg.norm(E[0], 2)
    # the middle delta is block diagonal: slow x_1..x_rho against the fast rest
    Em = 0.5 * (E[0] + E[1])
    slow, fast = np.arange(rho), np.arange(rho, Em.shape[0])
    coupling = np.abs(Em[np.ix_(slow, fast)]).max() + np.abs(Em[np.ix_(fast, slow)]).max()
    assert coupling < 1e-8 * np.abs(Em).max()


def test_slow_fast_coordinates_none_without_two_time_scales():
    D = -np.eye(8) + np.diag(np.ones(7), 1)  # one repeated eigenvalue: no separation
    assert slow_fast_coordinates([D, D], 3) is None


@pytest.mark.parametrize(("rho", "b_max", "gamma", "eps"),
                         [(3, 5.0, 0.02, 0.005), (4, 2.0, 0.02, 0.002), (4, 2.0, 0.02, 0.005)])
def test_rho3_rho4_certificate_holds_in_the_loops_coordinates(rho, b_max, gamma, eps):
    L = _Loop(_design(rho, 0.5 / b_max), (1.0, b_max), None, 41, 8)
    pc = L.point(eps, gamma)
    assert pc.certified, pc.reason
    M0, M1 = L.loop.parts(eps, gamma)
    pieces = pc.b_pieces
    assert pieces[0][0] == 1.0 and pieces[-1][1] == b_max
    assert all(a[1] == b[0] for a, b in itertools.pairwise(pieces))  # they cover [1, b_max]
    for (lo, hi), (P_lo, P_hi) in zip(pieces, pc.lyapunov):
        for b, P in ((lo, P_lo), (hi, P_hi)):
            # P > 0, and V decreases along the loop at this b
            assert _lyapunov_mp(P, M0 + b * M1) == (True, True)


@pytest.mark.slow
@pytest.mark.parametrize(("rho", "b_max"), [(3, 5.0), (4, 2.0)])
def test_rho3_rho4_curve_certifies_close_to_the_frozen_boundary(rho, b_max):
    gammas = [0.02 / b_max, 0.2 / b_max]
    c = fl.eps_star_curve(_design(rho, 0.5 / b_max), fl.PlantClass(rho=rho, T=T, b=(1.0, b_max)),
                          gammas)
    assert np.all(np.isfinite(c.eps_star_frozen))
    # sound (never above the eigenvalue refutation) and not a numerical 0
    assert np.all(c.eps_star_certified <= c.eps_star_frozen)
    assert np.all(c.eps_star_certified >= 0.9 * c.eps_star_frozen)


def test_exact_similarity_is_the_correctly_rounded_product():
    """``E_v`` against the same similarity in exact rational arithmetic (fractions): each
    entry the double nearest the exact value, and ``err`` bounds the 2-norm of the error."""
    from fractions import Fraction

    from fl_design.analysis._slow_fast import _exact_similarity

    rng = np.random.default_rng(3)
    n, S = 6, [0, 1]
    F = [i for i in range(n) if i not in S]
    Lb, Hb = np.zeros((n, n)), np.zeros((n, n))
    Lb[np.ix_(F, S)] = rng.normal(size=(len(F), len(S))) * 10.0 ** rng.integers(-3, 4, (4, 2))
    Hb[np.ix_(S, F)] = rng.normal(size=(len(S), len(F))) * 1e-3
    s0, s1 = 2.0 ** rng.integers(-8, 8, n), 2.0 ** rng.integers(-8, 8, n)
    D = [rng.normal(size=(n, n)) * 10.0 ** rng.integers(-4, 4, (n, n)) for _ in range(2)]
    E, K, err, S_out = _exact_similarity(D, Lb, Hb, s0, s1, S)
    assert S_out == S

    def q(M):
        return [[Fraction(float(x)) for x in row] for row in np.asarray(M)]

    def mul(A, B):
        return [[sum(A[i][k] * B[k][j] for k in range(len(B))) for j in range(len(B[0]))]
                for i in range(len(A))]

    eye = [[Fraction(int(i == j)) for j in range(n)] for i in range(n)]
    Lq, Hq = q(Lb), q(Hb)
    Ki = mul(mul([[Fraction(int(i == j)) / Fraction(s1[i]) for j in range(n)] for i in range(n)],
                 [[eye[i][j] - Hq[i][j] for j in range(n)] for i in range(n)]),
             mul([[eye[i][j] - Lq[i][j] for j in range(n)] for i in range(n)],
                 [[Fraction(int(i == j)) / Fraction(s0[i]) for j in range(n)] for i in range(n)]))
    Kinv = mul(mul([[Fraction(int(i == j)) * Fraction(s0[i]) for j in range(n)] for i in range(n)],
                   [[eye[i][j] + Lq[i][j] for j in range(n)] for i in range(n)]),
               mul([[eye[i][j] + Hq[i][j] for j in range(n)] for i in range(n)],
                   [[Fraction(int(i == j)) * Fraction(s1[i]) for j in range(n)] for i in range(n)]))
    assert mul(Ki, Kinv) == eye  # an exact inverse pair
    assert np.array_equal(K, np.array([[float(x) for x in row] for row in Ki]))
    u = np.finfo(float).eps / 2
    for Dv, Ev in zip(D, E):
        exact = mul(mul(Ki, q(Dv)), Kinv)
        nearest = np.array([[float(x) for x in row] for row in exact])  # correctly rounded
        assert np.array_equal(Ev, nearest)
        diff = np.array([[float(Fraction(float(Ev[i, j])) - exact[i][j]) for j in range(n)]
                         for i in range(n)])
        assert np.all(np.abs(diff) <= u * np.abs(Ev) * (1 + 4 * u))
        assert np.linalg.norm(diff, 2) <= err
