"""Certificates of the sampled linear surrogate against independent NumPy computations."""

from __future__ import annotations

import itertools
import json
import math

import numpy as np
import pytest
import scipy.linalg

import fl_design as fl
from fl_design.analysis._lmi import vertex_lmi
from fl_design.analysis._surrogate import SurrogateLoop
from fl_design.errors import CertificationError, DesignMismatchError, ParameterError
from tests.oracles import (
    B_TRMS,
    GAINS,
    KI,
    T,
    paper_ehgo,
    spectral_radius_over_b,
    surrogate_loop_matrix,
)

GAMMAS = (3e-4, 1e-3, 3e-3)


@pytest.fixture(scope="module")
def certs():
    """certify_eps of the paper's TRMS design at the three gains of the issue."""
    return {g: fl.certify_eps(fl.presets.paper_design(gamma=g), B_TRMS) for g in GAMMAS}


@pytest.mark.parametrize("eps,gamma,b", [(0.05, 3e-4, 3.6), (0.02, 3e-3, 6.8), (0.3, 1e-3, 5.0)])
def test_surrogate_matrix_equals_numpy_oracle(eps, gamma, b):
    design = fl.presets.paper_design(eps=eps, gamma=gamma)
    M0, M1 = SurrogateLoop(design).parts()
    M = surrogate_loop_matrix(design.estimator, GAINS, gamma, KI, b)
    np.testing.assert_allclose(M0 + b * M1, M, rtol=0, atol=1e-12)


@pytest.mark.parametrize("gamma", GAMMAS)
def test_eps_star_frozen_agrees_with_independent_eigenvalues(certs, gamma):
    """Just below eps*_frozen every b of the grid is Schur, just above one is not."""
    f = certs[gamma].eps_star_frozen
    grid = np.linspace(*B_TRMS, 41)
    below = paper_ehgo(f * (1 - 1e-3))
    above = paper_ehgo(f * (1 + 1e-2 * 0.2))
    assert spectral_radius_over_b(below, GAINS, gamma, KI, grid) < 1.0
    assert spectral_radius_over_b(above, GAINS, gamma, KI, grid) > 1.0


@pytest.mark.parametrize("gamma", GAMMAS)
def test_frozen_bracket_is_sound_and_tight(certs, gamma):
    c = certs[gamma]
    fr = c.bracket("frozen")
    assert fr.certified <= c.eps_star_frozen < fr.refuted
    assert fr.certified >= 0.8 * fr.refuted
    ehgo = paper_ehgo(fr.certified)  # certified => Schur
    assert spectral_radius_over_b(ehgo, GAINS, gamma, KI, np.linspace(*B_TRMS, 101)) < 1.0
    ehgo = paper_ehgo(fr.refuted)  # refuted => a constant b diverges
    assert spectral_radius_over_b(ehgo, GAINS, gamma, KI, np.linspace(*B_TRMS, 41)) > 1.0


def _period_radius(eps, gamma, runs):
    """Spectral radius of one period of ``runs`` ((b, samples), ...) from the oracle matrices."""
    ehgo = paper_ehgo(eps)
    acc = np.eye(7)
    for b, n in runs:
        acc = np.linalg.matrix_power(surrogate_loop_matrix(ehgo, GAINS, gamma, KI, b), n) @ acc
    return float(np.max(np.abs(np.linalg.eigvals(acc))))


def _attack(eps, gamma, seed):
    """Independent switching attack: dwell pairs and random dwell sequences (oracle matrices)."""
    rng = np.random.default_rng(seed)
    dwells = (1, 2, 5, 10, 20, 50, 100, 200, 300, 400, 450, 500, 550, 600, 800, 1000, 1500)
    worst = max(_period_radius(eps, gamma, ((B_TRMS[0], a), (B_TRMS[1], c)))
                for a in dwells for c in dwells)
    for _ in range(3):
        runs = [(float(rng.choice(B_TRMS)), int(rng.integers(1, 1200))) for _ in range(8)]
        worst = max(worst, _period_radius(eps, gamma, runs))
    return worst


@pytest.mark.parametrize("gamma", GAMMAS)
def test_varying_bracket_is_the_headline_and_holds_under_attack(certs, gamma):
    c = certs[gamma]
    v = c.bracket("varying")
    assert c.covers == "varying" and c.eps_star_certified == v.certified
    assert v.certified >= c.eps_star_common  # quartic SOS above common P, or common P itself
    assert ("SOS degree 4" in v.how_certified) == (v.certified > c.eps_star_common)
    assert v.certified < v.refuted <= c.bracket("frozen").refuted
    assert v.certified <= c.bracket("frozen").certified
    if v.counterexample:  # the refuting period, rebuilt from the oracle's matrices, grows
        assert _period_radius(v.refuted, gamma, v.counterexample) > 1.0
    assert _attack(0.99 * v.certified, gamma, seed=int(gamma * 1e5)) < 1.0


def test_paper_gamma_varying_bracket_matches_the_switching_counterexample(certs):
    """At gamma = 3e-4 switching b with ~1 s period diverges above ~0.122 (the issue's attack)."""
    v = certs[3e-4].bracket("varying")
    assert 0.115 < v.refuted < 0.13 and "periodic" in v.how_refuted
    assert 0.0814 * 0.99 < v.certified < v.refuted
    # issue 21 item 2: certified >= 0.8 x refuted (common P alone: 0.0814 / 0.1237 = 0.66)
    assert v.certified >= 0.8 * v.refuted and "SOS degree 4" in v.how_certified
    assert abs(certs[3e-4].eps_star_common - 0.0814) < 0.001


def test_small_gamma_is_refuted_for_varying_b_though_frozen_b_is_certified():
    """gamma = 1.5e-4: every constant b is fine at eps = 0.05, switching b diverges."""
    c = fl.certify_eps(fl.presets.paper_design(gamma=1.5e-4), B_TRMS)
    assert not c.certified and c.eps_star_certified is None
    v, fr = c.bracket("varying"), c.bracket("frozen")
    assert v.refuted < 0.0011 and _period_radius(v.refuted, 1.5e-4, v.counterexample) > 1.0
    assert fr.certified > 0.05  # frozen: certified at the design's eps
    assert fl.certify_eps(fl.presets.paper_design(gamma=1.5e-4), B_TRMS, b_rate=0,
                          search=False).certified


def test_rate_bounded_bracket_respects_the_rate():
    db = 0.01
    c = fl.certify_eps(fl.presets.paper_design(), B_TRMS, b_rate=db, rtol=0.05)
    r = c.bracket("rate-bounded")
    assert c.covers == "rate-bounded" and r.b_rate == db and c.eps_star_certified == r.certified
    assert r.certified >= c.bracket("varying").certified  # a varying certificate covers it
    assert r.refuted <= c.bracket("frozen").refuted
    if r.counterexample:
        seq = [b for b, n in r.counterexample for _ in range(n)]
        steps = np.abs(np.diff(seq + seq[:1]))
        assert steps.max() <= db * (1 + 1e-9)
        assert _period_radius(r.refuted, 3e-4, r.counterexample) > 1.0
    with pytest.raises(ParameterError, match="b_rate"):
        fl.certify_eps(fl.presets.paper_design(), B_TRMS, b_rate=-1.0)


def _rate_attack(eps, gamma, db, seed):
    """Random rate-bounded sequences of b (random walks, ramps with dwells), oracle matrices."""
    rng = np.random.default_rng(seed)
    ehgo = paper_ehgo(eps)
    worst = 0.0
    for _ in range(4):
        b, seq, step = B_TRMS[0], [], 1.0
        for _ in range(int(rng.integers(2000, 6000))):
            if rng.random() < 0.002:  # ramps and dwells of random length
                step = float(rng.choice((-1.0, 0.0, 1.0)))
            b = float(np.clip(b + db * step, *B_TRMS))
            seq.append(b)
        back = np.linspace(seq[-1], seq[0], int(np.ceil(abs(seq[0] - seq[-1]) / db)) + 1)[1:]
        acc = np.eye(7)
        for v in seq + list(back):
            acc = surrogate_loop_matrix(ehgo, GAINS, gamma, KI, v) @ acc
        worst = max(worst, float(np.max(np.abs(np.linalg.eigvals(acc)))))
    return worst


def test_rate_bounded_P_of_b_certifies_beyond_the_common_P():
    """gamma = 3e-4, |db| <= 1e-3 per sample: P(b) certifies beyond every varying certificate
    (common P 0.0814, quartic SOS 0.1167)."""
    design = fl.presets.paper_design(eps=0.119)
    c = fl.certify_eps(design, B_TRMS, b_rate=1e-3, search=False)
    assert c.certified and c.point.covers == "rate-bounded" and c.point.margin > 1e-9
    assert not fl.certify_eps(design, B_TRMS, search=False).certified  # no varying one here
    assert _rate_attack(0.119, 3e-4, 1e-3, seed=3) < 1.0


def test_paper_design_is_certified(certs):
    c = certs[3e-4]
    assert c.certified and c.point.certified and c.point.margin > 0
    assert c.eps == 0.05 and c.eps < c.eps_star_certified
    json.dumps(c.to_dict(), allow_nan=False)
    assert "certified" in repr(c)


def test_common_lyapunov_function_checked_independently():
    """A common P from the LMI makes M(b)^T P M(b) - P < 0 on a fine b grid (oracle matrices)."""
    ehgo = paper_ehgo(0.05)
    Ms = [surrogate_loop_matrix(ehgo, GAINS, 1e-3, KI, b) for b in B_TRMS]
    D = [(M - np.eye(7)) / T for M in Ms]
    _, (s, _) = scipy.linalg.matrix_balance(abs(D[0]) + abs(D[1]), permute=False, separate=True)
    S = np.diag(s)
    sol = vertex_lmi([np.linalg.solve(S, d @ S) for d in D], T, common=True)
    assert sol.certified
    Sinv = np.linalg.inv(S)
    P = Sinv @ sol.P[0] @ Sinv  # back to the original coordinates
    for b in np.linspace(*B_TRMS, 51):
        Db = (surrogate_loop_matrix(ehgo, GAINS, 1e-3, KI, b) - np.eye(7)) / T
        Q = S @ (Db.T @ P + P @ Db + T * Db.T @ P @ Db) @ S
        assert np.linalg.eigvalsh((Q + Q.T) / 2)[-1] < 0.0


def _hurwitz(c: float) -> bool:
    """Continuous limit (exact observer, T -> 0): s^4 + c s^3 + c k2 s^2 + c k1 s + c ki."""
    return bool(np.max(np.roots([1.0, c, c * GAINS[1], c * GAINS[0], c * KI]).real) < 0)


def test_too_small_gamma_is_never_certified_with_its_lower_bound():
    design = fl.presets.paper_design(gamma=1e-4)
    g = fl.certify_gamma(design, B_TRMS)
    assert not g.certified and "lower bound" in g.reason
    low = g.gamma_lower_bound
    assert low > 1e-4
    grid = np.linspace(*B_TRMS, 41)

    def rho_at(eps, gamma):
        return spectral_radius_over_b(paper_ehgo(eps), GAINS, gamma, KI,
                                      grid)

    # independent eigenvalues: below the bound no eps of the grid is stable, above one is
    assert min(rho_at(e, low * 0.995) for e in g.eps_grid) > 1.0
    assert min(rho_at(e, low * 1.005) for e in g.eps_grid) < 1.0
    # the continuous limit (T -> 0, exact estimates) gives the scale: b_min gamma / T > c*
    lo, hi = 0.1, 2.0
    while hi - lo > 1e-9:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if _hurwitz(mid) else (mid, hi)
    assert 0.9 < low / (T * hi / B_TRMS[0]) < 1.0
    e = fl.certify_eps(design, B_TRMS, search=True, n_scan=8)
    assert e.eps_star_frozen is None and e.eps_star_certified is None and not e.certified


def test_certify_gamma_of_the_paper_design():
    g = fl.certify_gamma(fl.presets.paper_design(), B_TRMS)
    assert g.certified and g.gamma_min < 3e-4 < g.gamma_max
    assert g.paper_bound == 1 / 6.8 and g.convergence_bound == 2 / 6.8
    ehgo = paper_ehgo(0.05)
    grid = np.linspace(*B_TRMS, 41)
    assert spectral_radius_over_b(ehgo, GAINS, g.gamma_max * 0.999, KI, grid) < 1.0
    assert spectral_radius_over_b(ehgo, GAINS, g.gamma_max * 1.01, KI, grid) > 1.0
    json.dumps(g.to_dict(), allow_nan=False)


def test_negative_b_is_certified_through_b_gamma():
    for eps, b_rate in ((0.06, None), (0.08, 0.0)):  # varying b; frozen b (beyond varying)
        design = fl.presets.paper_design(eps=eps, gamma=1e-3)
        pos = fl.certify_eps(design, B_TRMS, b_rate=b_rate, search=False)
        neg = fl.certify_eps(design, (-6.8, -3.6), b_rate=b_rate, search=False)
        assert pos.certified and neg.certified and pos.covers == neg.covers
        assert neg.gamma == -1e-3 and neg.b_bounds == (-6.8, -3.6)


def test_not_certified_is_a_value_unless_asked_to_raise():
    design = fl.presets.paper_design(eps=0.5)
    c = fl.certify_eps(design, B_TRMS, search=False)
    assert not c.certified and c.point.reason
    json.dumps(c.to_dict(), allow_nan=False)
    with pytest.raises(CertificationError, match="eps = 0.5 not certified"):
        fl.certify_eps(design, B_TRMS, search=False, raise_on_failure=True)


@pytest.mark.parametrize("bounds,match", [
    ((6.8, 3.6), "reversed"), ((0.0, 3.0), "contains 0"), ((-1.0, 2.0), "contains 0"),
    ((1.0, math.inf), "finite"), ((math.nan, 1.0), "finite"), ("ab", "pair"),
])
def test_bad_b_bounds(bounds, match):
    with pytest.raises(ParameterError, match=match):
        fl.certify_eps(fl.presets.paper_design(), bounds, search=False)


def test_bad_designs_and_jacobian_bounds():
    with pytest.raises(DesignMismatchError, match="rho = 2"):
        fl.certify_eps(fl.presets.paper_design(), B_TRMS, a_jacobian_bounds=[(0, 1)] * 3)
    with pytest.raises(ParameterError, match="EHGO"):
        fl.certify_gamma(fl.presets.least_squares_design(9), B_TRMS)


def test_eps_star_curve(tmp_path):
    curve = fl.eps_star_curve(fl.presets.paper_design(), B_TRMS, [1e-4, 1e-3, 3e-3])
    assert math.isnan(curve.eps_star_frozen[0]) and math.isnan(curve.eps_star_certified[0])
    assert np.all(curve.eps_star_certified[1:] <= curve.eps_star_frozen[1:])
    assert np.all(curve.ratio[1:] >= 0.8)
    d = json.loads(json.dumps(curve.to_dict(), allow_nan=False))
    assert d["eps_star_frozen"][0] is None
    curve.plot().savefig(tmp_path / "curve.png")


def _empirical_eps_star(plant, design, *, reference, duration):
    """Empirical eps* of the nonlinear loop (bisection of converging runs)."""
    return fl.estimate_eps_star(plant, design, fl.Scenario(reference, duration),
                                eps_range=(1e-3, 0.2), rtol=0.002).eps_star


def test_pendulum_ldi_certificate_below_the_empirical_eps_star():
    plant = fl.plants.pendulum()
    jb = plant.jacobian_bounds(region={"theta": (-0.5, 0.5)})
    design = fl.Design(estimator=fl.EHGO(rho=2, eps=0.01, T=T),
                       controller=fl.DynamicController((16, 8), 2e-2))
    c = fl.certify_eps(design, plant.b_bounds(), a_jacobian_bounds=jb, rtol=0.01)
    assert c.certified and c.point.kind == "ldi" and c.point.covers_time_varying_b
    assert c.eps_star_certified is not None
    # long runs: near eps* the decay is slow, and runs too short to settle are classified
    # "undecided", which biases the empirical eps* low (15 s: 0.02055, 40 s: 0.02066)
    empirical = _empirical_eps_star(plant, design, reference=0.1, duration=40.0)
    assert c.eps_star_certified <= empirical
    assert c.eps_star_certified <= c.eps_star_frozen


def test_cli_certify_prints_the_certificates(capsys):
    from fl_design.app import main

    assert main(["certify", "--eps", "0.05", "--gamma", "3e-4"]) == 0
    out = capsys.readouterr().out
    # the TRMS is certified as its class (friction slope box, b range): never the a = 0 chain;
    # switching the friction slope between -505 and -5 grows: not certified, and it says so
    assert "GammaCertificate" in out and "certifies the class of plant 'trms_yaw'" in out
    assert "a member of the class grows" in out and "eps* to use: none" in out
    assert "not covered: input saturation" in out
    assert main(["certify", "--eps", "-1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "eps" in err[0]


def test_bench_certify_quick_runs():
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    env = {**os.environ, "PYTHONPATH": str(root)}  # this tree's fl_design, not an installed one
    proc = subprocess.run([sys.executable, str(root / "verify" / "bench_certify.py"), "--quick"],
                          capture_output=True, text=True, timeout=300, cwd=root, check=False,
                          env=env)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "4-point eps*(gamma) curve (certified for frozen b)" in proc.stdout
    ratios = proc.stdout.split("certified/frozen at gamma ")[1].splitlines()[0]
    assert [float(r.split(": ")[1]) >= 0.8 for r in ratios.split(", ")] == [True] * 3


def _stored_certificate_holds(point, gamma, eps):
    """Re-check a certificate's stored ``P(b)`` with the oracle's loop matrices (NumPy only).

    At both ends of every piece and on a fine grid of b: ``P(b) > 0`` and the delta-form
    decrease ``Delta^T P + P Delta + T Delta^T P Delta < 0`` (i.e. ``M^T P M < P``), with
    ``P(b)`` interpolated linearly on its piece. A Jacobi congruence (``diag(P)^(-1/2)``,
    independent of the certifier's balancing) puts the matrices on one scale.
    """
    ehgo = paper_ehgo(eps)
    pieces, lyap = point.b_pieces, point.lyapunov
    assert point.certified and len(pieces) == len(lyap) == point.pieces >= 1
    assert pieces[0][0] == B_TRMS[0] and pieces[-1][1] == B_TRMS[1]
    assert all(a[1] == b[0] for a, b in itertools.pairwise(pieces))  # no gap
    grid = np.concatenate([np.linspace(*B_TRMS, 201), np.ravel(pieces)])
    for b in grid:
        k = next(i for i, (lo, hi) in enumerate(pieces) if lo <= b <= hi)
        (lo, hi), (P_lo, P_hi) = pieces[k], lyap[k]
        th = 0.0 if hi == lo else (b - lo) / (hi - lo)
        P = (1 - th) * P_lo + th * P_hi
        Db = (surrogate_loop_matrix(ehgo, GAINS, gamma, KI, b) - np.eye(7)) / T
        J = np.diag(1.0 / np.sqrt(np.diag(P)))
        W = J @ (Db.T @ P + P @ Db + T * Db.T @ P @ Db) @ J
        assert np.linalg.eigvalsh(J @ P @ J)[0] > 0.0
        assert np.linalg.eigvalsh((W + W.T) / 2)[-1] < 0.0, (eps, gamma, b)


@pytest.mark.parametrize("gamma", GAMMAS)
def test_every_certificate_stores_a_lyapunov_function_that_rechecks(certs, gamma):
    """The design's eps, and eps* itself (the hardest certified point), re-checked."""
    c = certs[gamma]
    if c.certified:
        _stored_certificate_holds(c.point, gamma, c.eps)
    top_eps = c.bracket("frozen").certified
    design = fl.presets.paper_design(eps=top_eps, gamma=gamma)
    top = fl.certify_eps(design, B_TRMS, b_rate=0.0, search=False)
    assert top.certified and top.point.pieces > 1 and top.point.covers == "frozen"
    _stored_certificate_holds(top.point, gamma, top_eps)


def test_lmi_certificates_store_a_lyapunov_function_that_rechecks():
    """The LMI paths (common P, vertex P_v on pieces) also store P, checked by the oracle."""
    from fl_design.analysis._certify import _Loop

    L = _Loop(fl.presets.paper_design(gamma=1e-3), B_TRMS, None, 41, 8)
    common = L.point(0.05, 1e-3, common_only=True)
    assert common.kind == "common" and common.covers_time_varying_b
    _stored_certificate_holds(common, 1e-3, 0.05)
    lo, hi = B_TRMS  # two pieces, the vertex P_v form asked directly (not a common P first)
    mid = 0.5 * (lo + hi)
    pd = L._pieces(0.08, 1e-3, None, edges=[(lo, mid, False), (mid, hi, False)])
    assert pd.kind == "parameter-dependent" and pd.solver == "CLARABEL"
    assert any(np.abs(a - b).max() > 0 for a, b in pd.lyapunov)  # P varies with b
    _stored_certificate_holds(pd, 1e-3, 0.08)


@pytest.mark.parametrize("box,db", [((0, 1, 0, 1), 0.25), ((0, 1, 1, 2), 0.1), ((0, 2, 0, 1), 0.5),
                                    ((0, 1, 3, 4), 0.5)])
def test_rate_cells_are_the_band_inside_the_box(box, db):
    """Vertices of {|b - b'| <= db} inside a box: in the set, and their hull has the set's area."""
    from scipy.spatial import ConvexHull

    from fl_design.analysis._rate import cell_vertices

    a0, a1, c0, c1 = box
    v = np.array(cell_vertices(a0, a1, c0, c1, db))
    rng = np.random.default_rng(7)
    pts = np.column_stack([rng.uniform(a0, a1, 200_000), rng.uniform(c0, c1, 200_000)])
    inside = np.abs(pts[:, 0] - pts[:, 1]) <= db
    area = inside.mean() * (a1 - a0) * (c1 - c0)
    if v.size == 0:
        assert not inside.any()
        return
    assert np.all(np.abs(v[:, 0] - v[:, 1]) <= db + 1e-12)
    assert np.all((v[:, 0] >= a0) & (v[:, 0] <= a1) & (v[:, 1] >= c0) & (v[:, 1] <= c1))
    hull = ConvexHull(v).volume if len(v) >= 3 else 0.0
    assert hull == pytest.approx(area, abs=0.01 * (a1 - a0) * (c1 - c0))


def test_gamma_lower_bound_to_a_tenth_of_a_percent():
    """Below 0.999 x the bound no eps works (dense oracle scan), above 1.001 x some eps does."""
    g = fl.certify_gamma(fl.presets.paper_design(), B_TRMS)
    low = g.gamma_lower_bound
    assert 1.30e-4 < low < 1.333e-4  # the coarse 6-point eps grid gave 1.3332e-4
    grid = np.linspace(*B_TRMS, 41)

    def stable_eps(gamma, eps_values):
        return [e for e in eps_values if spectral_radius_over_b(
            paper_ehgo(e), GAINS, gamma, KI, grid) < 1.0]

    dense = np.concatenate([np.geomspace(1e-3, 0.05, 40), np.linspace(0.05, 0.15, 300),
                            np.geomspace(0.15, 1.0, 40)])
    assert stable_eps(0.999 * low, dense) == []
    assert stable_eps(1.001 * low, dense)


def test_eps_star_is_a_band_just_above_the_gamma_lower_bound():
    """gamma = 1.35e-4: the frozen-stable eps form a band away from 0, reported as such."""
    c = fl.certify_eps(fl.presets.paper_design(gamma=1.35e-4), B_TRMS)
    (a, b), = c.eps_intervals_frozen
    assert 0.02 < a < 0.05 and 0.1 < b < 0.15 and "band" in c.reason
    grid = np.linspace(*B_TRMS, 41)
    for eps, inside in ((0.99 * a, False), (1.01 * a, True), (0.99 * b, True), (1.01 * b, False)):
        r = spectral_radius_over_b(paper_ehgo(eps), GAINS, 1.35e-4, KI, grid)
        assert (r < 1.0) == inside, (eps, r)


def test_flexible_joint_rho_4_certifies_at_its_design_eps():
    """rho = 4, eps = 0.005 (spectral radius 0.99692): a common P from the loop's modal basis
    (the closed-form modal P since the re-check margin bounds floating-point error, 1e-11;
    before, at 1e-9, the LMI in the real modal basis)."""
    plant, design = fl.plants.flexible_joint(), fl.presets.flexible_joint_design()
    c = fl.certify_eps(design, plant.b_bounds(), search=False)
    assert c.certified and c.point.covers == "varying" and "modal" in c.point.reason
    M0, M1 = SurrogateLoop(design).parts()
    M = M0 + plant.b_bounds()[0] * M1
    (P_lo, _), = c.point.lyapunov  # in the loop's coordinates: M^T P M - P < 0, P > 0
    L = np.linalg.cholesky(P_lo)  # P = L L^T: the decrease in the coordinates L^T x
    Mt = np.linalg.solve(L, M.T @ L).T  # L^T M L^-T
    assert np.linalg.norm(Mt, 2) < 1.0


def test_uncertifiable_designs_name_the_fix():
    """A gamma below the lower bound names the gain to use; the maglev names the b interval."""
    c = fl.certify_eps(fl.presets.paper_design(gamma=1e-4), B_TRMS)
    assert not c.certified and "raise |gamma| to at least" in c.reason
    need = float(c.reason.split("|gamma| >= ")[1].split(" ")[0])
    assert fl.certify_eps(fl.presets.paper_design(gamma=need), B_TRMS).eps_intervals_frozen
    plant, design = fl.plants.maglev(), fl.presets.maglev_design()
    m = fl.certify_eps(design, plant.b_bounds())
    assert not m.certified and "narrow the b interval" in m.reason
    assert m.gamma == design.controller.gamma < 0  # b < 0: gamma of the sign of b, used as |gamma|


def test_loop_margins_agree_with_the_gamma_interval_and_a_delayed_loop():
    """The loop depends on b gamma only: k_max at b_max is gamma_max / gamma; a delay of 80 %
    of the delay margin (whole samples, an independent augmented loop) keeps it Schur."""
    from fl_design.analysis import loop_margins

    design = fl.presets.paper_design()
    g = fl.certify_gamma(design, B_TRMS)
    m = loop_margins(design, B_TRMS[1])
    assert m.gain_margins[1] == pytest.approx(g.gamma_max / 3e-4, rel=2e-3)
    ehgo = paper_ehgo(0.05)
    M = surrogate_loop_matrix(ehgo, GAINS, 3e-4, KI, B_TRMS[1])
    np.testing.assert_allclose(np.sort(np.abs(m.poles)), np.sort(np.abs(np.linalg.eigvals(M))),
                               atol=1e-9)
    assert m.phase_margin > 0 and m.delay_margin > 0
    from fl_design.analysis._margins import open_loop

    A, B, C = open_loop(design, B_TRMS[1])
    n = int(0.8 * m.delay_margin / T)
    N = A.shape[0]
    big = np.zeros((N + n, N + n))  # w_k = u_(k-n): a shift register of n samples
    big[:N, :N] = A
    big[:N, N + n - 1] = B
    big[N, :N] = C
    for i in range(1, n):
        big[N + i, N + i - 1] = 1.0
    assert np.max(np.abs(np.linalg.eigvals(big))) < 1.0
