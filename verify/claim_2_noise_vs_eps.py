"""Claim 2 (paper, Sec. 6): the noise in sigmahat and u falls when eps rises (0.05 -> 0.5).

TRMS yaw, the paper's controller, sensor noise std sqrt(1e-3) (the paper's variance 0.001).
Noise level = std(diff(x))/sqrt(2) over the last 20 % of the run (sample-to-sample jitter).
Exit 1 unless both fall by at least a factor 10. ``--quick``: 6 s runs.
"""

from __future__ import annotations

import numpy as np
from _shared import quick_args

import fl_design as fl
from fl_design.app._job import noise_levels


def main(argv=None) -> int:
    args = quick_args(__doc__, "6 s runs", argv)
    duration = 6.0 if args.quick else 30.0
    plant, std = fl.plants.trms_yaw(), float(np.sqrt(1e-3))
    levels = {}
    print(f"TRMS yaw, noise std {std:.4f} rad, {duration:g} s runs; paper: the noise in the "
          "estimate and the input is suppressed by increasing eps")
    print(f"  {'eps (s)':<8}{'sigmahat noise':>16}{'u noise (V)':>14}  verdict")
    for eps in (0.05, 0.1, 0.2, 0.5):
        resp = fl.simulate(plant, fl.presets.paper_design(eps=eps),
                           fl.Scenario(0.3, duration, noise=fl.Noise(std, seed=1)))
        levels[eps] = noise_levels(resp)
        print(f"  {eps:<8g}{levels[eps]['sigmahat_noise']:>16.4g}"
              f"{levels[eps]['u_noise']:>14.4g}  {resp.status}")
    ratio_s = levels[0.05]["sigmahat_noise"] / levels[0.5]["sigmahat_noise"]
    ratio_u = levels[0.05]["u_noise"] / levels[0.5]["u_noise"]
    ok = ratio_s > 10 and ratio_u > 10
    print(f"eps 0.05 -> 0.5: sigmahat noise / {ratio_s:.3g}, u noise / {ratio_u:.3g}: "
          f"{'holds' if ok else 'FAILS'}")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
