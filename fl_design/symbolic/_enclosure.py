"""Rigorous interval enclosures of SymPy expressions over a box (mpmath's interval arithmetic).

Decides signs without thresholds: ``b = 1 + 40 u**39`` at ``u = 0`` is enclosed in ``[1, 1]``,
so it is nonzero whatever ``b`` does elsewhere (a relative threshold against ``b``'s size at
other points called it zero). Supported: numbers, symbols given a range, ``+ * /``, powers, and
the grammar's functions (:data:`fl_design.symbolic._grammar.FUNCTIONS`); anything else gives
None (the caller decides otherwise). Every operation rounds outward, so the true range lies
inside the enclosure.

Examples
--------
>>> import sympy as sp
>>> from fl_design.symbolic._enclosure import enclose
>>> u = sp.Symbol("u")
>>> enclose(1 + 40 * u**39, {u: (0.0, 0.0)})
(1.0, 1.0)
>>> lo, hi = enclose(sp.sin(u), {u: (0.0, 1.0)})
>>> lo <= 0.0 and hi >= 0.841
True
"""

from __future__ import annotations

import math

import sympy as sp
from mpmath import iv, mp

_PREC = 50  # relative widening (bits) of ends computed by mpmath at a higher precision


def _monotone(fn, x, increasing=True):
    """Enclosure of a monotone function from its values at the ends (widened outward)."""
    a, b = float(x.a), float(x.b)
    with mp.workprec(_PREC + 20):
        lo, hi = fn(mp.mpf(a)), fn(mp.mpf(b))
    if not increasing:
        lo, hi = hi, lo
    pad = lambda v: abs(v) * 2.0 ** (-_PREC) + 1e-300
    return iv.mpf([lo - pad(lo), hi + pad(hi)])


def _abs(x):
    lo, hi = x.a, x.b
    if lo >= 0:
        return x
    if hi <= 0:
        return -x
    return iv.mpf([0, max(-lo, hi)])


def _cosh(x):
    ends = _monotone(mp.cosh, iv.mpf([0, max(abs(x.a), abs(x.b))]))
    return iv.mpf([1 if x.a <= 0 <= x.b else min(mp.cosh(x.a), mp.cosh(x.b)) * (1 - 2.0**-_PREC),
                   ends.b])


def _sign(x):
    lo = -1 if x.a < 0 else (0 if x.a == 0 else 1)
    hi = 1 if x.b > 0 else (0 if x.b == 0 else -1)
    return iv.mpf([lo, hi])


def _minmax(pick):
    return lambda *xs: iv.mpf([pick(x.a for x in xs), pick(x.b for x in xs)])


def _inside(lo, hi):
    return lambda fn: lambda x: fn(x) if lo <= x.a and x.b <= hi else None


_FUNCTIONS: dict = {
    sp.sin: iv.sin, sp.cos: iv.cos, sp.tan: iv.tan, sp.exp: iv.exp,
    sp.log: lambda x: iv.log(x) if x.a > 0 else None,
    sp.atan: lambda x: _monotone(mp.atan, x), sp.sinh: lambda x: _monotone(mp.sinh, x),
    sp.tanh: lambda x: _monotone(mp.tanh, x), sp.asinh: lambda x: _monotone(mp.asinh, x),
    sp.erf: lambda x: _monotone(mp.erf, x), sp.cosh: _cosh,
    sp.asin: _inside(-1, 1)(lambda x: _monotone(mp.asin, x)),
    sp.acos: _inside(-1, 1)(lambda x: _monotone(mp.acos, x, increasing=False)),
    sp.atanh: lambda x: _monotone(mp.atanh, x) if -1 < x.a and x.b < 1 else None,
    sp.acosh: lambda x: _monotone(mp.acosh, x) if x.a >= 1 else None,
    sp.Abs: _abs, sp.sign: _sign, sp.Min: _minmax(min), sp.Max: _minmax(max),
}
#: The supported functions by name (for the refusal of any other).
_NAMES = ", ".join(sorted(f.__name__ for f in _FUNCTIONS))


class NotEnclosable(Exception):
    """Why an expression has no enclosure on a box (the message says, in words)."""


def _eval(expr, box):
    if expr in box:
        return box[expr]
    if expr.is_Float and expr._prec <= 53:  # a double: exact
        return iv.mpf([float(expr), float(expr)])
    if expr.is_Number or expr in (sp.pi, sp.E):
        with mp.workprec(_PREC + 20):
            v = mp.mpf(sp.N(expr, 40)) if not expr.is_Integer else mp.mpf(int(expr))
        if expr.is_Integer:
            return iv.mpf([v, v])
        w = abs(v) * 2.0**-_PREC
        return iv.mpf([v - w, v + w])
    if isinstance(expr, sp.Add):
        out = iv.mpf(0)
        for a in expr.args:
            out = out + _eval(a, box)
        return out
    if isinstance(expr, sp.Mul):
        out = iv.mpf(1)
        for a in expr.args:
            out = out * _eval(a, box)
        return out
    if isinstance(expr, sp.Pow):
        return _pow(_eval(expr.base, box), expr.exp, box)
    fn = _FUNCTIONS.get(type(expr)) or _FUNCTIONS.get(getattr(expr, "func", None))
    if fn is None:
        raise NotEnclosable(f"interval arithmetic does not support {type(expr).__name__}; "
                            f"supported: numbers, +, *, powers, {_NAMES}")
    out = fn(*(_eval(a, box) for a in expr.args))
    if out is None:
        raise NotEnclosable(f"{type(expr).__name__} is evaluated outside its domain")
    return out


def _pow(base, exponent, box):
    """``base ** exponent``: integer powers; square roots and real powers of a base >= 0."""
    if exponent.is_Integer or (exponent.is_Rational and exponent.q == 2):
        p = int(exponent.p)
        if exponent.q == 2:
            if base.a < 0:
                raise NotEnclosable(f"a square root of a base that can be negative "
                                    f"([{float(base.a):.6g}, ...])")
            base = iv.sqrt(base)
        if p < 0 and base.a <= 0 <= base.b:
            raise NotEnclosable(f"a division by an interval that contains 0 "
                                f"([{float(base.a):.6g}, {float(base.b):.6g}])")
        return base ** p
    if base.a < 0 or (base.a == 0 and not exponent.is_positive):
        raise NotEnclosable(f"a real power of a base that can be negative or 0 "
                            f"([{float(base.a):.6g}, ...])")
    return iv.exp(_eval(exponent, box) * iv.log(base))


def enclosure(expr, box) -> tuple[float, float]:
    """``(lo, hi)`` with ``lo <= expr <= hi`` over ``box``, or :class:`NotEnclosable` saying why.

    As :func:`enclose`, whose None this raises with its reason.

    Parameters
    ----------
    expr : sympy.Expr
        With no free symbols but those of ``box``.
    box : mapping of sympy.Symbol to (float, float)
        The range of each symbol.

    Returns
    -------
    (float, float)
        Rounded outward to doubles.

    Raises
    ------
    NotEnclosable
        A symbol without a range, an unsupported function, a division by a range holding
        zero, a negative base of a root, a non-finite end or a too deep expression.

    Examples
    --------
    >>> import sympy as sp
    >>> from fl_design.symbolic._enclosure import NotEnclosable, enclosure
    >>> x = sp.Symbol("x")
    >>> enclosure(sp.sqrt(x), {x: (0.0, 4.0)})
    (0.0, 2.0)
    >>> try:
    ...     enclosure(1 / x, {x: (-1.0, 1.0)})
    ... except NotEnclosable as why:
    ...     print(why)
    a division by an interval that contains 0 ([-1, 1])
    """
    if not isinstance(expr, sp.Basic):
        raise NotEnclosable(f"{expr!r} is not a SymPy expression")
    missing = sorted(str(s) for s in expr.free_symbols - set(box))
    if missing:
        raise NotEnclosable(f"{expr} depends on {missing}, which have no range: give one")
    ivbox = {s: iv.mpf([float(lo), float(hi)]) for s, (lo, hi) in box.items()}
    try:
        out = _eval(expr, ivbox)
        lo, hi = float(mp.mpf(out.a)), float(mp.mpf(out.b))
    except RecursionError:
        raise NotEnclosable("the expression is too deep to enclose") from None
    except (ZeroDivisionError, ValueError, TypeError, ArithmeticError, AttributeError,
            AssertionError) as err:
        raise NotEnclosable(f"interval arithmetic failed ({type(err).__name__}: {err})") from None
    if not (math.isfinite(lo) and math.isfinite(hi)) or lo > hi:
        raise NotEnclosable(f"the enclosure [{lo}, {hi}] is not finite")
    lo = lo if mp.mpf(lo) <= out.a else math.nextafter(lo, -math.inf)
    hi = hi if mp.mpf(hi) >= out.b else math.nextafter(hi, math.inf)
    return lo, hi


def enclose(expr, box) -> tuple[float, float] | None:
    """``(lo, hi)`` with ``lo <= expr <= hi`` over the box, or None when not enclosable.

    Parameters
    ----------
    expr : sympy.Expr
        With no free symbols but those of ``box``.
    box : mapping of sympy.Symbol to (float, float)
        The range of each symbol (equal ends for a point).

    Returns
    -------
    (float, float) or None
        Rounded outward to doubles; None for an unsupported function, a symbol without a
        range, a division by a range holding zero, a non-finite end or a too deep expression.

    Examples
    --------
    >>> import sympy as sp
    >>> from fl_design.symbolic._enclosure import enclose
    >>> x = sp.Symbol("x")
    >>> enclose(x**2 - 1, {x: (-1.0, 2.0)})
    (-1.0, 3.0)
    >>> enclose(1 / x, {x: (-1.0, 1.0)}) is None
    True
    """
    try:
        return enclosure(expr, box)
    except NotEnclosable:
        return None


__all__ = ["NotEnclosable", "enclose", "enclosure"]
