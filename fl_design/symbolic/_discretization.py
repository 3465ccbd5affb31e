"""Sampled plant under zero-order hold: the exact Taylor (Lie) series ``F^e``, the paper's
approximate extended model ``F^a`` and the residual ``F^e - F^a`` with its order per component.

With the input held over a sample (``u' = 0`` on ``[kT, (k+1)T)``, the paper's Assumption 1) the
sampled plant is the flow of the autonomous field ``F(x, u)`` for a time ``T``; its Taylor series
in ``T`` is the Lie series

    x(k+1) = sum_{j=0}^{N} T^j / j! (L_F^j x)(x(k), u(k))
             + T^(N+1) / (N+1)! (L_F^(N+1) x)(x(kT + theta T), u(k)),   0 < theta < 1,

the last term being the Lagrange remainder (``theta`` may differ per component). In the normal
form ``x_i' = x_(i+1)``, ``x_rho' = sigma(t)`` this reads

    x_i(k+1) = sum_{j=0}^{rho-i} T^j/j! x_(i+j) + T^(rho-i+1)/(rho-i+1)! sigma
               + T^(rho-i+2)/(rho-i+2)! sigma_dot + ...

Taking ``sigma`` as an extra state held constant gives the approximate extended model
``F^a = exp(T N)`` (``N`` the shift matrix), ``[[1, T, T^2/2], [0, 1, T], [0, 0, 1]]`` for
``rho = 2``; with ``T = alpha eps`` the residual of component ``x_i`` is ``O(eps^(rho-i+2))``
and that of the extended state ``sigma`` is ``O(eps)``. All of this is computed, not tabulated.

Examples
--------
>>> import fl_design as fl
>>> d = fl.taylor_discretization(2, order=3)
>>> d.approx
Matrix([
[1, T, T**2/2],
[0, 1,      T],
[0, 0,      1]])
>>> d.residual_orders
(3, 2, 1)
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np
import sympy as sp

from .._validate import integer, positive, real_scalar, real_vector
from ..errors import DimensionError, ParameterError, ResourceLimitError
from ._lie import lie_derivative
from ._series import (
    ALPHA_SYMBOL,
    EPS_SYMBOL,
    T_SYMBOL,
    _extended_order,
    _lowest_power,
    _mid,
    _sigma_latex,
    approximate_extended_model,
    chain_states,
    lie_series_terms,
    sigma_symbol,
)

if TYPE_CHECKING:  # annotations only (no import at run time)
    from ._plant import Plant


@dataclass(frozen=True)
class Discretization:
    """Zero-order-hold discretization of a plant: ``F^e`` (Taylor/Lie series), ``F^a``, residual.

    Built by :func:`taylor_discretization`; immutable and checked on construction. The symbols
    ``T``, ``alpha``, ``eps`` (``T = alpha eps``) are the attributes :attr:`T`, :attr:`alpha`,
    :attr:`eps`. The normal-form chain view uses the extended state
    :attr:`extended_states` ``= (x1, ..., x_rho, sigma)`` and the symbols ``sigma``,
    ``sigma_dot``, ``sigma_ddot``, ``sigma_d3``, ... for the time derivatives of ``sigma``
    (which evolves: the input is held, the state moves).

    Parameters
    ----------
    rho : int
        Relative degree (length of the normal-form chain), ``>= 1``.
    order : int
        Truncation order ``N >= 1`` of the exact series :attr:`exact`.
    states : tuple of sympy.Symbol
        States of :attr:`exact`: the plant's own states, or ``x1..x_rho`` for a bare chain.
    input : sympy.Symbol or None
        The held input ``u`` of the plant (``None`` for a bare chain, where ``sigma`` lumps it).
    exact : sympy.ImmutableMatrix
        ``x(k+1) = sum_{j=0}^{N} T^j/j! L_F^j x`` at ``x(k)``, shape ``(len(states), 1)``.
    remainder : sympy.ImmutableMatrix
        Lagrange remainder ``T^(N+1)/(N+1)! L_F^(N+1) x`` evaluated at an intermediate point
        ``x(kT + theta T)``, ``0 < theta < 1`` (``theta`` may differ per component), marked by
        the symbols ``<state>_mid`` (:attr:`mid_states`); the input stays ``u(k)``.
    extended_exact : sympy.ImmutableMatrix
        ``F^e`` of the chain on the extended state, to order :attr:`extended_order`
        ``= max(order, rho + 1)``, shape ``(rho + 1, 1)``.
    approx : sympy.ImmutableMatrix
        ``F^a``, see :func:`approximate_extended_model`, shape ``(rho + 1, rho + 1)``.
    plant : Plant or None
        The plant discretized, if any (used by :meth:`chain_substitution` and
        :meth:`exact_function`).

    Examples
    --------
    >>> import fl_design as fl
    >>> d = fl.taylor_discretization(2, order=3)
    >>> for row in d.exact: print(row)
    T**3*sigma_dot/6 + T**2*sigma/2 + T*x2 + x1
    T**3*sigma_ddot/6 + T**2*sigma_dot/2 + T*sigma + x2
    >>> list(d.remainder)
    [T**4*sigma_ddot_mid/24, T**4*sigma_d3_mid/24]
    >>> d.residual_orders, d.residual_orders_T
    ((3, 2, 1), (3, 2, 1))
    >>> d.approx_in_eps()[0, 2]
    alpha**2*epsilon**2/2
    """

    rho: int
    order: int
    states: tuple
    input: sp.Symbol | None
    exact: sp.ImmutableMatrix
    remainder: sp.ImmutableMatrix
    extended_exact: sp.ImmutableMatrix
    approx: sp.ImmutableMatrix
    plant: Any = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "rho", integer("rho", self.rho, minimum=1))
        object.__setattr__(self, "order", integer("order", self.order, minimum=1))
        object.__setattr__(self, "states", tuple(self.states))
        n, size = len(self.states), self.rho + 1
        expected = {"exact": (n, 1), "remainder": (n, 1), "extended_exact": (size, 1),
                    "approx": (size, size)}
        for name, shape in expected.items():
            value = sp.ImmutableMatrix(getattr(self, name))
            if value.shape != shape:
                raise DimensionError(f"{name} must have shape {shape}, got {value.shape}")
            object.__setattr__(self, name, value)
        if any(self.approx[i, j] != 0 for i in range(size) for j in range(i)) or any(
            self.approx[i, i] != 1 for i in range(size)
        ):
            raise ParameterError(
                f"approx must be unit upper-triangular (F^a = exp(T N)), got {self.approx}"
            )

    # --- symbols ------------------------------------------------------------------------------
    @property
    def T(self) -> sp.Symbol:
        """The sampling-time symbol ``T``."""
        return T_SYMBOL

    @property
    def alpha(self) -> sp.Symbol:
        """The ratio ``alpha = T / eps``."""
        return ALPHA_SYMBOL

    @property
    def eps(self) -> sp.Symbol:
        """The observer time constant ``eps``."""
        return EPS_SYMBOL

    @property
    def extended_states(self) -> tuple[sp.Symbol, ...]:
        """The chain's extended state ``(x1, ..., x_rho, sigma)``."""
        return chain_states(self.rho) + (sigma_symbol(0),)

    @property
    def extended_order(self) -> int:
        """Order of :attr:`extended_exact`: ``max(order, rho + 1)``."""
        return _extended_order(self.rho, self.order)

    @property
    def mid_states(self) -> tuple[sp.Symbol, ...]:
        """Markers of the intermediate point in :attr:`remainder` (one per symbol it uses)."""
        return tuple(sorted((s for s in self.remainder.free_symbols if s.name.endswith("_mid")),
                            key=lambda s: s.name))

    @property
    def symbol_names(self) -> dict[sp.Symbol, str]:
        """LaTeX names of the sigma derivatives and the intermediate-point markers."""
        names = {}
        for j in range(self.extended_order + 2):
            names[sigma_symbol(j)] = _sigma_latex(j)
            names[_mid(sigma_symbol(j))] = rf"{{{_sigma_latex(j)}}}^{{\star}}"
        for s in self.states + chain_states(self.rho):
            names[_mid(s)] = rf"{{{sp.latex(s)}}}^{{\star}}"
        return names

    def latex(self, expr) -> str:
        """LaTeX of ``expr`` with :attr:`symbol_names` (``\\dot{\\sigma}``, ``x^{\\star}``...).

        Parameters
        ----------
        expr : sympy expression or Matrix
            What to print.

        Examples
        --------
        >>> import fl_design as fl
        >>> d = fl.taylor_discretization(1, order=1)
        >>> d.latex(d.residual[0])
        '\\\\frac{T^{2} \\\\dot{\\\\sigma}}{2}'
        """
        return sp.latex(expr, symbol_names=self.symbol_names)

    # --- F^a and the residual -------------------------------------------------------------------
    def approx_in_eps(self) -> sp.ImmutableMatrix:
        """:attr:`approx` with ``T = alpha * eps`` substituted (the paper's form).

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.taylor_discretization(1, order=1).approx_in_eps()
        Matrix([
        [1, alpha*epsilon],
        [0,             1]])
        """
        return self.approx.subs(T_SYMBOL, ALPHA_SYMBOL * EPS_SYMBOL)

    @cached_property
    def residual(self) -> sp.ImmutableMatrix:
        """``F^e - F^a`` on the extended state, to order :attr:`extended_order` in ``T``."""
        xbar = sp.Matrix(self.extended_states)
        return sp.ImmutableMatrix((self.extended_exact - self.approx * xbar).applyfunc(sp.expand))

    def residual_in_eps(self) -> sp.ImmutableMatrix:
        """:attr:`residual` with ``T = alpha * eps`` substituted.

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.taylor_discretization(1, order=1).residual_in_eps()[0]
        alpha**2*epsilon**2*sigma_dot/2
        """
        return self.residual.subs(T_SYMBOL, ALPHA_SYMBOL * EPS_SYMBOL).applyfunc(sp.expand)

    def _orders(self, residual: sp.MatrixBase, var: sp.Symbol) -> tuple[int, ...]:
        # a component that vanishes up to the series' order is O(var^(extended_order + 1))
        powers = (_lowest_power(r, var) for r in residual)
        return tuple(self.extended_order + 1 if p is None else p for p in powers)

    @cached_property
    def residual_orders_T(self) -> tuple[int, ...]:
        """Per extended component, the lowest power of ``T`` in :attr:`residual` (computed)."""
        return self._orders(self.residual, T_SYMBOL)

    @cached_property
    def residual_orders(self) -> tuple[int, ...]:
        """Per extended component, the residual's order in ``eps`` (``T = alpha eps``; computed)."""
        return self._orders(self.residual_in_eps(), EPS_SYMBOL)

    @cached_property
    def residual_leading_terms(self) -> tuple[sp.Expr, ...]:
        """Per extended component, the residual's leading term ``c T^p`` (``p`` its order in T)."""
        return tuple(
            sp.expand(r).coeff(T_SYMBOL, p) * T_SYMBOL**p
            for r, p in zip(self.residual, self.residual_orders_T)
        )

    def residual_order_table(self) -> str:
        """Plain-text table: component, leading residual term, order in ``T`` and in ``eps``.

        Examples
        --------
        >>> import fl_design as fl
        >>> print(fl.taylor_discretization(2, order=3).residual_order_table())
        component  leading term of F^e - F^a  order in T  order in eps
        x1         T**3*sigma_dot/6           3           3
        x2         T**2*sigma_dot/2           2           2
        sigma      T*sigma_dot                1           1
        """
        rows = [("component", "leading term of F^e - F^a", "order in T", "order in eps")]
        for s, lead, pT, pe in zip(self.extended_states, self.residual_leading_terms,
                                   self.residual_orders_T, self.residual_orders):
            rows.append((str(s), str(lead), str(pT), str(pe)))
        widths = [max(len(r[c]) for r in rows) for c in range(3)]
        return "\n".join(
            "  ".join(cell.ljust(w) for cell, w in zip(r[:3], widths)) + "  " + r[3] for r in rows
        )

    # --- link to a plant ------------------------------------------------------------------------
    def _require_plant(self, what: str):
        if self.plant is None:
            raise ParameterError(
                f"{what} needs a discretization of a Plant; this one is the bare chain "
                f"rho={self.rho} (call taylor_discretization(plant, order) with an fl.Plant)"
            )
        return self.plant

    def chain_substitution(self, *, max_derivative: int | None = None) -> dict:
        """Map the chain symbols to the plant: ``x_i -> L_F^(i-1) h``, ``sigma^(j) -> L_F^j sigma``.

        With it the chain-view expressions (:attr:`extended_exact`, :attr:`residual`) become
        expressions in the plant's states and held input. Apply it with
        ``expr.subs(mapping, simultaneous=True)``: the chain's ``x1, x2, ...`` may have the same
        names as the plant's states.

        Parameters
        ----------
        max_derivative : int, optional
            Highest derivative of ``sigma`` to map (default :attr:`extended_order`, enough for
            :attr:`residual`).

        Examples
        --------
        >>> import fl_design as fl
        >>> d = fl.taylor_discretization(fl.plants.pendulum(), order=2)
        >>> d.chain_substitution()[sigma_symbol(0)]
        b*u - c*theta_dot - g*sin(theta)/l
        >>> d.residual_leading_terms[2].subs(d.chain_substitution(), simultaneous=True)
        T*(-c*(b*u - c*theta_dot - g*sin(theta)/l) - g*theta_dot*cos(theta)/l)
        """
        plant = self._require_plant("chain_substitution()")
        top = self.extended_order if max_derivative is None else integer(
            "max_derivative", max_derivative, minimum=0)
        nf = plant.normal_form()
        mapping = dict(zip(chain_states(self.rho), nf.coordinates))
        sigma = sp.Matrix([nf.sigma])
        for j in range(top + 1):
            mapping[sigma_symbol(j)] = sigma[0]
            if j < top:  # L_F sigma with the input held
                sigma = lie_derivative(sigma, plant.states, plant.rhs)
        return mapping

    def exact_function(self):
        """Numeric ``x(k+1) ~ exact(x, u, T)`` with the plant's parameter values substituted.

        Returns
        -------
        callable
            ``f(x, u, T) -> np.ndarray`` of shape ``(n,)``: the order-``N`` Taylor map.

        Examples
        --------
        >>> import fl_design as fl
        >>> d = fl.taylor_discretization(fl.plants.pendulum(), order=2)
        >>> d.exact[0]
        T**2*(b*u - c*theta_dot - g*sin(theta)/l)/2 + T*theta_dot + theta
        >>> d.exact_function()([0.1, 0.0], 0.0, 1e-3).round(8)
        array([ 0.09999951, -0.00097912])
        """
        plant = self._require_plant("exact_function()")
        params = {sp.Symbol(k) if isinstance(k, str) else k: v
                  for k, v in (plant.params or {}).items()}
        n = len(self.states)
        fn = sp.lambdify([self.states, self.input, T_SYMBOL], list(self.exact.subs(params)),
                         modules="numpy")

        def evaluate(x, u, T) -> np.ndarray:
            xv = real_vector("x", x, length=n)
            return np.asarray(fn(xv, real_scalar("u", u), positive("T", T)), dtype=float)

        return evaluate

    def to_dict(self) -> dict:
        """Plain-data summary (strings and ints) for reports and JSON.

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.taylor_discretization(2, order=2).to_dict()["residual_orders"]
        [3, 2, 1]
        """
        return {
            "rho": self.rho,
            "order": self.order,
            "plant": getattr(self.plant, "name", None),
            "states": [str(s) for s in self.states],
            "exact": [str(e) for e in self.exact],
            "remainder": [str(e) for e in self.remainder],
            "extended_states": [str(s) for s in self.extended_states],
            "extended_exact": [str(e) for e in self.extended_exact],
            "approx": [[str(e) for e in self.approx.row(i)] for i in range(self.rho + 1)],
            "residual": [str(e) for e in self.residual],
            "residual_orders": list(self.residual_orders),
            "residual_orders_T": list(self.residual_orders_T),
        }


# --- construction -------------------------------------------------------------------------------
def _truncated(terms: list[sp.ImmutableMatrix], rows: int, order: int) -> sp.ImmutableMatrix:
    """``sum_{j=0}^{order} T^j/j! terms[j][:rows]``."""
    return sp.ImmutableMatrix(rows, 1, lambda i, _: sp.Add(*[
        T_SYMBOL**j / sp.factorial(j) * terms[j][i] for j in range(order + 1)
    ]))


def _remainder(terms, states, rows: int, order: int) -> sp.ImmutableMatrix:
    at_mid = {s: _mid(s) for s in states}
    coeff = T_SYMBOL ** (order + 1) / sp.factorial(order + 1)
    return sp.ImmutableMatrix(rows, 1, lambda i, _: coeff * terms[order + 1][i].subs(at_mid))


def _chain_series(rho: int, order: int):
    """Exact series of the chain ``x_i' = x_(i+1)``, ``x_rho' = sigma(t)`` and its extension."""
    ext_order = _extended_order(rho, order)
    top = max(order, ext_order) + 1  # highest sigma derivative that can appear
    xs = chain_states(rho)
    sigmas = tuple(sigma_symbol(j) for j in range(top + 1))
    states = xs + sigmas[:-1]
    field = list(xs[1:]) + list(sigmas)  # sigma^(j)' = sigma^(j+1)
    terms = lie_series_terms(states, field, max(order + 2, ext_order + 1))
    exact = _truncated(terms, rho, order)
    remainder = _remainder(terms, states, rho, order)
    extended = _truncated(terms, rho + 1, ext_order)
    return xs, exact, remainder, extended


def _is_plant(obj) -> bool:
    return all(hasattr(obj, a) for a in ("states", "input", "rhs", "normal_form"))


#: Default cap on ``order`` for a plant (the Lie series swells: order 10 of the pendulum ~10 s)
#: and for a canonical chain; ``max_order=`` lifts it.
MAX_ORDER = {"plant": 8, "chain": 40}


def taylor_discretization(plant: Plant, order: int, *,
                          max_order: int | None = None) -> Discretization:
    """Zero-order-hold discretization: exact Taylor (Lie) series ``F^e``, ``F^a``, residuals.

    With the input held over each sample, ``x(k+1) = sum_{j=0}^{N} T^j/j! L_F^j x + R_N`` at
    ``x(k)``, where ``R_N = T^(N+1)/(N+1)! L_F^(N+1) x`` at an intermediate point. The normal-form
    chain of relative degree ``rho`` is expanded too, on the extended state
    ``(x1, ..., x_rho, sigma)``, and compared with the paper's ``F^a``: the residual orders per
    component (in ``T`` and in ``eps``, ``T = alpha eps``) are computed from the series.

    Parameters
    ----------
    plant : Plant or int
        An :class:`fl_design.Plant` (``.exact`` is then in the plant's own states, parameters
        symbolic; the chain view uses ``plant.normal_form().rho``), or a relative degree
        ``rho >= 1`` for the canonical chain ``x_i' = x_(i+1)``, ``x_rho' = sigma(t)`` with a
        symbolic lumped term ``sigma`` and its derivatives ``sigma_dot``, ``sigma_ddot``, ...
    order : int
        Truncation order ``N >= 1`` of the series.
    max_order : int, optional
        Largest ``order`` accepted (default 8 for a plant, whose symbolic series grows about
        tenfold per two orders, 40 for a chain); raise it knowingly.

    Returns
    -------
    Discretization

    Raises
    ------
    ParameterError
        If ``order`` (or ``rho``) is not an integer ``>= 1``, or ``plant`` is neither a Plant nor
        an integer.
    ResourceLimitError
        ``order > max_order``.

    Examples
    --------
    >>> import fl_design as fl
    >>> d = fl.taylor_discretization(3, order=4)
    >>> d.residual_orders
    (4, 3, 2, 1)
    >>> d.exact[0]
    T**4*sigma_dot/24 + T**3*sigma/6 + T**2*x3/2 + T*x2 + x1
    """
    order = integer("order", order, minimum=1)
    chain = isinstance(plant, (int, np.integer)) and not isinstance(plant, bool)
    cap = MAX_ORDER["chain" if chain else "plant"] if max_order is None else integer(
        "max_order", max_order, minimum=1)
    if order > cap:
        raise ResourceLimitError(
            f"order={order} exceeds max_order={cap}: the symbolic Taylor series grows about "
            "tenfold in time per two orders (minutes to hours beyond); pass "
            f"max_order={order} to taylor_discretization to compute it anyway")
    if chain:
        rho = integer("rho", plant, minimum=1)
        xs, exact, remainder, extended = _chain_series(rho, order)
        return Discretization(rho=rho, order=order, states=xs, input=None, exact=exact,
                              remainder=remainder, extended_exact=extended,
                              approx=approximate_extended_model(rho))
    if not _is_plant(plant):
        raise ParameterError(
            "plant must be an fl.Plant (with .states, .input, .rhs, .normal_form()) or a relative "
            f"degree rho (int >= 1), got {plant!r}"
        )
    rho = integer("plant relative degree", plant.normal_form().rho, minimum=1)
    states = tuple(plant.states)
    terms = lie_series_terms(states, plant.rhs, order + 2)
    _, _, _, extended = _chain_series(rho, order)
    return Discretization(
        rho=rho, order=order, states=states, input=plant.input,
        exact=_truncated(terms, len(states), order),
        remainder=_remainder(terms, states, len(states), order),
        extended_exact=extended, approx=approximate_extended_model(rho), plant=plant,
    )
