"""The symbols and series of the sampled chain: ``F^a = exp(T N)``, the Lie (Taylor) series.

Shared by :func:`fl_design.taylor_discretization` (``_discretization``): the chain's state
symbols, ``sigma`` and its derivatives, the approximate extended model of the paper and the
terms ``L_F^k x`` of the exact sampled plant's series.

Examples
--------
>>> from fl_design.symbolic import approximate_extended_model
>>> approximate_extended_model(2)
Matrix([
[1, T, T**2/2],
[0, 1,      T],
[0, 0,      1]])
"""

from __future__ import annotations

from typing import Any

import sympy as sp

from .._validate import integer, positive
from ..errors import DimensionError
from ._lie import lie_derivative

#: Sampling time, the observer's time constant and their ratio ``T = alpha * eps``.
T_SYMBOL = sp.Symbol("T", positive=True)
ALPHA_SYMBOL = sp.Symbol("alpha", positive=True)
EPS_SYMBOL = sp.Symbol("epsilon", positive=True)

_SIGMA_NAMES = {0: ("sigma", r"\sigma"), 1: ("sigma_dot", r"\dot{\sigma}"),
                2: ("sigma_ddot", r"\ddot{\sigma}")}


def sigma_symbol(j: int) -> sp.Symbol:
    """The symbol of the j-th time derivative of the lumped term ``sigma`` (held input).

    Names are ``sigma``, ``sigma_dot``, ``sigma_ddot``, then ``sigma_d3``, ``sigma_d4``, ...

    Parameters
    ----------
    j : int
        Order of the time derivative, ``j >= 0``.

    Examples
    --------
    >>> sigma_symbol(1), sigma_symbol(4)
    (sigma_dot, sigma_d4)
    """
    j = integer("j", j, minimum=0)
    return sp.Symbol(_SIGMA_NAMES[j][0] if j in _SIGMA_NAMES else f"sigma_d{j}", real=True)


def _sigma_latex(j: int) -> str:
    return _SIGMA_NAMES[j][1] if j in _SIGMA_NAMES else rf"\sigma^{{({j})}}"


def chain_states(rho: int) -> tuple[sp.Symbol, ...]:
    """The normal-form chain states ``x1, ..., x_rho`` (real SymPy symbols).

    Parameters
    ----------
    rho : int
        Relative degree, ``rho >= 1``.

    Examples
    --------
    >>> chain_states(3)
    (x1, x2, x3)
    """
    rho = integer("rho", rho, minimum=1)
    return tuple(sp.Symbol(f"x{i}", real=True) for i in range(1, rho + 1))


def approximate_extended_model(rho: int, *, T: Any = None) -> sp.ImmutableMatrix:
    """The paper's approximate extended model ``F^a`` for relative degree ``rho``.

    ``F^a`` acts on the extended state ``(x_1, ..., x_rho, sigma)`` with ``sigma`` held constant
    over a sample: the ``(rho+1) x (rho+1)`` upper-triangular Toeplitz matrix with entries
    ``T^(j-i) / (j-i)!`` for ``j >= i``, i.e. ``exp(T N)`` with ``N`` the shift matrix.

    Parameters
    ----------
    rho : int
        Relative degree, ``rho >= 1``.
    T : sympy expression or float, optional
        Sampling time; the positive symbol ``T`` by default (use ``ALPHA_SYMBOL * EPS_SYMBOL``
        for the paper's ``T = alpha eps``). A number must be > 0.

    Returns
    -------
    sympy.ImmutableMatrix
        ``F^a``, shape ``(rho + 1, rho + 1)``.

    Examples
    --------
    >>> approximate_extended_model(2)
    Matrix([
    [1, T, T**2/2],
    [0, 1,      T],
    [0, 0,      1]])
    >>> approximate_extended_model(1, T=0.5)
    Matrix([
    [1, 0.5],
    [0,   1]])
    """
    rho = integer("rho", rho, minimum=1)
    if T is None:
        T = T_SYMBOL
    elif not isinstance(T, sp.Basic):
        T = sp.Float(positive("T", T))
    size = rho + 1
    return sp.ImmutableMatrix(
        size, size,
        lambda i, j: T ** (j - i) / sp.factorial(j - i) if j >= i else sp.Integer(0),
    )


def lie_series_terms(states, rhs, count: int) -> list[sp.ImmutableMatrix]:
    """Return ``[L_F^0 x, L_F^1 x, ..., L_F^(count-1) x]`` for the field ``F = rhs``.

    Symbols in ``rhs`` that are not states (the held input, parameters) are constants.

    Parameters
    ----------
    states : sequence of sympy.Symbol
        The state vector ``x`` (length n).
    rhs : sequence or sympy.Matrix
        The vector field ``F``, n expressions.
    count : int
        Number of terms, ``>= 1``.

    Examples
    --------
    >>> import sympy as sp
    >>> p, v, u = sp.symbols("p v u")
    >>> [list(t) for t in lie_series_terms([p, v], [v, u], 3)]
    [[p, v], [v, u], [u, 0]]
    """
    states = tuple(states)
    field = sp.Matrix(rhs).reshape(len(rhs), 1) if not isinstance(rhs, sp.MatrixBase) else rhs
    if field.shape != (len(states), 1):
        raise DimensionError(
            f"rhs must have {len(states)} entries (one per state), got shape {field.shape}"
        )
    count = integer("count", count, minimum=1)
    terms = [sp.ImmutableMatrix(states)]
    for _ in range(count - 1):
        prev = terms[-1]
        terms.append(lie_derivative(prev, states, field))
    return terms


def _mid(symbol: sp.Symbol) -> sp.Symbol:
    return sp.Symbol(f"{symbol.name}_mid", **symbol.assumptions0)


def _lowest_power(expr, var: sp.Symbol) -> int | None:
    """Lowest power of ``var`` with a non-zero coefficient in the polynomial ``expr`` (None: 0)."""
    expr = sp.expand(expr)
    if expr == 0:
        return None
    poly = sp.Poly(expr, var)
    for (degree,), coeff in sorted(zip(poly.monoms(), poly.coeffs())):
        if sp.simplify(coeff) != 0:
            return int(degree)
    return None


def _extended_order(rho: int, order: int) -> int:
    """Order of the extended-state series: high enough to show every residual's leading term."""
    return max(order, rho + 1)
