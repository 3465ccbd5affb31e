"""eps* of the quartic SOS certificate: Newton steps on the SOS program's margin.

Each SOS program (:mod:`._sos`) returns, besides its verdict, its optimal margin ``eta`` (the
largest ``lambda_min`` of ``Q`` and of every ``R_v``, ``trace Q = m``: positive where a
strictly feasible quartic ``V`` exists) and, from its duals, ``d eta / d eps`` (the envelope
theorem, coordinates held fixed: the sign of ``eta``, strict feasibility, does not depend on
them). Where no ``V`` exists ``eta`` sits just below 0 (``Q`` degenerates), so the failed side
says nothing; the certified side does. A bisection of the verdict to ``rtol = 1e-2`` from
``0.9 top`` solved five programs on the paper's TRMS design; here:

1. ``hint * top`` first, steps down by ``step`` until a certified eps (or ``base``), as the
   bisection (``top`` is the refuted end, known to fail);
2. from the last certified eps ``g`` a Newton step to the root ``r = g - eta / slope``; the
   next eps tried is ``r (1 - rtol / 4)`` (expected certified), or ``g (1 + rtol)`` once
   ``r`` lies below it (expected to fail: it closes the bracket);
3. bisection (in ``log eps``) after two probes that the Newton step got wrong, without a
   usable slope, or when the root it predicts lies beyond the bracket (``eta`` is piecewise
   smooth: a slope of another piece); every probe kept strictly inside the bracket.

The answer is an eps where a certificate was found and re-checked (never an estimate), and
``[answer, bad]`` with ``bad / answer - 1 <= rtol`` contains the certificate's boundary when it
is unique, as the bisection's did.

Examples
--------
>>> from fl_design.analysis._sos_search import sos_eps_star
>>> # a margin 0.3 - eps (slope -1): certified below 0.3
>>> eps, n = sos_eps_star(lambda e: (0.3 - e > 0, 0.3 - e, -1.0), 0.01, 0.4, 1e-2)
>>> 0.297 <= eps <= 0.3, n
(True, 5)
"""

from __future__ import annotations

import math


class _Budget(Exception):
    """The search's budget of programs is spent."""


def sos_eps_star(solve, base: float, top: float, rtol: float, *, hint: float = 0.9,
                 step: float = 0.9, budget: int = 8):
    """Largest eps in ``[base, top]`` certified by ``solve``: ``(eps or None, programs)``.

    Parameters
    ----------
    solve : callable
        ``eps -> (certified, eta, slope)`` (``eta`` and ``slope = d eta / d eps`` None when
        the program gave none).
    base, top : float
        Search interval: ``top`` is known to fail (a refuted eps), ``base`` the lowest tried.
    rtol : float
        Relative resolution of the final bracket.
    hint : float, optional
        First eps tried, as a fraction of ``top`` (capped where the bracket is already closed).
    step : float, optional
        Factor of the steps down.
    budget : int, optional
        Most programs solved; past it the last certified eps is returned (sound: it was
        certified).

    Returns
    -------
    (float or None, int)
        The eps (None when none tried was certified) and the programs solved.

    Examples
    --------
    >>> sos_eps_star(lambda e: (False, -1e-7, None), 0.1, 1.0, 1e-2, budget=3)
    (None, 3)
    """
    count = [0]

    def ev(e: float):
        if count[0] >= budget:
            raise _Budget
        count[0] += 1
        return solve(e)

    good = None
    try:
        x = max(base, min(hint, 1.0 / (1.0 + 0.999 * rtol)) * top)
        bad = top
        while True:
            ok, eta, slope = ev(x)
            if ok:
                good = (x, eta, slope)
                break
            bad = x
            if x <= base:
                return None, count[0]
            x = max(base, step * x)
        misses = 0
        while bad / good[0] - 1.0 > rtol:
            x, expect = _next(good, bad, rtol, misses)
            ok, eta, slope = ev(x)
            if ok:
                good = (x, eta, slope)
            else:
                bad = x
            if expect is not None and ok != expect:
                misses += 1
    except _Budget:
        pass
    return (None if good is None else float(good[0])), count[0]


def _next(good, bad: float, rtol: float, misses: int):
    """The next eps and whether it is expected certified (None: a bisection step)."""
    g, eta, slope = good
    span = math.log(bad / g)
    lo, hi = g * math.exp(0.02 * span), bad * math.exp(-0.02 * span)
    x, expect = math.sqrt(g * bad), None
    if (misses < 2 and eta is not None and slope is not None and eta > 0.0 and slope < 0.0
            and math.isfinite(eta / slope)):
        r = g - eta / slope
        if r < g * (1.0 + rtol):
            x, expect = g * (1.0 + rtol) / (1.0 + 1e-6), False
        elif r * (1.0 - 0.25 * rtol) < hi:  # a root beyond the bracket: the slope misleads
            x, expect = r * (1.0 - 0.25 * rtol), True
    return min(max(x, lo), hi), expect


__all__ = ["sos_eps_star"]
