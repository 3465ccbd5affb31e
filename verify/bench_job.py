"""Benchmark: the main job (``fl-design run``, the TRMS of ``make demo``) cold and warm (issue 33).

Each measurement is ``fl-design run`` in a fresh process: **cold** with an empty
``FL_DESIGN_CACHE`` (every kernel compiled, every certificate solved), **quick warm** with
``--quick`` after a first ``--quick`` run filled the cache (what an engineer iterating sees).
Rounds are interleaved (cold, quick warm, cold, ...), so a change of the machine's load falls on
both. Each line gives the wall time, the CPU time of the process and its children (the C
compilers), the 1-minute load average, and the time of every stage read back from the run's
``summary.json`` (``timings_s``: the certify stage runs in a child process beside simulate and
codegen, so the stages' times add up to more than the wall time). It prints the machine (CPU,
cores, the kernels' instruction-set level) first.

Targets (issue 33): the cold job <= 15 s and the quick warm job <= 5 s, medians over the rounds
(exit status 1 on a miss). ``--quick`` runs the quick job cold and warm once and checks no
target (the tests run it). ``--config`` times another configuration (its own [plant]);
``--serial`` adds, in each round, a cold job whose stages run one after the other (the certify
stage not in its process) and prints the median ratio of the wall times.

    python verify/bench_job.py [--quick] [--rounds R] [--config FILE.toml] [--serial]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _shared import machine, target

COLD_TARGET_S = 15.0
QUICK_WARM_TARGET_S = 5.0


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


#: ``fl-design run`` in a fresh interpreter; ``{serial}`` True runs every stage in turn (the
#: certify stage not beside the others: the comparison of ``--serial``).
ENTRY = ("import sys\nimport fl_design.app._job as job\nif {serial}:\n    job.BESIDE = {{}}\n"
         "from fl_design.app._cli import main\nsys.exit(main(sys.argv[1:]))\n")


def run_once(cache: Path, out: Path, *, quick: bool, config: str | None, serial: bool = False,
             timeout: float = 900.0) -> dict:
    """One ``fl-design run``: wall and CPU seconds, load, stage times (or the failure)."""
    cmd = [sys.executable, "-c", ENTRY.format(serial=bool(serial)), "run"]
    # with its progress lines (piped, as the acceptance check and a user's terminal get them)
    cmd += ([config] if config else []) + ["--out", str(out)]
    cmd += ["--quick"] if quick else []
    env = dict(os.environ, FL_DESIGN_CACHE=str(cache), MPLBACKEND="Agg")
    cpu0, t0 = _children_cpu(), time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=timeout,
                          check=False)
    wall, cpu = time.perf_counter() - t0, _children_cpu() - cpu0
    res = {"wall": wall, "cpu": cpu, "load": os.getloadavg()[0], "rc": proc.returncode}
    if proc.returncode != 0:
        res["error"] = (proc.stderr.strip().splitlines() or ["?"])[-1][:200]
        return res
    summary = json.loads((out / "summary.json").read_text())
    res["stages"] = summary.get("timings_s", {})
    return res


def line(name: str, r: dict) -> str:
    """One measurement in words."""
    if r["rc"] != 0:
        return f"  {name}: FAILED (rc {r['rc']}): {r.get('error', '')}"
    stages = ", ".join(f"{k} {v:.1f}" for k, v in r["stages"].items())
    return (f"  {name}: {r['wall']:.1f} s wall, CPU {r['cpu']:.1f} s (with the compilers), "
            f"load {r['load']:.1f}; stages (s): {stages}")


def main(argv=None) -> int:
    """Run the benchmark; return the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="the quick job cold and warm once, no target")
    parser.add_argument("--rounds", type=int, default=3, help="interleaved rounds (default 3)")
    parser.add_argument("--config", default=None, help="a TOML config (default the TRMS demo)")
    parser.add_argument("--serial", action="store_true",
                        help="also time the cold job with every stage in turn (interleaved)")
    args = parser.parse_args(argv)
    rounds = 1 if args.quick else max(1, args.rounds)
    print(machine(), flush=True)
    cold, warm, serial = [], [], []
    with tempfile.TemporaryDirectory(prefix="bench_job_") as tmp:
        tmp = Path(tmp)
        for k in range(rounds):
            cache = tmp / f"cache{k}"
            if args.serial:
                r = run_once(tmp / f"cache_s{k}", tmp / f"serial{k}", quick=args.quick,
                             config=args.config, serial=True)
                serial.append(r)
                print(line(f"round {k + 1} cold, stages in turn", r), flush=True)
            r = run_once(cache, tmp / f"cold{k}", quick=args.quick, config=args.config)
            cold.append(r)
            print(line(f"round {k + 1} cold{' (--quick)' if args.quick else ''}", r), flush=True)
            run_once(cache, tmp / f"fill{k}", quick=True, config=args.config)
            r = run_once(cache, tmp / f"warm{k}", quick=True, config=args.config)
            warm.append(r)
            print(line(f"round {k + 1} --quick warm", r), flush=True)
    ok = all(r["rc"] == 0 for r in cold + warm + serial)
    if not ok:
        print("a run failed: FAILS")
        return 1
    c = statistics.median(r["wall"] for r in cold)
    w = statistics.median(r["wall"] for r in warm)
    if not args.quick:  # --quick runs the cold job with --quick too: not the target's job
        target("main job on the TRMS, cold (empty cache)", c, COLD_TARGET_S,
               detail=f"median of {rounds} round(s)")
    target("main job --quick on the TRMS, warm", w, QUICK_WARM_TARGET_S,
           checked=not args.quick, detail=f"median of {rounds} round(s)")
    print(f"main job{' --quick' if args.quick else ''} cold: median {c:.1f} s over {rounds} "
          f"round(s) (CPU {statistics.median(r['cpu'] for r in cold):.1f} s)"
          + ("" if args.quick else f"; target <= {COLD_TARGET_S:g} s"
             + ("" if c <= COLD_TARGET_S else f": MISS by {c - COLD_TARGET_S:.1f} s")))
    print(f"main job --quick warm: median {w:.1f} s (CPU "
          f"{statistics.median(r['cpu'] for r in warm):.1f} s)"
          + ("" if args.quick else f"; target <= {QUICK_WARM_TARGET_S:g} s"
             + ("" if w <= QUICK_WARM_TARGET_S else
                f": MISS by {w - QUICK_WARM_TARGET_S:.1f} s")))
    if serial:
        ratio = statistics.median(a["wall"] / b["wall"] for a, b in zip(cold, serial))
        print(f"cold, certify beside the other stages / every stage in turn: median wall ratio "
              f"{ratio:.2f} over {rounds} interleaved round(s)")
    print("load average (1, 5, 15 min): " + ", ".join(f"{x:.2f}" for x in os.getloadavg()))
    if args.quick:
        return 0
    return 0 if c <= COLD_TARGET_S and w <= QUICK_WARM_TARGET_S else 1


if __name__ == "__main__":
    sys.exit(main())
