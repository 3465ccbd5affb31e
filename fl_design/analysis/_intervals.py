"""Enclosures of SymPy expressions over boxes, split into sub-boxes against the dependency effect.

Each sub-box is enclosed by :func:`fl_design.symbolic._enclosure.enclosure` (the one interval
evaluator of fl_design: it walks the expression tree, never a string, never ``lambdify``, with
outward-rounded intervals, ``mpmath.iv``): the result *contains* every value the expression
takes on the box (sound), and is exact for expressions in which each variable occurs once and
every function is monotone on the sub-box. Where a
variable occurs several times the enclosure can be wider than the range (the dependency
effect); :func:`interval_range` shrinks that by splitting the box into sub-boxes (``splits``
per variable, at most :data:`MAX_BOXES` in all) and returning the hull of the enclosures.

Supported: what that evaluator supports (numbers, ``pi``, ``E``, ``+``, ``*``, integer powers,
square roots and real powers of a non-negative base, and the grammar's functions); anything
else raises :class:`~fl_design.errors.ParameterError` saying why.

Examples
--------
>>> import sympy as sp
>>> x = sp.Symbol("x")
>>> interval_range(-9.81 * sp.sin(x), {x: (-0.5, 0.5)})
(-4.703..., 4.703...)
>>> interval_range(x * (1 - x), {x: (0.0, 1.0)})   # the dependency effect: range [0, 0.25]
(0.0, 1.0)
>>> interval_range(x * (1 - x), {x: (0.0, 1.0)}, splits=64)[1]
0.2578125
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from ..errors import ParameterError

#: Most sub-boxes :func:`interval_range` evaluates.
MAX_BOXES = 4096


def interval_range(expr, box: dict, *, splits: int = 1) -> tuple[float, float]:
    """An enclosure ``(lo, hi)`` of ``expr`` over ``box`` (see the module docstring).

    Parameters
    ----------
    expr : sympy.Expr
        The expression.
    box : dict
        ``{symbol: (lo, hi)}`` for every free symbol (a degenerate range is a value).
    splits : int, optional
        Sub-intervals per variable that ``expr`` depends on (fewer when the product would
        exceed :data:`MAX_BOXES`).

    Returns
    -------
    (float, float)
        Contains every value of ``expr`` on the box.

    Raises
    ------
    ParameterError
        A symbol without a range, an unsupported function, a division by an interval
        containing 0, or a non-finite enclosure.

    Examples
    --------
    >>> import sympy as sp
    >>> u = sp.Symbol("u")
    >>> interval_range(0.8 * (0.09 + 0.032 * sp.Abs(u)) / 0.02, {u: (-2.5, 2.5)})
    (3.59..., 6.8...)
    """
    import sympy as sp

    from ..symbolic._enclosure import NotEnclosable, enclosure  # SymPy: imported on use

    expr = sp.sympify(expr)
    free = sorted(expr.free_symbols, key=str)
    missing = [str(s) for s in free if s not in box]
    if missing:
        raise ParameterError(f"{expr} depends on {missing}, which have no range: give one")
    varying = [s for s in free if box[s][0] != box[s][1]]
    k = max(1, int(splits))
    while varying and k > 1 and k ** len(varying) > MAX_BOXES:
        k -= 1
    edges = {s: np.linspace(float(box[s][0]), float(box[s][1]), k + 1) for s in varying}
    lo, hi = math.inf, -math.inf
    for cell in itertools.product(range(k), repeat=len(varying)):
        sub = {s: (float(box[s][0]), float(box[s][1])) for s in free}
        for s, i in zip(varying, cell):
            sub[s] = (float(edges[s][i]), float(edges[s][i + 1]))
        try:
            a, b = enclosure(expr, sub)
        except NotEnclosable as why:
            raise ParameterError(f"cannot enclose {expr} on the box: {why}") from None
        lo, hi = min(lo, a), max(hi, b)
    return float(lo), float(hi)


__all__ = ["MAX_BOXES", "interval_range"]
