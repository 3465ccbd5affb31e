"""Benchmark: a Monte Carlo of n plants against a sweep of n grid points (same run length).

``fl.monte_carlo`` runs one design against ``n`` plants whose uncertain parameters are run-time
inputs of the compiled kernel (one build for all samples); ``fl.sweep`` runs ``n`` (eps, gamma)
points of one plant. Both are whole calls (argument checks, setup, the runs, the
classification), timed in interleaved rounds; the ratio is the median of the per-round ratios
``t_monte_carlo / t_sweep``. The workloads are comparable: the pendulum
(``fl.presets.pendulum_design``, T = 1 ms, reference step 0.1 rad, 10 s runs, RK4 with one
substep), the family ``c ~ U(0.05, 1)``, ``b ~ N(1, 0.1)`` around the design, and a 32 x 32 grid
around the design's (eps, gamma) where the runs stay bounded, so both compute about the
same number of steps (the steps computed are printed: a diverged run stops early).

It also times one Monte Carlo of 1000 samples of 10 s on its own (compiled kernel warm).

Targets (exit status 1 when one is missed; ``--quick`` runs a reduced version and checks none):
Monte Carlo within 1.5x the sweep (median ratio <= 1.5); 1000 samples of 10 s within 5 s.

    python verify/bench_monte_carlo.py [--quick] [--rounds R]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np

import fl_design as fl

PARAMS = {"c": (0.05, 1.0), "b": fl.Normal(1.0, 0.1)}
RATIO_TARGET = 1.5
THOUSAND_TARGET = 5.0


def _steps(status_metrics, duration: float, T: float) -> int:
    """Steps computed: a diverged run stops at its divergence."""
    div = np.asarray(status_metrics, dtype=float).ravel()
    n_full = round(duration / T)
    return int(np.sum(np.where(np.isfinite(div), np.round(div / T), n_full)))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="reduced sizes, no targets checked")
    ap.add_argument("--rounds", type=int, default=None, help="interleaved rounds (default 5)")
    args = ap.parse_args(argv)
    quick = args.quick
    rounds = args.rounds or (2 if quick else 5)
    side, duration = (8, 2.0) if quick else (32, 10.0)
    n = side * side
    print(f"isa {fl.Kernel().describe()}")
    plant, design = fl.plants.pendulum(), fl.presets.pendulum_design()
    scenario = fl.Scenario(0.1, duration)
    eps = np.geomspace(0.01, 0.03, side)
    gamma = np.geomspace(0.004, 0.015, side)

    def run_mc():
        return fl.monte_carlo(plant, design, scenario, params=PARAMS, n=n, seed=0,
                              progress=False)

    def run_sweep():
        return fl.sweep(plant, design, scenario, eps=eps, gamma=gamma, progress=False)

    ens, smap = run_mc(), run_sweep()  # warm: compiled kernels in the cache, plant derived
    steps_mc = _steps(ens.metrics["divergence_time"], duration, design.T)
    steps_sw = _steps(smap.metrics["divergence_time"], duration, design.T)
    print(f"workload: {n} runs of {duration:g} s each; Monte Carlo "
          f"{ens.convergent_fraction:.0%} converge, {steps_mc:,} steps; sweep "
          f"{np.mean(np.isin(smap.status, (1, 2))):.0%} converge, {steps_sw:,} steps")
    ratios, t_mc, t_sw = [], [], []
    for _ in range(rounds):
        t0 = time.perf_counter()
        run_mc()
        t1 = time.perf_counter()
        run_sweep()
        t2 = time.perf_counter()
        t_mc.append(t1 - t0)
        t_sw.append(t2 - t1)
        ratios.append((t1 - t0) / (t2 - t1))
    ratio = statistics.median(ratios)
    print(f"Monte Carlo {statistics.median(t_mc):.3f} s, sweep {statistics.median(t_sw):.3f} s "
          f"(medians of {rounds} rounds); ratio t_mc / t_sweep median {ratio:.3f} "
          f"(rounds: {', '.join(f'{r:.3f}' for r in ratios)})")
    m = 64 if quick else 1000
    t0 = time.perf_counter()
    big = fl.monte_carlo(plant, design, fl.Scenario(0.1, duration), params=PARAMS, n=m,
                         seed=1, progress=False)
    t_big = time.perf_counter() - t0
    print(f"{m} samples of {duration:g} s: {t_big:.2f} s ({big})")
    if quick:
        print("quick mode: targets not checked")
        return 0
    ok = True
    for name, value, target in (("ratio", ratio, RATIO_TARGET),
                                ("1000 samples (s)", t_big, THOUSAND_TARGET)):
        holds = value <= target
        ok &= holds
        print(f"target {name} <= {target:g}: {value:.3f} {'holds' if holds else 'MISSED'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
