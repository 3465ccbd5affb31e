"""Operations of a CasADi SX function's instruction list, by kind (the cost tables' counts).

Examples
--------
>>> import casadi as ca
>>> from fl_design.codegen._opcount import operation_counts
>>> x = ca.SX.sym("x")
>>> operation_counts(ca.Function("f", [x], [3 * x + 1]))["mul"]
1
"""

from __future__ import annotations

import casadi as ca

_KIND = {"ADD": "add", "SUB": "add", "MUL": "mul", "DIV": "div", "NEG": "neg",
         "FMIN": "minmax", "FMAX": "minmax", "LT": "compare", "LE": "compare",
         "EQ": "compare", "NE": "compare", "NOT": "compare", "AND": "compare",
         "OR": "compare", "IF_ELSE_ZERO": "select"}
_NOT_FLOPS = {"CONST", "INPUT", "OUTPUT", "PARAMETER", "ASSIGN"}
#: kinds counted as floating-point operations (all but loads, stores and constants)
FLOP_KINDS = ("add", "mul", "div", "neg", "minmax", "compare", "select", "math")

def operation_counts(function: ca.Function) -> dict[str, int]:
    """Operations of an SX function's instruction list, by kind (``add`` counts subtractions).

    Parameters
    ----------
    function : casadi.Function
        An SX function.

    Returns
    -------
    dict
        ``{kind: count}`` over :data:`FLOP_KINDS` (``math``: any other elementary function).

    Examples
    --------
    >>> import casadi as ca
    >>> from fl_design.codegen import operation_counts
    >>> x = ca.SX.sym("x")
    >>> operation_counts(ca.Function("f", [x], [ca.fmax(2 * x - 1, 0)]))["minmax"]
    1
    """
    names = {getattr(ca, n): n[3:] for n in dir(ca) if n.startswith("OP_")}
    out = dict.fromkeys(FLOP_KINDS, 0)
    for k in range(function.n_instructions()):
        name = names.get(function.instruction_id(k), "?")
        if name not in _NOT_FLOPS:
            out[_KIND.get(name, "math")] += 1
    return out


__all__ = ["FLOP_KINDS", "operation_counts"]
