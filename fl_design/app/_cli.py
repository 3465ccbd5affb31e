"""Command-line interface: ``fl-design`` / ``python -m fl_design``.

Sub-commands
------------
``derive``
    Print the derivation report of a library plant: relative degree, ``a``, ``b``, the b-range
    over the plant's region, and the sampled-plant residual orders (plain text, ``--latex`` too).
``demo``
    The main job on the built-in Twin Rotor (TRMS yaw) example: derive the plant, build the
    paper's EHGO + dynamic controller design, locate the linearized ``eps*``, simulate the
    0.3 rad step and compare against the least-squares baseline; writes a figure.

Examples
--------
>>> from fl_design.app import main
>>> main(["derive", "--plant", "pendulum"])  # doctest: +ELLIPSIS
Plant: pendulum...
0
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from ..errors import FlDesignError

PLANT_CHOICES = ("trms", "trms-lag", "pendulum", "flexible-joint")


def _library_plant(key: str):
    from .. import plants

    factories = {
        "trms": lambda: plants.trms_yaw(),
        "trms-lag": lambda: plants.trms_yaw(motor_lag=True),
        "pendulum": plants.pendulum,
        "flexible-joint": plants.flexible_joint,
    }
    return factories[key]()


def _cmd_derive(args: argparse.Namespace) -> int:
    from ._report import derivation_report

    print(derivation_report(_library_plant(args.plant), latex=args.latex))
    return 0


def _cmd_demo(args: argparse.Namespace) -> int:
    from ._demo import run_demo

    return run_demo(quick=args.quick, out_dir=args.out, show_progress=not args.no_progress)


def build_parser() -> argparse.ArgumentParser:
    """Return the argument parser of ``fl-design`` (sub-commands ``derive`` and ``demo``).

    Returns
    -------
    argparse.ArgumentParser

    Examples
    --------
    >>> from fl_design.app import build_parser
    >>> build_parser().parse_args(["derive", "--plant", "pendulum"]).plant
    'pendulum'
    """
    parser = argparse.ArgumentParser(
        prog="fl-design",
        description="Model-free control of feedback-linearizable SISO plants (EHGO + dynamic controller).",
    )
    sub = parser.add_subparsers(dest="command", required=True)
    derive = sub.add_parser("derive", help="print the derivation report of a library plant")
    derive.add_argument("--plant", choices=PLANT_CHOICES, default="trms")
    derive.add_argument("--latex", action="store_true", help="also print LaTeX")
    derive.set_defaults(func=_cmd_derive)
    demo = sub.add_parser("demo", help="the main job on the Twin Rotor (TRMS yaw) example")
    demo.add_argument("--quick", action="store_true", help="short runs (seconds, for tests)")
    demo.add_argument("--out", default="out", help="folder for figures and the JSON summary")
    demo.add_argument("--no-progress", action="store_true", help="no progress bars")
    demo.set_defaults(func=_cmd_demo)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the process exit code (2 on a bad input).

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name (default ``sys.argv[1:]``).

    Returns
    -------
    int
        0 on success, 2 on a bad input (the message on stderr, no traceback).

    Examples
    --------
    >>> from fl_design.app import main
    >>> main(["derive", "--plant", "pendulum"])  # doctest: +ELLIPSIS
    Plant: pendulum...
    0
    """
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except FlDesignError as err:
        print(f"fl-design: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
