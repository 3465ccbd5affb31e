"""Command-line interface: ``fl-design`` / ``python -m fl_design``.

Sub-commands
------------
``derive``
    Print the derivation report of a library plant: relative degree, ``a``, ``b``, the b-range
    over the plant's region, and the sampled-plant residual orders (plain text, ``--latex`` too).
``certify``
    Print the certificates of a design on a library plant (default: the paper's TRMS design,
    ``eps = 0.05``, ``gamma = 3e-4``): the Lyapunov conditions of the gains, the admissible
    gamma interval and the certified eps* of the linear surrogate over the plant's b range.
``demo``
    The main job on the built-in Twin Rotor (TRMS yaw) example: derive the plant, build the
    paper's EHGO + dynamic controller design, locate the linearized ``eps*``, simulate the
    0.3 rad step and compare against the least-squares baseline; writes a figure.
``codegen``
    Write the paper's design (or a least-squares baseline) as a C99 package: sources, header,
    SIL harness, Makefile and README (``fl.generate_c``); ``--precision float`` for true single
    precision.

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


def _cmd_certify(args: argparse.Namespace) -> int:
    from .. import certify_eps, certify_gamma, certify_lyapunov, presets

    plant = _library_plant(args.plant)
    if plant.relative_degree() != 2:
        from ..errors import DesignMismatchError

        raise DesignMismatchError(
            f"plant {args.plant!r} has relative degree {plant.relative_degree()}; the certify "
            "command certifies the paper's rho = 2 design: use --plant trms or pendulum"
        )
    design = presets.paper_design(eps=args.eps, gamma=args.gamma)
    b = plant.b_bounds()
    print(f"Plant: {plant.name}, b in [{b[0]:.6g}, {b[1]:.6g}], T = {design.T:g} s")
    print(certify_lyapunov(design.controller.gains, T=design.T))
    print(certify_gamma(design, b))
    print(certify_eps(design, b))
    return 0


def _cmd_demo(args: argparse.Namespace) -> int:
    from ._demo import run_demo

    return run_demo(quick=args.quick, out_dir=args.out, show_progress=not args.no_progress)


def _cmd_codegen(args: argparse.Namespace) -> int:
    from .. import presets
    from ..codegen import generate_c

    designs = {
        "ehgo": lambda: presets.paper_design(eps=args.eps, gamma=args.gamma),
        "ls9": lambda: presets.least_squares_design(9, gamma=args.gamma),
        "ls26": lambda: presets.least_squares_design(26, gamma=args.gamma),
    }
    pkg = generate_c(designs[args.design](), args.out, precision=args.precision,
                     prefix=args.prefix)
    print(f"wrote {len(pkg.files)} files ({pkg.precision}, prefix {pkg.prefix!r}) "
          f"to {pkg.out_dir}:")
    for path in pkg.files:
        print(f"  {path.name}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    """Return the argument parser of ``fl-design`` (``derive``, ``certify``, ``demo``, ``codegen``).

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
    cert = sub.add_parser("certify", help="certificates of the paper's design on a plant")
    cert.add_argument("--plant", choices=PLANT_CHOICES, default="trms")
    cert.add_argument("--eps", type=float, default=0.05, help="observer eps (default 0.05)")
    cert.add_argument("--gamma", type=float, default=3e-4, help="controller gamma (3e-4)")
    cert.set_defaults(func=_cmd_certify)
    demo = sub.add_parser("demo", help="the main job on the Twin Rotor (TRMS yaw) example")
    demo.add_argument("--quick", action="store_true", help="short runs (seconds, for tests)")
    demo.add_argument("--out", default="out", help="folder for figures and the JSON summary")
    demo.add_argument("--no-progress", action="store_true", help="no progress bars")
    demo.set_defaults(func=_cmd_demo)
    code = sub.add_parser("codegen", help="write the loop step as a C99 package")
    code.add_argument("out", help="output folder (created if needed)")
    code.add_argument("--precision", default="double", help="double (default) or float")
    code.add_argument("--prefix", default="fl", help="prefix of the C names (default fl)")
    code.add_argument("--design", choices=("ehgo", "ls9", "ls26"), default="ehgo",
                      help="the paper's EHGO design (default) or a least-squares baseline")
    code.add_argument("--eps", type=float, default=0.05, help="EHGO eps (default 0.05)")
    code.add_argument("--gamma", type=float, default=3e-4, help="controller gamma (default 3e-4)")
    code.set_defaults(func=_cmd_codegen)
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
