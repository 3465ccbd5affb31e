"""The sub-commands of ``fl-design`` (``run``, ``derive``, ``certify``, ``simulate``, ``sweep``,
``codegen``, ``init``): each a function of the parsed arguments returning the exit code.

:mod:`fl_design.app._cli` builds the parser, binds these to it and turns errors into one line
and exit 2; ``ui`` stays there (the only module that imports :mod:`fl_design.ui`). Every
command reads its configuration with :func:`config_of` and checks it with :func:`prepare_config`
before any work.

Examples
--------
>>> import argparse
>>> from fl_design.app._commands import cmd_derive
>>> cmd_derive(argparse.Namespace(config=None, plant="pendulum", latex=False))  # doctest: +ELLIPSIS
Plant: pendulum...
0
"""

from __future__ import annotations

import sys
import time
from dataclasses import replace
from pathlib import Path

from ..errors import ParameterError
from ._class_run import run_class
from ._class_table import CLASS_TOML, is_class_config
from ._config import load_config, parse_config
from ._outdir import check_out_dir

#: ``fl-design run``'s exit code for a written but partial report (runs lost to a dead worker).
EXIT_PARTIAL = 3


def _executor(address: str | None):
    if address is None:
        return None
    from ..sim._executor import connect_scheduler

    # connected and answering within a bounded time, else one clear line (no hang)
    return connect_scheduler(address).get_executor()


def config_of(args):
    """The config of any subcommand: a TOML file (positional) or ``--plant P``, not both."""
    path, plant = getattr(args, "config", None), getattr(args, "plant", None)
    if path is not None and plant:
        raise ParameterError(f"give a config file or --plant, not both (got {path!r} and "
                             f"--plant {plant})")
    if plant:
        return parse_config(f'[plant]\nlibrary = "{plant}"', source=f"--plant {plant}")
    return load_config(path)


def prepare_config(cfg):
    """Plant and design fit, reference inside the region: refuse before any work; warn.

    A plant from expressions without ``[design]`` gets a proposed design
    (:func:`fl_design.app._propose.propose_design`; the reasons go to stderr and the report).
    Returns the (possibly completed) config and its job.
    """
    # --- issue 31: the method's assumptions first, a design and a step derived from the plant,
    # ranges that hold the design (fl_design.symbolic._assumptions, app._template.fit_ranges)
    from ..symbolic._assumptions import check_assumptions
    from ._build import build_plant, check_fit
    from ._job import prepare
    from ._template import fit_ranges

    plant = build_plant(cfg)
    check_assumptions(plant, what="fl-design")
    if cfg.design is None:
        from ._propose import propose_design

        print("fl-design: no [design] given: proposing one from the plant ...",
              file=sys.stderr, flush=True)
        cfg = propose_design(cfg, plant)
    cfg, widened = fit_ranges(cfg)
    for line in widened:
        print(f"fl-design: {line}", file=sys.stderr)
    # --- end issue 31
    job = prepare(cfg)
    for line in check_fit(cfg, job.plant):
        print(f"fl-design: warning: {line}" if not line.startswith("[design] proposed")
              else f"fl-design: {line}", file=sys.stderr)
    return cfg, job


def cmd_run(args) -> int:
    from ._console import print_job
    from ._job import note, run_job
    from ._report_csv import BackgroundCsv
    from ._report_figures import FiguresAhead
    from ._report_write import write_report

    if is_class_config(args.config):  # a [class] config: the model-free route (_class_run)
        return run_class(args, args.config)
    cfg, _ = prepare_config(config_of(args))  # plant and design fit: fail before any work
    out = check_out_dir(args.out, force=args.force)
    executor = _executor(args.scheduler)
    csv = BackgroundCsv(out, main=args.main_csv, full=args.full_csv)
    ahead = FiguresAhead(out)  # while the certify stage still runs: the simulate figures

    def after(stage, job):
        csv.after(stage, job)
        ahead.after(stage, job)

    try:
        job = run_job(cfg, quick=args.quick, out_dir=out, executor=executor,
                      progress=not args.no_progress, force=args.force, after=after)
    except Exception:
        csv.wait()  # a later stage failed: no half-written CSV file left behind
        raise
    start = time.perf_counter()
    written = csv.result()
    waited = time.perf_counter() - start
    start = time.perf_counter()
    paths = write_report(job, out, force=args.force, main_csv=args.main_csv,
                         csv_written=written, full_csv=args.full_csv,
                         interactive=not args.static_report, figures_ahead=ahead)
    during = (f" (CPU {csv.cpu:.1f} s, also counted in the stages running beside it; from the "
              f"end of simulate, {waited:.1f} s of it after the C stage)"
              if written is not None else "")
    note(f"report (figures, HTML, Markdown, JSON) written in "
         f"{time.perf_counter() - start:.1f} s (figures {job.timings['report_figures']:.1f} s"
         + (f", {ahead.seconds:.1f} s of it while certify ran" if ahead.drawn else "") + "); "
         f"{len(paths['csv'])} runs as CSV in {job.timings.get('report_csv', 0.0):.1f} s{during}",
         enabled=not args.no_progress)
    try:  # the report is written: a terminal that fails now loses only the console copy
        print_job(job, verbose=args.verbose)
        runs = f", {len(paths['csv'])} runs as CSV under {out / 'runs'}" if paths["csv"] else ""
        print(f"\nwrote {paths['html']}, {paths['markdown']}, {paths['summary']}, "
              f"{len(paths['figures'])} figures{runs}")
        if paths["failed_figures"]:
            print("figures not drawn (named in the report): "
                  + "; ".join(f"{k}: {v}" for k, v in paths["failed_figures"].items()))
        if not args.verbose:
            print("(--verbose: every stage's detail)")
        for line in job.lost.values():  # the last line too: a partial report is not complete
            print(f"PARTIAL REPORT (exit {EXIT_PARTIAL}): {line}")
        sys.stdout.flush()
    except BrokenPipeError:
        raise
    except (OSError, ValueError) as err:  # stdout full or closed
        print(f"fl-design: error: the report is written ({paths['html']}) but stdout "
              f"failed: {getattr(err, 'strerror', None) or err}", file=sys.stderr)
        return 2
    return EXIT_PARTIAL if job.lost else 0


def cmd_derive(args) -> int:
    from ._build import build_plant
    from ._report import derivation_report

    print(derivation_report(build_plant(config_of(args)), latex=args.latex))
    return 0


def cmd_certify(args) -> int:
    from ._console import print_certificates
    from ._job import run_job

    cfg, _ = prepare_config(config_of(args))
    if args.eps is not None or args.gamma is not None:
        d = replace(cfg.design, eps=cfg.design.eps if args.eps is None else args.eps,
                    gamma=cfg.design.gamma if args.gamma is None else args.gamma)
        cfg = replace(cfg, design=d)
    job = run_job(cfg, quick=args.quick, stages=("certify",), progress=not args.no_progress)
    print_certificates(job)
    return 0


def cmd_stage(stage: str):
    def command(args) -> int:
        from . import _console
        from ._job import run_job

        cfg, _ = prepare_config(config_of(args))
        out = check_out_dir(args.out, force=getattr(args, "force", False)) \
            if getattr(args, "out", None) else Path(".")
        executor = _executor(getattr(args, "scheduler", None))
        job = run_job(cfg, quick=args.quick, stages=(stage,), out_dir=out, executor=executor,
                      progress=not args.no_progress)
        getattr(_console, f"print_{stage}")(job)
        return 0
    return command


def cmd_sweep(args) -> int:
    """The stability map; with ``[uncertainty] params`` also the robust map (``--samples N``
    plants per point, default ``[uncertainty] map_samples``)."""
    from ._console import print_sweep
    from ._job import run_job
    from ._report_family import print_robust_map
    from ._stage_family import robust_map
    from ._uncertainty import MAX_SAMPLES

    cfg, _ = prepare_config(config_of(args))
    if args.samples is not None:
        if not cfg.uncertainty.params:
            raise ParameterError(f"--samples {args.samples} needs a family of plants: give "
                                 "[uncertainty.params] in the config (e.g. c = [0.05, 1.0])")
        if not 1 <= args.samples <= MAX_SAMPLES:
            raise ParameterError(f"--samples must be in 1 .. {MAX_SAMPLES}, got {args.samples}")
    executor = _executor(args.scheduler)
    progress = not args.no_progress
    job = run_job(cfg, quick=args.quick, stages=("sweep",), executor=executor,
                  progress=progress)
    print_sweep(job)
    out = robust_map(job.setup, args.quick, executor, progress, samples=args.samples)
    if "robust_map_seconds" in out:
        job.timings["robust_map"] = out.pop("robust_map_seconds")
    job.results.update(out)
    if "robust_map" in job.results:
        print()
        print_robust_map(job)
    elif "robust_map_skipped" in job.results:
        print(f"\n{job.results['robust_map_skipped']}")
    from ._brief import lost_line

    line = lost_line(job.results.get("robust_map"), "robust map")
    if line:
        job.lost["robust_map"] = line
    for line in job.lost.values():  # as `run`: a partial map is not a complete one
        print(f"PARTIAL (exit {EXIT_PARTIAL}): {line}")
    return EXIT_PARTIAL if job.lost else 0


def cmd_codegen(args) -> int:
    from ..codegen import generate_c
    from ._build import build_design
    from ._job import run_job

    _codegen_paths(args)
    cfg, job = prepare_config(config_of(args))
    precision = args.precision or cfg.codegen.precision
    if precision not in ("double", "float", "q31"):
        raise ParameterError(f"precision must be one of 'double', 'float', 'q31' (q31: "
                             f"fl-design codegen only), got {precision!r}")
    if precision == "q31" and args.verify:
        raise ParameterError("--verify: a precision='q31' package has no closed-loop SIL (its "
                             "make check replays vectors bit-exact with the integer model); "
                             "use --pil (the Cortex-M3 and M0+ models) or the package's make "
                             "check-m3 / check-m0plus")
    cg = replace(cfg.codegen, prefix=args.prefix or cfg.codegen.prefix,
                 **({} if precision == "q31" else {"precision": precision}))
    cfg = replace(cfg, codegen=cg)
    out = check_out_dir(args.out, force=args.force)
    if args.verify:
        from ._console import print_codegen

        # the package in --out itself, as without --verify (make -C OUT check); the cost
        # table's packages beside it in OUT/c_cost
        job = run_job(cfg, quick=args.quick, stages=("codegen",), out_dir=out,
                      progress=not args.no_progress, force=args.force, package_dir=out)
        print_codegen(job)
        cg = job.results["codegen"]
        if "sil" in cg and not cg["sil"].passed:  # a failed SIL is a failed command
            print(f"fl-design: the software-in-the-loop check failed: "
                  f"{_sil_reason(cg['sil'], cg.get('sil_noise_std'))}", file=sys.stderr)
            return 1
        return 0
    design = job.design if args.design == "config" else build_design(
        cfg, window=int(args.design[2:]), rho=job.plant.relative_degree())
    # the plant: the range check's limits from its region (and the Q31 word lengths)
    pkg = generate_c(design, out, precision=precision, prefix=cg.prefix, plant=job.plant,
                     force=args.force)
    print(f"wrote {len(pkg.files)} files ({pkg.precision}, prefix {pkg.prefix!r}) to "
          f"{pkg.out_dir}:")
    for path in pkg.files:
        print(f"  {path.relative_to(pkg.out_dir)}")
    return _pil(pkg, job, cfg) if args.pil else 0


def _sil_reason(sil, noise_std=None) -> str:
    """One line: why a SIL result did not pass.

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.codegen import SilResult
    >>> r = SilResult("double", np.zeros(2), np.array([1.0, 1.0]), np.array([1.0, 3.0]), 1e-12,
    ...               "diverged", "diverged", False, True)
    >>> _sil_reason(r, 1e-3)[:74]
    "the loop is 'diverged' under noise std 0.001 in C as in Python: the design"
    """
    if sil.c_failed and sil.verdicts_agree:  # the design fails the scenario, not the C
        under = f" under noise std {noise_std:g}" if noise_std else ""
        return (f"the loop is {sil.c_status!r}{under} in C as in Python: the design fails "
                f"the SIL scenario, not the C (C vs Design.step {sil.max_rel_error:.3g}: the "
                "C's fault handling departs from Design.step once the loop has failed)")
    why = []
    if not sil.matches:
        why.append(f"C vs Design.step {sil.max_rel_error:.3g} > bound {sil.bound:g}")
    if not sil.verdicts_agree:
        why.append(f"C loop {sil.c_status!r}, simulation {sil.sim_status!r}")
    if sil.c_failed:
        why.append(f"the C loop is {sil.c_status!r}")
    return "; ".join(why) or "see the result"


def _codegen_paths(args) -> None:
    """``codegen [CONFIG] --out DIR``; the older ``codegen DIR [--config C]`` still works."""
    if args.config_alias is not None:  # --config C: deprecated alias of the positional
        print("fl-design: note: codegen --config is deprecated: give the config as the "
              "positional argument and the folder as --out", file=sys.stderr)
        if args.config is not None and args.out is None:
            args.out = args.config
        elif args.config is not None:
            raise ParameterError(f"give the config once (positional {args.config!r} or "
                                 f"--config {args.config_alias!r})")
        args.config = args.config_alias
    elif args.config is not None and args.out is None and \
            not str(args.config).lower().endswith(".toml"):
        args.out, args.config = args.config, None  # `codegen DIR`: the older form
    if args.out is None:
        args.out = "c"


def cmd_init(args) -> int:
    from ._template import config_toml

    if args.from_ode and args.plant:
        raise ParameterError("give --plant P or --from-ode, not both")
    if args.class_:  # what a rig owner knows, no model (_class_table)
        sys.stdout.write(CLASS_TOML)
        return 0
    sys.stdout.write(config_toml(args.plant or "trms", from_ode=args.from_ode))
    return 0


def _pil(pkg, job, cfg) -> int:
    from ..codegen._pil import pil_tools
    from ..sim import Scenario

    reason = pil_tools()[2]
    if reason:
        print(f"error: --pil: {reason}", file=sys.stderr)
        return 2
    if pkg.precision == "q31":
        return _pil_q31(pkg, job, cfg)
    res = pkg.pil(job.plant, Scenario(cfg.scenario.reference, 2000 * pkg.design.T))
    print(f"PIL on a Cortex-M4F (QEMU mps2-an386): {res.instructions:.0f} instructions per step; "
          f"u within {res.max_rel_error:.3g} of max|u| of Design.step over {res.u_c.size} "
          f"samples (bound {res.bound:g}): {'passed' if res.passed else 'FAILED'}")
    return 0 if res.passed else 1


def _pil_q31(pkg, job, cfg) -> int:
    """``--pil`` of a Q31 package: its step on the Cortex-M3 and ARMv6-M models, bit-exact with
    the host build on a recorded closed-loop run."""
    from ..codegen._pil_q31 import q31_pil
    from ..sim import Scenario

    res = q31_pil(pkg, job.plant, Scenario(cfg.scenario.reference, 1000 * pkg.design.T))
    for cpu, (n, diff) in res.items():
        print(f"PIL on a {cpu} model (QEMU): {n:.0f} instructions per step; u "
              f"{'bit-exact with' if diff == 0.0 else 'DIFFERS from'} the host build")
    ok = all(diff == 0.0 for _, diff in res.values())
    print(f"Q31 error against Design.step (predicted): {pkg.predicted_float_error:.3g} of max|u|")
    return 0 if ok else 1


__all__ = ["EXIT_PARTIAL", "cmd_certify", "cmd_codegen", "cmd_derive", "cmd_init", "cmd_run",
           "cmd_stage", "cmd_sweep", "config_of", "prepare_config"]
