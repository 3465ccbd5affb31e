"""The one SymPy -> CasADi bridge: symbolic plant expressions become named ``casadi.Function``\\ s.

SymPy lives in the derivation layer (plant, normal form, discretization); everything that runs
(simulation, sweeps, generated C) uses CasADi SX functions. This module is the only place where
one is turned into the other, so that every function of the plant is translated the same way.

Supported: numbers and the constants ``pi``, ``E``; ``+ - * /`` and powers (``sqrt`` included);
``Abs`` (``fabs``), ``sign``, ``Heaviside`` (with its value at 0), ``Min``/``Max``, ``Piecewise``
with relational, ``And``/``Or``/``Not`` conditions; ``sin cos tan asin acos atan atan2 sinh cosh
tanh asinh acosh atanh exp log erf floor ceiling``. Anything else raises
:class:`~fl_design.errors.PlantDefinitionError` naming the function.

Examples
--------
>>> import sympy as sp
>>> from fl_design.symbolic import to_casadi
>>> x, u = sp.symbols("x u", real=True)
>>> fn = to_casadi([sp.Abs(x) * u, sp.tanh(x)], [[x], [u]], "demo")
>>> fn
Function(demo:(i0,i1)->(o0[2]) SXFunction)
>>> [round(float(v), 6) for v in fn(-2.0, 3.0).full().ravel()]
[6.0, -0.964028]
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterable, Mapping, Sequence

import casadi as ca
import sympy as sp

from ..errors import PlantDefinitionError

_UNARY = {
    sp.Abs: ca.fabs,
    sp.sign: ca.sign,
    sp.sin: ca.sin,
    sp.cos: ca.cos,
    sp.tan: ca.tan,
    sp.asin: ca.asin,
    sp.acos: ca.acos,
    sp.atan: ca.atan,
    sp.sinh: ca.sinh,
    sp.cosh: ca.cosh,
    sp.tanh: ca.tanh,
    sp.asinh: ca.asinh,
    sp.acosh: ca.acosh,
    sp.atanh: ca.atanh,
    sp.exp: ca.exp,
    sp.erf: ca.erf,
    sp.floor: ca.floor,
    sp.ceiling: ca.ceil,
}

_RELATIONAL = {
    sp.StrictLessThan: lambda a, b: a < b,
    sp.LessThan: lambda a, b: a <= b,
    sp.StrictGreaterThan: lambda a, b: a > b,
    sp.GreaterThan: lambda a, b: a >= b,
    sp.Equality: lambda a, b: a == b,
    sp.Unequality: lambda a, b: a != b,
}
_FOLDED = {sp.Min: ca.fmin, sp.Max: ca.fmax, sp.And: ca.logic_and, sp.Or: ca.logic_or}


def _group(arg) -> list[sp.Symbol]:
    """One Function input: a Symbol or a sequence of Symbols."""
    items = list(arg) if isinstance(arg, (Sequence, sp.MatrixBase)) else [arg]
    for s in items:
        if not isinstance(s, sp.Symbol):
            raise PlantDefinitionError(
                f"to_casadi arguments must be sympy Symbols, got {s!r} of type {type(s).__name__}"
            )
    return items


def _expr(e) -> sp.Expr:
    """A SymPy object or a number; a string is refused (it would be evaluated as Python)."""
    try:
        return sp.sympify(e, strict=True)
    except sp.SympifyError:
        raise PlantDefinitionError(
            f"to_casadi takes SymPy expressions or numbers, got {type(e).__name__} {e!r:.60}; "
            "parse a string with fl_design.symbolic._grammar.parse_expression") from None


def _as_list(exprs) -> list[sp.Expr]:
    if isinstance(exprs, sp.MatrixBase):
        return [_expr(e) for e in exprs]
    if isinstance(exprs, Iterable) and not isinstance(exprs, (str, sp.Basic)):
        return [_expr(e) for e in exprs]
    return [_expr(exprs)]


class _Translator:
    """Walks a SymPy tree once, memoising shared sub-expressions."""

    def __init__(self, table: Mapping[sp.Symbol, ca.SX]):
        self.memo: dict[sp.Basic, ca.SX] = dict(table)

    def __call__(self, expr: sp.Basic):
        hit = self.memo.get(expr)
        if hit is not None:
            return hit
        out = self._translate(expr)
        self.memo[expr] = out
        return out

    def _translate(self, e: sp.Basic):
        if isinstance(e, sp.Symbol):  # only reached for symbols that are not arguments
            raise PlantDefinitionError(f"symbol {e} is not an argument of the function")
        if e is sp.true or e is sp.false:
            return ca.SX(1.0 if e is sp.true else 0.0)
        if e.is_number:  # any constant sub-expression, folded to one float
            value = complex(e.evalf())
            if value.imag != 0.0 or not math.isfinite(value.real):
                raise PlantDefinitionError(f"the constant {e} is not a finite real number")
            return ca.SX(value.real)
        if isinstance(e, sp.Add):
            out = self(e.args[0])
            for a in e.args[1:]:
                out = out + self(a)
            return out
        if isinstance(e, sp.Mul):
            out = self(e.args[0])
            for a in e.args[1:]:
                out = out * self(a)
            return out
        if isinstance(e, sp.Pow):
            return self._power(e)
        return self._function(e)

    def _power(self, e: sp.Pow):
        base, expo = e.args
        b = self(base)
        if expo == sp.Rational(1, 2):
            return ca.sqrt(b)
        if expo == sp.Rational(-1, 2):
            return 1.0 / ca.sqrt(b)
        if expo.is_Integer:
            k = int(expo)
            return b ** k if k >= 0 else 1.0 / (b ** (-k))
        return b ** self(expo)

    def _function(self, e: sp.Basic):
        func = e.func
        if func in _UNARY:
            return _UNARY[func](self(e.args[0]))
        if func is sp.log:
            out = ca.log(self(e.args[0]))
            return out / ca.log(self(e.args[1])) if len(e.args) == 2 else out
        if func is sp.atan2:
            return ca.atan2(self(e.args[0]), self(e.args[1]))
        if func is sp.Heaviside:
            x = self(e.args[0])
            at0 = self(e.args[1]) if len(e.args) > 1 else ca.SX(0.5)
            return ca.if_else(x > 0, 1.0, ca.if_else(x == 0, at0, 0.0))
        if func in _FOLDED:  # n-ary Min, Max, And, Or: left fold of the binary CasADi op
            return functools.reduce(_FOLDED[func], (self(a) for a in e.args))
        if func is sp.Piecewise:
            return self._piecewise(e)
        if func in _RELATIONAL:
            return _RELATIONAL[func](self(e.args[0]), self(e.args[1]))
        if func is sp.Not:
            return ca.logic_not(self(e.args[0]))
        name = getattr(func, "__name__", type(e).__name__)
        raise PlantDefinitionError(
            f"the function {name} (in {e}) has no CasADi translation; supported: Abs, sign, "
            "Heaviside, Min, Max, Piecewise, sqrt, exp, log, erf, floor, ceiling, atan2 and the "
            "trigonometric and hyperbolic functions with their inverses"
        )

    def _piecewise(self, e: sp.Piecewise):
        pieces = list(e.args)
        last_expr, last_cond = pieces[-1]
        if last_cond is not sp.true:
            raise PlantDefinitionError(
                f"Piecewise {e} has no otherwise branch (condition True); add one so that the "
                "function is defined everywhere"
            )
        out = self(last_expr)
        for expr, cond in reversed(pieces[:-1]):
            out = ca.if_else(self(cond), self(expr), out)
        return out


def to_casadi(
    exprs,
    args: Sequence,
    name: str,
    *,
    subs: Mapping[sp.Symbol, float] | None = None,
    input_names: Sequence[str] | None = None,
    output_name: str | None = None,
) -> ca.Function:
    """Translate SymPy expressions into one ``casadi.Function`` built from SX.

    Parameters
    ----------
    exprs : sympy expression, sequence of expressions or sympy Matrix
        The output; a sequence of m expressions gives an m-vector output (a single expression a
        scalar output).
    args : sequence
        The Function's inputs, in order; each is a Symbol (scalar input) or a sequence of Symbols
        (a vector input of that length, possibly empty).
    name : str
        The Function's name (a valid C identifier if the function is to be code-generated).
    subs : mapping, optional
        ``{Symbol: float}`` numeric values substituted before the translation (e.g. parameters).
    input_names : sequence of str, optional
        Names of the inputs (default ``i0, i1, ...``).
    output_name : str, optional
        Name of the output (default ``o0``).

    Returns
    -------
    casadi.Function
        ``name(args...) -> (output)``.

    Raises
    ------
    PlantDefinitionError
        A symbol of ``exprs`` is neither an argument nor in ``subs``, an argument is not a Symbol
        or appears twice, or an expression uses a function with no CasADi translation.

    Examples
    --------
    >>> import sympy as sp
    >>> from fl_design.symbolic import to_casadi
    >>> x1, x2, k = sp.symbols("x1 x2 k")
    >>> f = to_casadi(sp.Matrix([x2, -k * sp.sin(x1)]), [[x1, x2]], "f", subs={k: 2.0})
    >>> import math
    >>> [round(float(v), 12) for v in f([math.pi / 2, 0.0]).full().ravel()]
    [0.0, -2.0]
    """
    groups = [_group(a) for a in args]
    flat = [s for g in groups for s in g]
    dup = sorted({str(s) for s in flat if flat.count(s) > 1})
    if dup:
        raise PlantDefinitionError(f"to_casadi arguments appear more than once: {dup}")
    table: dict[sp.Symbol, ca.SX] = {}
    inputs = []
    for k, g in enumerate(groups):
        label = input_names[k] if input_names is not None else f"i{k}"
        sym = ca.SX.sym(label, len(g))
        inputs.append(sym)
        for j, s in enumerate(g):
            table[s] = sym[j]
    values = {s: sp.Float(float(v)) for s, v in (subs or {}).items()}
    items = [e.xreplace(values) if values else e for e in _as_list(exprs)]
    unknown = sorted({str(s) for e in items for s in e.free_symbols} - {str(s) for s in flat})
    if unknown:
        raise PlantDefinitionError(
            f"expressions for {name!r} contain symbol(s) {unknown} that are neither arguments "
            f"{[str(s) for s in flat]} nor substituted values"
        )
    tr = _Translator(table)
    out = ca.vertcat(*[tr(e) for e in items]) if items else ca.SX(0, 1)
    in_names = list(input_names) if input_names is not None else [f"i{k}" for k in range(len(args))]
    return ca.Function(name, inputs, [out], in_names, [output_name or "o0"])


__all__ = ["to_casadi"]
