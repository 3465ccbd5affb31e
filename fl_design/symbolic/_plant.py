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

import functools
from collections.abc import Mapping, Sequence
from functools import cached_property

import casadi as ca
import numpy as np
import sympy as sp

from .. import _validate as V
from ..errors import PlantDefinitionError
from ._bridge import to_casadi
from ._casadi_functions import PlantFunctions
from ._definition import (
    _key,
    _symbols,
    _sympify,
    check_params,
    check_symbols,
    declared_names,
    operating_point_and_input,
)
from ._derivation_cache import PlantStore, plant_key
from ._equilibrium import Equilibrium, solve_equilibrium
from ._normal_form import LieChain, NormalForm, b_bounds, derive_normal_form, lie_chain
from ._probe import warn_notes


class Plant:
    """A SISO plant ``x' = f(x, u)``, ``y = h(x)`` defined by SymPy expressions.

    Validated on construction and immutable; derived results (relative degree, normal form,
    CasADi functions, bounds) are computed on first use and cached, in memory and on disk by
    content (:mod:`fl_design.symbolic._derivation_cache`, beside the compiled kernels). Build it with
    :meth:`Plant.from_ode` (same arguments) or take one from :mod:`fl_design.plants`.

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
        set_ = object.__setattr__
        set_(self, "_states", sts)
        set_(self, "_input", input)
        set_(self, "_rhs", f)
        set_(self, "_output", h)
        set_(self, "_params_map", pars)
        if name is not None and not isinstance(name, str):
            raise PlantDefinitionError(f"name must be a string, got {name!r}")
        set_(self, "_name", name or "plant")
        set_(self, "_input_range", V.interval("input_range", input_range))
        by_name = {s.name: s for s in sts}
        reg = None
        if region is not None:
            if not isinstance(region, Mapping):
                raise PlantDefinitionError(f"region must be a dict {{state: (lo, hi)}}, got {region!r}")
            reg = {_key("region", k, by_name): V.interval(f"region[{k}]", v, allow_none=False)
                   for k, v in region.items()}
        set_(self, "_region", reg)
        set_(self, "_store", PlantStore(plant_key(sts, input, f, h, pars, self._name,
                                                  self._input_range, reg, operating_point)))
        x_op, u_eq = self._store.get("op", lambda: operating_point_and_input(
            operating_point, by_name, self._rhs.subs(pars), self._input, self._region,
            self._input_range, self._solve), check=tuple)
        x_op = np.array(x_op, dtype=float)
        x_op.setflags(write=False)
        set_(self, "_x_op", x_op)
        set_(self, "_u_eq", float(u_eq))
        set_(self, "_cache", {})
        _ = self._fh  # every function has a CasADi translation, or a PlantDefinitionError now

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
    n = property(lambda self: len(self._states), doc="Number of states.")
    input_range = property(lambda self: self._input_range, doc="(lo, hi) or None.")
    region = property(lambda self: None if self._region is None else dict(self._region),
                      doc="{state Symbol: (lo, hi)} or None.")
    x_op = property(lambda self: self._x_op, doc="Operating point (read-only array of n floats).")
    u_eq = property(lambda self: self._u_eq, doc="Equilibrium input at the operating point.")

    def __repr__(self) -> str:
        return (f"Plant(name={self._name!r}, states={list(self._states)}, input={self._input}, "
                f"output={self._output})")

    def __reduce__(self):
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
        names = {s.name: s for s in self._params_map}
        unknown = sorted(set(values) - set(names))
        if unknown:
            raise PlantDefinitionError(f"unknown parameter(s) {unknown}; the plant has {sorted(names)}")
        new = {**self._params_map, **{names[k]: v for k, v in values.items()}}
        return Plant(self._states, self._input, list(self._rhs), self._output, params=new,
                     name=self._name, input_range=self._input_range, region=self._region,
                     operating_point=dict(zip(self._states, self._x_op.tolist())))

    def _derived(self, what: str, compute, check=None):
        """``what``, computed once per process and cached on disk by content (:mod:`._derivation_cache`)."""
        if what not in self._cache:
            self._cache[what] = self._store.get(what, compute, check)
        return self._cache[what]

    def _lie_chain(self) -> LieChain:
        if "chain" not in self._cache:
            warn_notes(self._derived("chain", lambda: lie_chain(self), LieChain).notes)
        return self._cache["chain"]

    def relative_degree(self) -> int:
        """The relative degree rho, by Lie derivatives along ``f(x, u)`` with u held constant.

        rho is the first i for which ``d y^(i)/du`` is not identically zero (checked at random
        points of the region, then symbolically); the input may enter non-affinely.

        Returns
        -------
        int

        Raises
        ------
        RelativeDegreeError
            If the input does not appear up to ``y^(n)``, or ``b = d y^(rho)/du`` vanishes at the
            operating point ``(x_op, u_eq)`` (the message names the point and ``b``).

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.plants.flexible_joint().relative_degree()
        4
        """
        return self._lie_chain().rho

    def output_derivatives(self, order: int) -> tuple:
        """``(y, y', ..., y^(order))`` as SymPy expressions (Lie derivatives along ``f``).

        Parameters
        ----------
        order : int
            Highest derivative, ``0 <= order <= rho``; below ``rho`` none depends on the input.

        Returns
        -------
        tuple of sympy.Expr

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.plants.pendulum().output_derivatives(1)
        (theta, theta_dot)
        """
        chain = self._lie_chain()
        order = V.integer("order", order, minimum=0, maximum=chain.rho)
        return tuple(chain.derivatives[: order + 1])

    def normal_form(self) -> NormalForm:
        """The normal form: rho, ``sigma = y^(rho)``, ``a``, ``b``, coordinates, zero dynamics.

        Returns
        -------
        NormalForm

        Examples
        --------
        >>> import fl_design as fl
        >>> nf = fl.plants.trms_yaw().normal_form()
        >>> nf.rho, nf.minimum_phase
        (2, True)
        """
        return self._derived("nf", lambda: derive_normal_form(self), NormalForm)

    @cached_property
    def _fh(self) -> tuple[ca.Function, ca.Function]:
        return self._store.get("fh", self._translate_fh, tuple)

    def _translate_fh(self) -> tuple[ca.Function, ca.Function]:
        args = [list(self._states), [self._input]]
        f = to_casadi(self._rhs, args, "f", subs=self._params_map, input_names=["x", "u"],
                      output_name="xdot")
        h = to_casadi(self._output, [list(self._states)], "h", subs=self._params_map,
                      input_names=["x"], output_name="y")
        return f, h

    def linearization(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Jacobians ``(A, B, C, D)`` at the operating point ``(x_op, u_eq)``.

        Returns
        -------
        A : numpy.ndarray, shape (n, n)
        B : numpy.ndarray, shape (n, 1)
        C : numpy.ndarray, shape (1, n)
        D : numpy.ndarray, shape (1, 1)
            Always zero (the output does not depend on the input).

        Examples
        --------
        >>> import fl_design as fl
        >>> A, B, C, D = fl.plants.pendulum().linearization()
        >>> A.round(3).tolist(), B.ravel().tolist()
        ([[0.0, 1.0], [-9.81, -0.5]], [0.0, 1.0])
        """
        f, h = self._fh
        x, u = ca.SX.sym("x", self.n), ca.SX.sym("u")
        jac = ca.Function("lin", [x, u], [ca.jacobian(f(x, u), x), ca.jacobian(f(x, u), u),
                                          ca.jacobian(h(x), x)])
        A, B, C = (np.array(m.full(), dtype=float) for m in jac(self._x_op, self._u_eq))
        return A, B.reshape(self.n, 1), C.reshape(1, self.n), np.zeros((1, 1))

    def casadi(self) -> PlantFunctions:
        """CasADi SX functions ``f, h, sigma, b`` with numeric parameters (cached).

        Returns
        -------
        PlantFunctions

        Raises
        ------
        RelativeDegreeError
            If the relative degree is not defined (``sigma`` and ``b`` need it).

        Examples
        --------
        >>> import fl_design as fl
        >>> fns = fl.plants.trms_yaw().casadi()
        >>> fns.f
        Function(f:(x[2],u)->(xdot[2]) SXFunction)
        """
        def translate():
            chain = self._lie_chain()
            args = [list(self._states), [self._input]]
            kw = {"subs": self._params_map, "input_names": ["x", "u"]}
            sigma = to_casadi(chain.derivatives[chain.rho], args, "sigma", output_name="sigma", **kw)
            return sigma, to_casadi(chain.b, args, "b", output_name="b", **kw)

        if "casadi" not in self._cache:
            sigma, b = self._derived("sigma_b", translate, tuple)
            f, h = self._fh
            self._cache["casadi"] = PlantFunctions(f=f, h=h, sigma=sigma, b=b)
        return self._cache["casadi"]

    def b_bounds(self, *, allow_sign_change: bool = False) -> tuple[float, float]:
        """Bounds ``(b_min, b_max)`` of ``b = d y^(rho)/du`` over ``region x input_range``.

        Method: ``b`` is evaluated (NumPy) on a dense tensor grid over the box of the variables
        it actually depends on (at most ~2e5 points: 2001 per axis in 1-D, 447 in 2-D, 58 in 3-D;
        each axis also contains 0 and the operating point when inside; beyond 7 variables a
        scrambled Sobol sample of 2^16 points), then the 4 best grid points of each extreme are
        refined by bounded L-BFGS-B. A constant ``b`` is returned exactly; extremes on the box's
        faces, edges, corners or at 0 (kinks of ``|x|``) are found exactly.

        Parameters
        ----------
        allow_sign_change : bool, optional
            The method needs a known sign of b: by default a range containing 0 raises
            RelativeDegreeError; True returns the bounds anyway.

        Returns
        -------
        (float, float)

        Raises
        ------
        ParameterError
            ``b`` depends on a state without a range in ``region`` (named) or on the input and
            ``input_range`` is missing.
        RelativeDegreeError
            ``b`` changes sign or vanishes on the region (unless ``allow_sign_change``).

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.plants.trms_yaw().b_bounds()
        (3.6..., 6.8...)
        """
        flag = bool(allow_sign_change)
        return self._derived(f"bounds{int(flag)}", lambda: b_bounds(self, allow_sign_change=flag),
                             tuple)

    def jacobian_bounds(self, *, region=None, margin: float = 0.05,
                        points: int = 200_000) -> tuple[tuple[float, float], ...]:
        """Bounds of ``d sigma/d xi_i`` (normal-form coordinates, ``u = u_eq``) over the region.

        The ``a_jacobian_bounds`` of :func:`fl_design.certify_eps`; computed by
        :func:`fl_design.symbolic._jacobian.jacobian_bounds` (dense grid, widened by ``margin``).

        Parameters
        ----------
        region : dict, optional
            ``{state: (lo, hi)}`` overriding the plant's region (e.g. a smaller one).
        margin : float, optional
            Relative widening of each range (default 0.05).
        points : int, optional
            Grid size (default 2e5).

        Returns
        -------
        tuple of (float, float)

        Raises
        ------
        RelativeDegreeError
            The plant has internal dynamics (``rho < n``).
        ParameterError
            A state has no range.

        Examples
        --------
        >>> import fl_design as fl
        >>> b = fl.plants.pendulum().jacobian_bounds(region={"theta": (-0.5, 0.5)}, margin=0)
        >>> [round(v, 2) for v in b[0]]
        [-9.81, -8.61]
        """
        from ._jacobian import jacobian_bounds

        return jacobian_bounds(self, region=region, margin=margin, points=points)


__all__ = ["Plant", "PlantFunctions"]
