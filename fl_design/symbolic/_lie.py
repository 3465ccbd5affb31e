"""The one Lie derivative of fl_design: ``L_F y = (dy/dx) F``, for an expression or a vector.

Used by the relative degree and normal form (output derivatives ``L_f^i h``), by the Taylor
(Lie) series of the sampled plant and by the chain substitution of the discretization report.
Symbols in ``field`` or ``y`` that are not states (the held input, parameters) are constants.

Examples
--------
>>> import sympy as sp
>>> from fl_design.symbolic._lie import lie_derivative
>>> p, v, u = sp.symbols("p v u")
>>> lie_derivative(p * v, [p, v], [v, u])
p*u + v**2
>>> lie_derivative(sp.Matrix([p, v]), [p, v], [v, u]).T
Matrix([[v, u]])
"""

from __future__ import annotations

import sympy as sp


def lie_derivative(y, states, field):
    """``L_F y = sum_i (dy/dx_i) F_i``: an expression, or each entry of a column matrix.

    Parameters
    ----------
    y : sympy.Expr or sympy.Matrix
        A scalar expression or a column of expressions.
    states : sequence of sympy.Symbol
        The state ``x``.
    field : sequence of sympy.Expr or sympy.Matrix
        The vector field ``F`` (one entry per state).

    Returns
    -------
    sympy.Expr or sympy.ImmutableMatrix
        Of the same kind as ``y``.

    Examples
    --------
    >>> import sympy as sp
    >>> from fl_design.symbolic._lie import lie_derivative
    >>> x = sp.symbols("x")
    >>> lie_derivative(sp.sin(x), [x], [x**2])
    x**2*cos(x)
    """
    states = tuple(states)
    f = tuple(field)
    if isinstance(y, sp.MatrixBase):
        return sp.ImmutableMatrix(y.jacobian(states) * sp.Matrix(f))
    return sum((sp.diff(y, s) * fi for s, fi in zip(states, f)), sp.S.Zero)


__all__ = ["lie_derivative"]
