"""The paper's experiment in simulation: EHGO vs the least-squares baseline on the TRMS yaw plant.

Same controller for every estimator (k = (2, 4), gamma = 3e-4, k_I = 1e-3, |xhat_2| <= 0.05,
T = 1 ms, 0.3 rad step). Estimators: EHGO with eps = 0.05 and 0.5 (s^3 + 6 s^2 + 11 s + 6), the
least-squares fit over 9 and 26 samples. Printed: overshoot, input RMS and total variation,
estimation error RMS and the computational cost per sample, without and with sensor noise of
variance 1e-3 (the paper's noise experiment).

Run ``python examples/paper_comparison.py`` (20 s runs) or ``--quick`` (3 s runs, for the tests).
"""

from __future__ import annotations

import argparse

import numpy as np

import fl_design as fl
from fl_design.presets import least_squares_design as baseline_design
from fl_design.presets import paper_design


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="3 s runs instead of 20 s")
    parser.add_argument("--seed", type=int, default=1, help="noise seed")
    args = parser.parse_args(argv)
    duration = 3.0 if args.quick else 20.0
    plant = fl.plants.trms_yaw()
    designs = {"EHGO eps=0.05": paper_design(0.05), "EHGO eps=0.5": paper_design(0.5),
               "LS N=9": baseline_design(9), "LS N=26": baseline_design(26)}
    for noise_var in (0.0, 1e-3):
        print(f"\n0.3 rad step, {duration:g} s, sensor noise variance {noise_var:g}")
        print(f"  {'estimator':<15}{'status':>10}{'overshoot %':>13}{'u RMS':>9}{'u TV':>11}"
              f"{'sigma err RMS':>15}{'flops':>7}")
        for name, design in designs.items():
            resp = fl.simulate(plant, design, fl.Scenario(0.3, duration, noise=fl.Noise(std=np.sqrt(noise_var), seed=args.seed)))
            print(f"  {name:<15}{resp.status:>10}{resp.overshoot:>13.1f}{resp.input_rms:>9.3f}"
                  f"{resp.input_tv:>11.2f}{resp.estimation_rms[-1]:>15.4g}"
                  f"{design.estimator.flops_per_step:>7d}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
