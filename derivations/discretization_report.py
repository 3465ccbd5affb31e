"""Derive and print the sampled plant under zero-order hold for relative degrees 2, 3, 4.

For each ``rho`` prints the exact Taylor series ``F^e`` of the normal-form chain on the extended
state ``(x1, ..., x_rho, sigma)`` (``sigma`` evolves: ``sigma_dot``, ``sigma_ddot``, ... are its
time derivatives), the paper's approximate extended model ``F^a`` (also with ``T = alpha eps``)
and the order of the residual ``F^e - F^a`` per component, in plain text and in LaTeX. Everything
is computed by :func:`fl_design.taylor_discretization`.

Usage (from the repository root)::

    python derivations/discretization_report.py                 # rho = 2, 3, 4, text + LaTeX
    python derivations/discretization_report.py --rho 2 --format latex --order 4
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

import sympy as sp

import fl_design as fl
from fl_design._validate import integer
from fl_design.errors import ParameterError

FORMATS = ("text", "latex", "both")


def _rule(title: str) -> str:
    return "\n".join(["=" * 78, title, "=" * 78])


def _text_block(d) -> str:
    names = [f"{s}(k+1)" for s in d.extended_states]
    width = max(len(n) for n in names)
    lines = [(f"F^e: exact ZOH Taylor series of the extended chain to order "
              f"{d.extended_order} in T (input held, sigma evolves):")]
    lines += [f"  {n.ljust(width)} = {e}" for n, e in zip(names, d.extended_exact)]
    lines.append(f"  Lagrange remainder of x(k+1) at order N = {d.order} "
                 "(*_mid: state at an intermediate time):")
    lines += [f"  R[{s}] = {r}" for s, r in zip(d.states, d.remainder)]
    lines.append("F^a: approximate extended model (sigma held constant), xbar(k+1) = F^a xbar(k):")
    lines += ["  " + row for row in sp.pretty(d.approx, use_unicode=False).splitlines()]
    lines.append("  with T = alpha*epsilon:")
    lines += ["  " + row for row in sp.pretty(d.approx_in_eps(), use_unicode=False).splitlines()]
    lines.append("Residual F^e - F^a per component (computed lowest power with non-zero "
                 "coefficient):")
    lines += ["  " + row for row in d.residual_order_table().splitlines()]
    return "\n".join(lines)


def _latex_block(d) -> str:
    def tex(expr):
        return d.latex(expr)

    rows = [rf"{tex(s)}(k+1) &= {tex(e)}" for s, e in zip(d.extended_states, d.extended_exact)]
    fa = sp.latex(d.approx_in_eps(), mat_str="bmatrix", mat_delim="")
    in_eps = {d.T: d.alpha * d.eps}
    res = [rf"{tex(s)}:\ & {tex(lead.subs(in_eps))} + \dots = O(\epsilon^{{{p}}})"
           for s, lead, p in zip(d.extended_states, d.residual_leading_terms, d.residual_orders)]
    return "\n".join([
        "% F^e: exact Taylor series of the extended chain (zero-order hold)",
        r"\begin{aligned}", " \\\\\n".join(rows), r"\end{aligned}",
        "% F^a: approximate extended model, T = alpha epsilon",
        rf"\bar{{x}}(k+1) = {fa}\,\bar{{x}}(k)",
        "% residual F^e - F^a: leading term and order in epsilon",
        r"\begin{aligned}", " \\\\\n".join(res), r"\end{aligned}",
    ])


def report(rho_values: Sequence[int] = (2, 3, 4), *, fmt: str = "both",
           order: int | None = None) -> str:
    """Return the derivation for each relative degree as text, LaTeX or both.

    Parameters
    ----------
    rho_values : sequence of int
        Relative degrees to derive (each ``>= 1``).
    fmt : {"text", "latex", "both"}
        Output format.
    order : int, optional
        Truncation order of the exact series; default ``rho + 1`` (shows every leading
        residual term).

    Examples
    --------
    >>> print(report((2,), fmt="text").splitlines()[1])
    rho = 2   (Taylor order N = 3; extended state x1, x2, sigma; T = alpha*epsilon)
    """
    if fmt not in FORMATS:
        raise ParameterError(f"fmt must be one of {FORMATS}, got {fmt!r}")
    rhos = [integer("rho", r, minimum=1) for r in rho_values]
    if not rhos:
        raise ParameterError("rho_values must list at least one relative degree, got none")
    blocks = []
    for rho in rhos:
        n = rho + 1 if order is None else order
        d = fl.taylor_discretization(rho, order=n)
        states = ", ".join(str(s) for s in d.extended_states)
        parts = [_rule(f"rho = {rho}   (Taylor order N = {d.order}; extended state {states}; "
                       "T = alpha*epsilon)")]
        if fmt in ("text", "both"):
            parts.append(_text_block(d))
        if fmt in ("latex", "both"):
            parts.append(f"LaTeX (rho = {rho}):\n{_latex_block(d)}")
        blocks.append("\n".join(parts))
    return "\n\n".join(blocks) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry: print :func:`report`; returns the exit status.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments (default ``sys.argv[1:]``): ``--rho R [R ...]``, ``--format``, ``--order``.

    Examples
    --------
    >>> main(["--rho", "1", "--format", "text"])  # doctest: +ELLIPSIS
    ===...
    0
    """
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rho", type=int, nargs="+", default=[2, 3, 4],
                        help="relative degrees (default: 2 3 4)")
    parser.add_argument("--format", choices=FORMATS, default="both", help="output format")
    parser.add_argument("--order", type=int, default=None,
                        help="Taylor order N of F^e (default: rho + 1)")
    args = parser.parse_args(argv)
    try:
        sys.stdout.write(report(args.rho, fmt=args.format, order=args.order))
    except ParameterError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
