"""Switching refutations: the common-mode guide and the maximum-principle polish."""

from __future__ import annotations

import numpy as np
import pytest

from fl_design.analysis._refute import (
    common_modes,
    guide_rate,
    pontryagin_period,
    switching_refutation,
)
from tests.oracles import B_TRMS, paper_surrogate


def _radius(Ms, seq):
    acc = np.eye(Ms[0].shape[0])
    for s in seq:
        acc = Ms[s] @ acc
    return float(np.max(np.abs(np.linalg.eigvals(acc))))


def test_guide_leaves_out_only_the_common_floor():
    A, B = np.diag([0.99, 0.5, 0.3]), np.diag([0.99, 0.2, 0.6])
    assert common_modes(A, B).tolist() == [0.99]
    mod = np.array([[0.99 ** 10, 0.7, 0.1], [0.99 ** 10, 1.2, 0.1]])
    r = guide_rate(mod, np.array([10, 10]), common_modes(A, B))
    np.testing.assert_allclose(r, np.log([0.7, 1.2]) / 10)
    assert guide_rate(mod, np.array([10, 10]), np.array([])).tolist() == pytest.approx(
        [np.log(0.99), np.log(1.2) / 10])  # the floor 0.99^10 counts when not left out


def test_trms_refutation_below_the_old_bound_checked_with_oracle_matrices():
    """eps = 0.1205: a dwell pair near (613, 433) grows (the log-grid search stopped at 0.1237
    while the integrator's floor hid the other eigenvalues)."""
    eps = 0.1205
    Ms = [paper_surrogate(eps, b) for b in B_TRMS]
    r = switching_refutation(lambda b: Ms[int(b == B_TRMS[1])], *B_TRMS, None)
    assert r.refuted
    seq = [int(b == B_TRMS[1]) for b, n in r.runs for _ in range(n)]
    assert len(seq) == r.period and _radius(Ms, seq) > 1.0 + 1e-4


@pytest.mark.parametrize("seed", [0, 2])
def test_pontryagin_climbs_from_a_random_period_to_a_growing_extremal(seed):
    """Two damped oscillators (k = 1, 4; damping 0.25) at T = 0.01: from a random bang-bang
    period of 213 samples that does not grow, the maximum principle reaches one that does
    (radius checked by multiplying out), an extremal with 2 switches."""
    Tn, damping = 1e-2, 0.25
    A1 = np.eye(2) + Tn * np.array([[-damping, 1.0], [-1.0, -damping]])
    A2 = np.eye(2) + Tn * np.array([[-damping, 1.0], [-4.0, -damping]])
    rng = np.random.default_rng(seed)
    start = []
    while len(start) < 213:
        start += [int(rng.integers(0, 2))] * int(rng.integers(20, 120))
    start = start[:213]
    assert _radius((A1, A2), start) < 1.0
    seq, radius, bad = pontryagin_period(A1, A2, start, iters=60)
    assert radius == pytest.approx(_radius((A1, A2), seq), rel=1e-12)
    assert radius > 1.1 and bad == 0 and np.count_nonzero(np.diff(seq)) == 2


def test_trms_best_dwell_pair_is_a_maximum_principle_extremal():
    eps = 0.12
    Ms = [paper_surrogate(eps, b) for b in B_TRMS]
    seq, radius, bad = pontryagin_period(Ms[0], Ms[1], [0] * 616 + [1] * 432)
    assert bad == 0 and seq == [0] * 616 + [1] * 432 and radius < 1.0
