"""Quartic SOS certificate of the varying coverage against independent computations."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

import fl_design as fl
from fl_design.analysis._certify import _Loop
from fl_design.analysis._lmi import vertex_lmi
from fl_design.analysis._refute import switching_refutation
from fl_design.analysis._sos import (
    gram_slack_basis,
    lift,
    lift_delta,
    pairs,
    recheck_sos,
    sos_certificate,
    sos_lyapunov,
)
from tests.oracles import B_TRMS, paper_surrogate


def _z(x):
    return np.array([x[i] * x[j] for i, j in pairs(len(x))])


@pytest.mark.parametrize("seed", [0, 1])
def test_lift_maps_the_monomials(seed):
    rng = np.random.default_rng(seed)
    n = 4
    M, D, x = rng.normal(size=(n, n)), rng.normal(size=(n, n)), rng.normal(size=n)
    np.testing.assert_allclose(lift(M) @ _z(x), _z(M @ x), rtol=1e-12, atol=1e-12)
    Tn = 1e-3
    np.testing.assert_allclose(np.eye(len(pairs(n))) + Tn * lift_delta(D, Tn),
                               lift(np.eye(n) + Tn * D), rtol=0, atol=1e-14)


@pytest.mark.parametrize("n", [2, 3, 5])
def test_gram_slack_basis_is_the_whole_null_space(n):
    """z^T N z == 0 for each basis N; their number is dim(sym) - dim(quartic forms)."""
    rng = np.random.default_rng(n)
    B = gram_slack_basis(n)
    m = len(pairs(n))
    assert B.shape[0] == m * (m + 1) // 2 - math.comb(n + 3, 4)
    for x in rng.normal(size=(5, n)):
        z = _z(x)
        assert np.max(np.abs(np.einsum("a,kab,b->k", z, B, z))) < 1e-12
    flat = B.reshape(B.shape[0], -1)
    assert np.linalg.matrix_rank(flat) == B.shape[0]  # independent


def _oscillators(damping):
    """Two damped oscillators x'' = -k x, k = 1 and 4 (Euler at T = 0.01: Delta = A)."""
    A1 = np.array([[-damping, 1.0], [-1.0, -damping]])
    A2 = np.array([[-damping, 1.0], [-4.0, -damping]])
    return A1, A2


def _no_cqlf_shorten_narendra(A1, A2) -> bool:
    """Closed form (Shorten and Narendra, 2x2 Hurwitz pairs): a common quadratic Lyapunov
    function exists iff A1 A2 and A1 A2^-1 have no real negative eigenvalue."""
    def neg_real(M):
        return any(abs(w.imag) < 1e-12 and w.real < 0 for w in np.linalg.eigvals(M))
    return neg_real(A1 @ A2) or neg_real(A1 @ np.linalg.inv(A2))


def _random_switching_growth(Ms, steps, seed):
    """Largest ||x_k|| / ||x_0|| along random switching from 20 unit starts (no fl_design)."""
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(Ms[0].shape[0], 20))
    X /= np.linalg.norm(X, axis=0)
    dwell = rng.integers(1, 200, size=steps)
    k, worst, which = 0, 0.0, 0
    for d in dwell:
        X = np.linalg.matrix_power(Ms[which], int(d)) @ X
        which, k = 1 - which, k + int(d)
        if k > steps:
            break
    worst = float(np.max(np.linalg.norm(X, axis=0)))
    return worst


def test_sos_certifies_a_pair_without_common_quadratic_lyapunov_function():
    """Stable under arbitrary switching, no CQLF (closed form), SOS degree 4 certifies."""
    Tn = 1e-2
    A1, A2 = _oscillators(0.4)
    assert _no_cqlf_shorten_narendra(A1, A2)
    # discrete CQLF for I + T A_i would be a continuous one too (A^T P + P A < -T A^T P A)
    assert not vertex_lmi([A1, A2], Tn, common=True).certified
    sol = sos_certificate([A1, A2], Tn)
    assert sol.certified and sol.margin > 1e-9
    Ms = [np.eye(2) + Tn * A for A in (A1, A2)]
    # independent: no switching of the exhaustive short products or the search grows
    worst_short = max(np.max(np.abs(np.linalg.eigvals(np.linalg.multi_dot(
        [np.linalg.matrix_power(Ms[i % 2], d) for i, d in enumerate(seq)]))))
        for seq in itertools.product((20, 50, 80, 120, 160), repeat=4))
    assert worst_short < 1.0
    assert switching_refutation(lambda b: Ms[int(b)], 0.0, 1.0, None).radius < 1.0
    assert _random_switching_growth(Ms, 20000, seed=3) < 1e-3  # decays (40 time units)


def test_sos_fails_where_switching_diverges():
    """Soundness: damping 0.25 has a diverging periodic switching; no SOS certificate."""
    Tn = 1e-2
    A1, A2 = _oscillators(0.25)
    Ms = [np.eye(2) + Tn * A for A in (A1, A2)]
    ref = switching_refutation(lambda b: Ms[int(b)], 0.0, 1.0, None)
    assert ref.refuted
    assert not sos_certificate([A1, A2], Tn).certified


def test_recheck_rejects_a_certificate_of_other_matrices():
    """The NumPy re-check is the proof: the Gram matrices of a stable pair fail on an
    unstable pair (negative margin), and pass on their own."""
    Tn = 1e-2
    good = list(_oscillators(0.4))
    sol = sos_lyapunov(good, Tn)
    assert sol.certified and recheck_sos(sol.Q, sol.N, good, Tn) > 1e-9
    assert recheck_sos(sol.Q, sol.N, list(_oscillators(0.1)), Tn) < 0.0


def _dense_dwell_radius(eps, step=8, top=1600):
    """Independent attack (oracle matrices): every dwell pair (a, c) on a uniform grid, the
    period ``M_hi^c M_lo^a``'s spectral radius, worst over the grid."""
    Ms = [paper_surrogate(eps, b) for b in B_TRMS]
    grid = range(step, top, step)

    def powers(M):
        out, acc, k = [], np.eye(7), 0
        for a in grid:
            while k < a:
                acc, k = M @ acc, k + 1
            out.append(acc.copy())
        return np.stack(out)

    P_lo, P_hi = powers(Ms[0]), powers(Ms[1])
    prod = np.einsum("cij,ajk->acik", P_hi, P_lo)
    return float(np.abs(np.linalg.eigvals(prod)).max())


def test_dense_dwell_attack_has_power():
    """The attack used below finds growth just above the refuted end (0.1214)."""
    assert _dense_dwell_radius(0.1215) > 1.001


def test_design_eps_between_common_p_and_sos_is_certified():
    c = fl.certify_eps(fl.presets.paper_design(eps=0.1), B_TRMS, search=False)
    assert c.certified and c.point.kind == "SOS degree 4" and c.point.covers == "varying"
    assert "common P" in c.point.reason
    assert _dense_dwell_radius(0.1) < 1.0


@pytest.fixture(scope="module")
def trms_loop():
    return _Loop(fl.presets.paper_design(gamma=3e-4), B_TRMS, None, 41, 8)


def test_trms_sos_certifies_beyond_common_p_and_survives_a_dwell_attack(trms_loop):
    from fl_design.analysis._coverage import sos_point

    L = trms_loop
    eps = 0.11  # common P stops at ~0.0814, switching diverges from ~0.1237
    assert not L.point(eps, 3e-4, common_only=True).certified
    sol = sos_point(L, eps, 3e-4)
    assert sol.certified and "quartic SOS" in sol.note
    assert _dense_dwell_radius(0.99 * eps) < 1.0


def test_trms_sos_refuses_a_refuted_eps(trms_loop):
    from fl_design.analysis._coverage import refute, sos_point

    eps = 0.125
    assert refute(trms_loop, eps, 3e-4, None).refuted
    assert not sos_point(trms_loop, eps, 3e-4).certified
