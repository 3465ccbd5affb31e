"""One-dimensional searches of eps*: frozen (scan + safeguarded secant) and certified.

Examples
--------
>>> from fl_design.analysis._search import frozen_eps_star
>>> round(frozen_eps_star(lambda e: e - 0.3, 1e-3, 1.0, 8, 1e-4), 3)
0.3
"""

from __future__ import annotations

import math

import numpy as np

from .._numerics import bisect_log


def _bracket(pred, good: float, bad: float, rtol: float) -> tuple[float, float]:
    """``(good, bad)`` after log-bisection (:func:`fl_design._numerics.bisect_log`)."""
    out = bisect_log(pred, good, bad, rtol=rtol)
    return out.lo, out.hi


def _refine(margin, good: float, m_good: float, bad: float, m_bad: float, rtol: float):
    """Shrink ``[good, bad]`` (``margin < 0`` good) to ``bad / good - 1 <= rtol``.

    Secant root of the margin in ``log eps``, evaluated a third of the tolerance on the good
    side, then on the bad side: two evaluations close the bracket when the root estimate is
    good; after eight tries it falls back to bisection. Every step keeps a valid bracket.
    """
    tol = math.log1p(rtol)
    lg, lb = math.log(good), math.log(bad)
    tries = 0
    while lb - lg > tol:
        tries += 1
        if tries > 8:
            x = 0.5 * (lg + lb)
        else:
            x = lg + (lb - lg) * m_good / (m_good - m_bad)
            x += tol / 3 if tries % 2 == 0 else -tol / 3
            x = min(max(x, lg + 0.02 * (lb - lg)), lb - 0.02 * (lb - lg))
        m = margin(math.exp(x))
        if m < 0.0:
            lg, m_good = x, m
        else:
            lb, m_bad = x, m
    return math.exp(lg), math.exp(lb)


class _Scan:
    """Margins of a scan grid, evaluated on demand in stacked chunks of :data:`SCAN_CHUNK`
    (a scan stops at its first failure: the points after it are never computed)."""

    def __init__(self, grid, margin, margins):
        self.grid, self.margin, self.margins = grid, margin, margins
        self.values: list[float] = []

    def __getitem__(self, i: int) -> float:
        if self.margins is None:
            return float(self.margin(self.grid[i]))
        while len(self.values) <= i:
            part = self.grid[len(self.values): len(self.values) + SCAN_CHUNK]
            self.values += [float(v) for v in np.asarray(self.margins(part), dtype=float)]
        return self.values[i]


#: Scan points evaluated per stacked call of :func:`frozen_bracket`.
SCAN_CHUNK = 6


def frozen_bracket(margin, lo: float, hi: float, n_scan: int, rtol: float, margins=None):
    """``(good, bad)``: the frozen eps* bracket of a scan + refinement (see frozen_eps_star).

    ``bad`` is an eps at which ``margin >= 0`` (a counterexample), None when no scan point
    fails; None altogether when ``lo`` already fails. ``margins`` (optional) evaluates many scan
    points at once (``array -> array``, stacked eigenvalue problems), in chunks up to the first
    failure.

    Examples
    --------
    >>> g, b = frozen_bracket(lambda e: e - 0.3, 1e-3, 1.0, 8, 1e-4)
    >>> round(g, 3), round(b, 3), b / g - 1 <= 1e-4
    (0.3, 0.3, True)
    """
    grid = np.geomspace(lo, hi, n_scan)
    scan = _Scan(grid, margin, margins)
    m_prev = scan[0]
    if not m_prev < 0.0:
        return None
    for i in range(1, n_scan):
        m = scan[i]
        if not m < 0.0:
            if not np.isfinite(m) or not np.isfinite(m_prev):
                good, bad = _bracket(lambda e: margin(e) < 0.0, grid[i - 1], grid[i],
                                           rtol)
                return float(good), float(bad)
            good, bad = _refine(margin, grid[i - 1], m_prev, grid[i], m, rtol)
            return float(good), float(bad)
        m_prev = m
    return float(hi), None


def frozen_eps_star(margin, lo: float, hi: float, n_scan: int, rtol: float) -> float | None:
    """Scan ``n_scan`` log points of ``[lo, hi]`` for the first failure, then refine.

    Parameters
    ----------
    margin : callable
        ``eps -> float``, negative exactly when every frozen loop is Schur at ``eps``.
    lo, hi : float
        The eps interval.
    n_scan : int
        Log-spaced scan points.
    rtol : float
        Relative width of the final bracket ``[good, bad]``; the good end is returned.

    Returns
    -------
    float or None
        None when ``lo`` already fails; ``hi`` when no scan point fails.

    Examples
    --------
    >>> frozen_eps_star(lambda e: 1.0, 1e-3, 1.0, 8, 1e-3) is None
    True
    """
    out = frozen_bracket(margin, lo, hi, n_scan, rtol)
    return None if out is None else out[0]


def certified_eps_star(pred, lo: float, top: float, rtol: float, hint: float = 0.9,
                       step: float = 0.5, accelerate: bool = False,
                       retry: float | None = None):
    """Largest certified eps in ``[lo, top]``: try ``hint * top``, step down by ``step``, bisect.

    Parameters
    ----------
    pred : callable
        ``eps -> bool``, True when certified.
    lo, top : float
        Search interval (``top`` is the frozen eps*, an upper bound).
    rtol : float
        Relative resolution of the bisection.
    hint : float, optional
        First ratio tried (continuation: the ratio found at the previous gamma).
    step : float, optional
        Factor of the downward steps when the hint fails.
    accelerate : bool, optional
        Square the factor after each failed step (0.95, 0.90, 0.81, 0.66, ...): a class
        certified far below its hint, or nowhere, costs ``O(log log(top / lo))`` failed
        steps instead of ``O(log(top / lo))``; the bisection that follows is as fine as
        ``rtol`` (the returned eps is one where ``pred`` held, as without it); the bracket
        above a certified eps is closed by steps up by squared factors (1.05, 1.10, ...)
        before the bisection.
    retry : float, optional
        When the hint fails and ``retry * top`` lies above it, the steps down start from
        ``retry * top`` instead: the certificates are not monotone in eps (a smaller eps, a
        faster observer, can fail where a larger one holds), so a continuation's low hint
        must not hide the eps above it.

    Returns
    -------
    float or None
        None when no tried eps is certified.

    Examples
    --------
    >>> round(certified_eps_star(lambda e: e <= 0.5, 1e-3, 1.0, 1e-3), 3)
    0.5
    >>> round(certified_eps_star(lambda e: e <= 0.01, 1e-3, 1.0, 1e-2, 0.9, 0.95, True), 4)
    0.01
    >>> round(certified_eps_star(lambda e: 0.8 <= e <= 0.9, 1e-3, 1.0, 1e-3, 0.5, retry=0.85), 3)
    0.9
    """
    close = _probe_up if accelerate else _bracket
    # the highest first try: one whose bracket [x, top] is already within rtol (a hint at the
    # cap ends the search in one evaluation, never a second one at ~top)
    x = max(lo, min(hint, 1.0 / (1.0 + 0.999 * rtol)) * top)
    if pred(x):
        return float(close(pred, x, top, rtol)[0])
    if retry is not None and min(retry, 1.0 - rtol) * top > x * (1.0 + rtol):
        x = min(retry, 1.0 - rtol) * top  # the descent starts from there instead
        if pred(x):
            return float(close(pred, x, top, rtol)[0])
    while x > lo:
        below = max(lo, step * x)
        if pred(below):
            return float(close(pred, below, x, rtol)[0])
        x = below
        if accelerate:
            step *= step
    return None


def _probe_up(pred, good: float, bad: float, rtol: float) -> tuple[float, float]:
    """:func:`_bracket` after steps up from ``good`` by squared factors (1.05, 1.10, 1.22,
    ...): a continuation's answer lies near its hint, and a failed test (the expensive kind:
    every certificate form tried) narrows the bracket at once."""
    factor = 1.05
    while good * factor < bad / (1.0 + rtol):
        if not pred(good * factor):
            return _bracket(pred, good, good * factor, rtol)
        good, factor = good * factor, factor * factor
    return _bracket(pred, good, bad, rtol)


def first_refuted(refute_at, start: float, top: float, n_scan: int, rtol: float, *,
                  below: float | None = None):
    """Smallest eps refuted above ``start``: a log scan up to ``top``, then log-bisection.

    Parameters
    ----------
    refute_at : callable
        ``eps -> Refutation`` (anything with a ``refuted`` flag).
    start, top : float
        The scan's ends (``start`` is not evaluated: the caller knows it holds).
    n_scan : int
        Points of the log-spaced scan, ``start`` included.
    rtol : float
        Relative width of the final bracket.
    below : float or None, optional
        The scan stops before reaching it (a counterexample already known there).

    Returns
    -------
    (float, Refutation) or None
        The first refuted eps of the bracket and its refutation; None when no scanned point
        is refuted.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> eps, r = first_refuted(lambda e: SimpleNamespace(refuted=e > 0.3), 0.01, 1.0, 6, 1e-6)
    >>> round(eps, 4), r.refuted
    (0.3, True)
    """
    prev, found = start, None
    for e in np.geomspace(start, top, n_scan)[1:]:
        if below is not None and e >= below:
            break
        r = refute_at(float(e))
        if r.refuted:
            found = (float(e), r)
            break
        prev = float(e)
    if found is None:
        return None
    seen = {found[0]: found[1]}

    def holds(eps: float) -> bool:
        seen[eps] = refute_at(eps)
        return not seen[eps].refuted

    out = bisect_log(holds, prev, found[0], rtol=rtol)
    return out.hi, seen[out.hi]


def stable_intervals(pred, lo: float, hi: float, n_scan: int, rtol: float,
                     preds=None) -> tuple:
    """Runs of a log scan where ``pred`` holds, each end refined by bisection to ``rtol``.

    Returns ``((a, b), ...)`` in increasing order; an end of the scan is kept as is when the
    run reaches it. Gaps narrower than the scan's spacing can be missed. ``preds`` (optional)
    evaluates the whole scan at once.

    Examples
    --------
    >>> [tuple(round(v, 3) for v in r)
    ...  for r in stable_intervals(lambda e: 0.1 < e < 0.2 or e > 0.5, 0.01, 1.0, 40, 1e-4)]
    [(0.1, 0.2), (0.5, 1.0)]
    """
    grid = np.geomspace(lo, hi, n_scan)
    ok = [bool(v) for v in preds(grid)] if preds is not None else [bool(pred(g)) for g in grid]
    out, i = [], 0
    while i < n_scan:
        if not ok[i]:
            i += 1
            continue
        j = i
        while j + 1 < n_scan and ok[j + 1]:
            j += 1
        a = grid[0] if i == 0 else 1.0 / _bracket(lambda x: pred(1.0 / x), 1.0 / grid[i],
                                                    1.0 / grid[i - 1], rtol)[0]
        b = grid[-1] if j == n_scan - 1 else _bracket(pred, grid[j], grid[j + 1], rtol)[0]
        out.append((float(a), float(b)))
        i = j + 1
    return tuple(out)


class _LazyOk:
    """``ok[i]`` of a scan grid, evaluated on demand: ``preds`` on up to :data:`SCAN_CHUNK`
    unevaluated points at once in the direction of travel (a walk from the design's gain
    reads only the points up to its run's ends), else ``pred`` one point at a time."""

    def __init__(self, grid, pred, preds):
        self.grid, self.pred, self.preds = grid, pred, preds
        self.ok: dict[int, bool] = {}

    def at(self, i: int, step: int = 1) -> bool:
        if i not in self.ok:
            if self.preds is None:
                self.ok[i] = bool(self.pred(self.grid[i]))
            else:
                idx = [i]
                while (len(idx) < SCAN_CHUNK and 0 <= idx[-1] + step < self.grid.size
                       and idx[-1] + step not in self.ok):
                    idx.append(idx[-1] + step)
                idx.sort()
                for k, v in zip(idx, self.preds(self.grid[idx])):
                    self.ok[k] = bool(v)
        return self.ok[i]


def _run_ends(ok: _LazyOk, n: int, design_gamma: float, lower_only: bool):
    """``(i, j)`` of the stable run containing ``design_gamma``, else of the lowest run (``j``
    None with ``lower_only``), else None; reads only the points it needs."""
    grid = ok.grid
    k = int(np.searchsorted(grid, design_gamma, side="right")) - 1
    inside = 0 <= k and design_gamma <= grid[-1]
    if inside and ok.at(k, -1) and (grid[k] == design_gamma or ok.at(k + 1, 1)):
        i, j = k, k if grid[k] == design_gamma else k + 1
    else:
        i = next((m for m in range(n) if ok.at(m, 1)), None)
        if i is None:
            return None
        j = i
    while i > 0 and ok.at(i - 1, -1):
        i -= 1
    if lower_only:
        return i, None
    while j + 1 < n and ok.at(j + 1, 1):
        j += 1
    return i, j


def gamma_interval(pred, design_gamma, lo, hi, n_scan, rtol, preds=None, *,
                   lower_only: bool = False):
    """Stable run of a log gamma scan containing ``design_gamma`` (else the lowest run).

    Returns ``(gamma_min, gamma_max)`` refined by bisection to ``rtol`` (an end of the scan
    when the run reaches it), or ``(None, None)`` when no scan point is stable. ``preds``
    (optional) evaluates many scan points at once (``array -> bools``, stacked eigenvalue
    problems); the refinement uses ``pred``. The scan is read from the design's gain outward
    (the lowest run from the bottom up) and stops at the run's ends: the points beyond them
    are never evaluated (the answer is the full scan's). ``lower_only``: ``gamma_max`` is not
    searched (None).

    Examples
    --------
    >>> lo, hi = gamma_interval(lambda g: 0.1 < g < 0.5, 0.2, 0.01, 1.0, 20, 1e-4)
    >>> round(lo, 3), round(hi, 3)
    (0.1, 0.5)
    """
    grid = np.geomspace(lo, hi, n_scan)
    run = _run_ends(_LazyOk(grid, pred, preds), n_scan, design_gamma, lower_only)
    if run is None:
        return None, None
    i, j = run
    g_min = grid[0] if i == 0 else 1.0 / _bracket(lambda x: pred(1.0 / x), 1.0 / grid[i],
                                                    1.0 / grid[i - 1], rtol)[0]
    if j is None:
        return float(g_min), None
    g_max = grid[-1] if j == n_scan - 1 else _bracket(pred, grid[j], grid[j + 1], rtol)[0]
    return float(g_min), float(g_max)


__all__ = ["certified_eps_star", "first_refuted", "frozen_bracket", "frozen_eps_star",
           "gamma_interval", "stable_intervals"]
