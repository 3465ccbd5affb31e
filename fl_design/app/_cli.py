"""Command-line interface: ``fl-design`` / ``python -m fl_design``.

Sub-commands
------------
``run [CONFIG.toml] [--out DIR] [--quick]``
    The main job: derive, certify, sweep, simulate the paper's comparison, generate and verify
    the C step, write ``report.html``, ``report.md``, the figures and ``summary.json``.
``derive``, ``certify``, ``simulate``, ``sweep``, ``codegen [CONFIG] [--out DIR]``
    Each stage alone, on the same configuration (default: the paper's TRMS design). Every
    subcommand takes the config as its positional argument, or ``--plant P`` (a library plant
    with its bench design, :func:`fl_design.presets.bench_design`).
``init [--plant P | --from-ode]``
    Write a commented configuration (every table and key) to stdout.
``ui [CONFIG.toml | --plant P | --class SPEC] [--port N] [--out DIR] [--open]``
    The tuner page on 127.0.0.1 (:mod:`fl_design.ui`); prints its URL (with its token).

Bad input (a config, an output folder, a scheduler address) is one line on stderr and exit 2,
checked before the work starts; a closed pipe (``| head``) too.

``run`` exits 3 (:data:`EXIT_PARTIAL`) when the report is written but partial: a worker of
the executor died mid-sweep, so some of the map's runs are lost (``undecided``, NaN metrics,
crossed in the figure; the finished ones exactly a complete run's). The report says so in its
first line, ``summary.json`` has ``"complete": false`` and the counts (``sweep`` prints the
partial map and exits 3 too). Not 0: a script or CI job that checks the exit code must not
take a partial map for a complete one (as a partial test bench log is not a pass); not 1 (a
failed check, e.g. the SIL test) or 2 (nothing computed, bad input): the report is there to
read, and a new run fills the lost points.

Examples
--------
>>> from fl_design.app import main
>>> main(["derive", "--plant", "pendulum"])  # doctest: +ELLIPSIS
Plant: pendulum...
0
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence

from .. import __version__
from ..errors import FlDesignError, ParameterError
from ._class_run import add_identify_parser
from ._class_table import is_class_config
from ._commands import (
    EXIT_PARTIAL,
    cmd_certify,
    cmd_codegen,
    cmd_derive,
    cmd_init,
    cmd_run,
    cmd_stage,
    cmd_sweep,
    config_of,
    prepare_config,
)
from ._config import LIBRARY, parse_config

#: ``--plant`` choices: the library plants of the config.
PLANT_CHOICES = tuple(LIBRARY)


def _run_guarded(args) -> int:
    """``args.func(args)`` with standard streams that cannot break it
    (:func:`fl_design._streams.guard_streams`: closed, full or ASCII-only); exit 2 with one
    line when the printed text was lost, the command's files written."""
    from .._streams import guard_streams

    saved = sys.stdout, sys.stderr
    out, _ = guard_streams()
    try:
        code = args.func(args)
        sys.stdout.flush()
        if out.failed is not None and code == 0:
            out.silence()
            print(f"fl-design: error: standard output could not be written ({out.failed}): "
                  "the printed text was lost; the command's files were written",
                  file=sys.stderr)
            return 2
        return code
    finally:  # a stream closed from the start stays the tolerant one (writes nowhere)
        sys.stdout = saved[0] if saved[0] is not None else sys.stdout
        sys.stderr = saved[1] if saved[1] is not None else sys.stderr


def _common(p, *, config=True, out=False, scheduler=False) -> None:
    if config:
        p.add_argument("config", nargs="?", default=None,
                       help="TOML configuration (default: the paper's TRMS experiment; "
                       "`fl-design init` writes one)")
        p.add_argument("--plant", choices=PLANT_CHOICES, default=None,
                       help="a library plant with its bench design instead of a config")
    p.add_argument("--quick", action="store_true", help="short runs, small grids (tests)")
    p.add_argument("--no-progress", action="store_true", help="no progress on stderr")
    if out:
        p.add_argument("--out", default="out", help="output folder (default out); must be "
                       "empty or hold fl_design's own earlier output")
        p.add_argument("--force", action="store_true",
                       help="write into --out even if it holds other files (may replace them)")
    if scheduler:
        p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                       help="run sweeps on a Dask cluster (e.g. tcp://host:8786)")


def build_parser() -> argparse.ArgumentParser:
    """Return the argument parser of ``fl-design``.

    Returns
    -------
    argparse.ArgumentParser

    Examples
    --------
    >>> from fl_design.app import build_parser
    >>> build_parser().parse_args(["run", "--quick"]).out
    'out'
    """
    parser = argparse.ArgumentParser(
        prog="fl-design", description="Model-free control of feedback-linearizable SISO plants "
        "(EHGO + dynamic controller): derive, certify, sweep, simulate, generate C, report.")
    parser.add_argument("--version", action="version", version=f"fl-design {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    run = sub.add_parser("run", help="the main job: every stage and the report",
                         epilog=f"exit status: 0 the report is complete; {EXIT_PARTIAL} the "
                         "report is written but PARTIAL (a worker died mid-sweep: the lost "
                         "runs are undecided, counted in the report and summary.json; run "
                         "again to fill them); 2 bad input or nothing written; 130 interrupted")
    _common(run, out=True, scheduler=True)
    run.add_argument("--main-csv", action="store_true",
                     help="also write the main run as CSV (runs/main_noise<std>.csv); the "
                     "compared runs are always written")
    run.add_argument("--full-csv", action="store_true",
                     help="every sample in the CSV files (default at most 10 000 rows each: "
                     "every k-th sample and the last)")
    run.add_argument("--verbose", action="store_true",
                     help="print every stage's detail (default: the summary, one screen)")
    run.add_argument("--static-report", action="store_true",
                     help="report.html with PNG figures only and no script (default: the main "
                     "figures interactive, Plotly.js inlined: about 5 MB, opens offline)")
    run.set_defaults(func=cmd_run)
    init = sub.add_parser("init", help="write a commented config (every table and key) to "
                          "stdout; `fl-design run` accepts it as is")
    init.add_argument("--plant", choices=PLANT_CHOICES, default=None,
                      help="a library plant with its bench design (default trms)")
    init.add_argument("--from-ode", action="store_true",
                      help="a plant written as expressions (states, rhs, output, params, "
                      "region, input range, operating point) to replace by yours")
    init.add_argument("--class", dest="class_", action="store_true", help="a [class] config: "
                      "what you know of a rig (rho, T, b range, noise, limits), no model")
    init.set_defaults(func=cmd_init)
    add_identify_parser(sub)  # `fl-design identify LOG.csv` (_class_run)
    derive = sub.add_parser("derive", help="relative degree, a, b, b-range, F^a, residuals")
    _common(derive)
    derive.add_argument("--latex", action="store_true", help="also print LaTeX")
    derive.set_defaults(func=cmd_derive)
    cert = sub.add_parser("certify", help="P_x, lambda_x, gamma interval, eps* certificates")
    _common(cert)
    cert.add_argument("--eps", type=float, default=None, help="override [design] eps")
    cert.add_argument("--gamma", type=float, default=None, help="override [design] gamma")
    cert.set_defaults(func=cmd_certify)
    simulate = sub.add_parser("simulate", help="the design and the least-squares baselines")
    _common(simulate)
    simulate.set_defaults(func=cmd_stage("simulate"))
    sweep = sub.add_parser("sweep", help="the empirical (eps, gamma) stability map; with "
                           "[uncertainty] params also the robust map",
                           epilog=f"exit status: 0 complete; {EXIT_PARTIAL} PARTIAL (a worker "
                           "died mid-sweep: the lost runs are undecided and counted); 2 bad "
                           "input; 130 interrupted")
    _common(sweep, scheduler=True)
    sweep.add_argument("--samples", type=int, default=None, metavar="N",
                       help="plants per grid point of the robust map (default [uncertainty] "
                       "map_samples; needs [uncertainty.params])")
    sweep.set_defaults(func=cmd_sweep)
    code = sub.add_parser("codegen", help="the loop step as a C99 package (SIL, cost)")
    code.add_argument("--out", default=None, help="output folder (default c; created if "
                      "needed); must be empty or hold fl_design's own earlier output")
    code.add_argument("--force", action="store_true",
                      help="write into the folder even if it holds other files (may replace them)")
    code.add_argument("--config", dest="config_alias", default=None,
                      help="deprecated: give the config as the positional argument")
    code.add_argument("--precision", default=None,
                      help="double, float ([codegen] precision) or q31 (FPU-less chips)")
    code.add_argument("--prefix", default=None, help="prefix of the C names ([codegen] prefix)")
    code.add_argument("--design", choices=("config", "ls9", "ls26"), default="config",
                      help="the configured design (default) or a least-squares baseline")
    code.add_argument("--verify", action="store_true",
                      help="also run software in the loop and measure the cost table")
    code.add_argument("--pil", action="store_true",
                      help="also run the step on a Cortex-M4F model (arm-none-eabi-gcc, QEMU)")
    _common(code)
    code.set_defaults(func=cmd_codegen)
    _ui_parser(sub)
    return parser


# --- `fl-design ui`: the tuner page (fl_design.ui; nothing else imports that package) ----------
def _ui_parser(sub) -> None:
    ui = sub.add_parser("ui", help="the tuner page on 127.0.0.1: sliders redraw the response, "
                        "the verdict, the map and the certificates")
    ui.add_argument("config", nargs="?", default=None, help="TOML configuration (a [plant] "
                    "model, or a [class] config as `fl-design init --class` writes)")
    ui.add_argument("--plant", choices=PLANT_CHOICES, default=None,
                    help="a library plant with its bench design instead of a config")
    ui.add_argument("--class", dest="plant_class", default=None, metavar="SPEC",
                    help="a plant class instead of a plant, e.g. rho=2,T=1e-3,b=1:50,"
                    "noise_std=1e-3 (keys rho, T, b, b_rate, noise_std, delay)")
    ui.add_argument("--port", type=int, default=0, help="TCP port (default: a free one)")
    ui.add_argument("--out", default="ui_out", help="where the page's buttons write (default "
                    "ui_out; must be empty or hold fl_design's own output)")
    ui.add_argument("--open", action="store_true", help="open the page in a browser")
    ui.add_argument("--no-background", action="store_true",
                    help="no stability map, certificates, margins or C cost")
    ui.set_defaults(func=_cmd_ui)


def ui_setup(cfg=None, *, plant_class=None):
    """The tuner's :class:`fl_design.ui.TunerSetup` of a config (checked as ``run`` checks it).

    Parameters
    ----------
    cfg : Config, optional
        Default: the paper's TRMS experiment (``load_config(None)``).
    plant_class : PlantClass, optional
        The class the page certifies (``--class``), its simulated member the config's plant.

    Returns
    -------
    fl_design.ui.TunerSetup

    Examples
    --------
    >>> from fl_design.app._cli import ui_setup
    >>> ui_setup().design.estimator.eps
    0.05
    """
    if cfg is None:
        from ._config import load_config

        cfg = load_config(None)
    from ..ui import TunerSetup
    from ._plant_table import LIBRARY
    from ._template import render

    cfg, job = prepare_config(cfg)
    return TunerSetup(config=cfg, plant=job.plant, design=job.design, render=render,
                      library=LIBRARY, plant_class=plant_class)


def _cmd_ui(args) -> int:
    from ..ui import serve
    from ..ui._class_mode import class_toml, parse_class_spec

    if args.plant_class is None and not args.plant and is_class_config(args.config):
        from ._class_table import load_class_config

        cc = load_class_config(args.config)  # a [class] config: as --class, its [tune] step
        cfg = parse_config(class_toml(cc.plant_class, reference=cc.tune.reference),
                           source=str(args.config))
        setup = ui_setup(cfg, plant_class=cc.plant_class)
    elif args.plant_class is None:
        setup = ui_setup(config_of(args))
    elif args.config is not None or args.plant:
        raise ParameterError("give a config, --plant or --class, not two of them")
    else:  # the class's simulated member and a starting design (fl_design.ui._class_mode)
        cls = parse_class_spec(args.plant_class)
        cfg = parse_config(class_toml(cls), source=f"--class {args.plant_class}")
        setup = ui_setup(cfg, plant_class=cls)
    return serve(setup, port=args.port, out=args.out, open_browser=args.open,
                 background=not args.no_background)


def _closed_pipe() -> int:
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    print("fl-design: error: the output pipe was closed", file=sys.stderr)
    return 2


def _tolerant_stdout() -> None:
    """A terminal that cannot print a character (a non-ASCII plant name on an ASCII stdout)
    gets a backslash escape instead of a UnicodeEncodeError after all the work."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.reconfigure(errors="backslashreplace")
        except (AttributeError, ValueError, OSError):  # a replaced or closed stream
            pass


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the process exit code (2 on a bad input).

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name (default ``sys.argv[1:]``).

    Returns
    -------
    int
        0 on success; 3 (:data:`EXIT_PARTIAL`) for ``run`` whose report is written but
        partial (a worker died mid-sweep: module doc); 2 on a bad input or a closed pipe (one
        line on stderr, no traceback); 130 on Ctrl-C.

    Examples
    --------
    >>> from fl_design.app import main
    >>> main(["derive", "--plant", "pendulum"])  # doctest: +ELLIPSIS
    Plant: pendulum...
    0
    """
    args = build_parser().parse_args(argv)
    _tolerant_stdout()
    try:
        code = _run_guarded(args)
        sys.stdout.flush()
        return code
    except FlDesignError as err:
        lines = str(err).splitlines() or [type(err).__name__]  # the whole message
        print("fl-design: error: " + "\n  ".join(lines), file=sys.stderr)
        return 2
    except BrokenPipeError:
        return _closed_pipe()
    except KeyboardInterrupt:
        print("fl-design: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
