"""eps* of the quartic SOS certificate: a secant on the SOS program's margin, not a bisection.

Each SOS program (:mod:`._sos`) returns, besides its verdict, its optimal margin ``eta`` (the
largest ``lambda_min`` of ``Q`` and of every ``R_v``, ``trace Q = m``): positive where a
strictly feasible quartic ``V`` exists, and a continuous function of eps (the optimal value of
an SDP whose data are continuous in eps). A bisection of the verdict to ``rtol = 1e-2`` from
``0.9 top`` solved about five programs; the margin's root, found by a safeguarded secant in
``log eps`` (:func:`._search._refine`: two evaluations close the bracket when the root estimate
is good, bisection after eight tries, a valid bracket kept at every step), needs fewer:

1. ``top / (1 + 0.999 rtol)`` first (``top`` the refuted end): certified there, the bracket
   ``[x, top]`` is already within ``rtol`` (one program);
2. else steps down from ``hint * top`` by ``step`` until a certified eps (or ``base``);
3. then the secant between the last certified and the first failed eps.

The answer is an eps where a certificate was found and re-checked (never the secant's
estimate), and ``[answer, bad]`` with ``bad / answer - 1 <= rtol`` contains the certificate's
boundary when it is unique, as the bisection's did. A verdict of "certified" always wins over
the margin's sign (a positive ``eta`` whose re-check fails counts as failed).

Examples
--------
>>> from fl_design.analysis._sos_search import sos_eps_star
>>> # a margin 0.3 - eps: certified below 0.3 (the verdict of the margin's sign)
>>> eps, n = sos_eps_star(lambda e: (0.3 - e > 0, 0.3 - e), 0.01, 0.4, 1e-2)
>>> 0.297 <= eps <= 0.3, n <= 6
(True, True)
"""

from __future__ import annotations

import math

from ._search import _refine

#: The margin given to a failed eps with no usable ``eta`` (solver failure, a frozen loop not
#: Schur): as bad as a margin can be (``eta <= 1`` with ``trace Q = m``).
NO_MARGIN = 1.0
#: The margin given to a failed eps whose ``eta`` is positive (the re-check failed).
TINY = 1e-12


class _Budget(Exception):
    """The search's budget of programs is spent."""


def sos_eps_star(solve, base: float, top: float, rtol: float, *, hint: float = 0.9,
                 step: float = 0.9, budget: int = 8):
    """Largest eps in ``[base, top]`` certified by ``solve``: ``(eps or None, programs)``.

    Parameters
    ----------
    solve : callable
        ``eps -> (certified, eta)`` (``eta`` None when no program gave one).
    base, top : float
        Search interval: ``top`` is known to fail (a refuted eps), ``base`` the lowest tried.
    rtol : float
        Relative resolution of the final bracket.
    hint : float, optional
        Start of the steps down, as a fraction of ``top``.
    step : float, optional
        Factor of the steps down.
    budget : int, optional
        Most programs solved; past it the best certified eps so far is returned (sound:
        it was certified).

    Returns
    -------
    (float or None, int)
        The eps (None when none tried was certified) and the programs solved.

    Examples
    --------
    >>> sos_eps_star(lambda e: (False, -1.0), 0.1, 1.0, 1e-2, budget=3)
    (None, 3)
    """
    count = [0]

    def margin(e: float) -> float:
        if count[0] >= budget:
            raise _Budget
        count[0] += 1
        ok, eta = solve(e)
        if ok:
            return -max(float(eta), TINY) if eta is not None else -TINY
        if eta is None or not math.isfinite(eta):
            return NO_MARGIN
        return max(-float(eta), TINY)

    good = None
    x = max(base, top / (1.0 + 0.999 * rtol))
    try:
        m = margin(x)
        if m < 0.0:
            return float(x), count[0]
        bad, m_bad = x, m
        x = max(base, min(hint * top, x / (1.0 + rtol)))
        while True:
            m = margin(x)
            if m < 0.0:
                good, m_good = x, m
                break
            bad, m_bad = x, m
            if x <= base:
                return None, count[0]
            x = max(base, step * x)
        good = _refine_counted(margin, good, m_good, bad, m_bad, rtol, count)
    except _Budget:
        pass
    return (None if good is None else float(good)), count[0]


def _refine_counted(margin, good, m_good, bad, m_bad, rtol, count):
    """:func:`._search._refine`, the last certified eps kept when the budget runs out."""
    best = [good]

    def tracked(e):
        m = margin(e)
        if m < 0.0 and e > best[0]:
            best[0] = e
        return m

    try:
        return _refine(tracked, good, m_good, bad, m_bad, rtol)[0]
    except _Budget:
        return best[0]


__all__ = ["sos_eps_star"]
