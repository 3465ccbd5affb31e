"""Benchmark: ``fl.tune(plant)`` on every library plant, first call, empty cache (issue 33).

Each measurement is a fresh process (``python -c``) with an empty ``FL_DESIGN_CACHE``: the
plant is built, then ``fl.tune(plant)`` with its defaults (the default objective, the
reference from the plant's region) is timed alone, as ``/work/shared/checks/speed.py`` does
(compilation of the check's kernel and the certificates' solves included; the interpreter's
start and ``import fl_design`` not). The plants are measured in interleaved rounds (round 1:
every plant once, then round 2, ...), so that a change of the machine's load falls on all of
them; each line gives the median wall time, the spread, the CPU time of the call (the
process and its compiler children: what an idle machine would take, about) and the 1-minute
load average at each measurement. It prints the machine (CPU, cores, instruction-set level of the kernels) first.

Target: the median of every plant <= 10 s (exit status 1 on a miss). ``--quick`` times the
pendulum and the TRMS once each and checks no target (the tests run it).

    python verify/bench_tune.py [--quick] [--rounds R] [--plants trms,pendulum,...]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile

from _shared import load_line, machine, target

TARGET_S = 10.0
#: fl-design's library names and the factory that builds each.
PLANTS = {"trms": "fl.plants.trms_yaw()", "trms-lag": "fl.plants.trms_yaw(True)",
          "pendulum": "fl.plants.pendulum()", "flexible-joint": "fl.plants.flexible_joint()",
          "cart-pendulum": "fl.plants.cart_pendulum()", "maglev": "fl.plants.maglev()"}


def one(expr: str, timeout: float = 600.0) -> tuple[float, str]:
    """``(seconds of fl.tune, summary line)`` in a fresh process with an empty cache."""
    code = ("import resource, time, fl_design as fl\n"
            f"p = {expr}\n"
            "def cpu():\n"
            "    a, b = (resource.getrusage(w) for w in (resource.RUSAGE_SELF, "
            "resource.RUSAGE_CHILDREN))\n"
            "    return a.ru_utime + a.ru_stime + b.ru_utime + b.ru_stime\n"
            "t, c0 = time.perf_counter(), cpu(); r = fl.tune(p)\n"
            "dt, dc = time.perf_counter() - t, cpu() - c0\n"
            "e, c = r.design.estimator, r.design.controller\n"
            "print(dt, f'(CPU {dc:.2f} s with the compiler) T={e.T:g} eps={e.eps:.4g} "
            "gamma={c.gamma:.4g} certified={r.certified}"
            " settling={r.settling_time:.3g}s pm={r.phase_margin:.3g}deg "
            "warnings={len(r.warnings)}')\n")
    with tempfile.TemporaryDirectory(prefix="bench_tune_") as cache:
        env = dict(os.environ, FL_DESIGN_CACHE=cache, MPLBACKEND="Agg")
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              env=env, timeout=timeout, check=False)
    if proc.returncode != 0:
        last = (proc.stderr.strip().splitlines() or ["?"])[-1]
        return float("nan"), f"FAILED: {last[:200]}"
    head, _, rest = proc.stdout.strip().splitlines()[-1].partition(" ")
    return float(head), rest


def main(argv=None) -> int:
    """Run the benchmark; return the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="pendulum and TRMS once, no target")
    parser.add_argument("--rounds", type=int, default=3, help="interleaved rounds (default 3)")
    parser.add_argument("--plants", default=None, help="comma-separated library names")
    args = parser.parse_args(argv)
    names = (args.plants.split(",") if args.plants else
             ["pendulum", "trms"] if args.quick else list(PLANTS))
    unknown = [n for n in names if n not in PLANTS]
    if unknown:
        parser.error(f"unknown plant(s) {unknown}; choose from {sorted(PLANTS)}")
    rounds = 1 if args.quick else max(1, args.rounds)
    print(machine())
    times = {n: [] for n in names}
    loads = {n: [] for n in names}
    notes = {}
    for r in range(rounds):
        for n in names:
            dt, note = one(PLANTS[n])
            times[n].append(dt)
            loads[n].append(os.getloadavg()[0])
            notes[n] = note
            print(f"  round {r + 1}: {n}: {dt:.2f} s (load {loads[n][-1]:.1f}) {note}",
                  flush=True)
    ok = True
    print(f"fl.tune, first call, empty cache (median of {rounds} interleaved round(s); "
          f"target <= {TARGET_S:g} s):")
    for n in names:
        med = statistics.median(times[n])
        spread = f"{min(times[n]):.2f}-{max(times[n]):.2f} s" if rounds > 1 else ""
        miss = not target(f"fl.tune on {n} (first call, empty cache)", med, TARGET_S,
                          checked=not args.quick, detail=f"median of {rounds} round(s)")
        ok &= not miss or args.quick
        print(f"  {n:15s} {med:6.2f} s {spread:17s} load {min(loads[n]):.1f}-"
              f"{max(loads[n]):.1f}{'  MISS' if miss and not args.quick else ''}")
    print(load_line())
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
