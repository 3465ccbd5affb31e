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
* running metrics (over accepted samples, error ``e = y - r`` on the true output): max and
  min of ``e``, sums of ``|e|``, ``u^2``, ``|u_k - u_(k-1)|`` and of the squared estimation
  errors ``xhat_i - y^(i-1)``, ``sigmahat - sigma``; over the tail ``k >= k_tail``: max ``|e|``,
  max and min of ``e``, sum of ``e``; the first samples where the output has covered 10 % and
  90 % of the step and the last sample with ``|e| > tol``.

The step is run over the samples and over the grid's parameter columns by a compiled C driver
(or, without a compiler, by CasADi's ``fold`` in its interpreter): see :mod:`fl_design.sim._runners`.
Memory is one accumulator per grid point, whatever the number of samples.

Examples
--------
>>> import fl_design as fl
>>> from fl_design.sim import ClosedLoop
>>> design = fl.Design(estimator=fl.EHGO(rho=2, eps=0.02, T=1e-3),
...                    controller=fl.DynamicController((2, 4), 1e-2))
>>> loop = ClosedLoop(fl.plants.pendulum(), design, substeps=1)
>>> loop.sample.name_in()
['x', 's', 'r', 'w', 'q', 'p']
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from .. import _validate as V
from ..errors import DesignMismatchError, ParameterError

#: Any design-state or input magnitude beyond this counts as non-finite (divergence).
HUGE = 1e300


@dataclass(frozen=True)
class AccumulatorLayout:
    """Named slices of the accumulator vector of the sweep kernel.

    Parameters
    ----------
    fields : tuple of (str, int)
        Names and lengths, in order.

    Examples
    --------
    >>> from fl_design.sim import accumulator_layout
    >>> lay = accumulator_layout(n=2, m=5, rho=2, n_p=28)
    >>> lay.slices["x"], lay.size > 2 + 5 + 28
    (slice(0, 2, None), True)
    """

    fields: tuple

    @functools.cached_property
    def slices(self) -> dict[str, slice]:
        """``{name: slice}`` into the accumulator."""
        out, start = {}, 0
        for name, length in self.fields:
            out[name] = slice(start, start + length)
            start += length
        return out

    @property
    def size(self) -> int:
        """Length of the accumulator."""
        return sum(length for _, length in self.fields)

    def pack(self, **values) -> np.ndarray:
        """An accumulator (or a matrix with one column per run) from named values.

        Every field must be given; a value is a scalar, a vector of the field's length, or a
        matrix ``(length, m)`` for ``m`` runs.

        Examples
        --------
        >>> from fl_design.sim import AccumulatorLayout
        >>> AccumulatorLayout((("a", 1), ("b", 2))).pack(a=1.0, b=[2.0, 3.0]).ravel().tolist()
        [1.0, 2.0, 3.0]
        """
        missing = [name for name, _ in self.fields if name not in values]
        if missing:
            raise ParameterError(f"accumulator fields {missing} are missing")
        cols = max(np.shape(v)[1] if np.ndim(v) == 2 else 1 for v in values.values())
        acc = np.empty((self.size, cols))
        for name, length in self.fields:
            value = np.asarray(values[name], dtype=float)
            acc[self.slices[name]] = value.reshape(length, -1) if value.ndim else value
        return acc

    def unpack(self, acc) -> dict[str, np.ndarray]:
        """Named rows of an accumulator matrix ``(size, m)`` (scalar fields as ``(m,)``).

        Examples
        --------
        >>> import numpy as np
        >>> from fl_design.sim import AccumulatorLayout
        >>> AccumulatorLayout((("a", 1), ("b", 2))).unpack(np.arange(3.0))["a"]
        array([0.])
        """
        acc = np.asarray(acc, dtype=float)
        acc = acc.reshape(self.size, -1)
        return {name: (acc[self.slices[name]][0] if length == 1 else acc[self.slices[name]])
                for name, length in self.fields}


_METRIC_FIELDS = ("e_max", "e_min", "abs_e_sum", "u2_sum", "du_sum")
_TAIL_FIELDS = ("tail_abs_e_max", "tail_e_max", "tail_e_min", "tail_e_sum")
_MARK_FIELDS = ("k10", "k90", "k_out")


def accumulator_layout(*, n: int, m: int, rho: int, n_p: int) -> AccumulatorLayout:
    """The accumulator of a plant with ``n`` states and a design of state size ``m``.

    Fields: ``x`` (n), ``s`` (m), ``u_prev``, ``k``, ``diverged``, ``k_div``, the running
    metrics ``e_max e_min abs_e_sum u2_sum du_sum est2_sum (rho+1) tail_abs_e_max tail_e_max
    tail_e_min tail_e_sum k10 k90 k_out``, and the run's constants ``N k_tail y0 step tol q
    x_op (n) bound (n) p (n_p)``.

    Parameters
    ----------
    n, m, rho, n_p : int
        Plant states, design state size, relative degree, parameter-vector length.

    Returns
    -------
    AccumulatorLayout

    Examples
    --------
    >>> from fl_design.sim import accumulator_layout
    >>> "est2_sum" in accumulator_layout(n=2, m=5, rho=2, n_p=28).slices
    True
    """
    fields = [("x", n), ("s", m), ("u_prev", 1), ("k", 1), ("diverged", 1), ("k_div", 1)]
    fields += [(name, 1) for name in _METRIC_FIELDS] + [("est2_sum", rho + 1)]
    fields += [(name, 1) for name in _TAIL_FIELDS + _MARK_FIELDS]
    fields += [(name, 1) for name in ("N", "k_tail", "y0", "step", "tol", "q")]
    fields += [("x_op", n), ("bound", n), ("p", n_p)]
    return AccumulatorLayout(tuple(fields))


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
    >>> from fl_design.sim import default_substeps
    >>> default_substeps(fl.plants.pendulum(), 1e-3)
    1
    """
    A = plant.linearization()[0]
    lam = float(np.max(np.abs(np.linalg.eigvals(A)))) if A.size else 0.0
    return max(1, math.ceil(T * lam - 1e-12))


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
        The plant's relative degree differs from the design's.

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim import ClosedLoop
    >>> d = fl.Design(estimator=fl.EHGO(rho=2, eps=0.02, T=1e-3),
    ...               controller=fl.DynamicController((2, 4), 1e-2))
    >>> loop = ClosedLoop(fl.plants.pendulum(), d, substeps=2)
    >>> x1 = loop.sample([0.1, 0.0], d.initial_state(), 0.0, 0.0, 0.0, d.parameter_vector())[0]
    >>> x1.shape
    (2, 1)
    """

    plant: Any
    design: Any
    substeps: int

    def __post_init__(self) -> None:
        object.__setattr__(self, "substeps", V.integer("substeps", self.substeps, minimum=1))
        rho_p = self.plant.relative_degree()
        if rho_p != self.design.rho:
            raise DesignMismatchError(
                f"the plant {self.plant.name!r} has relative degree {rho_p} but the design "
                f"serves rho={self.design.rho}; build the design with rho={rho_p} (gains of "
                f"length {rho_p}, EHGO(rho={rho_p}, ...))"
            )

    def __getstate__(self):  # CasADi graphs are rebuilt after unpickling
        return {k: v for k, v in self.__dict__.items() if k in ("plant", "design", "substeps")}

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
    def layout(self) -> AccumulatorLayout:
        """The accumulator layout (:func:`accumulator_layout`)."""
        return accumulator_layout(n=self.n, m=self.m, rho=self.rho, n_p=self.n_p)

    @property
    def record_layout(self) -> AccumulatorLayout:
        """Rows of :attr:`record`'s ``out``: ``x y ym u xhat sigma coords``."""
        return AccumulatorLayout((("x", self.n), ("y", 1), ("ym", 1), ("u", 1),
                                  ("xhat", self.rho + 1), ("sigma", 1), ("coords", self.rho)))

    # --- the functions --------------------------------------------------------------------------
    @functools.cached_property
    def plant_step(self) -> ca.Function:
        """``fl_rk4(x, u) -> x_next`` (classical RK4, ``substeps`` steps, u held)."""
        f = self.plant.casadi().f
        x, u = ca.SX.sym("x", self.n), ca.SX.sym("u")
        h = self.T / self.substeps
        xk = x
        for _ in range(self.substeps):
            k1 = f(xk, u)
            k2 = f(xk + (h / 2) * k1, u)
            k3 = f(xk + (h / 2) * k2, u)
            k4 = f(xk + h * k3, u)
            xk = xk + (h / 6) * (k1 + 2 * k2 + 2 * k3 + k4)
        return ca.Function("fl_rk4", [x, u], [xk], ["x", "u"], ["x_next"])

    @functools.cached_property
    def coordinates(self) -> ca.Function:
        """``fl_coords(x) -> [y, y', ..., y^(rho-1)]`` (true normal-form coordinates)."""
        from ..symbolic._bridge import to_casadi

        nf = self.plant.normal_form()
        return to_casadi(list(nf.coordinates), [list(self.plant.states)], "fl_coords",
                         subs=self.plant.params, input_names=["x"], output_name="coords")

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
        sigma = fns.sigma(x, u)
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
    def _accumulating(self) -> tuple[ca.SX, ca.SX, ca.SX, ca.SX]:
        """Symbolic ``(acc, d, acc_next, out)`` of one accumulating step."""
        lay = self.layout
        acc, d = ca.SX.sym("acc", lay.size), ca.SX.sym("d", 2)
        a = {name: acc[sl] for name, sl in lay.slices.items()}
        r, w = d[0], d[1]
        s_next, u, y, ym, xhat, sigma, coords = self.control(a["x"], a["s"], r, w, a["q"], a["p"])
        x_next = self.plant_step(a["x"], u)
        ok = 1
        for i in range(self.n):
            ok = ok * (ca.fabs(x_next[i] - a["x_op"][i]) <= a["bound"][i])
        for i in range(self.m):
            ok = ok * (ca.fabs(s_next[i]) < HUGE)
        ok = ok * (ca.fabs(u) < HUGE)
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
        e = y - r
        tail = k >= a["k_tail"]
        est_err = xhat - ca.vertcat(coords, sigma)
        upd = {
            "e_max": ca.fmax(a["e_max"], e), "e_min": ca.fmin(a["e_min"], e),
            "abs_e_sum": a["abs_e_sum"] + ca.fabs(e), "u2_sum": a["u2_sum"] + u * u,
            "du_sum": a["du_sum"] + ca.if_else(k > 0, ca.fabs(u - a["u_prev"]), 0),
            "est2_sum": a["est2_sum"] + est_err * est_err,
            "tail_abs_e_max": ca.if_else(tail, ca.fmax(a["tail_abs_e_max"], ca.fabs(e)),
                                         a["tail_abs_e_max"]),
            "tail_e_max": ca.if_else(tail, ca.fmax(a["tail_e_max"], e), a["tail_e_max"]),
            "tail_e_min": ca.if_else(tail, ca.fmin(a["tail_e_min"], e), a["tail_e_min"]),
            "tail_e_sum": ca.if_else(tail, a["tail_e_sum"] + e, a["tail_e_sum"]),
        }
        progress = ca.sign(a["step"]) * (y - a["y0"])
        for name, frac in (("k10", 0.1), ("k90", 0.9)):
            reached = (a[name] < 0) * (progress >= frac * ca.fabs(a["step"]))
            upd[name] = ca.if_else(reached, k, a[name])
        upd["k_out"] = ca.if_else(ca.fabs(e) > a["tol"], k, a["k_out"])
        for name, value in upd.items():
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

    def runner(self, *, compiled: bool = True, cache_dir=None):
        """The runner of :attr:`accumulate` / :attr:`record` (see :mod:`fl_design.sim._runners`).

        Parameters
        ----------
        compiled : bool, optional
            Generated C + driver, compiled and cached (default), or CasADi's interpreter.
        cache_dir : path-like, optional
            Cache of compiled kernels (default ``$FL_DESIGN_CACHE`` or ``~/.cache/fl_design``).

        Returns
        -------
        NativeRunner or InterpretedRunner

        Examples
        --------
        >>> import fl_design as fl
        >>> from fl_design.sim import ClosedLoop
        >>> d = fl.Design(estimator=fl.EHGO(rho=2, eps=0.02, T=1e-3),
        ...               controller=fl.DynamicController((2, 4), 1e-2))
        >>> ClosedLoop(fl.plants.pendulum(), d, substeps=1).runner(compiled=False).compiled
        False
        """
        from ._runners import make_runner

        sl = self.layout.slices
        indices = {"k": sl["k"].start, "div": sl["diverged"].start, "N": sl["N"].start}
        return make_runner(self.accumulate, self.record, indices, compiled=compiled,
                           cache_dir=cache_dir)


__all__ = ["HUGE", "AccumulatorLayout", "ClosedLoop", "accumulator_layout", "default_substeps"]
