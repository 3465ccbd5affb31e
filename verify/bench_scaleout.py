"""Scale-out that pays: a sweep on an executor against the same sweep in this process.

One run of this script, on the TRMS yaw loop at the paper's design (``fl.presets.paper_design``,
reference step 0.3 rad), a 64 x 64 (eps, gamma) map of 20 s runs:

* **in process**: ``fl.sweep(..., kernel=fl.Kernel(threads=2))`` (the default: all cores);
* **process pool**: ``concurrent.futures.ProcessPoolExecutor(2)`` (fork), one thread per task;
* **Dask**: a ``LocalCluster(n_workers=2, threads_per_worker=1)`` through
  ``client.get_executor()`` (skipped, with the reason, when dask.distributed is missing).

The executors are started before the timing and warmed by one small sweep (workers load the
compiled kernel once: what a user's long-lived cluster looks like); then rounds interleave the
three, and each ratio is the median over rounds of ``t_executor / t_in_process`` measured in the
same round. Every executor's map must classify every run as the in-process map does.

Target (exit status 1 when missed; ``--quick`` runs a 16 x 16 map of 2 s and checks only the
classifications): Dask on 2 local workers within 1.2x of in process; the process pool too.

    python verify/bench_scaleout.py [--quick] [--rounds R]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

import fl_design as fl

TARGET = 1.2


def _sweep(plant, design, sc, grid, **kw):
    return fl.sweep(plant, design, sc, progress=False, **grid, **kw)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--rounds", type=int, default=None)
    args = ap.parse_args(argv)
    n, duration = (16, 2.0) if args.quick else (64, 20.0)
    n_rounds = args.rounds or (1 if args.quick else 5)
    info = fl.Kernel().describe()
    print(f"machine: {info['cpu']} ({info['machine']}), {os.cpu_count()} cores, isa "
          f"{info['isa']} ({info['lanes']} lanes); load {os.getloadavg()[0]:.2f}")
    plant, design = fl.plants.trms_yaw(), fl.presets.paper_design()
    sc = fl.Scenario(0.3, duration)
    grid = {"eps": np.geomspace(1e-3, 1.0, n), "gamma": np.geomspace(1e-5, 1e-1, n)}
    warm = {"eps": grid["eps"][:4], "gamma": grid["gamma"][:4]}
    ref = _sweep(plant, design, sc, grid, kernel=fl.Kernel(threads=2))
    executors = {"process pool": ProcessPoolExecutor(2)}
    cluster = client = None
    try:
        from dask.distributed import Client, LocalCluster

        cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client = Client(cluster)
        executors["dask"] = client.get_executor()
    except ImportError as exc:
        print(f"dask: skipped ({exc}); pip install fl_design[dask]")
    ok = True
    try:
        for ex in executors.values():
            _sweep(plant, design, sc, warm, executor=ex)  # workers load the kernel once
        times = {"in process": [], **{name: [] for name in executors}}
        ratios = {name: [] for name in executors}
        for _ in range(n_rounds):
            t0 = time.perf_counter()
            _sweep(plant, design, sc, grid, kernel=fl.Kernel(threads=2))
            t_in = time.perf_counter() - t0
            times["in process"].append(t_in)
            for name, ex in executors.items():
                t0 = time.perf_counter()
                got = _sweep(plant, design, sc, grid, executor=ex)
                t = time.perf_counter() - t0
                times[name].append(t)
                ratios[name].append(t / t_in)
                if not np.array_equal(got.status, ref.status):
                    print(f"  {name}: classifications DIFFER from the in-process map")
                    ok = False
        print(f"{n} x {n} map of {duration:g} s runs, {n_rounds} interleaved rounds "
              f"(median time; median of per-round ratios):")
        print(f"  in process (2 threads): {statistics.median(times['in process']):.2f} s")
        for name in executors:
            r = statistics.median(ratios[name])
            met = r <= TARGET
            print(f"  {name:<13} {statistics.median(times[name]):.2f} s = {r:.2f}x in process "
                  f"(target <= {TARGET}x: {'met' if met or args.quick else 'MISSED'})")
            if not args.quick:
                ok &= met
        if ok or args.quick:
            print("classifications: every executor's map equals the in-process map")
    finally:
        for ex in executors.values():
            if isinstance(ex, ProcessPoolExecutor):
                ex.shutdown()
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
