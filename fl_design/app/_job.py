"""The main job (``fl-design run``): derive, certify, sweep, simulate, generate C, in order.

:func:`run_job` computes; :mod:`fl_design.app._report_write` writes. Progress goes to stderr,
one line per step (and the sweep's bar), never into the tables on stdout.

Examples
--------
>>> from fl_design.app import load_config, run_job
>>> job = run_job(load_config(None), quick=True, stages=("derive",), progress=False)
>>> job.derivation["rho"], job.timings["derive"] >= 0
(2, True)
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ._build import build_classifier, build_design, build_plant, build_scenario
from ._config import Config
from ._uncertainty import run_stage as run_robustness

STAGES = ("derive", "certify", "sweep", "simulate", "robustness", "codegen")
QUICK = {"duration": 4.0, "sweep_points": 5, "sweep_duration": 3.0, "certify_points": 3,
         "bench_steps": 20_000, "sil_duration": 1.0}


@dataclass
class Job:
    """Everything the main job computed (filled stage by stage).

    Parameters
    ----------
    config : Config
        The validated configuration.
    quick : bool
        Short runs (tests).
    plant : fl_design.Plant
        The plant (set by :func:`prepare`).
    design : fl_design.Design
        The design (set by :func:`prepare`).
    derivation : dict
        Relative degree, ``a``, ``b``, b-range, zero dynamics, ``F^a``, residual orders.
    results : dict
        Stage name -> its results (certificates, StabilityMap, Responses, C package).
    timings : dict
        Stage name -> seconds.
    cached : set
        The stages whose results were read from the private cache (derive, certify:
        :mod:`fl_design.app._stage_cache`).

    Examples
    --------
    >>> from fl_design.app import Job, load_config
    >>> Job(load_config(None), quick=True).results
    {}
    """

    config: Config
    quick: bool = False
    plant: object = None
    design: object = None
    derivation: dict = field(default_factory=dict)
    results: dict = field(default_factory=dict)
    timings: dict = field(default_factory=dict)
    cached: set = field(default_factory=set)


def note(message: str, *, enabled: bool = True) -> None:
    """Write one progress line to stderr (never to stdout, where the tables go).

    Parameters
    ----------
    message : str
        The line.
    enabled : bool, optional
        False: say nothing.

    Examples
    --------
    >>> from fl_design.app._job import note
    >>> note("sweeping", enabled=False)
    """
    if enabled:
        print(f"[fl-design] {message}", file=sys.stderr, flush=True)


def _derive(job: Job) -> None:
    from ._stage_cache import cached_stage

    job.derivation, hit = cached_stage(job, "derive", False, lambda: _derive_fresh(job))
    if hit:
        job.cached.add("derive")


def _derive_fresh(job: Job) -> dict:
    import sympy as sp

    from ..symbolic import taylor_discretization
    from ._report import derivation_report

    plant = job.plant
    nf = plant.normal_form()
    disc = taylor_discretization(nf.rho, order=nf.rho + 1)
    has_b = plant.region is not None and plant.input_range is not None
    return {
        "plant": plant.name, "rho": nf.rho, "n": plant.n, "a": sp.sstr(nf.a), "b": sp.sstr(nf.b),
        "b_bounds": list(plant.b_bounds()) if has_b else None,
        "zero_dynamics_eigenvalues": [str(complex(z)) for z in nf.zero_dynamics_eigenvalues]
        if plant.n > nf.rho else [],
        "minimum_phase": bool(nf.minimum_phase) if plant.n > nf.rho else True,
        "F_a": sp.sstr(disc.approx), "residual_orders": disc.residual_order_table(),
        "a_latex": sp.latex(nf.a), "b_latex": sp.latex(nf.b),
        "a_mathml": sp.mathml(nf.a, printer="presentation"),
        "b_mathml": sp.mathml(nf.b, printer="presentation"),
        "x_op": [float(v) for v in plant.x_op], "u_eq": float(plant.u_eq),
        "states": [str(s) for s in plant.states],
        "text": derivation_report(plant),
    }


def _certify(job: Job, quick: bool) -> None:
    from ._stage_cache import cached_stage

    job.results["certify"], hit = cached_stage(job, "certify", quick,
                                               lambda: _certify_fresh(job, quick))
    if hit:
        job.cached.add("certify")


def _certify_fresh(job: Job, quick: bool) -> dict:
    from ..analysis import (
        certify_eps,
        certify_gamma,
        certify_lyapunov,
        eps_star_curve,
        linearized_eps_star,
        loop_margins,
    )

    cfg, design, plant = job.config.certify, job.design, job.plant
    b = job.derivation["b_bounds"]
    out = {"lyapunov": certify_lyapunov(design.controller.gains, T=design.T)}
    box = job.config.uncertainty.box()
    if b is not None and box["ranges"]:
        # the family's uniform ranges: b (and the rest) enclosed over the whole box, so the
        # certificates cover every plant of [uncertainty] (normal ones have no box: named)
        from ..analysis import plant_bounds

        b = plant_bounds(plant, params=box["ranges"])
        out["box"] = {"params": {k: list(v) for k, v in box["ranges"].items()},
                      "not_covered": box["unbounded"], "b_bounds": list(b.b_bounds)}
    n = QUICK["certify_points"] if quick else cfg.points
    gammas = np.geomspace(*cfg.gamma, n)
    eps_range = tuple(cfg.eps_range or job.config.sweep.eps)  # [certify] eps_range
    if b is not None and design.estimator.has_time_constant and cfg.enabled:
        # [classcert] the certificates certify the plant's class (fl.PlantClass.from_plant:
        # b, the slopes of sigma and b's rate over its region, or over the [uncertainty] box
        # given as a PlantBounds), never the a = 0 chain of its b range
        bb = b if "box" in out else plant
        out["gamma"] = certify_gamma(design, bb)
        out["eps"] = certify_eps(design, bb, eps_range=eps_range)
        out["curve"] = eps_star_curve(design, bb, np.abs(gammas), eps_range=eps_range)  # |gamma|
        # margins at both ends of b, as plain numbers and text (cached without python-control)
        out["margins"] = [{**m.to_dict(), "text": m._repr_lines()[0]}
                          for m in (loop_margins(design, bb) for bb in out["eps"].b_bounds)]
        out["nonlinear"], out["nonlinear_summary"] = _nonlinear(design, plant, box["ranges"],
                                                                quick)
    elif b is None:
        out["skipped"] = "the plant declares no region and input range: no b-range to certify"
    out["linearized"] = {"gamma": gammas, "eps_range": eps_range, "eps_star": [
        linearized_eps_star(plant, design, gamma=float(g), eps_range=eps_range)
        for g in gammas]}  # fl.EpsStar brackets: "> eps_max" / "< eps_min" outside the range
    out["linearized_design"] = linearized_eps_star(plant, design, eps_range=eps_range)
    return out


def _nonlinear(design, plant, ranges, quick: bool) -> tuple[str, str]:
    """The nonlinear certificate's line and summary words (``analysis.nonlinear_region``).

    Not searched in ``--quick``: the region search solves tens of LMIs and the quick job is for
    tests and a first look (target 5 s); the full job searches it once (3 bisection steps of
    the scale: 17.8 s on the TRMS on a 2-core machine, against 41.7 s for 5 steps under
    cProfile and 50 s on a loaded machine; the 5-step region is at most a few times wider)
    and the stage cache keeps it. ``nonlinear_region`` itself searches finer (12 steps).
    """
    from ..analysis import nonlinear_region
    from ..errors import ParameterError

    if quick:
        return (("nonlinear: not searched in --quick (the region search takes tens of seconds; "
                 "the full job or `fl-design certify` without --quick searches it)"),
                "not searched in --quick")
    try:
        region = nonlinear_region(design, plant, params=ranges or None, steps=3)
    except ParameterError as err:
        return f"nonlinear: not certified: {err}", "not certified (see Certificates)"
    return region.words(), region.summary()


def _sweep(job: Job, quick: bool, executor, progress: bool) -> None:
    from ..sim import sweep

    cfg = job.config.sweep
    n = QUICK["sweep_points"] if quick else cfg.points
    duration = QUICK["sweep_duration"] if quick else cfg.duration
    eps, gamma = np.geomspace(*cfg.eps, n), np.geomspace(*cfg.gamma, n)
    smap = sweep(job.plant, job.design, build_scenario(job.config, duration=duration,
                                                       noise_std=0.0),
                 eps=eps, gamma=gamma, classifier=build_classifier(job.config),
                 executor=executor, progress=progress)
    job.results["sweep"] = smap


def _simulate_one(job: Job, design, duration: float, std: float):
    from ..sim import simulate

    scenario = build_scenario(job.config, duration=duration, noise_std=std,
                              seed=job.config.compare.seed)
    return simulate(job.plant, design, scenario, classifier=build_classifier(job.config))


def _simulate(job: Job, quick: bool) -> None:
    cfg = job.config
    # the main run's length (default adaptive: long enough for its verdict); the compared runs
    # are about the transient (overshoot, noise) and share one fixed length
    duration = QUICK["duration"] if quick else cfg.scenario.duration
    compare = QUICK["duration"] if quick else cfg.compare.duration
    rho = job.plant.relative_degree()
    designs = {_label(job.design): job.design}
    if job.design.estimator.has_time_constant:
        designs |= {f"LS({w})": build_design(cfg, window=int(w), rho=rho)
                    for w in cfg.compare.windows}
    stds = [0.0] + [float(s) for s in cfg.compare.noise_std]
    runs = {(name, std): _simulate_one(job, d, compare, std)
            for std in stds for name, d in designs.items()}
    main = _simulate_one(job, job.design, duration, cfg.scenario.noise_std)
    tradeoff = []
    if job.design.estimator.has_time_constant:
        std = stds[-1]
        for e in cfg.compare.eps_tradeoff:
            resp = _simulate_one(job, job.design.replace(eps=float(e)), compare, std)
            tradeoff.append({"eps": float(e), "noise_std": std, **noise_levels(resp),
                             "status": resp.status, "overshoot_%": resp.overshoot})
    job.results["simulate"] = {"main": main, "runs": runs, "stds": stds,
                               "duration": main.duration,
                               "compare_duration": float(next(iter(runs.values())).duration),
                               "duration_reason": main.duration_reason,
                               "designs": list(designs), "tradeoff": tradeoff}


def noise_levels(resp) -> dict:
    """High-frequency noise of ``sigmahat`` and ``u`` over a run's tail.

    The level is ``std(diff(x)) / sqrt(2)`` on the tail window: the sample-to-sample jitter,
    which a slow limit cycle or the transient does not inflate.

    Parameters
    ----------
    resp : fl_design.Response
        A run.

    Returns
    -------
    dict
        ``sigmahat_noise`` and ``u_noise`` (NaN for a diverged run).

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.app._job import noise_levels
    >>> r = fl.simulate(fl.plants.pendulum(), fl.presets.pendulum_design(), fl.Scenario(0.1, 1.0))
    >>> noise_levels(r)["u_noise"] < 1e-3
    True
    """
    k = resp.k_tail
    out = {}
    for name, x in (("sigmahat_noise", resp.sigmahat), ("u_noise", resp.u)):
        d = np.diff(np.asarray(x[k:], dtype=float))
        out[name] = float(np.std(d) / math.sqrt(2)) if np.all(np.isfinite(d)) else math.nan
    return out


def _codegen(job: Job, quick: bool, out_dir: Path, force: bool = False) -> None:
    from ..codegen import compare_costs, generate_c
    from ..sim import Noise, Scenario

    cfg = job.config.codegen
    if not cfg.enabled:
        job.results["codegen"] = {"skipped": "[codegen] enabled = false"}
        return
    pkg = generate_c(job.design, out_dir / "c", precision=cfg.precision, prefix=cfg.prefix,
                     force=force)
    sil_t = QUICK["sil_duration"] if quick else cfg.sil_duration
    std = float(job.config.compare.noise_std[0]) if job.config.compare.noise_std else 0.0
    sil = pkg.verify(job.plant, Scenario(job.config.scenario.reference, sil_t,
                                         noise=Noise(std, seed=1),
                                         disturbance=job.config.scenario.disturbance))
    rho = job.plant.relative_degree()
    designs = {_label(job.design): job.design}
    if job.design.estimator.has_time_constant:
        designs |= {f"LS({w})": build_design(job.config, window=int(w), rho=rho)
                    for w in job.config.compare.windows}
    steps = QUICK["bench_steps"] if quick else 1_000_000
    # rows measured by an earlier run with the same generated files, compilers and machine
    # are reused (codegen/_cost.py cost_key); the table counts them
    costs = compare_costs(designs, out_dir / "c_cost", precision=cfg.precision,
                          bench_steps=steps, cache=True)
    job.results["codegen"] = {"package": pkg, "sil": sil, "costs": costs,
                              "sil_duration": sil_t, "sil_noise_std": std}


def _label(design) -> str:
    est = design.estimator
    if est.has_time_constant:
        return f"EHGO eps={est.eps:g}"
    return f"LS({est.window})"


def prepare(config: Config) -> Job:
    """Build the plant and design of ``config`` and check they fit (cheap; before any work).

    Parameters
    ----------
    config : Config
        A validated configuration.

    Returns
    -------
    Job
        With ``plant`` and ``design`` set.

    Raises
    ------
    DesignMismatchError
        The design's relative degree (its number of gains) differs from the plant's.

    Examples
    --------
    >>> from fl_design.app import load_config
    >>> from fl_design.app._job import prepare
    >>> prepare(load_config(None)).design.controller.gamma
    0.0003
    """
    from ..errors import DesignMismatchError

    plant = build_plant(config)
    rho = plant.relative_degree()
    if len(config.design.gains) != rho:
        raise DesignMismatchError(
            f"[design] gains has {len(config.design.gains)} entries but the plant "
            f"{plant.name!r} has relative degree {rho}: give {rho} gains (and "
            f"{rho + 1} coeffs)")
    return Job(config, plant=plant, design=build_design(config, rho=rho))


def run_job(config: Config, *, quick: bool = False, out_dir: str | Path = "out",
            stages=STAGES, executor=None, progress: bool = True, force: bool = False,
            after=None) -> Job:
    """Run the main job's stages (derive, certify, sweep, simulate, robustness, codegen).

    ``robustness`` (:func:`fl_design.monte_carlo` over the ``[uncertainty]`` family) runs only
    when the config gives ``[uncertainty] params``.

    Parameters
    ----------
    config : Config
        A validated configuration (:func:`load_config`).
    quick : bool, optional
        Short runs and small grids (seconds; for tests).
    out_dir : str or pathlib.Path, optional
        Where the C package goes (``out_dir/c``).
    stages : sequence of str, optional
        A subset of :data:`STAGES`, run in the canonical order.
    executor : concurrent.futures.Executor, optional
        Runs the sweep's chunks (e.g. a Dask cluster's ``client.get_executor()``).
    progress : bool, optional
        Progress lines and the sweep's bar on stderr.
    force : bool, optional
        Write the C package into ``out_dir/c`` even if it holds files fl_design did not write.
    after : callable, optional
        Called as ``after(stage, job)`` when each stage is done (``fl-design run`` starts
        writing the runs' CSV files after ``simulate``, while the C compilers run).

    Returns
    -------
    Job

    Examples
    --------
    >>> from fl_design.app import load_config, run_job
    >>> job = run_job(load_config(None), quick=True, stages=("derive",), progress=False)
    >>> [round(b, 9) for b in job.derivation["b_bounds"]]
    [3.6, 6.8]
    """
    job = prepare(config)
    job.quick = quick
    steps = {"derive": lambda: _derive(job), "certify": lambda: _certify(job, quick),
             "sweep": lambda: _sweep(job, quick, executor, progress),
             "simulate": lambda: _simulate(job, quick),
             "robustness": lambda: run_robustness(job, quick, executor, progress),
             "codegen": lambda: _codegen(job, quick, Path(out_dir), force)}
    todo = [s for s in STAGES if s in stages or (s == "derive" and "certify" in stages)]
    if not config.uncertainty.params:  # robustness only with [uncertainty] params
        todo = [s for s in todo if s != "robustness"]
    for i, stage in enumerate(todo, 1):
        note(f"{i}/{len(todo)} {stage} ...", enabled=progress)
        start, cpu = time.perf_counter(), time.process_time()
        steps[stage]()
        job.timings[stage] = time.perf_counter() - start
        # this process's CPU time beside the wall time: on a loaded machine they differ
        how = " from the cache" if stage in job.cached else ""
        note(f"{i}/{len(todo)} {stage} done in {job.timings[stage]:.1f} s (CPU "
             f"{time.process_time() - cpu:.1f} s{how})", enabled=progress)
        if after is not None:
            after(stage, job)
    return job


__all__ = ["QUICK", "STAGES", "Job", "noise_levels", "note", "prepare", "run_job"]
