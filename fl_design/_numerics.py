"""Small numerical helpers shared across layers: the one log-scale bisection.

Examples
--------
>>> from fl_design._numerics import bisect_log
>>> res = bisect_log(lambda x: x < 0.3, 0.01, 1.0, rtol=1e-6)
>>> round(res.lo, 4), round(res.hi, 4), res.converged
(0.3, 0.3, True)
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from .errors import ParameterError


@dataclass(frozen=True)
class Bisection:
    """Bracket ``[lo, hi]`` with ``good(lo)`` and not ``good(hi)``, and how it was found.

    Parameters
    ----------
    lo, hi : float
        Last good and first bad point.
    evaluations : int
        Calls of the predicate (ends included).
    converged : bool
        ``hi / lo - 1 <= rtol`` was reached within the budget.

    Examples
    --------
    >>> from fl_design._numerics import Bisection
    >>> Bisection(1.0, 1.01, 7, True).hi
    1.01
    """

    lo: float
    hi: float
    evaluations: int
    converged: bool


def bisect_log(good: Callable[[float], bool], lo: float, hi: float, *, rtol: float = 0.01,
               max_evaluations: int = 200) -> Bisection:
    """Bisection in ``log x`` for the boundary of a predicate that holds at ``lo``, not at ``hi``.

    The ends are not evaluated: the caller checks them (and reports "no boundary in range"
    itself). Stops when ``hi / lo - 1 <= rtol`` or after ``max_evaluations`` calls.

    Parameters
    ----------
    good : callable
        ``good(x) -> bool``.
    lo, hi : float
        ``0 < lo < hi`` with ``good(lo)`` and not ``good(hi)``.
    rtol : float, optional
        Relative width of the final bracket (default 0.01; >= 1e-12: finer brackets are below
        what double precision resolves).
    max_evaluations : int, optional
        Budget of predicate calls (default 200).

    Returns
    -------
    Bisection

    Raises
    ------
    ParameterError
        ``lo``/``hi`` not ordered positive numbers, or ``rtol`` below 1e-12 or not positive.

    Examples
    --------
    >>> from fl_design._numerics import bisect_log
    >>> bisect_log(lambda x: x * x < 2.0, 1.0, 2.0, rtol=1e-9).lo ** 2 < 2.0
    True
    """
    if not (0.0 < lo < hi and math.isfinite(hi)):
        raise ParameterError(f"bisection needs 0 < lo < hi (finite), got lo={lo!r}, hi={hi!r}")
    if not (rtol >= 1e-12):
        raise ParameterError(f"rtol must be >= 1e-12 (double precision resolves no finer "
                             f"bracket), got {rtol!r}")
    n = 0
    while hi / lo - 1.0 > rtol and n < max_evaluations:
        mid = math.sqrt(lo * hi)
        n += 1
        if good(mid):
            lo = mid
        else:
            hi = mid
    return Bisection(lo, hi, n, hi / lo - 1.0 <= rtol)


__all__ = ["Bisection", "bisect_log"]
