"""``simulate``: one closed-loop run of a plant and a design, with noise and quantization.

The plant is integrated inside the sampled loop (:class:`fl_design.sim.ClosedLoop`):
fixed-step RK4 with ``substeps`` steps per sample and the input held (zero-order hold), the
measurement ``y_k + w_k`` (``w_k`` drawn from ``numpy.random.default_rng(seed)``, scaled by
``noise_std``) quantized to multiples of ``quantization``. ``method="cvodes"`` integrates the
same loop with CasADi's adaptive ``cvodes`` (BDF, tight tolerances) sample by sample: the
reference against which the fixed-step integrator is checked (tests).

Examples
--------
>>> import fl_design as fl
>>> design = fl.Design(estimator=fl.EHGO(rho=2, eps=0.02, T=1e-3),
...                    controller=fl.DynamicController((2, 4), 1e-2))
>>> resp = fl.simulate(fl.plants.pendulum(), design, 0.1, 20.0, noise_std=1e-4)
>>> resp.status, bool(abs(resp.y[-1] - 0.1) < 1e-3)
('stable', True)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca
import numpy as np

from .. import _validate as V
from ._closed_loop import HUGE, ClosedLoop, default_substeps
from ..errors import DimensionError, ParameterError
from ._response import Response


def default_divergence_bound(plant) -> np.ndarray:
    """Per-state bound on ``|x - x_op|``: 10 x the region's width, else 1e6.

    A run whose state leaves this box is *diverged* (it has left the region of interest ten
    times over: no controller of that region is working any more); states without a region get
    a large absolute bound that only catches escapes.

    Parameters
    ----------
    plant : Plant
        The plant.

    Returns
    -------
    numpy.ndarray
        ``(n,)`` bounds.

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim import default_divergence_bound
    >>> default_divergence_bound(fl.plants.pendulum()).round(2).tolist()
    [62.83, 200.0]
    """
    region = plant.region or {}
    return np.array([10.0 * (region[s][1] - region[s][0]) if s in region else 1e6
                     for s in plant.states])


@dataclass(frozen=True)
class RunSetup:
    """Validated inputs of one run (or of every run of a sweep): samples and constants.

    Built by :func:`prepare_run`. ``r`` and ``noise`` are the per-sample inputs ``d_k``; the
    constants go into every accumulator.

    Parameters
    ----------
    loop : ClosedLoop
        Plant, design and integrator.
    N : int
        Samples.
    r, noise : numpy.ndarray
        ``(N,)`` reference and measurement noise (already scaled by ``noise_std``).
    x0 : numpy.ndarray
        Initial plant state.
    y0, step, tol, q : float
        Initial output, ``r[-1] - y0``, absolute tolerance, quantization step (0: none).
    k_tail : int
        First sample of the tail window.
    bound : numpy.ndarray
        Divergence bound per state.

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim import prepare_run
    >>> d = fl.Design(estimator=fl.EHGO(rho=2, eps=0.02, T=1e-3),
    ...               controller=fl.DynamicController((2, 4), 1e-2))
    >>> run = prepare_run(fl.plants.pendulum(), d, 0.1, 1.0)
    >>> run.N, run.k_tail, run.step, run.D.shape
    (1000, 800, 0.1, (2, 1000))
    """

    loop: ClosedLoop
    N: int
    r: np.ndarray
    noise: np.ndarray
    x0: np.ndarray
    y0: float
    step: float
    tol: float
    q: float
    k_tail: int
    bound: np.ndarray

    @property
    def T(self) -> float:
        """Sampling time."""
        return self.loop.T

    @property
    def D(self) -> np.ndarray:
        """``(2, N)`` per-sample inputs ``(r_k, w_k)``."""
        return np.vstack([self.r, self.noise])

    def initial_accumulator(self, P) -> np.ndarray:
        """``(nacc, m)`` accumulators for the parameter columns ``P`` (``(n_p, m)``)."""
        P = np.asarray(P, dtype=float).reshape(self.loop.n_p, -1)
        design = self.loop.design
        return self.loop.layout.pack(
            x=self.x0, s=design.initial_state(), u_prev=design.controller.u0, k=0.0,
            diverged=0.0, k_div=-1.0, e_max=-np.inf, e_min=np.inf, abs_e_sum=0.0, u2_sum=0.0,
            du_sum=0.0, est2_sum=np.zeros(self.loop.rho + 1), tail_abs_e_max=0.0,
            tail_e_max=-np.inf, tail_e_min=np.inf, tail_e_sum=0.0, k10=-1.0, k90=-1.0,
            k_out=-1.0, N=float(self.N), k_tail=float(self.k_tail), y0=self.y0,
            step=self.step, tol=self.tol, q=self.q, x_op=self.loop.plant.x_op,
            bound=self.bound, p=P,
        )


def _reference(reference, N: int, T: float) -> np.ndarray:
    t = np.arange(N) * T
    if callable(reference):
        try:
            values = np.asarray(reference(t), dtype=float)
        except (TypeError, ValueError, AttributeError):  # scalar-only: sample point by point
            values = None
        if values is None or values.shape != (N,):
            values = np.array([float(reference(tk)) for tk in t])
        if not np.all(np.isfinite(values)):
            raise ParameterError("reference(t) returned non-finite values; it must be finite")
        return values
    if np.ndim(reference) == 0:
        return np.full(N, V.real_scalar("reference", reference))
    arr = np.asarray(reference, dtype=float) if not isinstance(reference, str) else None
    if arr is None or arr.ndim != 1 or arr.shape[0] != N:
        got = "a string" if arr is None else f"shape {arr.shape}"
        raise DimensionError(
            f"reference must be a scalar, a callable r(t) or an array of N = round(duration/T)"
            f" = {N} samples (t = 0, T, ..., (N-1)T), got {got}"
        )
    return V.real_vector("reference", arr, length=N)


def prepare_run(plant, design, reference, duration, *, x0=None, noise_std=0.0,
                quantization=None, seed=0, substeps=None, tolerance=0.02, tail_fraction=0.2,
                divergence_bound=None) -> RunSetup:
    """Validate the inputs of :func:`fl_design.simulate` / :func:`fl_design.sweep`.

    Parameters are those of :func:`fl_design.simulate` (see there).

    Returns
    -------
    RunSetup

    Raises
    ------
    ParameterError
        Non-positive duration or one shorter than a sample, negative ``noise_std``,
        non-positive quantization, tolerance or bound, ``tail_fraction`` outside (0, 1].
    DimensionError
        Reference array or ``x0`` or bound of the wrong length.
    DesignMismatchError
        Relative degrees of plant and design differ.

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim import prepare_run
    >>> d = fl.Design(estimator=fl.EHGO(rho=2, eps=0.02, T=1e-3),
    ...               controller=fl.DynamicController((2, 4), 1e-2))
    >>> prepare_run(fl.plants.pendulum(), d, lambda t: 0.1 * (t > 0.5), 1.0).r[[0, -1]]
    array([0. , 0.1])
    """
    T = design.T
    duration = V.positive("duration", duration)
    N = round(duration / T)
    if N < 1:
        raise ParameterError(f"duration={duration!r} is shorter than one sample (T={T!r}); "
                             "give a duration >= T")
    steps = default_substeps(plant, T) if substeps is None else substeps
    loop = ClosedLoop(plant, design, substeps=steps)
    r = _reference(reference, N, T)
    x0 = plant.x_op.copy() if x0 is None else V.real_vector("x0", x0, length=plant.n)
    noise_std = V.nonnegative("noise_std", noise_std)
    q = 0.0 if quantization is None else V.positive("quantization", quantization)
    seed = V.integer("seed", seed, minimum=0)
    noise = (noise_std * np.random.default_rng(seed).standard_normal(N) if noise_std > 0
             else np.zeros(N))
    tolerance = V.positive("tolerance", tolerance)
    tail_fraction = V.real_scalar("tail_fraction", tail_fraction)
    if not 0.0 < tail_fraction <= 1.0:
        raise ParameterError(f"tail_fraction must be in (0, 1], got {tail_fraction!r}")
    if divergence_bound is None:
        bound = default_divergence_bound(plant)
    elif np.ndim(divergence_bound) == 0:
        bound = np.full(plant.n, V.positive("divergence_bound", divergence_bound))
    else:
        bound = V.real_vector("divergence_bound", divergence_bound, length=plant.n)
        if np.any(bound <= 0):
            raise ParameterError(f"divergence_bound must be > 0, got {bound.tolist()}")
    y0 = float(plant.casadi().h(x0))
    step = float(r[-1] - y0)
    scale = max(abs(step), float(np.ptp(r)))
    return RunSetup(loop=loop, N=N, r=r, noise=noise, x0=x0, y0=y0, step=step,
                    tol=tolerance * (scale if scale > 0 else 1.0), q=q,
                    k_tail=min(N - 1, math.floor((1.0 - tail_fraction) * N)), bound=bound)


def simulate(plant, design, reference, duration, *, x0=None, noise_std: float = 0.0,
             quantization: float | None = None, seed: int = 0, substeps: int | None = None,
             method: str = "rk4", tolerance: float = 0.02, tail_fraction: float = 0.2,
             divergence_bound=None, compiled: bool = False, cache_dir=None) -> Response:
    """Simulate the sampled closed loop of ``plant`` and ``design`` for ``duration`` seconds.

    Parameters
    ----------
    plant : Plant
        The plant; its relative degree must equal ``design.rho``.
    design : Design
        Estimator + dynamic controller (its sampling time ``T`` is the loop's).
    reference : float, callable or array_like
        A constant (a step at t = 0 from the initial output), a function ``r(t)`` sampled at
        ``t = kT``, or ``N = round(duration / T)`` samples.
    duration : float
        Length of the run in seconds (> 0, at least one sample).
    x0 : array_like, optional
        Initial plant state (default: the plant's operating point).
    noise_std : float, optional
        Standard deviation of the additive white measurement noise (default 0).
    quantization : float, optional
        Quantization step of the measurement (default: none).
    seed : int, optional
        Seed of the noise (``numpy.random.default_rng(seed)``); runs are deterministic.
    substeps : int, optional
        RK4 steps per sample (default :func:`fl_design.sim.default_substeps`).
    method : {"rk4", "cvodes"}, optional
        Fixed-step RK4 in the compiled or interpreted kernel (default), or CasADi's adaptive
        ``cvodes`` (``reltol=1e-10``, ``abstol=1e-12``) sample by sample (slow; a reference).
    tolerance : float, optional
        Relative tolerance of the classification and settling band (default 0.02, see
        :mod:`fl_design.sim`).
    tail_fraction : float, optional
        Fraction of the run, at its end, used for the tail metrics (default 0.2).
    divergence_bound : float or array_like, optional
        Bound on ``|x - x_op|`` per state beyond which the run is diverged (default
        :func:`default_divergence_bound`: 10 x the region's width, else 1e6).
    compiled : bool, optional
        Run the RK4 loop as compiled C (see :mod:`fl_design.sim._runners`); default False: for a
        single run CasADi's interpreter (about 2 us per sample) is faster than compiling.
    cache_dir : path-like, optional
        Cache of compiled kernels (with ``compiled=True``).

    Returns
    -------
    Response
        Trajectories (NaN after a divergence), metrics and classification.

    Raises
    ------
    ParameterError
        Bad numbers (negative duration, negative noise, unknown ``method``...).
    DimensionError
        A reference array, ``x0`` or bound of the wrong length.
    DesignMismatchError
        The plant's relative degree differs from the design's.

    Examples
    --------
    >>> import fl_design as fl
    >>> design = fl.Design(estimator=fl.EHGO(rho=2, eps=0.02, T=1e-3),
    ...                    controller=fl.DynamicController((2, 4), 1e-2))
    >>> resp = fl.simulate(fl.plants.pendulum(), design, 0.2, 20.0)
    >>> resp.stable, round(float(resp.y[-1]), 3)
    (True, 0.2)
    """
    if method not in ("rk4", "cvodes"):
        raise ParameterError(f"method must be 'rk4' or 'cvodes', got {method!r}")
    run = prepare_run(plant, design, reference, duration, x0=x0, noise_std=noise_std,
                      quantization=quantization, seed=seed, substeps=substeps,
                      tolerance=tolerance, tail_fraction=tail_fraction,
                      divergence_bound=divergence_bound)
    p = design.parameter_vector()
    if method == "rk4":
        runner = run.loop.runner(compiled=compiled, cache_dir=cache_dir)
        acc, out = runner.record(run.initial_accumulator(p)[:, 0], run.D)
        info = run.loop.layout.unpack(acc)
        k_div = int(info["k_div"][0]) if info["diverged"][0] else None
    else:
        out, k_div = _cvodes_loop(run, p)
    return _response(run, out, k_div, method)


def _response(run: RunSetup, out: np.ndarray, k_div: int | None, method: str) -> Response:
    rows = run.loop.record_layout.unpack(out)
    if k_div is not None:
        for value in rows.values():
            value[..., k_div:] = np.nan
    rho = run.loop.rho
    return Response(
        t=np.arange(run.N) * run.T, r=run.r.copy(), y=rows["y"], ym=rows["ym"], u=rows["u"],
        xhat=rows["xhat"][:rho].T.copy(), sigmahat=rows["xhat"][rho].copy(),
        sigma=rows["sigma"], coords=np.atleast_2d(rows["coords"]).reshape(rho, -1).T.copy(),
        x=np.atleast_2d(rows["x"]).reshape(run.loop.n, -1).T.copy(), T=run.T, tol=run.tol,
        k_tail=run.k_tail, y0=run.y0, step=run.step, divergence_index=k_div, method=method,
    )


def _cvodes_loop(run: RunSetup, p: np.ndarray) -> tuple[np.ndarray, int | None]:
    """The loop sample by sample with ``cvodes`` for the plant; same rules as the kernel."""
    loop = run.loop
    x, u = ca.SX.sym("x", loop.n), ca.SX.sym("u")
    integ = ca.integrator("fl_cvodes", "cvodes", {"x": x, "p": u,
                                                  "ode": loop.plant.casadi().f(x, u)},
                          0.0, run.T, {"abstol": 1e-12, "reltol": 1e-10,
                                       "max_num_steps": 20000,
                                       "disable_internal_warnings": True})
    xk, sk = run.x0.copy(), loop.design.initial_state()
    out = np.full((loop.record_layout.size, run.N), np.nan)
    x_op = loop.plant.x_op
    for k in range(run.N):
        s_next, uk, y, ym, xhat, sigma, coords = (
            np.asarray(v, dtype=float).ravel()
            for v in loop.control(xk, sk, run.r[k], run.noise[k], run.q, p))
        out[:, k] = np.concatenate([xk, y, ym, uk, xhat, sigma, coords])
        try:
            x_next = np.asarray(integ(x0=xk, p=uk)["xf"], dtype=float).ravel()
        except RuntimeError:  # cvodes gave up: finite escape or stiffness blow-up
            return out, k + 1
        with np.errstate(invalid="ignore"):
            ok = (np.all(np.abs(x_next - x_op) <= run.bound) and np.all(np.abs(s_next) < HUGE)
                  and abs(float(uk[0])) < HUGE)
        if not ok:
            return out, k + 1
        xk, sk = x_next, s_next
    return out, None


__all__ = ["RunSetup", "default_divergence_bound", "prepare_run", "simulate"]
