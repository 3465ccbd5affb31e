"""A plant's definition, checked: symbols, parameters, the equilibrium input at the operating point.

Private helpers of :class:`fl_design.Plant` (one concept: "is this a valid plant definition?").

Examples
--------
>>> import numpy as np, sympy as sp
>>> from fl_design.symbolic._definition import equilibrium_input
>>> x, u = sp.symbols("x u")
>>> equilibrium_input(sp.Matrix([-x + u]), (x,), u, np.array([2.0]), None)
2.0
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import NamedTuple

import numpy as np
import sympy as sp

from .. import _validate as V
from ..errors import PlantDefinitionError

#: Keys of ``operating_point`` that give the output value instead of a state.
OUTPUT_KEYS = ("y", "output")
from ._constructs import check_expression, mismatched_assumptions, non_finite_at
from ._grammar import check_names, check_size, parse_expression


def _symbols(name: str, value) -> tuple:
    if isinstance(value, (sp.MatrixBase, np.ndarray)):
        value = list(np.ravel(value)) if isinstance(value, np.ndarray) else list(value)
    if isinstance(value, sp.Symbol) or not isinstance(value, Sequence) or isinstance(value, str):
        raise PlantDefinitionError(f"{name} must be a sequence of sympy Symbols, got {value!r}")
    out = tuple(value)
    if not out:
        raise PlantDefinitionError(f"{name} must contain at least one state, got an empty sequence")
    bad = [s for s in out if not isinstance(s, sp.Symbol)]
    if bad:
        raise PlantDefinitionError(f"{name} must be sympy Symbols, got {bad!r}")
    names = [s.name for s in out]
    dup = sorted({nm for nm in names if names.count(nm) > 1})
    if dup:
        raise PlantDefinitionError(f"{name} contains duplicate state(s) {dup}; each state once")
    check_names(names, what=name)  # no two names Python reads as one (NFKC), no function names
    return out


def declared_names(sts, u, params) -> dict:
    """``{name: Symbol}`` a string expression may use: states, input, parameter names."""
    names = {s.name: s for s in (*sts, u)}
    if isinstance(params, Mapping):
        for k in params:
            nm = k.name if isinstance(k, sp.Symbol) else k
            if isinstance(nm, str) and nm not in names:
                names[nm] = k if isinstance(k, sp.Symbol) else sp.Symbol(nm)
    return names


def _sympify(what: str, value, names: Mapping[str, sp.Symbol]) -> sp.Expr:
    """A SymPy expression from ``value``; a string goes through the grammar, never ``eval``."""
    try:
        out = parse_expression(value, names, what=what) if isinstance(value, str) else \
            sp.sympify(value, strict=True)
    except (sp.SympifyError, TypeError) as err:
        raise PlantDefinitionError(f"{what} must be a sympy expression, got {value!r}") from err
    if not isinstance(out, sp.Expr):
        raise PlantDefinitionError(f"{what} must be a scalar sympy expression, got {out!r}")
    return check_expression(what, check_size(out, what))


def _key(kind: str, key, by_name: Mapping[str, sp.Symbol]) -> sp.Symbol:
    name = key.name if isinstance(key, sp.Symbol) else key
    if not isinstance(name, str) or name not in by_name or (
            isinstance(key, sp.Symbol) and by_name[name] != key):
        raise PlantDefinitionError(
            f"{kind} key {key!r} is not one of the allowed symbols {sorted(by_name)}"
        )
    return by_name[name]


def check_params(params, f, h, sts, u) -> dict:
    """``{parameter Symbol: value}`` from ``params`` (names or symbols), checked."""
    if params is None:
        return {}
    if not isinstance(params, Mapping):
        raise PlantDefinitionError(f"params must be a dict {{symbol or name: value}}, got {params!r}")
    free = f.free_symbols | h.free_symbols
    taken = {s.name for s in sts} | {u.name}
    by_name = {s.name: s for s in free if s.name not in taken}
    out = {}
    for k, v in params.items():
        nm = k.name if isinstance(k, sp.Symbol) else k
        if nm in taken:
            raise PlantDefinitionError(f"params key {k!r} is a state or the input, not a parameter")
        sym = _key("params", k, by_name) if by_name else None
        if sym is None:
            raise PlantDefinitionError(f"params key {k!r} does not appear in rhs or output")
        out[sym] = V.real_scalar(f"params[{nm}]", v)
    return out

def check_symbols(f, h, sts, u, pars) -> None:
    """Every symbol known, the input actuates the rhs, the output depends on states only."""
    known = set(sts) | {u} | set(pars)
    unknown = sorted(str(s) for s in (f.free_symbols | h.free_symbols) - known)
    if unknown:
        twin = mismatched_assumptions((f.free_symbols | h.free_symbols) - known, known)
        if twin:
            raise PlantDefinitionError(twin)
        raise PlantDefinitionError(
            f"unknown symbol(s) {unknown}: each must be a state {[str(s) for s in sts]}, the "
            f"input {u} or a parameter with a value in params"
        )
    if u not in f.free_symbols:
        raise PlantDefinitionError(f"the input {u} does not appear in rhs: the plant is not actuated")
    if u in h.free_symbols:
        raise PlantDefinitionError(
            f"the output {h} depends on the input {u} (relative degree 0); the output must be "
            "a function of the states only"
        )
    if not h.free_symbols & set(sts):
        raise PlantDefinitionError(
            f"the output {h} is not a function of the states {[str(s) for s in sts]}"
        )


class Definition(NamedTuple):
    """A plant's checked SymPy definition (what :func:`define` returns)."""

    states: tuple
    input: sp.Symbol
    rhs: sp.ImmutableMatrix
    output: sp.Expr
    params_map: dict
    region: dict | None
    operating_point: object = None  # as given: checked with the equilibrium


def define(states, input, rhs, output, params=None, region=None,
           operating_point=None) -> Definition:
    """The checked definition of :class:`fl_design.Plant` (its arguments; see its Raises).

    Parameters
    ----------
    states, input, rhs, output, params, region, operating_point
        As :class:`fl_design.Plant` takes them.

    Returns
    -------
    Definition

    Examples
    --------
    >>> import sympy as sp
    >>> from fl_design.symbolic._definition import define
    >>> x, u = sp.symbols("x u")
    >>> define([x], u, [-x + u], x, region={"x": (-1, 1)}).region
    {x: (-1.0, 1.0)}
    """
    sts = _symbols("states", states)
    if not isinstance(input, sp.Symbol):
        raise PlantDefinitionError(f"input must be a sympy Symbol, got {input!r}")
    if input.name in {s.name for s in sts}:
        raise PlantDefinitionError(f"the input {input} is also listed among the states {sts}")
    rows = list(rhs) if isinstance(rhs, (sp.MatrixBase, Sequence, np.ndarray)) and \
        not isinstance(rhs, str) else None
    if rows is None:
        raise PlantDefinitionError(f"rhs must be a sequence of {len(sts)} expressions, got {rhs!r}")
    if len(rows) != len(sts):
        raise PlantDefinitionError(
            f"rhs has {len(rows)} entries but there are {len(sts)} states {list(sts)}; give one "
            "derivative per state"
        )
    names = declared_names(sts, input, params)
    f = sp.ImmutableMatrix([_sympify(f"rhs[{i}]", e, names) for i, e in enumerate(rows)])
    h = _sympify("output", output, names)
    pars = check_params(params, f, h, sts, input)
    check_symbols(f, h, sts, input, pars)
    by_name = {s.name: s for s in sts}
    reg = None
    if region is not None:
        if not isinstance(region, Mapping):
            raise PlantDefinitionError(f"region must be a dict {{state: (lo, hi)}}, got {region!r}")
        reg = {_key("region", k, by_name): V.interval(f"region[{k}]", v, allow_none=False)
               for k, v in region.items()}
    return Definition(sts, input, f, h, pars, reg, operating_point)


def equilibrium_input(rhs, states, input, x_op, input_range) -> float:
    """``u_eq`` with ``f(x_op, u_eq) = 0`` (least squares from a few starts), or a clear error."""
    at_op = list(rhs.subs(
        dict(zip(states, x_op.tolist()))))
    where = ", ".join(f"{s}={v:g}" for s, v in zip(states, x_op))
    non_finite_at(at_op, where)
    fn = sp.lambdify([input], at_op, modules="numpy")

    def resid(u):
        with np.errstate(all="ignore"):
            out = np.asarray(fn(float(np.ravel(u)[0])), dtype=complex)
        if np.any(out.imag != 0):  # e.g. sqrt of a negative number
            raise PlantDefinitionError(
                f"f(x_op, u) takes the complex values {out.tolist()} at the operating point "
                f"({where}) and u={float(np.ravel(u)[0]):g}: the plant must be real there; "
                "choose an operating_point inside the domain of f")
        return out.real

    scale = max([1.0] + [float(np.nanmax(np.abs(resid(v)))) for v in (0.0, -1.0, 1.0)])
    tol = 1e-9 * scale
    best_u, best_r = 0.0, float(np.max(np.abs(resid(0.0))))
    for u0 in (0.0, 1.0, -1.0, *(input_range or ())):
        if best_r <= tol:
            break
        import scipy.optimize  # lazy: 0.3-0.8 s to import, needed only when solving

        sol = scipy.optimize.least_squares(resid, [u0], xtol=1e-15, ftol=1e-15, gtol=1e-15)
        r = float(np.max(np.abs(resid(sol.x[0]))))
        if r < best_r:
            best_u, best_r = float(sol.x[0]), r
    where = ", ".join(f"{s}={v:g}" for s, v in zip(states, x_op))
    if not best_r <= tol:
        raise PlantDefinitionError(
            f"the operating point ({where}) is not an equilibrium for any input: the smallest "
            f"residual max|f(x_op, u)| is {best_r:.3g} (at u={best_u:.6g}); choose a point where "
            "f(x_op, u_eq) = 0 for some u_eq"
        )
    best_u = 0.0 if abs(best_u) < 1e-12 else best_u
    if input_range and not input_range[0] <= best_u <= input_range[1]:
        raise PlantDefinitionError(
            f"the operating point ({where}) needs the input u_eq={best_u:.6g}, outside the "
            f"input range {input_range}"
        )
    return best_u


def parse_operating_point(point, by_name, states, region, solve) -> tuple[np.ndarray, float | None]:
    """``(x_op, u_eq)`` from ``operating_point``; ``u_eq`` None when every state is given.

    ``solve(fixed, y)`` finds the equilibrium when only some states or the output are given.
    """
    x = np.zeros(len(states))
    fixed, y = {}, None
    if point is not None:
        if not isinstance(point, Mapping):
            raise PlantDefinitionError(
                f"operating_point must be a dict {{state or 'y': value}}, got {point!r}")
        for k, v in point.items():
            if k in OUTPUT_KEYS and k not in by_name:
                y = V.real_scalar(f"operating_point[{k}]", v)
                continue
            sym = _key("operating_point", k, by_name)
            fixed[sym] = V.real_scalar(f"operating_point[{k}]", v)
            x[states.index(sym)] = fixed[sym]
    legacy = y is None and (point is None or len(fixed) == len(states))
    for s, (lo, hi) in (region or {}).items():
        xi = x[states.index(s)]
        if (s in fixed or legacy) and not lo <= xi <= hi:
            raise PlantDefinitionError(
                f"the operating point {s}={xi:g} lies outside the region "
                f"[{lo:g}, {hi:g}] of {s}; choose a value inside it or widen the region"
            )
    if legacy:
        x.setflags(write=False)
        return x, None
    eq = solve(fixed, y)
    return eq.x, eq.u


def operating_point_and_input(point, by_name, rhs, input, region, input_range,
                              solve) -> tuple[np.ndarray, float]:
    """``(x_op, u_eq)``: :func:`parse_operating_point`, then :func:`equilibrium_input` if needed.

    ``rhs`` has numeric parameters; ``by_name`` maps state names to the states, in order.
    """
    states = tuple(by_name.values())
    x_op, u_eq = parse_operating_point(point, by_name, states, region, solve)
    if u_eq is None:
        u_eq = equilibrium_input(rhs, states, input, x_op, input_range)
    return x_op, u_eq


__all__ = [
    "Definition",
    "check_params",
    "check_symbols",
    "define",
    "equilibrium_input",
    "operating_point_and_input",
    "parse_operating_point",
]
