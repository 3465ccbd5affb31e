"""Computational cost of the generated C step: the paper's EHGO against least squares N = 9, 26.

Generates the paper's TRMS design (EHGO rho = 2, eps = 0.05, K = (2, 4), gamma = 3e-4,
k_I = 1e-3, |xhat_2| <= 0.05, u in [-2.5, 2.5], T = 1 ms) and the least-squares baselines with
windows 9 and 26 under the same controller as C (``fl.generate_c``), builds them with
``-O2 -std=c99 -pedantic -Wall -Wextra -Werror`` and prints the cost table (operations per
step from CasADi's instruction list, measured ns per step, stack, code size, state size), in
double and in single precision (with the Cortex-M4F figures when ``arm-none-eabi-gcc`` is
installed). Targets, in double:

1. the EHGO step costs at most 60 floating-point operations;
2. at most 50 ns per call on this machine;
3. at most half of the LS(26) step, in operations and in time.

Exits with status 1 when a target is missed. ``--quick`` times short runs (targets on the
operation counts still checked, the timing targets not): the tests run it.

    python verify/bench_codegen.py [--quick] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile

from fl_design import presets
from fl_design.codegen import compare_costs

MAX_FLOPS = 60
MAX_NS = 50.0


def _table(out_dir: str, precision: str, steps: int):
    designs = {"EHGO": presets.paper_design(), "LS(9)": presets.least_squares_design(9),
               "LS(26)": presets.least_squares_design(26)}
    return compare_costs(designs, f"{out_dir}/{precision}", precision=precision,
                         bench_steps=steps)


def _check(table, *, timing: bool) -> list[str]:
    rows = {row.name: row for row in table.rows}
    ehgo, ls26 = rows["EHGO"], rows["LS(26)"]
    checks = [(f"EHGO flops {ehgo.flops} <= {MAX_FLOPS}", ehgo.flops <= MAX_FLOPS),
              (f"EHGO flops {ehgo.flops} <= LS(26) flops / 2 = {ls26.flops / 2:g}",
               2 * ehgo.flops <= ls26.flops)]
    if timing:
        checks += [(f"EHGO {ehgo.ns_per_step:.3g} ns/step <= {MAX_NS:g}",
                    ehgo.ns_per_step <= MAX_NS),
                   (f"EHGO {ehgo.ns_per_step:.3g} ns <= LS(26) {ls26.ns_per_step:.3g} ns / 2",
                    2 * ehgo.ns_per_step <= ls26.ns_per_step)]
    misses = []
    for text, ok in checks:
        print(f"  [{'ok' if ok else 'MISS'}] {text}")
        if not ok:
            misses.append(text)
    return misses


def main(argv=None) -> int:
    """Print the tables and check the targets; the exit status (1 on a miss)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short timing runs, no timing targets")
    parser.add_argument("--json", help="write both tables as strict JSON here")
    args = parser.parse_args(argv)
    steps = 20_000 if args.quick else 5_000_000
    misses, tables = [], {}
    with tempfile.TemporaryDirectory() as tmp:
        for precision in ("double", "float"):
            table = _table(tmp, precision, steps)
            tables[precision] = table.to_dict()
            print(f"\n{precision} precision ({steps} timed steps per design):\n")
            print(table.to_markdown())
            for row in table.rows:
                if row.arm is not None:
                    print(f"  {row.name} on Cortex-M4F: {row.arm['code_bytes']} B code, "
                          f"{row.arm['stack_bytes']} B stack, double helpers: "
                          f"{row.arm['double_helpers'] or 'none'}")
                    if row.arm["double_helpers"]:
                        misses.append(f"{row.name} float calls {row.arm['double_helpers']}")
                elif precision == "float":
                    print(f"  {row.name} on Cortex-M4F: skipped ({row.arm_skipped})")
            if precision == "double":
                misses += _check(table, timing=not args.quick)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(tables, fh, indent=1, allow_nan=False)
    print("\nall targets met" if not misses else f"\n{len(misses)} target(s) missed")
    return 1 if misses else 0


if __name__ == "__main__":
    sys.exit(main())
