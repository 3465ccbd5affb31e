"""Benchmark: the C compiler's CPU in the cold main job, and the compiles it no longer does (issue 33).

The TRMS job of ``make demo`` (the default configuration) compiles, cold, a scalar record kernel
per compared design (``fl.simulate``), the software-in-the-loop driver, and each compared
design's package for the cost table. Measured here, as CPU seconds of the compiler processes
(``RUSAGE_CHILDREN``), each compile cold (a fresh cache folder):

1. **record kernels**: the one-step source (``fl_rec`` only; ``fl_run`` calls it without its
   output) against the two-step source of before (``fl_acc`` generated beside ``fl_rec``);
2. **cost table**: the package compiled once (its object with ``-fstack-usage``, ``main.c``
   linked against it: ``bench_executable``) against twice (``CPackage.build`` compiling the
   package again for the timing harness);
3. **SIL driver**: cold (compiled) and warm (read back from the cache: no compiler).

Also the record kernel's time per step on a 60 s run at T = 1 ms, and that the one-step kernel
records bit for bit what the two-step one records. Rounds are interleaved (new, old, ...);
medians. Targets: the cold compiles of 1 and 2 take at most 0.65 of the CPU of the old way, and
a warm SIL driver runs no compiler (under 0.02 s of children CPU). ``--quick``: the EHGO design
only, one round, short runs, no target (the tests run it).

    python verify/bench_compile.py [--quick] [--rounds R]
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _shared import finish, machine, target

import fl_design as fl
from fl_design._toolchain import build, generate_source
from fl_design.app import load_config
from fl_design.app._build import build_setup
from fl_design.codegen._build import compiler_or_raise
from fl_design.codegen._cost import _objects, bench_executable
from fl_design.codegen._sil import build_driver
from fl_design.sim._run import prepare_run
from fl_design.sim.kernel._runners import NativeRunner, runner_source

RATIO_TARGET = 0.65
WARM_SIL_CPU_S = 0.02


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _cpu(fn):
    """(result, compiler CPU seconds) of ``fn()``."""
    c0 = _children_cpu()
    out = fn()
    return out, _children_cpu() - c0


def _sources(loop) -> tuple[str, str, dict]:
    """The one-step kernel source, the two-step source of before, the indices."""
    sl = loop.layout.slices
    idx = {"k": sl["k"].start, "div": sl["diverged"].start, "N": sl["N"].start}
    new = runner_source(loop.accumulate, loop.record, idx)
    head = generate_source(loop.record)
    old = generate_source(loop.accumulate, loop.record) + new[len(head):]
    return new, old, idx


def _kernels(design, setup, tmp: Path, duration: float) -> dict:
    run = prepare_run(setup.plant, design, setup.run_scenario(duration=duration,
                                                              noise_std=1e-3, seed=1))
    new, old, idx = _sources(run.loop)
    out = {}
    for tag, src in (("new", new), ("old", old)):
        lib, cpu = _cpu(lambda s=src: build(s, "fl_loop", cache_dir=tempfile.mkdtemp(dir=tmp)))
        runner = NativeRunner(run.loop.accumulate, run.loop.record, idx, lib)
        acc0 = run.initial_accumulator(design.parameter_vector())[:, 0]
        t = time.process_time()
        rec = runner.record(acc0, run.D)
        out[tag] = {"cpu": cpu, "ns": (time.process_time() - t) / run.N * 1e9, "rec": rec}
    same = all(np.array_equal(np.asarray(a).view(np.int64), np.asarray(b).view(np.int64))
               for a, b in zip(out["new"]["rec"], out["old"]["rec"]))
    return {"new": out["new"]["cpu"], "old": out["old"]["cpu"], "ns": out["new"]["ns"],
            "same": same}


def _cost(design, folder: Path, cc: str) -> dict:
    pkg = fl.generate_c(design, folder)
    res = {}
    for tag in ("new", "old"):
        def work(tag=tag):
            objs, _ = _objects(pkg, cc, pkg.flags(), folder / "build" / f"host_{tag}")
            return (bench_executable(pkg, objs, compiler=cc) if tag == "new"
                    else pkg.build(compiler=cc))
        _, res[tag] = _cpu(work)
    return res


def _sil(setup, folder: Path, cc: str) -> dict:
    pkg = fl.generate_c(setup.design, folder, plant=setup.plant)
    with tempfile.TemporaryDirectory(dir=folder.parent) as cache:  # cold: its own cache
        old = os.environ.get("FL_DESIGN_CACHE")
        os.environ["FL_DESIGN_CACHE"] = cache
        try:
            _, cold = _cpu(lambda: build_driver(pkg, setup.plant, 1, compiler=cc))
            _, warm = _cpu(lambda: build_driver(pkg, setup.plant, 1, compiler=cc))
        finally:
            if old is None:
                del os.environ["FL_DESIGN_CACHE"]
            else:
                os.environ["FL_DESIGN_CACHE"] = old
    return {"cold": cold, "warm": warm}


def main(argv=None) -> int:
    """Run the benchmark; return the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one design, one round, no target")
    parser.add_argument("--rounds", type=int, default=3, help="interleaved rounds (default 3)")
    args = parser.parse_args(argv)
    rounds = 1 if args.quick else max(1, args.rounds)
    print(machine(), flush=True)
    setup = build_setup(load_config(None))
    designs = dict(list(setup.compared.items())[:1] if args.quick else setup.compared.items())
    cc = compiler_or_raise()
    rows = {name: [] for name in designs}
    sil = []
    with tempfile.TemporaryDirectory(prefix="bench_compile_") as tmp:
        tmp = Path(tmp)
        for k in range(rounds):
            for i, (name, design) in enumerate(designs.items()):
                kern = _kernels(design, setup, tmp, 2.0 if args.quick else 60.0)
                cost = _cost(design, tmp / f"cost{k}_{i}", cc)
                rows[name].append({"kernel": kern, "cost": cost})
                print(f"  round {k + 1} {name}: record kernel {kern['new']:.2f} s (two-step "
                      f"{kern['old']:.2f} s; {kern['ns']:.0f} ns/step, same bits: "
                      f"{kern['same']}), cost build {cost['new']:.2f} s (twice: "
                      f"{cost['old']:.2f} s)", flush=True)
            s = _sil(setup, tmp / f"sil{k}", cc)
            sil.append(s)
            print(f"  round {k + 1} SIL driver: cold {s['cold']:.2f} s, warm {s['warm']:.3f} s",
                  flush=True)
    new = [sum(r[k]["kernel"]["new"] + r[k]["cost"]["new"] for r in rows.values())
           for k in range(rounds)]
    old = [sum(r[k]["kernel"]["old"] + r[k]["cost"]["old"] for r in rows.values())
           for k in range(rounds)]
    ratio = statistics.median(a / b for a, b in zip(new, old))
    same = all(r["kernel"]["same"] for rs in rows.values() for r in rs)
    warm = statistics.median(s["warm"] for s in sil)
    print(f"record kernels + cost builds of {len(designs)} design(s): compiler CPU median "
          f"{statistics.median(new):.2f} s, the old way {statistics.median(old):.2f} s: "
          f"{statistics.median(o - n for n, o in zip(new, old)):.2f} s less (ratio {ratio:.2f}; "
          f"target <= {RATIO_TARGET:g}); the SIL driver warm {warm:.3f} s (cold "
          f"{statistics.median(s['cold'] for s in sil):.2f} s)")
    ok1 = target("cold compiles of the job's record kernels and cost builds, new / old CPU",
                 ratio, RATIO_TARGET, unit="x", checked=not args.quick,
                 detail=f"median of {rounds} interleaved round(s), {len(designs)} design(s)")
    ok2 = target("SIL driver warm: compiler CPU", warm, WARM_SIL_CPU_S, checked=not args.quick)
    return finish(same and (args.quick or (ok1 and ok2)))


if __name__ == "__main__":
    sys.exit(main())
