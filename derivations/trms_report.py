"""Derive and print the TRMS yaw plant's normal form: relative degree, a, b and the range of b.

For the static-motor model (``fl.plants.trms_yaw()``) and the motor-lag model
(``fl.plants.trms_yaw(motor_lag=True)``) prints the states, the relative degree ``rho``, the
lumped term ``sigma = y^(rho)``, its split ``a + b u`` (``b = d sigma/du``, ``a = sigma - b u``;
for the static motor the input enters through ``tau |tau|`` with ``tau = k2 u / T20``, so ``a``
and ``b`` depend on ``u``), ``b`` with the numeric parameter values and ``[b_min, b_max]`` over
the plant's region and input range, in plain text and in LaTeX. Everything is computed by
:class:`fl_design.Plant` (Lie derivatives in SymPy, bounds by :meth:`fl_design.Plant.b_bounds`).

Usage (from the repository root)::

    python derivations/trms_report.py                          # both variants, text + LaTeX
    python derivations/trms_report.py --variant motor_lag --format latex
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

import sympy as sp

import fl_design as fl
from fl_design.errors import ParameterError

FORMATS = ("text", "latex", "both")
VARIANTS = {"static": False, "motor_lag": True}


def _rule(title: str) -> str:
    return "\n".join(["=" * 78, title, "=" * 78])


def _numeric(plant, expr: sp.Expr) -> sp.Expr:
    return sp.nsimplify(expr.subs(plant.params), rational=False).evalf(6)


def _text_block(plant, nf, bounds) -> str:
    lines = [
        f"states: {', '.join(map(str, plant.states))}; input: {plant.input}; output: {plant.output}",
        f"input range: {plant.input_range}; region: "
        + ", ".join(f"{s} in [{lo:.4g}, {hi:.4g}]" for s, (lo, hi) in (plant.region or {}).items()),
        f"relative degree rho = {nf.rho} (n = {nf.n}); input enters "
        + ("affinely" if nf.affine else "non-affinely (a and b depend on u)"),
        f"sigma = y^({nf.rho}) = {nf.sigma}",
        f"a = sigma - b*u    = {nf.a}",
        f"b = d sigma/du     = {nf.b}",
        f"b (numeric)        = {_numeric(plant, nf.b)}",
        f"b range on the region: [b_min, b_max] = [{bounds[0]:.6g}, {bounds[1]:.6g}]",
        nf.zero_dynamics_report(),
    ]
    return "\n".join(lines)


def _latex_block(plant, nf, bounds) -> str:
    names = {s: rf"\dot{{\{s.name[:-4]}}}" for s in plant.states if s.name.endswith("_dot")}

    def tex(expr):
        return sp.latex(expr, symbol_names=names)

    rows = [
        rf"\rho &= {nf.rho}",
        rf"\sigma = y^{{({nf.rho})}} &= {tex(nf.sigma)}",
        rf"a &= {tex(nf.a)}",
        (rf"b = \frac{{\partial \sigma}}{{\partial u}} &= {tex(nf.b)}"
         rf" = {tex(_numeric(plant, nf.b))}"),
        rf"b &\in [{bounds[0]:.6g},\ {bounds[1]:.6g}]",
    ]
    return "\\begin{align*}\n" + " \\\\\n".join(rows) + "\n\\end{align*}"


def report(*, variants: Sequence[str] = ("static", "motor_lag"), fmt: str = "both") -> str:
    """The report as one string.

    Parameters
    ----------
    variants : sequence of str, optional
        Any of ``"static"`` (``trms_yaw()``) and ``"motor_lag"`` (``trms_yaw(motor_lag=True)``).
    fmt : {"text", "latex", "both"}, optional
        Output format.

    Returns
    -------
    str

    Examples
    --------
    >>> import runpy
    >>> mod = runpy.run_path("derivations/trms_report.py")  # doctest: +SKIP
    >>> "b_max" in mod["report"](variants=["static"], fmt="text")  # doctest: +SKIP
    True
    """
    if fmt not in FORMATS:
        raise ParameterError(f"fmt must be one of {FORMATS}, got {fmt!r}")
    unknown = [v for v in variants if v not in VARIANTS]
    if unknown or not variants:
        raise ParameterError(f"variants must be a non-empty subset of {list(VARIANTS)}, got {variants!r}")
    blocks = []
    for v in variants:
        plant = fl.plants.trms_yaw(motor_lag=VARIANTS[v])
        nf, bounds = plant.normal_form(), plant.b_bounds()
        blocks.append(_rule(f"TRMS yaw, {v.replace('_', ' ')} model ({plant.name})"))
        if fmt in ("text", "both"):
            blocks.append(_text_block(plant, nf, bounds))
        if fmt in ("latex", "both"):
            blocks.append("LaTeX:\n" + _latex_block(plant, nf, bounds))
    return "\n".join(blocks) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point; prints :func:`report` and returns the exit status.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        0 on success, 2 on bad arguments.
    """
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--variant", choices=[*VARIANTS, "both"], default="both")
    parser.add_argument("--format", choices=FORMATS, default="both", dest="fmt")
    args = parser.parse_args(argv)
    variants = list(VARIANTS) if args.variant == "both" else [args.variant]
    sys.stdout.write(report(variants=variants, fmt=args.fmt))
    return 0


if __name__ == "__main__":
    sys.exit(main())
