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

Then the paper's EHGO step against a hand-written one (``_hand_step.py``: the same loop, the
design's numbers as literals, no checks), both checked against ``Design.step`` first: time per
call on this machine, instructions per call under ``valgrind --tool=callgrind`` (x86), and, when
``arm-none-eabi-gcc`` and ``qemu-system-arm`` are installed, the float steps' instructions per
call on the Cortex-M4F model (``CPackage.pil``, QEMU ``mps2-an386``; the hand-written step in
the same timed loop, ``run_on_model(..., step=...)``). Targets:

4. the generated step within 1.3x the hand-written one's time on this machine (each precision);
5. the float step at most 120 instructions per call on the Cortex-M4F model;
6. the float step's common path (the default checks on) within 1.3x the hand-written step's
   instructions on the Cortex-M4F model (issue 32);
7. the paper's design and the maglev and flexible-joint presets in ``precision="q31"`` at
   most 200 instructions per step on the Cortex-M3 model (QEMU ``mps2-an385``) and at most
   1000 for the Cortex-M0+ build (QEMU ``microbit``, its Cortex-M0: the same ARMv6-M
   instructions), ``u`` bit-exact with the host build (the table also gives each package's
   measured quantization error and how its observer update is computed);
8. cppcheck's MISRA C:2012 addon on the firmware source of those three designs in double,
   float and Q31: no finding of a required rule, every rule found a documented deviation of
   the package's ``MISRA_DEVIATIONS.md`` (the findings per rule printed; skipped, with the
   reason, without cppcheck; ``--quick``: the paper's design only).

Exits with status 1 when a target is missed. ``--quick`` times short runs (targets on the
operation counts still checked, the timing and Cortex-M4F instruction targets not; the Q31
instruction targets are, QEMU's ``-icount`` counts being load-independent): the tests run it.

    python verify/bench_codegen.py [--quick] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np
from _hand_step import compare_with_hand, hand_source

import fl_design as fl
from fl_design import presets
from fl_design.codegen import compare_costs, generate_c
from fl_design.codegen._compare import recorded_run
from fl_design.codegen._pil import pil_tools, run_on_model
from fl_design.codegen._pil_q31 import q31_pil

MAX_FLOPS = 60
MAX_NS = 50.0
MAX_HAND_RATIO = 1.3
MAX_M4_INSTRUCTIONS = 120
MAX_M4_HAND_RATIO = 1.3
MAX_Q31 = {"cortex-m3": 200, "cortex-m0plus": 1000}


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


def _against_hand(tmp: str, steps: int, *, timing: bool) -> dict:
    out, misses = {}, []
    print("\nthe paper's EHGO step, generated vs hand-written (x86, -O2):\n")
    print("| precision | max |u - Design.step| / max|u| (gen, hand) | ns gen | ns hand | ratio "
          "| instr gen | instr hand |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for precision in ("double", "float"):
        pkg = generate_c(presets.paper_design(), f"{tmp}/hand_{precision}", precision=precision)
        row = compare_with_hand(pkg, Path(tmp) / f"hand_{precision}" / "bench", steps=steps)
        out[precision] = row
        ratio = row["ns_generated"] / row["ns_hand"]
        print(f"| {precision} | {row['max_diff_generated']:.2g}, {row['max_diff_hand']:.2g} | "
              f"{row['ns_generated']:.3g} | {row['ns_hand']:.3g} | {ratio:.2f} | "
              f"{row.get('ir_generated', float('nan')):.0f} | "
              f"{row.get('ir_hand', float('nan')):.0f} |")
        bound = 1e-12 if precision == "double" else 1e-4
        if max(row["max_diff_generated"], row["max_diff_hand"]) > bound:
            misses.append(f"{precision}: a step differs from Design.step beyond {bound:g}")
        if timing and ratio > MAX_HAND_RATIO:
            misses.append(f"{precision}: generated step {ratio:.2f}x the hand-written time "
                          f"> {MAX_HAND_RATIO}")
    _, _, reason = pil_tools()
    if reason:
        print(f"\n  Cortex-M4F model: skipped ({reason})")
    else:
        out["cortex_m4"], m4_misses = _on_cortex_m4(tmp, timing=timing)
        misses += m4_misses
    for text in misses:
        print(f"  [MISS] {text}")
    out["misses"] = misses
    return out


def _on_cortex_m4(tmp: str, *, timing: bool) -> tuple[dict, list[str]]:
    """The float step on the Cortex-M4F model: generated and hand-written, in the same timed
    loop, on the same recorded TRMS run."""
    plant, scenario = fl.plants.trms_yaw(), fl.Scenario(0.3, 2.0)
    pkg = generate_c(presets.paper_design(), f"{tmp}/pil", precision="float")
    res = pkg.pil(plant, scenario)
    hand_c = Path(tmp) / "pil_hand.c"
    hand_c.write_text(hand_source(pkg.design, "float"))
    ym, r, u0 = recorded_run(plant, pkg.design, scenario, max_samples=res.u_c.size)
    u_hand, hand = run_on_model(pkg, ym, r, float(ym[0]), u0, step=(hand_c, "hand_step"))
    hand_err = float(np.max(np.abs(u_hand - res.u_ref)) / np.max(np.abs(res.u_ref)))
    print(f"\n  Cortex-M4F model (QEMU mps2-an386, {res.u_c.size} samples of the TRMS run, "
          "instructions per call beyond an empty call):")
    print(f"    generated {res.instructions:.1f} (target <= {MAX_M4_INSTRUCTIONS}), "
          f"u within {res.max_rel_error:.2g} of max|u| of Design.step")
    print(f"    hand-written {hand:.1f} ({res.instructions / hand:.2f}x, target <= "
          f"{MAX_M4_HAND_RATIO}), u within {hand_err:.2g}")
    misses = []
    if not (res.passed and hand_err <= res.bound):
        misses.append("a Cortex-M4F step differs from Design.step beyond the bound")
    if timing and res.instructions > MAX_M4_INSTRUCTIONS:
        misses.append(f"Cortex-M4F float step {res.instructions:.0f} instructions > "
                      f"{MAX_M4_INSTRUCTIONS}")
    if timing and res.instructions > MAX_M4_HAND_RATIO * hand:
        misses.append(f"Cortex-M4F float step {res.instructions / hand:.2f}x the hand-written "
                      f"step's instructions > {MAX_M4_HAND_RATIO}")
    paths = _paths_on_cortex_m4(pkg, ym, r, u0)
    return {"generated": res.to_dict(), "hand_instructions_per_step": hand,
            "hand_max_rel_error": hand_err, "paths": paths}, misses


def _paths_on_cortex_m4(pkg, ym, r, u0) -> dict:
    """Instructions per call of each path of the float step on the Cortex-M4F model (the WCET
    table): the common path, the periodic checksum path (every sample with a period of 1),
    u at a limit (a reference 100 rad away: u pinned from the first samples), rejected
    samples, and rejections alternating with accepted samples (each accepted one then takes
    the checked path)."""
    y0 = float(ym[0])
    bad = np.full_like(ym, 1e30)  # outside the default range |y| <= 1e9
    alt = ym.copy()
    alt[1::2] = 1e30
    rows = {
        "common path (range check on; y within the band around y_c)":
            run_on_model(pkg, ym, r, y0, u0)[1],
        "common path, y outside the band (the range test; FL_NO_BAND)":
            run_on_model(pkg, ym, r, y0, u0, cflags=("-DFL_NO_BAND",))[1],
        "checksum + checked path (FL_PARAM_CHECK_PERIOD=1)":
            run_on_model(pkg, ym, r, y0, u0, cflags=("-DFL_PARAM_CHECK_PERIOD=1u",))[1],
        "u at a limit (every sample; the saturated branches out of line)":
            run_on_model(pkg, ym, r + 100.0, y0, u0)[1],
        "every sample rejected (range; sensor lost after 10)": run_on_model(pkg, bad, r, y0, u0)[1],
        "rejected / accepted alternating (mean of the two)": run_on_model(pkg, alt, r, y0, u0)[1],
    }
    rows["accepted after a rejection (checked path, derived)"] = (
        2 * rows["rejected / accepted alternating (mean of the two)"]
        - rows["every sample rejected (range; sensor lost after 10)"])
    print("\n  Cortex-M4F model, instructions per call by path (the float TRMS step; the worst "
          "case is the checksum sample, once per FL_PARAM_CHECK_PERIOD = 100):")
    print("\n  | path | instructions per call |\n  | --- | --- |")
    for name, value in rows.items():
        print(f"  | {name} | {value:.0f} |")
    return rows


def _q31_on_fpu_less(tmp: str) -> tuple[dict, list[str]]:
    """The Q31 step on the Cortex-M3 and M0+ models: instructions per call, bit-exact with the
    host build, against the targets (the paper's TRMS design and two presets)."""
    _, _, reason = pil_tools()
    if reason:
        print(f"\n  Q31 on the Cortex-M3 / M0+ models: skipped ({reason})")
        return {"skipped": reason}, []
    cases = {"paper TRMS": (presets.paper_design, fl.plants.trms_yaw, 0.3),
             "maglev": (presets.maglev_design, fl.plants.maglev, 0.0005),
             "flexible joint": (presets.flexible_joint_design, fl.plants.flexible_joint, 0.05)}
    out, misses = {}, []
    print("\n  Q31 step, instructions per call beyond an empty call (QEMU -icount, 1000 recorded "
          "samples):\n\n  | design | Cortex-M3 | Cortex-M0+ | u vs host | the targets (200, 1000) "
          "| error vs Design.step | observer update |\n  | --- | --- | --- | --- | --- | --- | --- |")
    for name, (design, make_plant, step) in cases.items():
        plant = make_plant()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", fl.errors.FloatPrecisionWarning)
            pkg = generate_c(design(), f"{tmp}/q31_{name.replace(' ', '_')}", precision="q31",
                             plant=plant)
        r0 = 0.3 if name == "paper TRMS" else float(plant.x_op[0]) + step
        models = q31_pil(pkg, plant, fl.Scenario(r0, 1.0), max_samples=1000)
        row = {}
        for cpu, limit in MAX_Q31.items():
            n, row[f"{cpu}_max_diff"] = models[cpu]
            row[cpu] = n
            if row[f"{cpu}_max_diff"] != 0.0:
                misses.append(f"q31 {name} on {cpu}: u differs from the host build")
            if n > limit:
                misses.append(f"q31 {name} on {cpu}: {n:.0f} instructions > {limit}")
        same = max(row["cortex-m3_max_diff"], row["cortex-m0plus_max_diff"]) == 0.0
        over = [f"{cpu} {row[cpu] - limit:+.0f}" for cpu, limit in MAX_Q31.items()
                if row[cpu] > limit]
        row["error"] = pkg.predicted_float_error
        readme = (pkg.out_dir / "README.md").read_text()
        row["update"] = "recursion" if "update as its recursion (see Cost)" in readme else "matrix"
        print(f"  | {name} | {row['cortex-m3']:.0f} | {row['cortex-m0plus']:.0f} | "
              f"{'bit-exact' if same else 'DIFFERS'} | "
              f"{'within' if not over else 'over by ' + ', '.join(over)} | "
              f"{row['error']:.2g} | {row['update']} |")
        out[name] = row
    return out, misses


def _misra(tmp: str, quick: bool = False) -> tuple[dict, list[str]]:
    """cppcheck's MISRA C:2012 addon on the firmware source (``<prefix>.c``) of the three
    designs in every precision: findings per rule, none of a required rule, every rule found a
    deviation documented in the package's ``MISRA_DEVIATIONS.md``."""
    import re
    import shutil
    import subprocess

    from fl_design.codegen._misra import DEVIATIONS

    if shutil.which("cppcheck") is None:
        reason = "cppcheck is not installed (apt-get install cppcheck)"
        print(f"\n  MISRA C:2012: skipped ({reason})")
        return {"skipped": reason}, []
    cases = {"paper TRMS": (presets.paper_design, fl.plants.trms_yaw),
             "maglev": (presets.maglev_design, fl.plants.maglev),
             "flexible joint": (presets.flexible_joint_design, fl.plants.flexible_joint)}
    if quick:  # the tests: the paper's design only
        cases = {"paper TRMS": cases["paper TRMS"]}
    out, misses = {}, []
    print("\n  MISRA C:2012 (cppcheck's addon on <prefix>.c; required rules: none allowed):\n\n"
          "  | design | precision | findings | rules (count) | required | undocumented |\n"
          "  | --- | --- | --- | --- | --- | --- |")
    for name, (design, make_plant) in cases.items():
        for precision in ("double", "float", "q31"):
            folder = f"{tmp}/misra_{name.replace(' ', '_')}_{precision}"
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", fl.errors.FloatPrecisionWarning)
                pkg = generate_c(design(), folder, precision=precision, plant=make_plant())
            proc = subprocess.run(["cppcheck", "--addon=misra", "--quiet", "--template={id}",
                                   str(pkg.sources[0])], capture_output=True, text=True,
                                  timeout=600, check=False)
            found = re.findall(r"misra-c2012-(\d+\.\d+)", proc.stdout + proc.stderr)
            rules = {rule: found.count(rule) for rule in sorted(set(found))}
            documented = (pkg.out_dir / "MISRA_DEVIATIONS.md").read_text()
            undocumented = [r for r in rules
                            if r not in DEVIATIONS or f"| {r} |" not in documented]
            # the deviations are advisory rules by construction (_misra.DEVIATIONS); a rule
            # outside them may be required: counted as such
            required = [r for r in rules if r not in DEVIATIONS]
            if not found and proc.returncode != 0:
                misses.append(f"MISRA {name} {precision}: cppcheck failed: {proc.stderr[-200:]}")
            misses += [f"MISRA {name} {precision}: rule {r} not a documented deviation"
                       for r in undocumented]
            listed = ", ".join(f"{r} ({n})" for r, n in rules.items()) or "none"
            print(f"  | {name} | {precision} | {len(found)} | {listed} | {len(required)} | "
                  f"{len(undocumented)} |")
            out[f"{name} {precision}"] = {"findings": len(found), "rules": rules,
                                          "required": len(required),
                                          "undocumented": len(undocumented)}
    return out, misses


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
        hand = _against_hand(tmp, steps, timing=not args.quick)
        misses += hand.pop("misses")
        tables["hand"] = hand
        # QEMU -icount counts instructions: load-independent, so checked in --quick too
        tables["q31"], q31_misses = _q31_on_fpu_less(tmp)
        misses += q31_misses
        tables["misra"], misra_misses = _misra(tmp, quick=args.quick)
        misses += misra_misses
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(tables, fh, indent=1, allow_nan=False)
    print("\nall targets met" if not misses else f"\n{len(misses)} target(s) missed")
    return 1 if misses else 0


if __name__ == "__main__":
    sys.exit(main())
