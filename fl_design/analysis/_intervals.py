"""Enclosures of SymPy expressions over boxes by interval arithmetic (mpmath ``iv``).

:func:`interval_range` walks the expression tree (never a string, never ``lambdify``) and
evaluates every node with outward-rounded intervals (``mpmath.iv``, 53-bit): the result
*contains* every value the expression takes on the box (sound), and is exact for expressions
in which each variable occurs once and every function is monotone on the sub-box. Where a
variable occurs several times the enclosure can be wider than the range (the dependency
effect); :func:`interval_range` shrinks that by splitting the box into sub-boxes (``splits``
per variable, at most :data:`MAX_BOXES` in all) and returning the hull of the enclosures.

Supported: numbers, ``pi``, ``E``, ``+``, ``*``, powers (integer, and ``x**(p/q)`` of a
non-negative base), ``sin``, ``cos``, ``tan``, ``exp``, ``log``, ``Abs``, ``sign``, ``Min``,
``Max``, and the monotone ``tanh``, ``atan``, ``sinh``, ``asinh`` (end points widened by 4
ulps), ``cosh``. Anything else raises :class:`~fl_design.errors.ParameterError` naming it.

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


def _iv():
    from mpmath import iv

    return iv


def _ends(x) -> tuple[float, float]:
    return float(x.a), float(x.b)


def _widened(lo: float, hi: float):
    lo = float(np.nextafter(lo, -np.inf))
    hi = float(np.nextafter(hi, np.inf))
    for _ in range(3):
        lo, hi = float(np.nextafter(lo, -np.inf)), float(np.nextafter(hi, np.inf))
    return _iv().mpf([lo, hi])


def _monotone(fn, x):
    """Increasing ``fn`` (float -> float, within an ulp) on the interval ``x``."""
    lo, hi = _ends(x)
    return _widened(fn(lo), fn(hi))


def _cosh(x):
    lo, hi = _ends(x)
    top = max(math.cosh(lo), math.cosh(hi))
    bottom = 1.0 if lo <= 0.0 <= hi else min(math.cosh(lo), math.cosh(hi))
    return _widened(bottom, top)


def _abs(x):
    lo, hi = _ends(x)
    if lo >= 0.0:
        return x
    if hi <= 0.0:
        return -x
    return _iv().mpf([0.0, max(-lo, hi)])


def _sign(x):
    lo, hi = _ends(x)
    return _iv().mpf([float(np.sign(lo)), float(np.sign(hi))])


def _minmax(args, take_max: bool):
    ends = [_ends(a) for a in args]
    pick = max if take_max else min
    return _iv().mpf([pick(e[0] for e in ends), pick(e[1] for e in ends)])


def _pow(base, exponent, expr):
    import sympy as sp

    if exponent.is_Integer:
        k = int(exponent)
        if k >= 0:
            return base ** k
        lo, hi = _ends(base)
        if lo <= 0.0 <= hi:
            raise ParameterError(
                f"{expr} is unbounded on the box: its base ranges over "
                f"[{lo:.6g}, {hi:.6g}], which contains 0; narrow the region or the parameters")
        return 1 / base ** (-k)
    if exponent.is_Rational:
        lo, _ = _ends(base)
        if lo < 0.0:
            raise ParameterError(
                f"{expr}: a fractional power of a base that can be negative ([{lo:.6g}, ...])")
        iv = _iv()
        root = iv.sqrt(base) if exponent.q == 2 else iv.exp(iv.log(base) / int(exponent.q))
        return _pow(root, sp.Integer(exponent.p), expr) if exponent.p != 1 else root
    raise ParameterError(f"interval arithmetic supports integer and rational exponents; got {expr}")


def _eval(expr, env: dict):
    import sympy as sp

    iv = _iv()
    if expr.is_Symbol:
        if expr not in env:
            raise ParameterError(f"{expr} has no range: give one (region, input_range or params)")
        return env[expr]
    if expr.is_Integer:
        return iv.mpf(int(expr))
    if expr.is_Rational:
        return iv.mpf(int(expr.p)) / int(expr.q)
    if expr.is_Float:
        return iv.mpf(float(expr))
    if expr is sp.pi:
        return iv.pi
    if expr is sp.E:
        return iv.e
    if expr.is_Add:
        return sum((_eval(a, env) for a in expr.args[1:]), _eval(expr.args[0], env))
    if expr.is_Mul:
        out = _eval(expr.args[0], env)
        for a in expr.args[1:]:
            out = out * _eval(a, env)
        return out
    if expr.is_Pow:
        base, exponent = expr.args
        if base is sp.E:
            return iv.exp(_eval(exponent, env))
        return _pow(_eval(base, env), exponent, expr)
    unary = {sp.sin: iv.sin, sp.cos: iv.cos, sp.tan: iv.tan, sp.exp: iv.exp, sp.log: iv.log,
             sp.Abs: _abs, sp.sign: _sign, sp.cosh: _cosh,
             sp.tanh: lambda x: _monotone(math.tanh, x),
             sp.atan: lambda x: _monotone(math.atan, x),
             sp.sinh: lambda x: _monotone(math.sinh, x),
             sp.asinh: lambda x: _monotone(math.asinh, x)}
    if expr.func in unary and len(expr.args) == 1:
        return unary[expr.func](_eval(expr.args[0], env))
    if expr.func in (sp.Max, sp.Min):
        return _minmax([_eval(a, env) for a in expr.args], expr.func is sp.Max)
    raise ParameterError(
        f"interval arithmetic does not support {expr.func.__name__} (in {expr}); supported: "
        "+, *, powers, sin, cos, tan, exp, log, Abs, sign, Min, Max, tanh, atan, sinh, asinh, cosh")


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

    iv = _iv()
    expr = sp.sympify(expr)
    free = sorted(expr.free_symbols, key=str)
    missing = [str(s) for s in free if s not in box]
    if missing:
        raise ParameterError(f"{expr} depends on {missing}, which have no range: give one")
    varying = [s for s in free if box[s][0] != box[s][1]]
    k = max(1, int(splits))
    while varying and k > 1 and k ** len(varying) > MAX_BOXES:
        k -= 1
    base = {s: iv.mpf([float(box[s][0]), float(box[s][1])]) for s in free}
    edges = {s: np.linspace(float(box[s][0]), float(box[s][1]), k + 1) for s in varying}
    lo, hi = math.inf, -math.inf
    for cell in itertools.product(range(k), repeat=len(varying)):
        env = dict(base)
        for s, i in zip(varying, cell):
            env[s] = iv.mpf([edges[s][i], edges[s][i + 1]])
        a, b = _ends(_eval(expr, env))
        lo, hi = min(lo, a), max(hi, b)
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise ParameterError(f"the enclosure of {expr} on the box is not finite ([{lo}, {hi}])")
    return float(lo), float(hi)


__all__ = ["MAX_BOXES", "interval_range"]
