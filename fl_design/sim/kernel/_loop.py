"""The sampled closed loop (plant + design) as CasADi functions, and the folded sweep kernel.

One sample of the loop, ``k -> k + 1`` (time ``kT``)::

    y_k      = h(x_k)                              true output
    ym_k     = quantize(y_k + w_k)                 measured output (noise, then quantization)
    s_(k+1), u_k, xhat_k = design.parametric_step(s_k, ym_k, r_k, p)
    x_(k+1)  = RK4 of x' = f(x, u_k) over [kT, (k+1)T), `substeps` steps, u_k held (ZOH)

``design.parametric_step`` is *called* inside the graph (the loop is never re-implemented) and
``p`` is the design's parameter vector, an input: a sweep changes ``eps`` and ``gamma`` without
rebuilding or recompiling anything. Quantization is ``q * floor(y / q + 1/2)`` (round half up;
``q = 0`` means none).

For sweeps the sample is wrapped in an *accumulating step* ``acc_(k+1) = F(acc_k, d_k)`` whose
state ``acc`` holds the plant and design states, running metrics, the run's constants and ``p``
(see :func:`accumulator_layout`), and ``d_k = (r_k, w_k)``. Its rules:

* **divergence**: the proposed ``x_(k+1)`` leaves ``|x - x_op| <= bound`` (per state) or any new
  value is not finite (``NaN`` fails every comparison, so it counts as out of bounds). The
  run is then marked diverged at sample ``k + 1`` and its state is **frozen** at the last
  accepted (finite) value: nothing non-finite ever enters the state, so NaN, inf and finite
  escape neither crash nor slow down the run. CasADi's ``if_else`` evaluates both branches but
  selects with ``c ? a : 0`` (not ``c * a``), so a NaN in the rejected branch is dropped; this
  is tested for the interpreted and the compiled kernel.
* **padding**: samples ``k >= N`` change nothing (only ``k < N`` samples count), so blocks of
  samples may be padded and a frozen run may skip its remaining samples.
* running metrics: every accepted sample updates the accumulators of
  :data:`fl_design.sim._metrics.ACCUMULATORS` (defined once, in :mod:`fl_design.sim._metrics`).

The step is run over the samples and over the grid's parameter columns by a compiled C driver
(or, without a compiler, by CasADi's ``fold`` in its interpreter): see :mod:`fl_design.sim.kernel._runners`.
Memory is one accumulator per grid point, whatever the number of samples.

Examples
--------
>>> import fl_design as fl
>>> from fl_design.sim import ClosedLoop
>>> design = fl.presets.pendulum_design()
>>> loop = ClosedLoop(fl.plants.pendulum(), design, substeps=1)
>>> loop.sample.name_in()
['x', 's', 'r', 'w', 'q', 'p']
"""

from __future__ import annotations

import functools
import math
import warnings
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from ... import _validate as V
from ..._limits import check_substeps, env_flag
from ...design import Layout
from ...errors import DesignMismatchError, NonMinimumPhaseWarning, UnmodeledDynamicsWarning
from .._metrics import RUN_CONSTANTS, metric_layout, signals, update

#: Any design-state or input magnitude beyond this counts as non-finite (divergence).
HUGE = 1e300


#: Per-sample inputs ``d_k`` of the accumulating step: reference, what is added to the
#: measurement (noise and output disturbance), what is added to ``u`` at the plant.
N_INPUTS = 3


def accumulator_layout(*, n: int, m: int, rho: int, n_p: int, n_theta: int = 0) -> Layout:
    """The accumulator of a plant with ``n`` states and a design of state size ``m``.

    Fields: ``x`` (n), ``s`` (m), ``u_prev``, ``k``, ``diverged``, ``k_div``, the running
    values of :data:`fl_design.sim._metrics.ACCUMULATORS` (``est2_sum`` has ``rho + 1`` entries), and
    the run's constants ``N k_tail k_mid y0 step tol noise q x_op (n) bound (n) region_lo (n)
    region_hi (n) p (n_p)``, then ``theta (n_theta)``, the plant parameters given at run time
    (only when ``n_theta > 0``: :attr:`ClosedLoop.uncertain`).

    Parameters
    ----------
    n, m, rho, n_p : int
        Plant states, design state size, relative degree, parameter-vector length.
    n_theta : int, optional
        Plant parameters that are run-time inputs (default 0).

    Returns
    -------
    Layout

    Examples
    --------
    >>> from fl_design.sim.kernel._loop import accumulator_layout
    >>> lay = accumulator_layout(n=2, m=5, rho=2, n_p=28)
    >>> lay["x"], "est2_sum" in lay, lay.size
    (slice(0, 2, None), True, 106)
    """
    fields = [("x", n), ("s", m), ("u_prev", 1), ("k", 1), ("diverged", 1), ("k_div", 1)]
    fields += list(metric_layout(rho).fields)
    fields += [(name, 1) for name in (*RUN_CONSTANTS, "q")]
    fields += [("x_op", n), ("bound", n), ("region_lo", n), ("region_hi", n), ("p", n_p)]
    if n_theta:
        fields.append(("theta", n_theta))
    return Layout(tuple(fields))


def default_substeps(plant, T: float) -> int:
    """RK4 substeps so that ``h * max|eig(A)| <= 1`` with ``h = T / substeps``.

    ``A`` is the plant's Jacobian at its operating point. RK4 is stable up to ``h |lambda| =
    2.78`` on the negative real axis; at ``h |lambda| = 1`` the fastest mode's one-step factor
    is 0.375 instead of ``exp(-1) = 0.368`` while that mode shrinks by ``e`` per step, so its
    share of the error is negligible and slower modes are integrated far more accurately (the
    TRMS loop, ``h |lambda| = 0.5``, agrees with ``cvodes`` at ``reltol = 1e-10`` to 1e-9).
    Give ``substeps`` explicitly for plants whose fast dynamics lie away from the operating
    point.

    Parameters
    ----------
    plant : Plant
        The plant.
    T : float
        Sampling time.

    Returns
    -------
    int

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim.kernel._loop import default_substeps
    >>> default_substeps(fl.plants.pendulum(), 1e-3)
    1
    """
    A = plant.linearization()[0]
    lam = float(np.max(np.abs(np.linalg.eigvals(A)))) if A.size else 0.0
    return max(1, math.ceil(T * lam - 1e-12))


def resolve_substeps(plant, T: float, substeps: int | None) -> int:
    """``substeps`` as given, or :func:`default_substeps` when None (the one place deciding).

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim.kernel._loop import resolve_substeps
    >>> resolve_substeps(fl.plants.pendulum(), 1e-3, None), resolve_substeps(None, 1e-3, 4)
    (1, 4)
    """
    return default_substeps(plant, T) if substeps is None else int(substeps)


def _warn_if_not_minimum_phase(plant) -> None:
    """A :class:`~fl_design.errors.NonMinimumPhaseWarning` naming the unstable zero dynamics."""
    minimum_phase, eig = plant._zero_dynamics()  # cached: no SymPy when loaded
    if minimum_phase:
        return
    listed = ", ".join(f"{z.real:.4g}" if abs(z.imag) < 1e-12 else f"{z.real:.4g}{z.imag:+.4g}j"
                       for z in eig)
    warnings.warn(
        f"plant {plant.name!r} is not minimum phase: the eigenvalues of its zero dynamics "
        f"(linearized at the operating point) are [{listed}], largest real part "
        f"{float(np.max(eig.real)):.4g} (not < 0); the method's guarantees do not hold: the "
        "output may settle while the internal states "
        "leave the region (see Response.region_exit_time)", NonMinimumPhaseWarning, stacklevel=4)


@dataclass(frozen=True)
class ClosedLoop:
    """Plant and design joined into the sampled closed loop (CasADi functions, built lazily).

    Parameters
    ----------
    plant : Plant
        The plant; its relative degree must equal the design's.
    design : Design
        Estimator + controller.
    substeps : int
        RK4 steps per sample (>= 1).
    allow_unmodeled : bool, optional
        Accept a design of relative degree ``rho_d`` lower than the plant's ``rho_p`` (an
        unmodeled fast actuator, the paper's hardware situation), with an
        :class:`~fl_design.errors.UnmodeledDynamicsWarning`. The design's "true" coordinates
        are then the plant's ``y, ..., y^(rho_d - 1)`` and its ``sigma`` is ``y^(rho_d) =
        L_f^rho_d h`` (no input term). Default False: a mismatch is refused.
    uncertain : tuple of str, optional
        Names of plant parameters that are *run-time inputs* of the accumulating step (the
        accumulator's ``theta``, one value per run) instead of numbers compiled in: one
        kernel runs a whole family of plants (:func:`fl_design.monte_carlo`). The plant
        step then integrates ``[x; theta]`` with ``theta' = 0`` (``theta`` is carried
        exactly). :attr:`control`, :attr:`sample` and :attr:`plant_step` keep the plant's
        own values. Default ``()``.
    accumulators : tuple of str, optional
        The accumulators the step updates (:func:`fl_design.sim._metrics.accumulators_for`);
        the others keep their initial values and cost nothing in the kernel (the lanes
        emitter drops an entry the step only copies). Default None: all of them.

    Attributes
    ----------
    plant_step : casadi.Function
        ``fl_rk4(x, u) -> x_next``.
    control : casadi.Function
        ``fl_control(x, s, r, w, q, p) -> (s_next, u, y, ym, xhat, sigma, coords)``: measurement,
        then the design step; ``coords`` are the true ``y, y', ..., y^(rho-1)``, ``sigma`` the
        true ``y^(rho)`` with the applied input.
    sample : casadi.Function
        ``fl_loop(x, s, r, w, q, p) -> (x_next, s_next, u, y, ym, xhat, sigma)``: one sample.
    accumulate : casadi.Function
        ``fl_acc(acc, d) -> acc_next``: the accumulating step (module docstring).
    record : casadi.Function
        ``fl_rec(acc, d) -> (acc_next, out)`` with ``out = [x, y, ym, u, xhat, sigma, coords]``
        at sample ``k`` (see :attr:`record_layout`).

    Raises
    ------
    DesignMismatchError
        The plant's relative degree differs from the design's (lower, or higher without
        ``allow_unmodeled``).

    Warns
    -----
    NonMinimumPhaseWarning
        The plant has zero dynamics (``n > rho``) that are not asymptotically stable at the
        operating point (:attr:`fl_design.NormalForm.minimum_phase` False); the message names
        their eigenvalues. A warning, not an error: simulating such a plant is how one sees
        the internal states run away (the run's ``region_exit_time``), but no verdict on the
        output alone means the loop works.

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim import ClosedLoop
    >>> d = fl.presets.pendulum_design()
    >>> loop = ClosedLoop(fl.plants.pendulum(), d, substeps=2)
    >>> x1 = loop.sample([0.1, 0.0], d.initial_state(), 0.0, 0.0, 0.0, d.parameter_vector())[0]
    >>> x1.shape
    (2, 1)
    """

    plant: Any
    design: Any
    substeps: int
    allow_unmodeled: bool = False
    uncertain: tuple = ()
    accumulators: tuple | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "substeps", check_substeps(self.substeps))
        if self.accumulators is not None:
            object.__setattr__(self, "accumulators", tuple(self.accumulators))
        V.boolean("allow_unmodeled", self.allow_unmodeled)
        if self.uncertain != ():
            from ._parametric import uncertain_names

            object.__setattr__(self, "uncertain", uncertain_names(self.plant, self.uncertain))
        rho_p, rho_d = self.plant.relative_degree(), self.design.rho
        if self.plant.n > rho_p:
            _warn_if_not_minimum_phase(self.plant)
        if rho_p == rho_d:
            return
        if rho_d < rho_p and self.allow_unmodeled:
            warnings.warn(
                f"the design (rho={rho_d}) runs on plant {self.plant.name!r} of relative degree "
                f"{rho_p}: {rho_p - rho_d} order(s) of unmodeled dynamics, outside the theory's "
                "guarantees (allow_unmodeled=True)", UnmodeledDynamicsWarning, stacklevel=3)
            return
        hint = (" or pass allow_unmodeled=True to run it on purpose (unmodeled dynamics)"
                if rho_d < rho_p else " (a design of higher relative degree is not supported)")
        raise DesignMismatchError(
            f"the plant {self.plant.name!r} has relative degree {rho_p} but the design "
            f"serves rho={rho_d}; build the design with rho={rho_p} (gains of "
            f"length {rho_p}, EHGO(rho={rho_p}, ...)){hint}"
        )

    def __getstate__(self):  # CasADi graphs are rebuilt after unpickling
        keep = ("plant", "design", "substeps", "allow_unmodeled", "uncertain", "accumulators")
        return {k: v for k, v in self.__dict__.items() if k in keep}

    # --- sizes ----------------------------------------------------------------------------------
    @property
    def n(self) -> int:
        """Plant states."""
        return self.plant.n

    @property
    def m(self) -> int:
        """Design state size."""
        return self.design.state_size

    @property
    def rho(self) -> int:
        """Relative degree."""
        return self.design.rho

    @property
    def T(self) -> float:
        """Sampling time."""
        return self.design.T

    @functools.cached_property
    def n_p(self) -> int:
        """Length of the design's parameter vector."""
        return int(self.design.parameter_vector().size)

    @functools.cached_property
    def layout(self) -> Layout:
        """The accumulator layout (:func:`accumulator_layout`)."""
        return accumulator_layout(n=self.n, m=self.m, rho=self.rho, n_p=self.n_p,
                                  n_theta=len(self.uncertain))

    @property
    def record_layout(self) -> Layout:
        """Rows of :attr:`record`'s ``out``: ``x y ym u xhat sigma coords``."""
        return Layout((("x", self.n), ("y", 1), ("ym", 1), ("u", 1),
                                  ("xhat", self.rho + 1), ("sigma", 1), ("coords", self.rho)))

    # --- the functions --------------------------------------------------------------------------
    @functools.cached_property
    def rk4_step(self) -> ca.Function:
        """``fl_rk4_step(x, u) -> x_next``: ONE classical RK4 step of ``h = T / substeps``."""
        f = self.plant.casadi().f
        x, u = ca.SX.sym("x", self.n), ca.SX.sym("u")
        h = self.T / self.substeps
        k1 = f(x, u)
        k2 = f(x + (h / 2) * k1, u)
        k3 = f(x + (h / 2) * k2, u)
        k4 = f(x + h * k3, u)
        x_next = x + (h / 6) * (k1 + 2 * k2 + 2 * k3 + k4)
        return ca.Function("fl_rk4_step", [x, u], [x_next], ["x", "u"], ["x_next"])

    @functools.cached_property
    def plant_step(self) -> ca.Function:
        """``fl_rk4(x, u) -> x_next`` (classical RK4, ``substeps`` steps, u held).

        One substep is inlined into the graphs that call it; more are a ``fold`` of
        :attr:`rk4_step` that callers keep as one call (``never_inline``): generated C loops
        over the substeps, so its size does not grow with them.
        """
        x, u = ca.SX.sym("x", self.n), ca.SX.sym("u")
        if self.substeps == 1:
            return ca.Function("fl_rk4", [x, u], [self.rk4_step(x, u)], ["x", "u"],
                               ["x_next"])
        X, U = ca.MX.sym("x", self.n), ca.MX.sym("u")
        x_next = self.rk4_step.fold(self.substeps)(X, ca.repmat(U, 1, self.substeps))
        return ca.Function("fl_rk4", [X, U], [x_next], ["x", "u"], ["x_next"],
                           {"never_inline": True})

    @functools.cached_property
    def coordinates(self) -> ca.Function:
        """``fl_coords(x) -> [y, y', ..., y^(rho-1)]`` (true normal-form coordinates).

        ``rho`` is the design's: with unmodeled dynamics the plant's first ``rho`` output
        derivatives (Lie derivatives of ``h`` along ``f``).
        """
        return self.plant._coordinates_function(self.rho)  # cached: no SymPy when loaded

    @functools.cached_property
    def true_sigma(self) -> ca.Function:
        """``fl_sigma(x, u) -> y^(rho)`` with the design's ``rho`` (the plant's ``sigma`` when
        the relative degrees agree, ``L_f^rho h`` without an input term otherwise)."""
        if self.plant.relative_degree() == self.rho:
            return self.plant.casadi().sigma
        from ...symbolic._bridge import to_casadi

        expr = self.plant.output_derivatives(self.rho)[-1]
        return to_casadi(expr, [list(self.plant.states), [self.plant.input]], "sigma",
                         subs=self.plant.params, input_names=["x", "u"], output_name="sigma")

    @functools.cached_property
    def control(self) -> ca.Function:
        """``fl_control(x, s, r, w, q, p) -> (s_next, u, y, ym, xhat, sigma, coords)``."""
        fns = self.plant.casadi()
        x, s = ca.SX.sym("x", self.n), ca.SX.sym("s", self.m)
        r, w, q, p = ca.SX.sym("r"), ca.SX.sym("w"), ca.SX.sym("q"), ca.SX.sym("p", self.n_p)
        y = fns.h(x)
        q_safe = ca.if_else(q > 0, q, 1.0)
        ym = ca.if_else(q > 0, q_safe * ca.floor((y + w) / q_safe + 0.5), y + w)
        s_next, u, xhat = self.design.parametric_step(s, ym, r, p)
        sigma = self.true_sigma(x, u)
        return ca.Function(
            "fl_control", [x, s, r, w, q, p],
            [s_next, u, y, ym, xhat, sigma, ca.vec(self.coordinates(x))],
            ["x", "s", "r", "w", "q", "p"],
            ["s_next", "u", "y", "ym", "xhat", "sigma", "coords"],
        )

    @functools.cached_property
    def sample(self) -> ca.Function:
        """``fl_loop(x, s, r, w, q, p) -> (x_next, s_next, u, y, ym, xhat, sigma)``."""
        x, s = ca.SX.sym("x", self.n), ca.SX.sym("s", self.m)
        r, w, q, p = ca.SX.sym("r"), ca.SX.sym("w"), ca.SX.sym("q"), ca.SX.sym("p", self.n_p)
        s_next, u, y, ym, xhat, sigma, _ = self.control(x, s, r, w, q, p)
        x_next = self.plant_step(x, u)
        return ca.Function("fl_loop", [x, s, r, w, q, p],
                           [x_next, s_next, u, y, ym, xhat, sigma],
                           ["x", "s", "r", "w", "q", "p"],
                           ["x_next", "s_next", "u", "y", "ym", "xhat", "sigma"])

    @functools.cached_property
    def within_bounds(self) -> ca.Function:
        """``fl_ok(x_next, s_next, u, x_op, bound) -> ok``: the one divergence rule.

        ``ok = 1`` when every ``|x_next_i - x_op_i| <= bound_i`` and every design state and
        the input are below :data:`HUGE` in magnitude; NaN fails every comparison, so a
        non-finite value is never ok. The kernel and the ``cvodes`` reference both call it.
        """
        x, xo, b = ca.SX.sym("x", self.n), ca.SX.sym("x_op", self.n), ca.SX.sym("b", self.n)
        s, u = ca.SX.sym("s", self.m), ca.SX.sym("u")
        ok = 1
        for i in range(self.n):
            ok = ok * (ca.fabs(x[i] - xo[i]) <= b[i])
        for i in range(self.m):
            ok = ok * (ca.fabs(s[i]) < HUGE)
        ok = ok * (ca.fabs(u) < HUGE)
        return ca.Function("fl_ok", [x, s, u, xo, b], [ok],
                           ["x_next", "s_next", "u", "x_op", "bound"], ["ok"])

    @functools.cached_property
    def uncertain_functions(self) -> dict:
        """The plant with the parameters :attr:`uncertain` as an input ``theta``.

        ``f(x, u, theta)``, ``h(x, theta)``, ``b(x, u, theta)``, ``control(x, s, r, w, q, p,
        theta)`` (as :attr:`control`), and ``plant_step([x; theta], u) -> [x_next; theta]``
        (``substeps`` RK4 steps of the augmented state, ``theta' = 0``; named as
        :attr:`plant_step` so the lanes emitter unrolls it the same way).
        """
        from ._parametric import parametric_loop

        return parametric_loop(self)

    @functools.cached_property
    def _accumulating(self) -> tuple[ca.SX, ca.SX, ca.SX, ca.SX]:
        """Symbolic ``(acc, d, acc_next, out)`` of one accumulating step."""
        lay = self.layout
        acc, d = ca.SX.sym("acc", lay.size), ca.SX.sym("d", N_INPUTS)
        a = {name: acc[sl] for name, sl in lay.slices.items()}
        r, w, d_in = d[0], d[1], d[2]
        if self.uncertain:  # the plant's parameters theta are inputs (one value per run)
            fns = self.uncertain_functions
            s_next, u, y, ym, xhat, sigma, coords = fns["control"](
                a["x"], a["s"], r, w, a["q"], a["p"], a["theta"])
            x_next = fns["plant_step"](ca.vertcat(a["x"], a["theta"]), u + d_in)[:self.n]
        else:
            s_next, u, y, ym, xhat, sigma, coords = self.control(a["x"], a["s"], r, w, a["q"],
                                                                 a["p"])
            x_next = self.plant_step(a["x"], u + d_in)  # the input disturbance acts at the plant
        ok = self.within_bounds(x_next, s_next, u, a["x_op"], a["bound"])
        k = a["k"]
        active = k < a["N"]
        live = active * (1 - a["diverged"])
        accept, newdiv = live * ok, live * (1 - ok)
        new = dict(a)
        new["x"] = ca.if_else(accept, x_next, a["x"])
        new["s"] = ca.if_else(accept, s_next, a["s"])
        new["u_prev"] = ca.if_else(accept, u, a["u_prev"])
        new["k"] = k + active
        new["diverged"] = ca.if_else(newdiv, 1, a["diverged"])
        new["k_div"] = ca.if_else(newdiv, k + 1, a["k_div"])
        outside = 0
        for i in range(self.n):
            outside = ca.fmax(outside, (a["x"][i] < a["region_lo"][i]) + (a["x"][i] > a["region_hi"][i]))
        sig = signals(e=y - r, u=u, u_prev=a["u_prev"], k=k,
                      est_err=xhat - ca.vertcat(coords, sigma), y=y, y0=a["y0"],
                      step=a["step"], tol=a["tol"], k_tail=a["k_tail"], k_mid=a["k_mid"],
                      outside=outside, noise=a["noise"],
                      u_range=self.design.controller.u_range, k_dist=a["k_dist"])
        kept = self.accumulators
        for name, value in update(a, sig).items():
            if kept is None or name in kept:  # the others are copied: no code for them
                new[name] = ca.if_else(accept, value, a[name])
        acc_next = ca.vertcat(*[new[name] for name, _ in lay.fields])
        out = ca.vertcat(a["x"], y, ym, u, xhat, sigma, ca.vec(coords))
        return acc, d, acc_next, out

    @functools.cached_property
    def accumulate(self) -> ca.Function:
        """``fl_acc(acc, d) -> acc_next``."""
        acc, d, acc_next, _ = self._accumulating
        return ca.Function("fl_acc", [acc, d], [acc_next], ["acc", "d"], ["acc_next"])

    @functools.cached_property
    def record(self) -> ca.Function:
        """``fl_rec(acc, d) -> (acc_next, out)``."""
        acc, d, acc_next, out = self._accumulating
        return ca.Function("fl_rec", [acc, d], [acc_next, out], ["acc", "d"],
                           ["acc_next", "out"])

    def runner(self, *, compiled: bool = True, cache_dir=None, kernel=None):
        """The runner of :attr:`accumulate` / :attr:`record` (see :mod:`fl_design.sim.kernel._runners`).

        Parameters
        ----------
        compiled : bool, optional
            Generated C + driver, compiled and cached (default), or CasADi's interpreter.
        cache_dir : path-like, optional
            Cache of compiled kernels (default ``$FL_DESIGN_CACHE`` or ``~/.cache/fl_design``).
        kernel : Kernel, optional
            All kernel options at once (overrides ``compiled`` and ``cache_dir``; also
            ``lanes``, ``vector_math`` and ``isa``).

        Returns
        -------
        LanesRunner, NativeRunner or InterpretedRunner

        Raises
        ------
        ParameterError
            ``$FL_DESIGN_VECTOR_MATH`` is set to something other than ``0`` or ``1``.

        Examples
        --------
        >>> import fl_design as fl
        >>> from fl_design.sim import ClosedLoop
        >>> d = fl.presets.pendulum_design()
        >>> ClosedLoop(fl.plants.pendulum(), d, substeps=1).runner(compiled=False).compiled
        False
        """
        from ._runners import make_runner

        env_flag("FL_DESIGN_VECTOR_MATH", True)  # strict: "banana" is an error, not "on"

        sl = self.layout.slices
        indices = {"k": sl["k"].start, "div": sl["diverged"].start, "N": sl["N"].start}
        if kernel is not None:
            return make_runner(self.accumulate, self.record, indices, compiled=kernel.compiled,
                               cache_dir=kernel.cache_dir, lanes=kernel.lanes,
                               vector_math=kernel.vector_math, isa=kernel.isa)
        return make_runner(self.accumulate, self.record, indices, compiled=compiled,
                           cache_dir=cache_dir)


__all__ = ["HUGE", "ClosedLoop", "accumulator_layout", "default_substeps", "resolve_substeps"]
