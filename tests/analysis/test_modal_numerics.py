"""The closed-form modal certificates on ill-posed input: a b-range that crosses instability
and a P whose Cholesky factor does not exist in floating point (issue 33: both raised a raw
LinAlgError from a 12-gain curve of a rho = 2 and a rho = 4 class)."""

import numpy as np
import pytest

from fl_design.analysis._analytic import _whitened, piecewise_modal
from fl_design.analysis._lmi import RECHECK_TOL, recheck_stack


def test_piecewise_modal_range_crossing_instability_names_the_failing_piece():
    # Delta(b) has the eigenvalue b: Hurwitz for b < 0 only; the halving reaches a piece
    # whose midpoint has no modal P (NaN) - it must fail there, not raise from LAPACK
    def delta_at(b):
        return np.array([[-1.0, 0.0, 0.0], [0.0, b, 1.0], [0.0, 0.0, -2.0]])

    done, _margin, bad = piecewise_modal(delta_at, -1.0, 1.0, 1e-3, 0.1)
    # the piece named is one of min width that reaches the unstable b >= 0
    assert bad is not None and bad[1] >= 0.0 and bad[1] - bad[0] <= 0.1 * (1 + 1e-9)
    for lo, hi, P, _ in done:  # what was certified holds, re-checked independently
        assert hi <= 0.0
        for b in (lo, hi):
            D = delta_at(b)
            # the delta-form decrease: D^T P + P D + T D^T P D < 0 and P > 0
            assert np.all(np.linalg.eigvalsh(P) > 0)
            assert np.all(np.linalg.eigvalsh(D.T @ P + P @ D + 1e-3 * D.T @ P @ D) < 0)


def _no_cholesky(seed: int) -> np.ndarray:
    """A symmetric P whose eigvalsh are > 0 but whose Cholesky factorization fails."""
    rng = np.random.default_rng(seed)
    for _ in range(100000):
        Q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
        P = Q @ np.diag([1.0, 1.0, 10 ** rng.uniform(-18, -15)]) @ Q.T
        P = (P + P.T) / 2
        if np.all(np.linalg.eigvalsh(P) > 0):
            try:
                np.linalg.cholesky(P)
            except np.linalg.LinAlgError:
                return P
    raise AssertionError("no such matrix found")


def test_whitened_skips_a_p_without_cholesky_factor_and_whitens_the_others(seed=0):
    T = 1e-3
    bad = _no_cholesky(seed)
    good = np.diag([1.0, 1e-6, 1e-13])  # ill-conditioned: plain margin fails, whitened passes
    D = -np.eye(3)
    P = np.stack([good, bad])
    ends = np.stack([D, D, D, D])
    plain = np.minimum(*np.split(recheck_stack(np.concatenate([P, P]),
                                               np.concatenate([P, P]), ends, T), 2))
    assert np.all(plain <= RECHECK_TOL)  # both need the whitened re-check
    out = _whitened(P, ends, T, plain)
    assert out[1] == plain[1]  # no factor: the plain margin, never a raised LinAlgError
    alone = _whitened(P[:1], ends[[0, 2]], T, plain[:1])
    assert out[0] == alone[0] and out[0] > RECHECK_TOL  # the other one still whitened


@pytest.mark.parametrize("seed", [1, 2])  # 1: covered by 2 pieces; 2: fails near b = 50
def test_piecewise_modal_batched_deltas_give_the_same_pieces(seed):
    # Delta(b) affine in b with eigenvalues moving a lot over [1, 50]: several pieces
    rng = np.random.default_rng(seed)
    A0 = rng.standard_normal((4, 4)) - 2.0 * np.eye(4)
    A1 = rng.standard_normal((4, 4)) - 1.0 * np.eye(4)
    one = piecewise_modal(lambda b: A0 + b * A1 / 49.0, 1.0, 50.0, 1e-3, 0.05)
    many = piecewise_modal(lambda b: A0 + b * A1 / 49.0, 1.0, 50.0, 1e-3, 0.05,
                           lambda bs: A0 + bs[:, None, None] * A1 / 49.0)
    assert len(one[0]) > 1 and one[2] == many[2] and one[1] == many[1]
    assert [(a, b) for a, b, _, _ in one[0]] == [(a, b) for a, b, _, _ in many[0]]
    assert all(np.array_equal(p[2], q[2]) for p, q in zip(one[0], many[0]))
