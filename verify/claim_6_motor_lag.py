"""Claim 6 (the hardware's situation): the rho = 2 design on the TRMS with its motor lag
(relative degree 3: an unmodeled actuator) still tracks for a small enough eps.

Needs ``fl.simulate(..., allow_unmodeled=True)`` (issue 10); without it the script says
"skipped" and exits 0. With it: the paper's design (eps = 0.05) on ``trms_yaw(motor_lag=True)``
must stay bounded; its verdict and overshoot are printed beside the static-motor run.
"""

from __future__ import annotations

import argparse
import inspect

import fl_design as fl


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="12 s runs")
    args = parser.parse_args(argv)
    if "allow_unmodeled" not in inspect.signature(fl.simulate).parameters:
        print("skipped: needs allow_unmodeled (issue 10)")
        return 0
    duration = 12.0 if args.quick else 30.0
    design, scenario = fl.presets.paper_design(), fl.Scenario(0.3, duration)
    static = fl.simulate(fl.plants.trms_yaw(), design, scenario)
    lag = fl.simulate(fl.plants.trms_yaw(motor_lag=True), design, scenario,
                      allow_unmodeled=True)
    print("paper (hardware, motor lag present): overshoot 36 %")
    print(f"static motor model: {static.verdict()}")
    print(f"motor-lag model:    {lag.verdict()}")
    ok = lag.bounded
    print("holds (bounded with the unmodeled actuator)" if ok else "FAILS: not bounded")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
