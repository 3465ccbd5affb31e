"""Which SymPy constructs a plant may contain: each refused one gets a PlantDefinitionError.

A plant is ``x' = f(x, u)``, ``y = h(x)`` with ``f`` and ``h`` written out in closed form from
numbers, the states, the input and parameters, with the functions of
:mod:`fl_design.symbolic._bridge`. Refused here, before SciPy or SymPy's printers see them:
non-finite constants (``zoo``, ``oo``, ``nan``), undefined functions (``g(x1)``),
unevaluated operations (``Derivative``, ``Integral``, ``Subs``, ``Limit``, ``Sum``,
``Product``, ``Order``), a ``Piecewise`` without an otherwise branch; and symbols that share a
state's name but not its assumptions (a string rhs against ``real=True`` symbols).

Examples
--------
>>> import sympy as sp
>>> from fl_design.symbolic._constructs import check_expression
>>> x = sp.Symbol("x")
>>> check_expression("rhs[0]", sp.sin(x)) == sp.sin(x)
True
>>> check_expression("rhs[0]", sp.Function("g")(x))
Traceback (most recent call last):
...
fl_design.errors.PlantDefinitionError: rhs[0] calls the undefined function g(x): ...
"""

from __future__ import annotations

import sympy as sp
from sympy.core.function import AppliedUndef

from ..errors import PlantDefinitionError

_UNEVALUATED = (sp.Derivative, sp.Integral, sp.Subs, sp.Limit, sp.Sum, sp.Product, sp.Order)
_NON_FINITE = {sp.zoo: "zoo (complex infinity)", sp.oo: "oo (infinity)",
               -sp.oo: "-oo (minus infinity)", sp.nan: "nan (not a number)"}


def check_expression(what: str, expr: sp.Expr) -> sp.Expr:
    """Return ``expr`` if a plant may contain it, else raise PlantDefinitionError naming the part.

    Parameters
    ----------
    what : str
        Where the expression comes from (``"rhs[1]"``, ``"output"``).
    expr : sympy.Expr
        The expression.

    Returns
    -------
    sympy.Expr
        ``expr``, unchanged.

    Raises
    ------
    PlantDefinitionError
        A non-finite constant, an undefined function, an unevaluated operation or a
        ``Piecewise`` without an otherwise branch.

    Examples
    --------
    >>> import sympy as sp
    >>> from fl_design.symbolic._constructs import check_expression
    >>> check_expression("rhs[1]", sp.zoo + sp.Symbol("u"))
    Traceback (most recent call last):
    ...
    fl_design.errors.PlantDefinitionError: rhs[1] contains the constant zoo (complex infinity): ...
    """
    for const, name in _NON_FINITE.items():
        if expr.has(const):
            raise PlantDefinitionError(
                f"{what} contains the constant {name}: every term of a plant must be finite "
                f"(got {_short(expr)}); write the finite expression meant")
    undefined = sorted(expr.atoms(AppliedUndef), key=str)
    if undefined:
        raise PlantDefinitionError(
            f"{what} calls the undefined function {undefined[0]}: a plant is written out in "
            f"closed form; replace it, e.g. expr.subs({undefined[0]}, sp.sin("
            f"{', '.join(map(str, undefined[0].args))})), with supported functions")
    for kind in _UNEVALUATED:
        found = sorted(expr.atoms(kind), key=str)
        if found:
            raise PlantDefinitionError(
                f"{what} contains the unevaluated {kind.__name__} {_short(found[0])}: give f(x, "
                "u) in closed form (call .doit() first; a state's derivative is the rhs of that "
                "state, not a Derivative)")
    for pw in expr.atoms(sp.Piecewise):
        if pw.args[-1].cond is not sp.true:
            raise PlantDefinitionError(
                f"{what} has a Piecewise without an otherwise branch, {_short(pw)}: add a last "
                "pair (value, True) so that it is defined everywhere")
    return expr


def mismatched_assumptions(unknown, known) -> str | None:
    """A message when an unknown symbol has a known symbol's name but other assumptions.

    Examples
    --------
    >>> import sympy as sp
    >>> from fl_design.symbolic._constructs import mismatched_assumptions
    >>> print(mismatched_assumptions({sp.Symbol("x")}, {sp.Symbol("x", real=True)}))
    symbol x appears with assumptions {} but the state/input/parameter x has {'real': True} ...
    """
    by_name = {s.name: s for s in known}
    for sym in sorted(unknown, key=str):
        twin = by_name.get(sym.name)
        if twin is not None:
            return (f"symbol {sym.name} appears with assumptions {_given(sym)} but the "
                    f"state/input/parameter {twin.name} has {_given(twin)} (SymPy sees two "
                    "different symbols; strings make symbols without assumptions): build rhs and "
                    "output from the same Symbol objects, or create them with the same "
                    "assumptions")
    return None


def non_finite_at(rows, point: str) -> None:
    """Raise PlantDefinitionError if an entry of ``rows`` (substituted at ``point``) is not finite.

    Examples
    --------
    >>> import sympy as sp
    >>> from fl_design.symbolic._constructs import non_finite_at
    >>> non_finite_at([sp.Integer(1), sp.zoo], "x1=0")
    Traceback (most recent call last):
    ...
    fl_design.errors.PlantDefinitionError: rhs[1] is singular at the operating point (x1=0): ...
    """
    for i, row in enumerate(rows):
        if any(row.has(c) for c in _NON_FINITE):
            raise PlantDefinitionError(
                f"rhs[{i}] is singular at the operating point ({point}): it evaluates to "
                f"{_short(row)}; choose an operating_point where f(x, u) is finite")


def _given(sym: sp.Symbol) -> dict:
    """The assumptions a symbol was created with (not the ones SymPy derives from them)."""
    return dict(getattr(sym, "_assumptions_orig", sym.assumptions0))


def _short(expr, limit: int = 80) -> str:
    text = str(expr)
    return text if len(text) <= limit else text[: limit - 3] + "..."


__all__ = ["check_expression", "mismatched_assumptions", "non_finite_at"]
