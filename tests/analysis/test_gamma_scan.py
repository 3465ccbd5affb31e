"""The certify stage's shortcuts give the full computation's answers (issue 33, TRMS job).

* :func:`._search.gamma_interval` reads its scan from the design's gain outward: its ends are
  the full scan's (a reference scan written here), on predicates with several runs;
* ``_Loop.frozen_ok`` (screened) is exactly ``frozen_margin < 0``, and ``frozen_margin`` (the
  corners stacked, each distinct corner once) matches SciPy's eigenvalues of the sampled
  loops;
* :func:`._gamma.refine_lower_bound` (squared steps, an eps witness) lands within its
  ``LOWER_RTOL`` of the halving search it replaced (written here);
* the curve's vertex switching before the LDI's SDP: the TRMS class's curve solves no conic
  program and certifies what the SDPs certify (nothing: checked by solving them);
* :func:`fl_design.certify_lyapunov`'s LMI is counted by ``solve_count``.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

import fl_design as fl
from fl_design._numerics import bisect_log
from fl_design.analysis._certify import _Loop
from fl_design.analysis._coverage import best_margin
from fl_design.analysis._gamma import LOWER_RTOL, refine_lower_bound
from fl_design.analysis._ldi import ldi_point
from fl_design.analysis._lmi import solve_count
from fl_design.analysis._search import _bracket, gamma_interval

TRMS_BOX = [(0.0, 0.0), (-505.0, -5.0)]  # the TRMS yaw's friction slopes (d sigma/d xi)


def _full_scan_interval(pred, design_gamma, lo, hi, n, rtol, lower_only=False):
    """The reference: every scan point evaluated, runs listed, the design's run refined."""
    grid = np.geomspace(lo, hi, n)
    ok = [bool(pred(g)) for g in grid]
    runs, i = [], 0
    while i < n:
        if ok[i]:
            j = i
            while j + 1 < n and ok[j + 1]:
                j += 1
            runs.append((i, j))
            i = j + 1
        else:
            i += 1
    if not runs:
        return None, None
    i, j = next((r for r in runs if grid[r[0]] <= design_gamma <= grid[r[1]]), runs[0])
    g_min = grid[0] if i == 0 else 1.0 / _bracket(lambda x: pred(1.0 / x), 1.0 / grid[i],
                                                    1.0 / grid[i - 1], rtol)[0]
    if lower_only:
        return float(g_min), None
    g_max = grid[-1] if j == n - 1 else _bracket(pred, grid[j], grid[j + 1], rtol)[0]
    return float(g_min), float(g_max)


BANDS = [(0.02, 0.05), (0.1, 0.4), (0.6, 0.61)]


def _in_bands(g):
    return any(a < g < b for a, b in BANDS)


@pytest.mark.parametrize("design_gamma", [0.2, 0.03, 0.08, 0.005, 2.0, 0.6052])
@pytest.mark.parametrize("stacked", [False, True])
@pytest.mark.parametrize("lower_only", [False, True])
def test_gamma_interval_is_the_full_scans(design_gamma, stacked, lower_only):
    calls = []

    def pred(g):
        calls.append(g)
        return _in_bands(g)

    preds = (lambda gs: np.array([_in_bands(g) for g in gs])) if stacked else None
    got = gamma_interval(pred, design_gamma, 1e-3, 1.0, 80, 1e-4, preds, lower_only=lower_only)
    want = _full_scan_interval(_in_bands, design_gamma, 1e-3, 1.0, 80, 1e-4, lower_only)
    assert got == want
    grid = np.geomspace(1e-3, 1.0, 80)
    if design_gamma == 0.2 and not stacked:  # a run in the middle: its points and the ends'
        assert len([g for g in calls if g in grid]) < 40


def test_gamma_interval_without_a_stable_point():
    assert gamma_interval(lambda g: False, 0.1, 1e-3, 1.0, 20, 1e-3,
                          lambda gs: np.zeros(len(gs), bool)) == (None, None)


def _trms_class_loop():
    return _Loop(fl.presets.paper_design(), (3.6, 6.8), TRMS_BOX, 41, 8)


def test_slope_box_corners_are_distinct():
    L = _trms_class_loop()
    corners = L._corners()
    assert corners.tolist() == [[0.0, -505.0], [0.0, -5.0]]  # (0, 0) gave each one twice


@pytest.mark.parametrize("box", [None, TRMS_BOX])
def test_frozen_ok_and_margin_agree_with_scipy_eigenvalues(box):
    design = fl.presets.paper_design()
    L = _Loop(design, (3.6, 6.8), box, 41, 8)
    T, rho = design.T, design.rho
    rows = [None] if box is None else [np.array(r) for r in
                                       {(a, c) for a in box[0] for c in box[1]}]
    seen = set()
    for eps in (0.005, 0.05, 0.2, 0.8):
        for gamma in (2e-5, 3e-4, 3e-3, 0.3):
            worst = -np.inf
            for a_row in rows:
                # the sampled loop: the chain's exact ZOH (SciPy expm) and the design's parts
                X = np.eye(rho + 1, k=1)
                if a_row is not None:
                    X[rho - 1, :rho] += a_row
                E = scipy.linalg.expm(T * X)
                for b in L.b_grid:
                    M0, M1 = L.loop.assemble(E[:rho, :rho], E[:rho, rho], L.loop.input_row(
                        eps, gamma), eps, gamma)
                    r = np.max(np.abs(scipy.linalg.eigvals(M0 + b * M1)))
                    worst = max(worst, (r * r - 1.0) / T)  # |1 + T mu|^2 < 1 <=> r < 1
            m = L.frozen_margin(eps, gamma)
            assert m == pytest.approx(worst, rel=1e-6, abs=1e-6)
            assert L.frozen_ok(eps, gamma) == (m < 0.0)
            seen.add(m < 0.0)
    assert seen == {True, False}


def _halving_lower_bound(L, good, g_floor, lo, hi):
    """The search :func:`refine_lower_bound` replaced: halving, then log-bisection."""
    def works(g):
        return best_margin(L, g, lo, hi) < 0.0

    if not works(good):
        return good
    bad = good / 2.0
    while works(bad):
        if bad <= g_floor:
            return bad
        good, bad = bad, bad / 2.0
    return float(1.0 / bisect_log(lambda x: works(1.0 / x), 1.0 / good, 1.0 / bad,
                                  rtol=LOWER_RTOL).lo)


@pytest.mark.parametrize("box", [None, TRMS_BOX])
def test_lower_bound_within_its_rtol_of_the_halving_search(box):
    L = _Loop(fl.presets.paper_design(), (3.6, 6.8), box, 41, 8)
    start = 1.4e-4 if box is None else 2e-5
    fast = refine_lower_bound(L, start, 1e-9, 1e-3, 1.0)
    slow = _halving_lower_bound(L, start, 1e-9, 1e-3, 1.0)
    assert fast == pytest.approx(slow, rel=2 * LOWER_RTOL)
    assert best_margin(L, fast, 1e-3, 1.0) < 0.0  # some eps works at the bound
    assert best_margin(L, fast / (1 + 2 * LOWER_RTOL), 1e-3, 1.0) >= 0.0  # none below


def test_trms_class_curve_refutes_what_its_sdps_cannot_certify():
    design = fl.presets.paper_design()
    gammas = [3e-4, 3e-3]
    n0 = solve_count()
    c = fl.eps_star_curve(design, (3.6, 6.8), gammas, a_jacobian_bounds=TRMS_BOX,
                          eps_range=(0.005, 1.0), progress=False)
    assert solve_count() == n0  # every gain refuted by a growing switching: no SDP
    assert np.all(np.isnan(c.eps_star_certified)) and np.all(np.isfinite(c.eps_star_frozen))
    L = _Loop(design, (3.6, 6.8), TRMS_BOX, 41, 8)
    for g, f in zip(gammas, c.eps_star_frozen):  # the floor each gain was checked at: the SDPs
        pc = ldi_point(L, max(0.005, 0.5 * f), g)
        assert not pc.certified and pc.solver_status != "not solved"


def test_lyapunov_lmi_is_counted():
    n0 = solve_count()
    c = fl.certify_lyapunov((2, 4), T=1e-3)
    assert c.lmi_status == "optimal" and solve_count() == n0 + 1


def test_bench_certify_stage_quick_runs(capsys):
    """``verify/bench_certify.py --stage --quick``'s measurement, in process."""
    import sys
    from pathlib import Path

    verify = Path(__file__).resolve().parents[2] / "verify"
    sys.path.insert(0, str(verify))
    try:
        from bench_certify import stage_parts
    finally:
        sys.path.remove(str(verify))
    assert stage_parts(True)
    out = capsys.readouterr().out
    for part in ("the gamma interval: CPU", "the eps* brackets: CPU", "8 gains: CPU",
                 "together: CPU", "load average"):
        assert part in out, out
