"""Benchmark: the step certificate of the main job and the certify stage's tail, in process
(issue 33).

The default job (``fl.app.load_config(None)``: the TRMS, the paper's design, the 0.3 rad step)
ends its certify stage with :func:`fl_design.certify_step` on the plant (regions about the
target, each an LDI certificate, a start-covering LMI and the sector ellipsoids), the loop
margins at both ends of ``b`` and :func:`fl_design.linearized_eps_star` for the stage's gains
and the design. This script times exactly that, in one process after a warm-up (the imports
and the plant's derivations paid once), ``--repeat`` rounds, and prints the median CPU time
(``time.process_time``: single-threaded work, the better measure under load), the wall time,
the conic programs solved, the answer (certified or not, the largest certified step, the
region) and the machine with its load. Target: CPU <= 1.5 s (2 shared cores, idle); a miss
exits 1. ``--quick``: the pendulum's 0.1 rad step, one round, the answer checked (certified),
the time not judged (the tests run it).

    python verify/bench_step_cert.py [--quick] [--repeat N]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
from _shared import machine, target

import fl_design as fl
from fl_design.analysis import linearized_eps_star, loop_margins
from fl_design.analysis._lmi import solve_count

TARGET_S = 1.5


def _case(quick: bool):
    """``(plant, design, reference, gammas, eps_range)`` of the job (or the quick case)."""
    if quick:
        return (fl.plants.pendulum(), fl.presets.pendulum_design(), 0.1,
                np.geomspace(1e-3, 1e-1, 4), (0.01, 2.0))
    from fl_design.app import load_config
    from fl_design.app._build import build_setup

    setup = build_setup(load_config(None))
    cfg = setup.config
    return (setup.plant, setup.design, float(cfg.scenario.reference),
            np.geomspace(*cfg.certify.gamma, cfg.certify.points),
            tuple(cfg.certify.eps_range or cfg.sweep.eps))


def one_round(plant, design, r, gammas, eps_range):
    """The step certificate and the tail, timed: ``(cpu, wall, programs, certificate)``."""
    c0, w0, n0 = time.process_time(), time.perf_counter(), solve_count()
    cert = fl.certify_step(plant, design, fl.Scenario(r))
    for b in plant.b_bounds():
        loop_margins(design, b, statespace=False)
    for g in gammas:
        linearized_eps_star(plant, design, gamma=float(g), eps_range=eps_range)
    linearized_eps_star(plant, design, eps_range=eps_range)
    return (time.process_time() - c0, time.perf_counter() - w0, solve_count() - n0, cert)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="the pendulum's step, one round, the time not judged")
    parser.add_argument("--repeat", type=int, default=3, help="timed rounds (median)")
    args = parser.parse_args(argv)
    case = _case(args.quick)
    one_round(*case)  # warm-up: imports, derivations, compiled functions
    rounds = [one_round(*case) for _ in range(1 if args.quick else max(1, args.repeat))]
    cpu = statistics.median(r[0] for r in rounds)
    wall = statistics.median(r[1] for r in rounds)
    _, _, programs, cert = rounds[-1]
    print(machine())
    print(f"step certificate of {case[0].name!r} ({case[2]:g} step) + margins + "
          f"{len(case[3]) + 1} linearized eps*: CPU {cpu:.2f} s (median of {len(rounds)}), "
          f"wall {wall:.2f} s, {programs} conic programs")
    print(f"answer: {'certified' if cert.certified else 'not certified'}, largest certified "
          f"step {cert.largest_step:.4g}, region scale {cert.region_scale}")
    ok = target("step certificate + tail CPU", cpu, TARGET_S, checked=not args.quick,
                detail=f"{case[0].name}, {programs} conic programs")
    if args.quick:
        ok = bool(cert.certified)  # the pendulum's 0.1 rad step is certified
        print(f"the pendulum's 0.1 rad step certified: {'holds' if ok else 'FAILS'}")
    else:
        print(f"target CPU <= {TARGET_S:g} s: {'met' if ok else 'MISSED'}")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
