"""Claim 8 (paper, Conclusions): compared with the data-driven estimator the proposed method
"exhibits better performance in terms of overshoot, settling time, and robustness to sensor
noise".

The paper's experiment (TRMS yaw, 0.3 rad step, the same controller K = (2, 4),
gamma = 3e-4, k_I = 1e-3 behind the EHGO (eps = 0.05 s), LS(26) and LS(9)) simulated on the
static-motor model, 400 s runs (the integrator's slow mode settles after about 250 s), the
settling time in the classifier's band (2 % of the step):

* without noise, reported: the three settle within 1 % of each other (the estimators differ
  only in noise and delay, and the loop is far slower than either);
* with sensor noise of std 1e-3 (median over seeds): checked, the EHGO settles first, then
  LS(26), then LS(9) (a run that does not settle within 400 s counts as slower than any that
  does). So the settling-time advantage is a noise effect, which the script says.

Exit 1 when the ordering with noise fails. ``--quick``: one seed.
"""

from __future__ import annotations

import math

import numpy as np
from _shared import quick_args

import fl_design as fl

DURATION = 400.0


def designs() -> dict:
    return {"EHGO": fl.presets.paper_design(), "LS(26)": fl.presets.least_squares_design(26),
            "LS(9)": fl.presets.least_squares_design(9)}


def settling(std: float, seeds) -> dict:
    """Median settling time (inf when a run does not settle) per estimator."""
    plant = fl.plants.trms_yaw()
    out = {}
    for name, d in designs().items():
        times = [fl.simulate(plant, d, fl.Scenario(0.3, DURATION, noise=fl.Noise(std, seed=s)))
                 .settling_time for s in seeds]
        out[name] = float(np.median([t if math.isfinite(t) else math.inf for t in times]))
    return out


def text(t: float) -> str:
    return f"{t:.1f} s" if math.isfinite(t) else f"not within {DURATION:g} s"


def main(argv=None) -> int:
    args = quick_args(__doc__, "one seed", argv)
    seeds = (1,) if args.quick else (1, 2, 3, 4, 5)
    print("Paper (Conclusions): better 'overshoot, settling time, and robustness to sensor "
          "noise' than the data-driven estimator.")
    free, noisy = settling(0.0, (1,)), settling(1e-3, seeds)
    print(f"TRMS yaw, 0.3 rad step, {DURATION:g} s runs, settling into the 2 % band "
          f"(median over seeds {list(seeds)} with noise):")
    print(f"  {'estimator':<10}{'no noise':>16}{'noise std 1e-3':>22}")
    for name in designs():
        print(f"  {name:<10}{text(free[name]):>16}{text(noisy[name]):>22}")
    spread = max(free.values()) / min(free.values()) - 1.0
    print(f"without noise the three settle within {100 * spread:.2f} % of each other (reported)")
    e, l26, l9 = noisy["EHGO"], noisy["LS(26)"], noisy["LS(9)"]
    ok = e < l26 and e < l9 and l26 <= l9
    print(f"with noise: EHGO {text(e)} < LS(26) {text(l26)} <= LS(9) {text(l9)}: "
          f"{'holds' if ok else 'FAILS'}")
    print("What it means: the EHGO's advantage in settling time comes from noise rejection; "
          "without noise the same controller settles the same with any of the estimators.")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
