"""``simulate``: one closed-loop run of a plant and a design, with noise and quantization.

The plant is integrated inside the sampled loop (:class:`fl_design.sim.ClosedLoop`):
fixed-step RK4 with ``substeps`` steps per sample and the input held (zero-order hold), the
measurement ``y_k + w_k`` (:class:`~fl_design.Noise`) quantized to multiples of
``quantization``. With ``integrator=fl.Cvodes()`` the same loop is integrated by CasADi's
adaptive ``cvodes`` (BDF, tight tolerances) sample by sample: the reference against which the
fixed-step integrator is checked (tests). Metrics come from the accumulators of
:mod:`fl_design.sim._metrics` in both cases.

Examples
--------
>>> import fl_design as fl
>>> design = fl.presets.pendulum_design()
>>> sc = fl.Scenario(0.1, 20.0, noise=fl.Noise(std=1e-4))
>>> resp = fl.simulate(fl.plants.pendulum(), design, sc)
>>> resp.status, bool(abs(resp.y[-1] - 0.1) < 1e-3)
('converged', True)
"""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from .._limits import check_memory
from ._metrics import ACCUMULATORS, initial_values, metric_layout, signals, update
from ._options import RK4, Classifier, Cvodes, Kernel, Scenario, option
from ._response import Response
from ._run import RunSetup, prepare_run

if TYPE_CHECKING:  # annotations only (no import at run time)
    from ..design import Design
    from ..symbolic import Plant

#: Growth of the state within the failing sample beyond which a cvodes failure is an escape.
ESCAPE_GROWTH = 10.0


def simulate(plant: Plant, design: Design, scenario: Scenario, *,
             integrator: RK4 | Cvodes | None = None,
             classifier: Classifier | None = None, kernel: Kernel | None = None,
             allow_unmodeled: bool = False) -> Response:
    """Simulate the sampled closed loop of ``plant`` and ``design`` under ``scenario``.

    Parameters
    ----------
    plant : Plant
        The plant; its relative degree must equal ``design.rho``.
    design : Design
        Estimator + dynamic controller (its sampling time ``T`` is the loop's).
    scenario : Scenario
        Reference, duration, initial state, noise and quantization. Without a duration the
        run chooses its length from the loop's slowest time constant
        (:attr:`Response.duration_reason` says what and why).
    integrator : RK4 or Cvodes, optional
        Fixed-step RK4 in the kernel (default ``fl.RK4()``, substeps from the plant's fastest
        mode), or CasADi's adaptive ``cvodes`` sample by sample (slow; a reference).
    classifier : Classifier, optional
        Tolerance, tail window and divergence bound (default ``fl.Classifier()``).
    kernel : Kernel, optional
        Compiled C or CasADi's interpreter (default ``fl.Kernel()``: the step compiled once
        and cached, 8-15x faster than the interpreter from the second run on; without a
        working compiler, the interpreter with a ``CompilationWarning``; same results).
    allow_unmodeled : bool, optional
        Run a design of lower relative degree than the plant's on purpose (unmodeled
        dynamics: an :class:`~fl_design.errors.UnmodeledDynamicsWarning`, and the design's
        "true" ``sigma`` is ``L_f^rho h``); default False (a ``DesignMismatchError``).

    Returns
    -------
    Response
        Trajectories (NaN after a divergence), metrics and classification.

    Raises
    ------
    ParameterError
        An option object of the wrong type, a duration shorter than one sample, a ``gamma``
        whose sign differs from ``b``'s.
    DimensionError
        A reference array, ``x0``, ``initial_estimate`` or bound of the wrong length.
    DesignMismatchError
        The plant's relative degree differs from the design's (see ``allow_unmodeled``).

    Warns
    -----
    NonMinimumPhaseWarning
        The plant's zero dynamics are not asymptotically stable at the operating point (e.g.
        ``fl.plants.cart_pendulum(inverted=True)``): the run goes ahead (it shows the internal
        states leaving the region, ``Response.region_exit_time``), but the method does not apply
        and an output that settles proves nothing.

    Examples
    --------
    >>> import fl_design as fl
    >>> design = fl.presets.pendulum_design()
    >>> resp = fl.simulate(fl.plants.pendulum(), design, fl.Scenario(0.2, 20.0))
    >>> resp.stable, round(float(resp.y[-1]), 3)
    (True, 0.2)
    """
    integrator = option("integrator", integrator, (RK4, Cvodes), default=RK4,
                        what="fl.RK4(...) or fl.Cvodes(...)")
    kernel = option("kernel", kernel, Kernel)
    rk4 = integrator if isinstance(integrator, RK4) else RK4(substeps=1)
    run = prepare_run(plant, design, scenario, integrator=rk4, classifier=classifier,
                      allow_unmodeled=allow_unmodeled)
    check_memory(8.0 * run.N * (run.loop.record_layout.size + 4),
                  f"recording a run of {run.N:.3g} samples",
                  "shorten the run (Scenario duration) or sample slower (a larger T)")
    p = design.parameter_vector()
    if isinstance(integrator, RK4):
        runner = run.loop.runner(kernel=kernel)
        acc, out = runner.record(run.initial_accumulator(p)[:, 0], run.D)
        summary = {k: np.asarray(v).copy() for k, v in run.loop.layout.unpack(acc).items()}
        summary["solver_failed"] = 0.0
        method = "rk4"
    else:
        out, summary = _cvodes_loop(run, p, integrator)
        method = "cvodes"
    return _response(run, out, summary, method)


def _summary_fields(run: RunSetup, summary: dict) -> dict:
    keep = {a.name for a in ACCUMULATORS} | {"diverged", "k_div", "solver_failed"}
    out = {k: (np.asarray(v, dtype=float).ravel() if k == "est2_sum" else float(np.ravel(v)[0]))
           for k, v in summary.items() if k in keep}
    out.update(run_constants(run))
    return out


def run_constants(run: RunSetup) -> dict:
    """The constants a run's summary holds beside its accumulators: ``run.constants()`` and
    ``loop_tau_samples`` (a run whose analysed half is shorter than the designed loop's time
    constant cannot show a stall: :func:`fl_design.sim._status.classify` says undecided).

    Every classification of a run's accumulators uses them: :func:`fl_design.simulate`'s and
    the SIL's verdict on the C loop (:func:`fl_design.codegen._verdict.c_loop_response`).

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim._run import prepare_run
    >>> from fl_design.sim._simulate import run_constants
    >>> run = prepare_run(fl.plants.pendulum(), fl.presets.pendulum_design(), fl.Scenario(0.1, 1.0))
    >>> sorted(run_constants(run))[:3]
    ['N', 'k_dist', 'k_mid']
    """
    out = dict(run.constants())
    out["loop_tau_samples"] = run.loop.design.controller.time_constant / run.T
    return out


def _response(run: RunSetup, out: np.ndarray, summary: dict, method: str) -> Response:
    rows = run.loop.record_layout.unpack(out)
    k_div = int(np.ravel(summary["k_div"])[0]) if np.ravel(summary["diverged"])[0] else None
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
        summary=_summary_fields(run, summary), duration_reason=run.duration_reason,
        disturbance_start=run.disturbance_start,
    )


def metric_step(rho: int, u_range=None) -> ca.Function:
    """``fl_metrics(m, sig, c) -> m_next``: one update of a run's accumulator table, to replay
    a run sample by sample (the ``cvodes`` loop, the C step's closed loop of
    :mod:`fl_design.codegen`) by the kernel's rules.

    ``sig = [e, u, u_prev, k, y, outside, est_err (rho + 1)]``, ``c = [y0, step, tol, k_tail,
    k_mid, noise]`` (the signals of :func:`fl_design.sim._metrics.signals`).

    Parameters
    ----------
    rho : int
        Relative degree.
    u_range : (float, float) or None, optional
        The controller's input saturation (``Design.controller.u_range``): ``u`` at either
        end counts as saturated.

    Returns
    -------
    casadi.Function
        Built once per ``(rho, u_range)`` in a process.

    Examples
    --------
    >>> from fl_design.sim._simulate import metric_step
    >>> f = metric_step(2)
    >>> f.name(), f.size1_in(1), f.size1_in(2)
    ('fl_metrics', 9, 6)
    """
    return _metric_step(int(rho), None if u_range is None else tuple(map(float, u_range)))


@functools.lru_cache(maxsize=16)
def _metric_step(rho: int, u_range: tuple | None) -> ca.Function:
    lay = metric_layout(rho)
    m = ca.SX.sym("m", lay.size)
    sig = ca.SX.sym("sig", 6 + rho + 1)  # e, u, u_prev, k, y, outside, est_err
    c = ca.SX.sym("c", 6)  # y0, step, tol, k_tail, k_mid, noise
    acc = {name: m[sl] for name, sl in lay.slices.items()}
    s = signals(e=sig[0], u=sig[1], u_prev=sig[2], k=sig[3], y=sig[4], outside=sig[5],
                est_err=sig[6:], y0=c[0], step=c[1], tol=c[2], k_tail=c[3], k_mid=c[4],
                noise=c[5], u_range=u_range)
    new = update(acc, s)
    return ca.Function("fl_metrics", [m, sig, c], [ca.vertcat(*[new[n] for n, _ in lay.fields])])


def _cvodes_loop(run: RunSetup, p: np.ndarray, opts: Cvodes) -> tuple[np.ndarray, dict]:
    """The loop sample by sample with ``cvodes`` for the plant; same rules as the kernel.

    A sample on which ``cvodes`` gives up is retried in 64 pieces: if the state grew by more
    than :data:`ESCAPE_GROWTH` times its distance from the operating point (plus one) before the
    failing piece, the run is a finite escape (``diverged``); otherwise the solver failed on a
    bounded state (``solver_failed``, not a verdict on the loop).
    """
    loop = run.loop
    integ = functools.partial(_integrator, loop, opts)
    xk, sk, u_prev = run.x0.copy(), run.s0.copy(), run.u0
    out = np.full((loop.record_layout.size, run.N), np.nan)
    lay = metric_layout(loop.rho)
    m = lay.pack(**initial_values(loop.rho))[:, 0]
    c = [run.y0, run.step, run.tol, run.k_tail, run.k_mid, run.noise_level]
    step_m = metric_step(loop.rho, loop.design.controller.u_range)
    status = {"diverged": 0.0, "k_div": -1.0, "solver_failed": 0.0}
    for k in range(run.N):
        s_next, uk, y, ym, xhat, sigma, coords = (
            np.asarray(v, dtype=float).ravel()
            for v in loop.control(xk, sk, run.r[k], run.noise[k], run.q, p))
        out[:, k] = np.concatenate([xk, y, ym, uk, xhat, sigma, coords])
        u_plant = uk + run.d_in[k]  # the input disturbance acts at the plant
        try:
            x_next = np.asarray(integ(run.T)(x0=xk, p=u_plant)["xf"], dtype=float).ravel()
        except RuntimeError:
            escaped = _escaped(loop, opts, xk, u_plant, run)
            status.update(diverged=float(escaped), solver_failed=float(not escaped),
                          k_div=float(k + 1) if escaped else -1.0)
            break
        ok = float(loop.within_bounds(x_next, s_next, uk, loop.plant.x_op, run.bound))
        if not ok:
            status.update(diverged=1.0, k_div=float(k + 1))
            break
        est_err = xhat - np.concatenate([coords, sigma])
        outside = float(np.any((xk < run.region[0]) | (xk > run.region[1])))
        sig = np.concatenate([[y[0] - run.r[k], uk[0], u_prev, k, y[0], outside], est_err])
        m = np.asarray(step_m(m, sig, c), dtype=float).ravel()
        xk, sk, u_prev = x_next, s_next, uk[0]
    summary = lay.unpack(m)
    summary.update(status)
    return out, summary


@functools.lru_cache(maxsize=64)
def _integrator_cached(loop, reltol, abstol, max_steps, h):
    x, u = ca.SX.sym("x", loop.n), ca.SX.sym("u")
    return ca.integrator("fl_cvodes", "cvodes", {"x": x, "p": u,
                                                 "ode": loop.plant.casadi().f(x, u)},
                         0.0, h, {"abstol": abstol, "reltol": reltol,
                                  "max_num_steps": max_steps,
                                  "disable_internal_warnings": True})


def _integrator(loop, opts: Cvodes, h: float):
    return _integrator_cached(loop, float(opts.reltol), float(opts.abstol),
                              int(opts.max_num_steps), float(h))


def _escaped(loop, opts: Cvodes, xk: np.ndarray, uk, run: RunSetup) -> bool:
    """Whether the state grows without bound within the sample on which cvodes failed."""
    pieces = 64
    piece = _integrator(loop, opts, run.T / pieces)
    x, x_op = xk.copy(), loop.plant.x_op
    start = float(np.max(np.abs(xk - x_op)))
    for _ in range(pieces):
        try:
            x = np.asarray(piece(x0=x, p=uk)["xf"], dtype=float).ravel()
        except RuntimeError:
            break
        if not np.all(np.isfinite(x)) or np.any(np.abs(x - x_op) > run.bound):
            return True
    return float(np.max(np.abs(x - x_op))) > ESCAPE_GROWTH * (start + 1.0)


__all__ = ["metric_step", "run_constants", "simulate"]
