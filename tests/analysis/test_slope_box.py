"""A class with a slope box for a: the second-order sample-map model, its certificates, and the
members no eps stabilizes.

Oracles: SciPy ``expm`` of random piecewise-constant slope and b paths inside the box (the
transition over one sample, and its two time averages in closed form), the test oracle's
surrogate loop matrix (tests/oracles.py) with the plant block replaced by those transitions,
and ``numpy.linalg.eigvals`` of the sampled loop of one frozen member.
"""

from __future__ import annotations

import itertools

import numpy as np
import scipy.linalg

import fl_design as fl
from fl_design.analysis._certify import _Loop
from fl_design.analysis._class_bracket import no_stable_eps
from fl_design.analysis._ldi import _remainder_bound
from fl_design.analysis._sample_model import second_order_maps
from tests.oracles import surrogate_loop_matrix

T = 1e-3
A_BOX = ((-0.2, 0.2), (-0.1, 0.1))
B_RNG = (1.0, 5.0)
GAINS = fl.synthesize_gains(2, decay=1.0).gains


def _X(a1, a2, b):
    return np.array([[0.0, 1.0, 0.0], [a1, a2, b], [0.0, 0.0, 0.0]])


def _vertices():
    return np.stack([_X(a1, a2, b) for a1 in A_BOX[0] for a2 in A_BOX[1] for b in B_RNG])


def _random_path(rng, pieces):
    """A piecewise-constant (a1, a2, b) path over one sample, bang-bang and interior values:
    its transition, and its two time averages (weights 1/T and 2 (T - s)/T^2), exactly."""
    cuts = np.sort(rng.uniform(0.0, T, pieces - 1))
    t = np.concatenate([[0.0], cuts, [T]])
    lo = np.array([A_BOX[0][0], A_BOX[1][0], B_RNG[0]])
    hi = np.array([A_BOX[0][1], A_BOX[1][1], B_RNG[1]])
    Psi, avg1, avg2 = np.eye(3), np.zeros(3), np.zeros(3)
    for s0, s1 in itertools.pairwise(t):
        v = rng.uniform(lo, hi) if rng.random() < 0.5 else np.where(rng.random(3) < 0.5, lo, hi)
        Psi = scipy.linalg.expm((s1 - s0) * _X(*v)) @ Psi
        avg1 += (s1 - s0) / T * v
        avg2 += ((T - s0) ** 2 - (T - s1) ** 2) / T ** 2 * v  # int (T - s) ds * 2 / T^2
    return Psi, avg1, avg2


def test_second_order_model_encloses_every_time_varying_sample_map():
    Xs = _vertices()
    m = second_order_maps(Xs, T, 2)
    Xc = 0.5 * (Xs.max(axis=0) + Xs.min(axis=0))
    c = Xc[1]  # the centre of the varying row (a1, a2, b)
    half = np.abs(Xs[:, 1] - c).max(axis=0)
    E = scipy.linalg.expm(T * Xc)
    rng = np.random.default_rng(11)
    for _ in range(300):
        Psi, avg1, avg2 = _random_path(rng, int(rng.integers(1, 12)))
        d1, d2 = avg1 - c, avg2 - c
        # the two averages: the first in the box, their difference in half of it
        assert np.all(np.abs(d1) <= half * (1 + 1e-12))
        assert np.all(np.abs(d2 - d1) <= 0.5 * half * (1 + 1e-12) + 1e-15)
        model = E.copy()
        model[1] += T * d1
        model += 0.5 * T * T * np.outer(Xc[:, 1], d2)
        assert np.all(np.abs(Psi - model) <= m.Rbar)
    # the model's pairs are the corners of (box) x (box / 2): 8 corners -> 64 maps, and the
    # corner's own map (avg_2 = avg_1) is its exact ZOH up to the remainder
    assert len(m.lmi) == 8 and len(m.pairs) == 64
    for X, P in zip(Xs, m.lmi):
        assert np.all(np.abs(scipy.linalg.expm(T * X) - P) <= m.Rbar)
    # the remainder is smaller than the first-order model's (what failed the certificate)
    assert m.Rbar.max() < 0.5 * _remainder_bound(Xs, T)[1].max()


def test_second_order_model_refuses_what_is_not_a_chain_box():
    Xs = _vertices().copy()
    Xs[0, 0, 1] = 2.0  # a vertex that differs outside the chain's last row
    assert second_order_maps(Xs, T, 2) is None


def _design(gamma, eps):
    return fl.Design(estimator=fl.EHGO(2, eps, T), controller=fl.DynamicController(GAINS, gamma))


def _slope_loop(design, Psi, gamma):
    """The oracle's loop matrix with the plant block a sample map ``Psi`` of ``(x, u)``."""
    base = surrogate_loop_matrix(design.estimator, GAINS, gamma, 0.0, 1.0)
    M = base.copy()
    M[:2] = np.hstack([Psi[:2, :2], np.zeros((2, 5))]) + np.outer(Psi[:2, 2], base[5])
    return M[:6, :6]  # ki = 0: the integrator z is not a state of the loop


def test_benchmark_class_is_certified_where_the_first_order_model_failed_and_p_contracts():
    gamma, eps = 0.0165908, 0.004  # the benchmark's 5th gain: frozen eps* 0.0096
    cls = fl.PlantClass(rho=2, T=T, b=B_RNG, a_slopes=A_BOX)
    c = fl.certify_eps(_design(gamma, eps), cls, search=False)
    assert c.certified and c.covers == "nonlinear" and "second-order model" in c.point.reason
    P = c.point.lyapunov[0][0]
    design, rng, worst = _design(gamma, eps), np.random.default_rng(5), 0.0
    for _ in range(200):
        M = _slope_loop(design, _random_path(rng, int(rng.integers(1, 8)))[0], gamma)
        worst = max(worst, scipy.linalg.eigh(M.T @ P @ M, P, eigvals_only=True)[-1])
    assert worst < 1.0


def test_no_eps_stabilizes_a_member_and_eigenvalues_agree():
    gamma, (lo, hi) = 0.2, (1e-3, 1.0)
    L = _Loop(_design(gamma, 1e-2), B_RNG, A_BOX, 41, 8)
    why = no_stable_eps(L, gamma, lo, hi)
    assert why is not None and "cannot be certified" in why
    a = [float(x) for x in why.split("d sigma/d xi = (")[1].split(")")[0].split(", ")]
    b = float(why.split("b = ")[1].split(" ")[0])
    assert A_BOX[0][0] <= a[0] <= A_BOX[0][1] and B_RNG[0] <= b <= B_RNG[1]
    Psi = scipy.linalg.expm(T * _X(a[0], a[1], b))
    for eps in np.geomspace(lo, hi, 48):
        M = _slope_loop(_design(gamma, eps), Psi, gamma)
        assert np.max(np.abs(np.linalg.eigvals(M))) > 1.0
    # a gain with stable eps: None (and the member is stable there, by eigenvalues)
    assert no_stable_eps(L, 0.004, lo, hi) is None
    M = _slope_loop(_design(0.004, 0.01), Psi, 0.004)
    assert np.max(np.abs(np.linalg.eigvals(M))) < 1.0


def test_curve_of_the_slope_box_class_says_why_a_gain_has_no_eps():
    cls = fl.PlantClass(rho=2, T=T, b=B_RNG, a_slopes=A_BOX)
    c = fl.eps_star_curve(_design(0.1, 1e-2), cls, [0.0165908, 0.14, 0.2],
                          eps_range=(1e-3, 1.0))
    assert np.isfinite(c.eps_star_certified[0])
    assert c.eps_star_certified[0] <= c.eps_star_frozen[0]
    assert np.isnan(c.eps_star_frozen[2]) and np.isnan(c.eps_star_certified[2])
    assert any("no eps of [0.001, 1] stabilizes the member" in u and "gamma = 0.2" in u
               for u in c.uncovered)
    # a gain whose frozen eps* exists but no certificate was found: said, not refuted
    # (or, certified, below its frozen eps*)
    assert np.isfinite(c.eps_star_frozen[1])
    if np.isnan(c.eps_star_certified[1]):
        assert any(u.startswith("gamma = 0.14: no certificate found") and "undecided" in u
                   for u in c.uncovered)
    else:
        assert c.eps_star_certified[1] <= c.eps_star_frozen[1]
    assert "gamma = 0.2" in repr(c)
    # the certified eps is certified by certify_eps at that gain too (same class)
    pc = fl.certify_eps(_design(0.0165908, float(c.eps_star_certified[0])), cls, search=False)
    assert pc.certified


def test_frozen_scan_of_corners_finds_the_worst_member_of_the_benchmark_class():
    # every frozen member (slopes on a 5 x 5 grid of the box, b on 9 points) against the
    # corners, by eigenvalues of the oracle loop: the corners are the worst, so the curve's
    # frozen eps* (a corner scan) is the frozen boundary of the whole class here
    gamma = 0.0165908
    bs = np.linspace(*B_RNG, 9)
    for eps in (0.005, 0.0096, 0.02):
        design = _design(gamma, eps)
        corner, inner = 0.0, 0.0
        for a1 in np.linspace(*A_BOX[0], 5):
            for a2 in np.linspace(*A_BOX[1], 5):
                for b in bs:
                    M = _slope_loop(design, scipy.linalg.expm(T * _X(a1, a2, b)), gamma)
                    r = float(np.max(np.abs(np.linalg.eigvals(M))))
                    inner = max(inner, r)
                    if abs(a1) == A_BOX[0][1] and abs(a2) == A_BOX[1][1]:
                        corner = max(corner, r)
        assert inner <= corner + 1e-12
