"""Benchmark of the closed-loop kernel and of a 64 x 64 (eps, gamma) sweep of the TRMS yaw loop.

Prints, from one run (medians of repeats):

1. ns per closed-loop step of the sweep kernel (1 thread, and the throughput with all cores);
2. the ratio to the straightforward per-sample ``scipy.integrate.solve_ivp`` loop (design
   step evaluated by CasADi, plant integrated by ``solve_ivp`` over each sample)
   -- target >= 200x faster;
3. the ratio to a plain C loop of the same CasADi-generated step and integrator (``fl_loop``:
   measurement, design step, RK4), compiled with the same flags -- target <= 1.5x;
4. the wall time of a 64 x 64 TRMS map of 20 s runs at T = 1 ms, compilation included (fresh
   kernel cache) -- target <= 60 s on 2 cores;
5. the peak memory traced during 8 x 8 and 32 x 32 sweeps: per extra run only its running
   metrics (a few hundred bytes), no trajectories.

Exits with status 1 when a target is missed. ``--quick`` runs a reduced version (short runs,
8 x 8 map, targets not checked): the tests run it to see that it works.

    python verify/bench_sweep.py [--quick]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
import tracemalloc

import numpy as np
import scipy.integrate
import sympy as sp

import fl_design as fl
from fl_design.codegen import build, generate_source
from fl_design.sim import STATUS_CODES, prepare_run

T = 1e-3
REFERENCE = 0.3


def trms_design(eps: float = 0.05, gamma: float = 3e-4) -> fl.Design:
    """The paper's TRMS yaw design (``fl.presets.paper_design``)."""
    return fl.presets.paper_design(eps, gamma)


_MAIN = r"""
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
int main(int argc, char** argv) {{
  long N = atol(argv[1]); int reps = atoi(argv[2]), rep; long k; int i;
  const casadi_real* arg[{sz_arg}]; casadi_real* res[{sz_res}];
  casadi_int iw[{sz_iw}]; casadi_real w[{sz_w}];
  static const double p[{n_p}] = {{ {p} }};
  static const double x_init[{n}] = {{ {x0} }}, s_init[{m}] = {{ {s0} }};
  double *rr = malloc(N * sizeof(double)), *ww = malloc(N * sizeof(double));
  double times[64], q = 0.0;
  for (k = 0; k < N; ++k) {{ rr[k] = {r}; ww[k] = 0.0; }}
  for (rep = 0; rep < reps && rep < 64; ++rep) {{
    double x[{n}], s[{m}], xn[{n}], sn[{m}], u, y, ym, xhat[{rho1}], sig;
    struct timespec t0, t1;
    for (i = 0; i < {n}; ++i) x[i] = x_init[i];
    for (i = 0; i < {m}; ++i) s[i] = s_init[i];
    clock_gettime(CLOCK_MONOTONIC, &t0);
    for (k = 0; k < N; ++k) {{
      arg[0] = x; arg[1] = s; arg[2] = rr + k; arg[3] = ww + k; arg[4] = &q; arg[5] = p;
      res[0] = xn; res[1] = sn; res[2] = &u; res[3] = &y; res[4] = &ym; res[5] = xhat;
      res[6] = &sig;
      if (fl_loop(arg, res, iw, w, 0)) return 1;
      for (i = 0; i < {n}; ++i) x[i] = xn[i];
      for (i = 0; i < {m}; ++i) s[i] = sn[i];
    }}
    clock_gettime(CLOCK_MONOTONIC, &t1);
    times[rep] = ((t1.tv_sec - t0.tv_sec) * 1e9 + (t1.tv_nsec - t0.tv_nsec)) / N;
    printf("%.6f %.17g\n", times[rep], x[0]);
  }}
  return 0;
}}
"""


def plain_c_ns(run, cache_dir: str, repeats: int) -> tuple[float, float]:
    """Median ns per step of a plain C loop over the generated ``fl_loop``; and its final y."""
    loop, design = run.loop, run.loop.design
    f = loop.sample
    fmt = lambda a: ", ".join(repr(float(v)) for v in np.ravel(a))
    source = "#define _POSIX_C_SOURCE 199309L\n" + generate_source(f) + _MAIN.format(
        sz_arg=max(1, f.sz_arg()), sz_res=max(1, f.sz_res()), sz_iw=max(1, f.sz_iw()),
        sz_w=max(1, f.sz_w()), n_p=loop.n_p, p=fmt(design.parameter_vector()), n=loop.n,
        m=loop.m, x0=fmt(run.x0), s0=fmt(design.initial_state()), r=repr(float(run.r[0])),
        rho1=loop.rho + 1)
    exe = build(source, "fl_plain_loop", shared=False, cache_dir=cache_dir)
    if exe is None:
        raise SystemExit("bench: no C compiler: cannot build the plain C loop")
    out = subprocess.run([str(exe), str(run.N), str(repeats)], capture_output=True, text=True,
                         check=True).stdout.split("\n")
    rows = [line.split() for line in out if line.strip()]
    return statistics.median(float(r[0]) for r in rows), float(rows[-1][1])


def kernel_ns(run, cache_dir: str, repeats: int, columns: int, threads: int) -> float:
    """Median ns per closed-loop step of the compiled sweep kernel over ``columns`` runs."""
    runner = run.loop.runner(cache_dir=cache_dir)
    P = np.tile(run.loop.design.parameter_vector()[:, None], (1, columns))
    acc0, D = run.initial_accumulator(P), run.D
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        acc = runner.run(acc0, D, threads=threads)
        times.append(time.perf_counter() - t0)
    assert np.all(acc[run.loop.layout.slices["k"]] == run.N)
    return statistics.median(times) / (columns * run.N) * 1e9


def solve_ivp_ns(plant, design, n_samples: int, repeats: int) -> float:
    """Median ns per sample of the straightforward loop: CasADi design step + solve_ivp."""
    rhs = sp.lambdify([list(plant.states), plant.input],
                      list(plant.rhs.subs(plant.params)), modules="numpy")
    h = sp.lambdify([list(plant.states)], plant.output.subs(plant.params), modules="numpy")
    step = design.step
    times = []
    for _ in range(repeats):
        x, s = plant.x_op.astype(float).copy(), design.initial_state()
        t0 = time.perf_counter()
        for k in range(n_samples):
            s_next, u = step(s, float(h(x)), REFERENCE)
            s, u = np.asarray(s_next).ravel(), float(u)
            sol = scipy.integrate.solve_ivp(lambda t, z, u=u: rhs(z, u), (k * T, (k + 1) * T), x)
            x = sol.y[:, -1]
        times.append(time.perf_counter() - t0)
    return statistics.median(times) / n_samples * 1e9


def trms_map(n_grid: int, duration: float, threads: int) -> tuple[float, object]:
    """Wall time of an n x n TRMS map with a fresh kernel cache (plant and compile included)."""
    with tempfile.TemporaryDirectory() as cache:
        t0 = time.perf_counter()
        plant = fl.plants.trms_yaw()
        smap = fl.sweep(plant, trms_design(), fl.Scenario(REFERENCE, duration), eps=np.geomspace(1e-3, 1.0, n_grid), gamma=np.geomspace(1e-5, 1e-1, n_grid), progress=False, kernel=fl.Kernel(cache_dir=cache, threads=threads))
        return time.perf_counter() - t0, smap


def peak_memory(plant, design, duration: float, n_grid: int, cache_dir: str) -> float:
    """Peak traced Python memory (MB) of a sweep."""
    tracemalloc.start()
    fl.sweep(plant, design, fl.Scenario(REFERENCE, duration), eps=np.geomspace(0.01, 0.5, n_grid), gamma=np.geomspace(1e-4, 1e-2, n_grid), progress=False, kernel=fl.Kernel(cache_dir=cache_dir))
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak / 1e6


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="reduced run, targets not checked")
    args = parser.parse_args(argv)
    quick = args.quick
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    duration, n_grid = (2.0, 8) if quick else (20.0, 64)
    reps = 3 if quick else 7
    plant, design = fl.plants.trms_yaw(), trms_design()
    run = prepare_run(plant, design, fl.Scenario(REFERENCE, duration))
    print(f"fl_design sweep benchmark{' (--quick)' if quick else ''}: TRMS yaw, T = {T:g} s, "
          f"RK4 with {run.loop.substeps} substeps, {cores} cores available")
    ok = True
    with tempfile.TemporaryDirectory() as cache:
        ns1 = kernel_ns(run, cache, reps, 16 if quick else 64, threads=1)
        nsp = kernel_ns(run, cache, reps, 16 if quick else 64, threads=cores)
        print(f"kernel: {ns1:.1f} ns per closed-loop step (1 thread, median of {reps}); "
              f"{nsp:.1f} ns/step throughput with {cores} threads")
        plain, _y_plain = plain_c_ns(run, cache, reps)
        ratio_c = ns1 / plain
        print(f"plain C loop of the same generated step and integrator: {plain:.1f} ns per step "
              f"(median of {reps})")
        good = ratio_c <= 1.5
        ok &= good
        print(f"  ratio kernel / plain C = {ratio_c:.2f}  (target <= 1.5)  "
              f"{'PASS' if good else 'FAIL'}")
        n_ivp = 200 if quick else 1000
        ivp = solve_ivp_ns(plant, design, n_ivp, 1 if quick else 3)
        ratio_ivp = ivp / ns1
        good = ratio_ivp >= 200
        ok &= good
        print(f"per-sample solve_ivp loop: {ivp / 1e3:.1f} us per step ({n_ivp} samples)")
        print(f"  ratio solve_ivp / kernel = {ratio_ivp:.0f}x  (target >= 200x)  "
              f"{'PASS' if good else 'FAIL'}")
        peak_memory(plant, design, 2.0, 8, cache)  # warm-up: kernel built and loaded
        dur_m = 2.0 if quick else duration
        mem = {g: peak_memory(plant, design, dur_m, g, cache) for g in (8, 32)}
        per_run = (mem[32] - mem[8]) / (32 * 32 - 8 * 8) * 1e6
        print(f"peak traced memory of sweeps of {dur_m:g} s runs: {mem[8]:.2f} MB (8 x 8), "
              f"{mem[32]:.2f} MB (32 x 32); {per_run:.0f} bytes per extra run (running "
              f"metrics only, no trajectories; the {run.N}-sample reference/noise inputs are "
              "shared)")
    wall, smap = trms_map(n_grid, duration, cores)
    steps = n_grid * n_grid * run.N
    counts = {name: int(np.sum(smap.status == code)) for name, code in STATUS_CODES.items()}
    good = wall <= 60.0
    ok &= good
    print(f"{n_grid} x {n_grid} TRMS map of {duration:g} s runs ({steps:,} closed-loop steps), "
          f"compilation included, {cores} cores: {wall:.1f} s wall  (target <= 60 s)  "
          f"{'PASS' if good else 'FAIL'}")
    print(f"  {steps / wall / 1e6:.1f} M steps/s; status counts {counts}")
    if quick:
        print("quick mode: targets not enforced")
        return 0
    print("all targets met" if ok else "SOME TARGETS MISSED")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
