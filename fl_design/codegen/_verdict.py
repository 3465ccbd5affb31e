"""The verdict on a closed loop run by compiled C: a :class:`fl_design.sim.Response` of its samples.

The C driver of :func:`~fl_design.codegen.software_in_the_loop` records, per sample, the true
output, the measurement, the input and the plant state before and after the sample. This
module classifies that run with the simulation layer's own rules, through its public
functions: the divergence rule (``ClosedLoop.within_bounds``), the accumulator table
(:func:`fl_design.sim._simulate.metric_step`, the update the ``cvodes`` loop of
:func:`fl_design.simulate` replays too) replayed over the samples, and
:class:`fl_design.sim.Response` (metrics and status from the accumulators). The estimates
``xhat`` the accumulators need are those of ``Design.step`` fed the same measurements.

Examples
--------
>>> from fl_design.sim._simulate import metric_step
>>> metric_step(2).size1_in(2)  # the run constants y0, step, tol, k_tail, k_mid, noise
6
"""

from __future__ import annotations

import numpy as np

from ..sim import Response
from ..sim._metrics import ACCUMULATORS, metric_layout
from ..sim._simulate import metric_step, run_constants


def _first_out_of_bounds(run, X_next, S_next, u) -> int | None:
    loop, N = run.loop, u.size
    ok = loop.within_bounds.map(N)(X_next.T, S_next.T, u[None, :],
                                   np.tile(loop.plant.x_op[:, None], (1, N)),
                                   np.tile(np.asarray(run.bound, float)[:, None], (1, N)))
    bad = np.flatnonzero(np.asarray(ok, dtype=float).ravel() < 0.5)
    return int(bad[0]) if bad.size else None


def c_loop_response(run, y, ym, u, X, X_next, xhat, S_next) -> Response:
    """The :class:`~fl_design.sim.Response` of a closed loop whose inputs ``u`` came from C.

    Parameters
    ----------
    run : fl_design.sim.RunSetup
        The run (from :func:`fl_design.sim._run.prepare_run`): reference, constants, bounds.
    y, ym, u : numpy.ndarray
        ``(N,)`` true outputs, measurements and the C step's inputs.
    X, X_next : numpy.ndarray
        ``(N, n)`` plant states before and after each sample.
    xhat : numpy.ndarray
        ``(N, rho + 1)`` estimates of ``Design.step`` fed ``ym`` (for the estimation metrics).
    S_next : numpy.ndarray
        ``(N, state_size)`` design states of that reference run (for the divergence rule).

    Returns
    -------
    Response
        ``method="sil"``; samples from a divergence on are NaN.

    Examples
    --------
    >>> import numpy as np
    >>> import fl_design as fl
    >>> from fl_design.sim._run import prepare_run
    >>> from fl_design.codegen._verdict import c_loop_response
    >>> d = fl.presets.pendulum_design()
    >>> run = prepare_run(fl.plants.pendulum(), d, fl.Scenario(0.0, 0.01))
    >>> N, n = run.N, run.loop.n
    >>> X = np.tile(run.x0, (N, 1))
    >>> resp = c_loop_response(run, np.zeros(N), np.zeros(N), np.zeros(N), X, X,
    ...                        np.zeros((N, 3)), np.tile(run.s0, (N, 1)))
    >>> resp.method, resp.divergence_index
    ('sil', None)
    """
    loop, N, rho = run.loop, u.size, run.loop.rho
    k_div = _first_out_of_bounds(run, X_next, S_next, u)
    K = N if k_div is None else k_div  # samples whose metrics count (as the kernel does)
    coords = np.asarray(loop.coordinates.map(N)(X.T), dtype=float).reshape(rho, N).T
    sigma = np.asarray(loop.true_sigma.map(N)(X.T, u[None, :]), dtype=float).ravel()
    est_err = xhat - np.column_stack([coords, sigma])
    region = np.asarray(run.region, dtype=float)
    outside = np.any((X < region[0]) | (X > region[1]), axis=1).astype(float)
    u_prev = np.concatenate([[run.u0], u[:-1]])
    sig = np.column_stack([y - run.r, u, u_prev, np.arange(N), y, outside, est_err])[:K]
    lay = metric_layout(rho)
    from ..sim._metrics import initial_values

    m = lay.pack(**initial_values(rho))[:, 0]
    step_m = metric_step(rho, loop.design.controller.u_range)
    maps, chunk = {}, 20_000  # a mapaccum per chunk size, reused (building one costs most)
    for start in range(0, K, chunk):
        part = sig[start:start + chunk].T
        n = part.shape[1]
        if n not in maps:
            maps[n] = step_m.mapaccum("fl_sil_acc", n)
        c = np.tile([[run.y0], [run.step], [run.tol], [run.k_tail], [run.k_mid],
                     [run.noise_level]], (1, n))
        m = np.asarray(maps[n](m, part, c), dtype=float)[:, -1]
    acc = lay.unpack(m)
    keep = {a.name for a in ACCUMULATORS}
    summary = {k: (np.asarray(v, dtype=float).ravel() if k == "est2_sum"
                   else float(np.ravel(v)[0])) for k, v in acc.items() if k in keep}
    summary.update(diverged=float(k_div is not None),
                   k_div=float(k_div + 1) if k_div is not None else -1.0, solver_failed=0.0)
    summary.update(run_constants(run))  # as fl.simulate's summary: the same classification
    rows = {"y": y, "ym": ym, "u": u, "sigmahat": xhat[:, rho], "sigma": sigma}
    rows = {k: v.astype(float).copy() for k, v in rows.items()}
    arrays = {"xhat": xhat[:, :rho].copy(), "coords": coords, "x": X.copy()}
    div_index = None if k_div is None else k_div + 1
    if div_index is not None:
        for v in list(rows.values()) + list(arrays.values()):
            v[div_index:] = np.nan
    return Response(t=np.arange(N) * run.T, r=run.r.copy(), y=rows["y"], ym=rows["ym"],
                    u=rows["u"], xhat=arrays["xhat"], sigmahat=rows["sigmahat"],
                    sigma=rows["sigma"], coords=arrays["coords"], x=arrays["x"], T=run.T,
                    tol=run.tol, k_tail=run.k_tail, y0=run.y0, step=run.step,
                    divergence_index=div_index, method="sil", summary=summary,
                    duration_reason=run.duration_reason)


__all__ = ["c_loop_response"]
