"""The symbolic SISO plant ``x' = f(x, u)``, ``y = h(x)``: validated on construction, immutable.

A :class:`Plant` holds SymPy expressions (parameters kept symbolic, their values alongside), an
operating point with its equilibrium input, an optional input range and region of interest. It
derives its relative degree and normal form (:mod:`fl_design.symbolic`), bounds the input
coefficient ``b`` over the region (:meth:`Plant.b_bounds`) and hands CasADi functions to the
numerical layers (:meth:`Plant.casadi`, through the one bridge :func:`fl_design.symbolic.to_casadi`).

Examples
--------
>>> import sympy as sp
>>> import fl_design as fl
>>> th, om, u = sp.symbols("theta omega u")
>>> g, c = sp.symbols("g c", positive=True)
>>> plant = fl.Plant.from_ode([th, om], u, [om, -g * sp.sin(th) - c * om + u], th,
...                           params={"g": 9.81, c: 0.5}, input_range=(-20, 20))
>>> plant.relative_degree(), plant.u_eq
(2, 0.0)
"""

from __future__ import annotations

import dataclasses
import functools
from typing import TYPE_CHECKING

import numpy as np

from .. import _validate as V
from ..errors import PlantDefinitionError
from ._casadi_functions import PlantFunctions
from ._derivation_cache import PlantStore
from ._plant_derived import Derivations
from ._recipe import Recipe

if TYPE_CHECKING:  # pragma: no cover - annotations only (the module imports SymPy)
    from ._equilibrium import Equilibrium

# SymPy and the derivations are imported on first use (a plant whose quantities are all in the
# cache never imports SymPy); a module-level name, so that tests can watch it.
def operating_point_and_input(*args):
    from ._definition import operating_point_and_input as solve
    return solve(*args)


def _from_recipe(recipe: Recipe) -> Plant:
    """The library plant of ``recipe`` (what :meth:`Plant.__reduce__` of such a plant calls)."""
    self = object.__new__(Plant)
    self._setup(None, recipe, recipe.name, recipe.input_range, recipe.key())
    return self


#: Longest plant name (it titles every figure: matplotlib lays out 100 000 characters for
#: minutes).
MAX_NAME = 200


class Plant(Derivations):
    """A SISO plant ``x' = f(x, u)``, ``y = h(x)`` defined by SymPy expressions.

    Validated on construction and immutable; derived results (relative degree, normal form,
    CasADi functions, bounds) are computed on first use and cached, in memory and on disk by
    content (:mod:`fl_design.symbolic._derivation_cache`, beside the compiled kernels). Build it with
    :meth:`Plant.from_ode` (same arguments) or take one from :mod:`fl_design.plants`: a library
    plant is known by its recipe (:mod:`fl_design.symbolic._recipe`) and builds its SymPy
    expressions only when something not in the cache needs them.

    Parameters
    ----------
    states : sequence of sympy.Symbol
        The n states, distinct.
    input : sympy.Symbol
        The input u (not a state).
    rhs : sequence of n sympy expressions or sympy.Matrix
        ``f(x, u)``; every free symbol must be a state, the input or a parameter, and the input
        must appear.
    output : sympy expression
        ``h(x)``: a function of the states (and parameters) only; it may not contain the input.
    params : dict, optional
        ``{Symbol or name: value}`` numeric values of the remaining symbols (finite reals).
    name : str, optional
        A label for reports (default ``"plant"``).
    input_range : (lo, hi) or float, optional
        Admissible inputs; a scalar c > 0 means ``(-c, c)``.
    region : dict, optional
        ``{state Symbol or name: (lo, hi)}`` region of interest (some states may be left out).
    operating_point : dict, optional
        ``{state Symbol or name: value}`` and/or ``{"y": value}`` (the output). Default: the
        origin (with ``u_eq`` solved). Given states (and the output) are held; the other states
        and ``u_eq`` are solved (:meth:`equilibrium`), the unique equilibrium inside the region
        and input range. Every state given: it must be an equilibrium for some ``u_eq``.

    Attributes
    ----------
    states, input, rhs, output, params, name, n, input_range, region, x_op, u_eq

    Raises
    ------
    PlantDefinitionError
        Inconsistent definition: unknown symbols (named), wrong lengths, duplicate states, an
        output that is not a function of the states, an input missing from ``rhs``, an operating
        point that is not an equilibrium for any (admissible) input.
    ParameterError
        Non-finite parameter values, reversed or empty intervals.

    Examples
    --------
    >>> import sympy as sp
    >>> import fl_design as fl
    >>> x1, x2, u = sp.symbols("x1 x2 u")
    >>> plant = fl.Plant(states=[x1, x2], input=u, rhs=[x2, -x1 + u + u**3 / 3], output=x1)
    >>> plant.relative_degree(), plant.normal_form().b
    (2, u**2 + 1)
    """

    def __init__(self, states, input, rhs, output, *, params=None, name=None, input_range=None,
                 region=None, operating_point=None):
        from ._definition import define
        from ._derivation_cache import plant_key

        d = define(states, input, rhs, output, params, region, operating_point)
        if name is not None and not isinstance(name, str):
            raise PlantDefinitionError(f"name must be a string, got {name!r}")
        if name is not None and len(name) > MAX_NAME:  # it titles every figure and table
            raise PlantDefinitionError(f"name has {len(name)} characters, above the limit of "
                                       f"{MAX_NAME} (it titles every figure): shorten it")
        name = name or "plant"
        input_range = V.interval("input_range", input_range)
        self._setup(d, None, name, input_range, plant_key(
            d.states, d.input, d.rhs, d.output, d.params_map, name, input_range, d.region,
            operating_point))

    def _setup(self, definition, recipe, name, input_range, key) -> None:
        """Fill a new plant: its definition (or recipe), then the operating point, checked."""
        set_ = object.__setattr__
        set_(self, "_def", definition)
        set_(self, "_recipe", recipe)
        set_(self, "_name", name)
        set_(self, "_input_range", input_range)
        set_(self, "_store", PlantStore(key))
        set_(self, "_cache", {})
        x_op, u_eq, names, u_name, y_text, ranges = self._store.get("header", self._header,
                                                                     check=tuple)
        x_op = np.array(x_op, dtype=float)
        x_op.setflags(write=False)
        set_(self, "_x_op", x_op)
        set_(self, "_u_eq", float(u_eq))
        set_(self, "_names", (tuple(names), u_name, y_text))
        set_(self, "_ranges", tuple(None if r is None else tuple(r) for r in ranges))
        _ = self._fh  # every function has a CasADi translation, or a PlantDefinitionError now

    def _header(self) -> tuple:
        """``(x_op, u_eq, state names, input name, output text, state ranges)``: what the
        plant shows without SymPy."""
        d = self._sym()
        by_name = {s.name: s for s in d.states}
        x_op, u_eq = operating_point_and_input(
            d.operating_point, by_name, d.rhs.subs(d.params_map), d.input, d.region,
            self._input_range, self._solve)
        region = d.region or {}
        return (tuple(float(v) for v in x_op), float(u_eq), tuple(by_name), d.input.name,
                str(d.output), tuple(region.get(s) for s in d.states))

    def _sym(self):
        """The SymPy definition (:class:`~fl_design.symbolic._definition.Definition`), built from
        the recipe on first use."""
        if self._def is None:
            from ._definition import define

            kw = self._recipe.build()
            object.__setattr__(self, "_def", define(
                kw["states"], kw["input"], kw["rhs"], kw["output"], kw.get("params"),
                kw.get("region"), kw.get("operating_point")))
        return self._def

    _states = property(lambda self: self._sym().states)
    _input = property(lambda self: self._sym().input)
    _rhs = property(lambda self: self._sym().rhs)
    _output = property(lambda self: self._sym().output)
    _params_map = property(lambda self: self._sym().params_map)
    _region = property(lambda self: self._sym().region)

    @classmethod
    def from_ode(cls, states, input, rhs, output, *, params=None, name=None, input_range=None,
                 region=None, operating_point=None) -> Plant:
        """Build a plant from ``x' = rhs(x, u)``, ``y = output(x)`` (see :class:`Plant`).

        Parameters
        ----------
        states, input, rhs, output
            The n states (sympy Symbols), the input Symbol, ``f(x, u)`` (n expressions),
            ``h(x)``.
        params, name, input_range, region : optional
            ``{Symbol or name: value}``, a label, ``(lo, hi)``, ``{state or name: (lo, hi)}``.
        operating_point : dict, optional
            ``{state or name: value}`` and/or ``{"y": value}`` (default: the origin).

        Returns
        -------
        Plant

        Examples
        --------
        >>> import sympy as sp
        >>> import fl_design as fl
        >>> x1, x2, u = sp.symbols("x1 x2 u")
        >>> fl.Plant.from_ode([x1, x2], u, [x2, x1 * u + 1], x1, operating_point={x1: 1.0}).u_eq
        -1.0
        >>> p = fl.Plant.from_ode([x1, x2], u, [x2, -x1 + u], x1, operating_point={"y": 0.01})
        >>> p.x_op.tolist(), p.u_eq
        ([0.01, 0.0], 0.01)
        """
        return cls(states, input, rhs, output, params=params, name=name, input_range=input_range,
                   region=region, operating_point=operating_point)

    def _solve(self, fixed: dict, y: float | None) -> Equilibrium:
        from ._equilibrium import solve_equilibrium

        return solve_equilibrium(
            states=self._states, input=self._input, rhs=list(self._rhs), output=self._output,
            params=self._params_map, region=self._region, input_range=self._input_range,
            fixed=fixed, y=y, name=self._name)

    def equilibrium(self, *, y: float | None = None, **states: float) -> Equilibrium:
        """The equilibrium holding the output at ``y`` (and/or given states) in the region.

        Parameters
        ----------
        y : float, optional
            The output value held.
        **states : float
            ``name=value`` of states held (the others and the input are solved).

        Returns
        -------
        Equilibrium
            States ``x``, input ``u``, output ``y``.

        Raises
        ------
        PlantDefinitionError
            No equilibrium, or more than one, inside the region and input range.

        Examples
        --------
        >>> import fl_design as fl
        >>> eq = fl.plants.trms_yaw().equilibrium(y=0.2)
        >>> eq.x.tolist(), eq.u
        ([0.2, 0.0], 0.0)
        """
        from ._definition import _key

        by_name = {s.name: s for s in self._states}
        fixed = {_key("equilibrium", k, by_name): V.real_scalar(k, v) for k, v in states.items()}
        return self._solve(fixed, None if y is None else V.real_scalar("y", y))

    def __setattr__(self, key, value):
        raise AttributeError(f"Plant is immutable; cannot set {key!r} (build a new plant)")

    states = property(lambda self: self._states, doc="The states (tuple of Symbol).")
    input = property(lambda self: self._input, doc="The input Symbol.")
    rhs = property(lambda self: self._rhs, doc="f(x, u): n x 1 sympy Matrix, parameters symbolic.")
    output = property(lambda self: self._output, doc="h(x), a sympy expression.")
    params = property(lambda self: dict(self._params_map), doc="{Symbol: float} parameter values.")
    name = property(lambda self: self._name, doc="Label of the plant.")
    n = property(lambda self: len(self._x_op), doc="Number of states.")
    input_range = property(lambda self: self._input_range, doc="(lo, hi) or None.")
    region = property(lambda self: None if self._region is None else dict(self._region),
                      doc="{state Symbol: (lo, hi)} or None.")
    x_op = property(lambda self: self._x_op, doc="Operating point (read-only array of n floats).")
    u_eq = property(lambda self: self._u_eq, doc="Equilibrium input at the operating point.")

    def _state_ranges(self) -> tuple[dict, str | None]:
        """``({state name: (lo, hi) or None}`` in state order, ``output name)``, read without
        SymPy (:attr:`region` builds a library plant's definition); the output's name is None
        when the output is not a state.

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.plants.pendulum()._state_ranges()
        ({'theta': (-3.14159..., 3.14159...), 'theta_dot': (-10.0, 10.0)}, 'theta')
        """
        names, _, y_text = self._names
        return dict(zip(names, self._ranges)), (y_text if y_text in names else None)

    def __repr__(self) -> str:
        names, u_name, y_text = self._names
        return (f"Plant(name={self._name!r}, states=[{', '.join(names)}], input={u_name}, "
                f"output={y_text})")

    def __reduce__(self):
        if self._recipe is not None:
            return (_from_recipe, (self._recipe,))
        kw = {"params": self._params_map, "name": self._name, "input_range": self._input_range,
                  "region": self._region, "operating_point": dict(zip(self._states, self._x_op.tolist()))}
        return (functools.partial(Plant, **kw),
                (self._states, self._input, list(self._rhs), self._output))

    def with_params(self, **values: float) -> Plant:
        """A new plant with some parameter values replaced (by name).

        Parameters
        ----------
        **values : float
            ``name=value`` for existing parameters.

        Returns
        -------
        Plant

        Examples
        --------
        >>> import fl_design as fl
        >>> p = fl.plants.pendulum().with_params(c=0.1)
        >>> {str(k): v for k, v in p.params.items()}["c"]
        0.1
        """
        names = {k: k for k, _ in self._recipe.params} if self._recipe is not None else \
            {s.name: s for s in self._params_map}
        unknown = sorted(set(values) - set(names))
        if unknown:
            raise PlantDefinitionError(f"unknown parameter(s) {unknown}; the plant has {sorted(names)}")
        if self._recipe is not None:  # checked as Plant checks params, then a new recipe
            new = dict(self._recipe.params)
            new.update({k: V.real_scalar(f"params[{k}]", v) for k, v in values.items()})
            return _from_recipe(dataclasses.replace(
                self._recipe, params=tuple(new.items()),
                operating_point=tuple(zip(self._names[0], self._x_op.tolist()))))
        new = {**self._params_map, **{names[k]: v for k, v in values.items()}}
        return Plant(self._states, self._input, list(self._rhs), self._output, params=new,
                     name=self._name, input_range=self._input_range, region=self._region,
                     operating_point=dict(zip(self._states, self._x_op.tolist())))

__all__ = ["Plant", "PlantFunctions"]
