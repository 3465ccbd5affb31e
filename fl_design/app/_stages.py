"""The main job's stages: each a function of the :class:`~fl_design.app._build.Setup` (the
config's objects, built once) and of earlier stages' results, returning its own results.

``derive(setup)``, ``certify(setup, derivation, quick)``, ``sweep(setup, quick, executor,
progress)``, ``simulate(setup, quick)``, ``codegen(setup, quick, out_dir, force)``; the family
stages are in :mod:`fl_design.app._stage_family`. :mod:`fl_design.app._job` runs them in order.

Examples
--------
>>> from fl_design.app import load_config
>>> from fl_design.app._build import build_setup
>>> from fl_design.app._stages import derive
>>> derive(build_setup(load_config(None)))["rho"]
2
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from ._build import Setup, design_name

STAGES = ("derive", "certify", "sweep", "simulate", "robustness", "codegen")
QUICK = {"duration": 4.0, "sweep_points": 5, "sweep_duration": 3.0, "certify_points": 3,
         "bench_steps": 20_000, "sil_duration": 1.0}
#: Seconds of the certify stage after which the curve's certified searches and the step
#: certificate's smaller regions are no longer started (the results name what was left).
CERTIFY_BUDGET_S = 120.0
#: ``[compare] duration = "adaptive"``: the compared runs last this many rise times (10-90 %)
#: of this design's run: the transient (overshoot, noise), not the slow final approach.
COMPARE_RISE_TIMES = 15.0
#: Most samples of one compared run (a run of a fast loop stays small on disk and in memory).
COMPARE_MAX_SAMPLES = 60_000


def derive(setup: Setup) -> dict:
    """Relative degree, ``a``, ``b``, b-range, zero dynamics, ``F^a`` and the text.

    Parameters
    ----------
    setup : Setup
        The config's objects.

    Returns
    -------
    dict
        JSON-ready: ``plant``, ``rho``, ``a``, ``b`` (SymPy text, LaTeX, MathML), ``b_bounds``,
        zero dynamics, ``F_a`` and its residual orders, ``text`` (the derivation in words).

    Examples
    --------
    >>> from fl_design.app import load_config
    >>> from fl_design.app._build import build_setup
    >>> from fl_design.app._stages import derive
    >>> [round(b, 9) for b in derive(build_setup(load_config(None)))["b_bounds"]]
    [3.6, 6.8]
    """
    import sympy as sp

    from ..symbolic import taylor_discretization
    from ._report import derivation_report

    plant = setup.plant
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


def certify(setup: Setup, derivation: dict, quick: bool, progress=None) -> dict:
    """Lyapunov, gamma and eps* certificates, margins, the nonlinear region, linearized eps*.

    The curve's certified searches and the step certificate's regions stop starting after
    :data:`CERTIFY_BUDGET_S` seconds of the stage (what was not searched is named in the
    results: never a hang on a plant whose LMIs are slow).

    Parameters
    ----------
    setup : Setup
        The config's objects.
    derivation : dict
        :func:`derive`'s results (its b-range).
    quick : bool
        Fewer gamma points; no nonlinear region search.
    progress : callable, optional
        ``progress(line)``: one line per step (what it does, seconds so far, conic programs
        solved, the curve's gains done and its time to go).

    Returns
    -------
    dict
        The certificates by name (``gamma``, ``eps``, ``curve``, ``margins``, ``nonlinear``,
        ``linearized``, ``box``), or ``skipped`` with the reason.

    Examples
    --------
    >>> from fl_design.app import load_config
    >>> from fl_design.app._build import build_setup
    >>> from fl_design.app._stages import certify, derive
    >>> s = build_setup(load_config(None))
    >>> e = certify(s, derive(s), True)["eps"]  # the TRMS's class: its friction slope box
    >>> e.covers, e.certified, e.eps_star_certified  # no quadratic certificate covers it
    ('nonlinear', False, None)
    """
    from ..analysis import (
        certify_eps,
        certify_gamma,
        certify_lyapunov,
        eps_star_curve,
        linearized_eps_star,
        loop_margins,
    )
    from ..analysis._lmi import solve_count, solve_progress

    cfg, design, plant = setup.config.certify, setup.design, setup.plant
    start, solves = time.perf_counter(), solve_count()

    def say(what: str) -> None:
        if progress is not None:
            progress(f"certify: {what} ({time.perf_counter() - start:.1f} s, "
                     f"{solve_count() - solves} conic programs solved)")

    def left() -> float:  # seconds of the stage's budget left
        return max(0.0, CERTIFY_BUDGET_S - (time.perf_counter() - start))

    b = derivation["b_bounds"]
    out = {"lyapunov": certify_lyapunov(design.controller.gains, T=design.T)}
    box = setup.config.uncertainty.box()
    if b is not None and box["ranges"]:
        # the family's uniform ranges: b (and the rest) enclosed over the whole box, so the
        # certificates cover every plant of [uncertainty] (normal ones have no box: named)
        from ..analysis import plant_bounds

        b = plant_bounds(plant, params=box["ranges"])
        out["box"] = {"params": {k: list(v) for k, v in box["ranges"].items()},
                      "not_covered": box["unbounded"], "b_bounds": list(b.b_bounds)}
    n = QUICK["certify_points"] if quick else cfg.points
    gammas = np.geomspace(*cfg.gamma, n)
    eps_range = tuple(cfg.eps_range or setup.config.sweep.eps)  # [certify] eps_range
    if b is not None and design.estimator.has_time_constant and cfg.enabled:
        # the certificates certify the plant's class (fl.PlantClass.from_plant: b, the slopes
        # of sigma and b's rate over its region, or over the [uncertainty] box given as a
        # PlantBounds), never the a = 0 chain of its b range
        bb = b if "box" in out else setup.plant
        say("the gamma interval")
        with solve_progress(lambda: say("the gamma interval, still solving")):
            out["gamma"] = certify_gamma(design, bb)
        say("the eps* brackets")
        with solve_progress(lambda: say("the eps* brackets, still solving")):
            out["eps"] = certify_eps(design, bb, eps_range=eps_range)
        say(f"the eps*(gamma) curve, {gammas.size} gains")
        curve_start = time.perf_counter()

        def gains_done(k, n):
            if 0 < k < n:
                eta = (time.perf_counter() - curve_start) / k * (n - k)
                say(f"the curve: {k}/{n} gains, about {eta:.0f} s to go")

        out["curve"] = eps_star_curve(design, bb, np.abs(gammas), eps_range=eps_range,
                                      time_budget=left(), progress=gains_done)  # |gamma|
        # margins at both ends of b, as plain numbers and text (cached without python-control)
        out["margins"] = [{**m.to_dict(), "text": m._repr_lines()[0]}
                          for m in (loop_margins(design, bb, statespace=False)
                                    for bb in out["eps"].b_bounds)]
        if not quick:
            say("the step certificate (regions about the target)")
        out["nonlinear"], out["nonlinear_summary"] = step_line(
            design, plant, setup.config.scenario, quick, time_budget=left(),
            progress=lambda k, n: say(f"the step certificate: region {k + 1}/{n}"))
    elif b is None:
        out["skipped"] = "the plant declares no region and input range: no b-range to certify"
    out["linearized"] = {"gamma": gammas, "eps_range": eps_range, "eps_star": [
        linearized_eps_star(plant, design, gamma=float(g), eps_range=eps_range)
        for g in gammas]}  # fl.EpsStar brackets: "> eps_max" / "< eps_min" outside the range
    out["linearized_design"] = linearized_eps_star(plant, design, eps_range=eps_range)
    say("done")
    return out


def step_line(design, plant, scenario, quick: bool, *, time_budget=None,
              progress=None) -> tuple[str, str]:
    """The step certificate's text and summary words (:func:`fl_design.certify_step`).

    The user's question on the nonlinear plant: is this step, from the plant's operating point
    with the observer and controller at rest, certified (bounded and converging), with the
    input limits and the estimate clamps inside the argument? Noise-free (sensor noise is
    covered only when bounded: ``fl.certify_step(..., noise_bound=...)``). Not computed in
    ``--quick`` (seconds of LMIs: the quick job is a first look); a constant reference only.

    Parameters
    ----------
    design : Design
    plant : Plant
    scenario : ScenarioTable
        The config's ``[scenario]`` (its reference).
    quick : bool
    time_budget : float, optional
        Seconds after which no smaller region is tried (:func:`fl_design.certify_step`).
    progress : callable, optional
        ``progress(done, total)`` before each region.

    Returns
    -------
    (str, str)
        The long text and the summary words (``certified ...``, ``not certified (...)``,
        ``not searched ...``).

    Examples
    --------
    >>> from fl_design.app._stages import step_line
    >>> step_line(None, None, None, True)[1]
    'not searched in --quick'
    """
    from ..analysis._step_cert import certify_step
    from ..errors import FlDesignError
    from ..sim import Scenario

    if quick:
        return (("this step: not certified in --quick (the step certificate solves LMIs for "
                 "seconds; the full job or fl.certify_step answers)"), "not searched in --quick")
    r = scenario.reference
    if callable(r) or not isinstance(r, (int, float)):
        return "this step: a constant reference only", "not certified (a varying reference)"
    try:
        c = certify_step(plant, design, Scenario(float(r)), time_budget=time_budget,
                         progress=progress)
    except FlDesignError as err:
        return f"this step: not analysed: {err}", "not certified (see Certificates)"
    text = "the step on the nonlinear plant: " + "; ".join(c._repr_lines())
    if c.certified:
        return text, f"certified the {c.step:.3g} step from rest (limits and clamp inside)"
    return text, (f"not certified (the {c.step:.3g} step; largest certified step "
                  f"{c.largest_step:.3g})")


def sweep(setup: Setup, quick: bool, executor=None, progress: bool = False):
    """The noise-free stability map over the ``[sweep]`` grid.

    A worker of ``executor`` that dies (or hangs) mid-sweep does not end the job: the
    :class:`~fl_design.errors.WorkerLostError`'s partial map is this stage's map (a
    :class:`~fl_design.sim._partial.PartialStabilityMap`: every finished run exactly as a
    complete sweep gives it, the lost ones ``undecided`` with NaN metrics, flagged in its
    ``lost`` mask). No later stage reads the map's points (certify, simulate and codegen run
    their own computations; eps* read from it treats a lost point as undecided, never as
    converging), and the report says how many runs were lost (:func:`fl_design.app._brief.
    lost_line`). The map is never cached. A lost worker with no partial map is re-raised.

    Returns
    -------
    fl_design.StabilityMap
        Or its partial subclass, ``n_lost`` > 0.

    Examples
    --------
    >>> from fl_design.app import load_config
    >>> from fl_design.app._build import build_setup
    >>> from fl_design.app._stages import sweep
    >>> sweep(build_setup(load_config(None)), True).status.shape
    (5, 5)
    """
    from ..errors import WorkerLostError
    from ..sim import sweep as run_sweep

    cfg = setup.config.sweep
    n = QUICK["sweep_points"] if quick else cfg.points
    duration = QUICK["sweep_duration"] if quick else cfg.duration
    eps, gamma = np.geomspace(*cfg.eps, n), np.geomspace(*cfg.gamma, n)
    try:
        return run_sweep(setup.plant, setup.design,
                         setup.run_scenario(duration=duration, noise_std=0.0), eps=eps,
                         gamma=gamma, classifier=setup.classifier, executor=executor,
                         progress=progress)
    except WorkerLostError as err:  # the finished runs are kept: the job goes on (above)
        if err.partial is None:
            raise
        return err.partial


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
    >>> from fl_design.app._stages import noise_levels
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


def compare_window(setup: Setup, main, quick: bool) -> tuple[float, str]:
    """Length of the compared runs and why: given, or from this design's own run.

    ``[compare] duration = "adaptive"``: :data:`COMPARE_RISE_TIMES` rise times of the main
    run (the transient: overshoot and noise), at least 1000 samples, at most the main run and
    :data:`COMPARE_MAX_SAMPLES` samples.

    Parameters
    ----------
    setup : Setup
        The config's objects.
    main : fl_design.Response
        This design's run.
    quick : bool
        The quick length.

    Returns
    -------
    (float, str)
        The run length in seconds and where it came from (in words).

    Examples
    --------
    >>> from fl_design.app import load_config
    >>> from fl_design.app._build import build_setup
    >>> from fl_design.app._stages import compare_window
    >>> s = build_setup(load_config(None))
    >>> compare_window(s, None, False)
    (30.0, 'given by [compare] duration')
    """
    given = setup.config.compare.duration
    if quick:
        return QUICK["duration"], "quick mode"
    T = setup.design.T
    hi = min(main.duration if main is not None else math.inf, COMPARE_MAX_SAMPLES * T)
    if given != "adaptive":
        if float(given) <= hi:
            return float(given), "given by [compare] duration"
        return hi, (f"[compare] duration {float(given):g} s capped at {hi:g} s "
                    f"({COMPARE_MAX_SAMPLES} samples or this design's run)")
    rise = main.rise_time
    if not math.isfinite(rise) or rise <= 0:
        return hi, "this design's run length (it has no 10-90 % rise time)"
    want = max(COMPARE_RISE_TIMES * rise, 1000 * T)
    d = min(want, hi)
    return d, (f"{COMPARE_RISE_TIMES:g} x this design's rise time {rise:.3g} s: the transient"
               + ("" if d == want else f", capped at {d:g} s"))


def simulate(setup: Setup, quick: bool) -> dict:
    """This design's run, the compared runs (every design x noise level) and the eps trade-off.

    Returns
    -------
    dict
        ``main``, ``runs`` ({(name, std): Response}), ``levels`` (their noise levels),
        ``stds``, ``designs``, ``duration``, ``duration_reason``, ``compare_duration``,
        ``compare_reason``, ``tradeoff``.

    Examples
    --------
    >>> from fl_design.app import load_config
    >>> from fl_design.app._build import build_setup
    >>> from fl_design.app._stages import simulate
    >>> sim = simulate(build_setup(load_config(None)), True)
    >>> len(sim["runs"]), sim["compare_duration"]
    (9, 4.0)
    """
    from ..sim import simulate as run

    cfg = setup.config
    seed = cfg.compare.seed

    def one(design, duration, std):
        return run(setup.plant, design, setup.run_scenario(duration=duration, noise_std=std,
                                                           seed=seed),
                   classifier=setup.classifier)

    main = one(setup.design, QUICK["duration"] if quick else cfg.scenario.duration,
               cfg.scenario.noise_std)
    window, why = compare_window(setup, main, quick)
    stds = [0.0] + [float(s) for s in cfg.compare.noise_std]
    runs = {(name, std): one(d, window, std) for std in stds
            for name, d in setup.compared.items()}
    tradeoff = []
    if setup.design.estimator.has_time_constant:
        std = stds[-1]
        for e in cfg.compare.eps_tradeoff:
            resp = one(setup.design.replace(eps=float(e)), window, std)
            tradeoff.append({"eps": float(e), "noise_std": std, **noise_levels(resp),
                             "status": resp.status, "overshoot_%": resp.overshoot})
    return {"main": main, "runs": runs, "levels": {k: noise_levels(r) for k, r in runs.items()},
            "stds": stds, "duration": main.duration, "compare_duration": float(window),
            "compare_reason": why, "duration_reason": main.duration_reason,
            "designs": list(setup.compared), "tradeoff": tradeoff}


def codegen(setup: Setup, quick: bool, out_dir, force: bool = False, package_dir=None) -> dict:
    """The C package of this design, its software-in-the-loop test and the cost table.

    Returns
    -------
    dict
        ``package``, ``sil``, ``costs``, ``sil_duration``, ``sil_noise_std``; or ``skipped``.

    Examples
    --------
    >>> from fl_design.app import parse_config
    >>> from fl_design.app._build import build_setup
    >>> from fl_design.app._stages import codegen
    >>> codegen(build_setup(parse_config("[codegen]\\nenabled = false")), True, ".")
    {'skipped': '[codegen] enabled = false'}
    """
    from ..codegen import compare_costs, generate_c
    from ..sim import Noise, Scenario

    cfg = setup.config.codegen
    if not cfg.enabled:
        return {"skipped": "[codegen] enabled = false"}
    out_dir = Path(out_dir)
    # the plant gives the package its plausibility range of y and the operating-point input
    # (the safe u, main.c's start)
    pkg_dir = out_dir / "c" if package_dir is None else Path(package_dir)
    pkg = generate_c(setup.design, pkg_dir, precision=cfg.precision, prefix=cfg.prefix,
                     force=force, plant=setup.plant)
    sil_t = QUICK["sil_duration"] if quick else cfg.sil_duration
    std = float(setup.config.compare.noise_std[0]) if setup.config.compare.noise_std else 0.0
    sc = setup.config.scenario
    sil = pkg.verify(setup.plant, Scenario(sc.reference, sil_t, noise=Noise(std, seed=1),
                                           disturbance=sc.disturbance))
    steps = QUICK["bench_steps"] if quick else 1_000_000
    # rows measured by an earlier run with the same generated files, compilers and machine
    # are reused (codegen/_cost.py cost_key); the table counts them
    costs = compare_costs(setup.compared, out_dir / "c_cost", precision=cfg.precision,
                          bench_steps=steps, cache=True)
    return {"package": pkg, "sil": sil, "costs": costs, "sil_duration": sil_t,
            "sil_noise_std": std}


__all__ = ["CERTIFY_BUDGET_S", "COMPARE_MAX_SAMPLES", "COMPARE_RISE_TIMES", "QUICK", "STAGES", "certify",
           "codegen", "compare_window", "derive", "design_name", "noise_levels",
           "simulate", "step_line", "sweep"]
