"""Benchmark: the time of a 50-point eps*(gamma) curve of the paper's TRMS design.

For 50 log-spaced gains in ``[1.5e-4, 1e-2]`` (TRMS static motor, ``b in [3.6, 6.8]``,
``K = (2, 4)``, ``k_I = 1e-3``, ``alpha = (6, 11, 6)``, ``T = 1 ms``) computes the frozen-b
``eps*`` and the certified ``eps*`` (certificates re-checked in NumPy) with
:func:`fl_design.eps_star_curve` in this one process, and prints the wall time, the
certified/frozen ratios (also at the issue's gains 3e-4, 1e-3, 3e-3, untimed) and the load
average. The curve certifies *frozen* ``b`` (each constant ``b``; ``certify_eps`` brackets the
varying-``b`` eps*). Target: under 5 s on the development machine (2 cores, idle); exits with status 1 on a
miss, when a certified eps* exceeds its frozen one (soundness) or when a ratio at the issue's
gains is below 0.8. ``--quick`` computes 4 points and checks soundness and the ratios only (the
tests run it).

    python verify/bench_certify.py [--quick]
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

import fl_design as fl

TARGET_S = 5.0
ISSUE_GAMMAS = (3e-4, 1e-3, 3e-3)


def main(argv=None) -> int:
    """Run the benchmark; return the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="4 points, no time target")
    args = parser.parse_args(argv)
    n = 4 if args.quick else 50
    gammas = np.geomspace(1.5e-4, 1e-2, n)
    design = fl.presets.paper_design()
    fl.eps_star_curve(design, (3.6, 6.8), gammas[:1])  # warm-up: CasADi and CVXPY compile
    t0, c0 = time.perf_counter(), time.process_time()
    curve = fl.eps_star_curve(design, (3.6, 6.8), gammas)
    elapsed, cpu = time.perf_counter() - t0, time.process_time() - c0
    ratio = curve.ratio
    print(f"{n}-point eps*(gamma) curve (certified for {curve.covers} b): {elapsed:.2f} s "
          f"(target < {TARGET_S:g} s); CPU time of this process {cpu:.2f} s")
    print(f"certified/frozen ratio: min {np.nanmin(ratio):.3f}, median "
          f"{np.nanmedian(ratio):.3f} over {int(np.sum(np.isfinite(ratio)))} certified gains")
    ok = bool(np.all(~(curve.eps_star_certified > curve.eps_star_frozen)))
    if not ok:
        print("FAIL: a certified eps* exceeds the frozen eps* (unsound)")
    issue = fl.eps_star_curve(design, (3.6, 6.8), ISSUE_GAMMAS)
    print("certified/frozen at gamma " + ", ".join(
        f"{g:g}: {r:.3f}" for g, r in zip(ISSUE_GAMMAS, issue.ratio)))
    if not np.all(issue.ratio >= 0.8):
        print("FAIL: a ratio at the issue's gains is below 0.8")
        ok = False
    print("load average (1, 5, 15 min): " + ", ".join(f"{x:.2f}" for x in os.getloadavg()))
    if not args.quick and elapsed >= TARGET_S:
        print(f"MISS: {elapsed:.2f} s >= {TARGET_S:g} s")
        ok = False
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
