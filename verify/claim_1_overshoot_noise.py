"""Claim 1 (paper, Sec. 6): with sensor noise the EHGO overshoots less than LS(26), which
overshoots less than LS(9) (hardware: 36 %, 70 %, over 100 %).

Same controller for all (K = (2, 4), gamma = 3e-4, k_I = 1e-3, |xhat_2| <= 0.05), TRMS yaw
static-motor model, 0.3 rad step. Checked at noise std 1e-3 over several seeds (median);
reported, not checked, at std sqrt(1e-3), the paper's "variance 0.001", where LS(9) no longer
tracks. Exit 1 when the ordering fails. ``--quick``: 12 s runs, 2 seeds.
"""

from __future__ import annotations

import numpy as np
from _shared import quick_args

import fl_design as fl
from fl_design.app._report_sections import overshoot_text

PAPER = {"EHGO": "36 %", "LS(26)": "70 %", "LS(9)": "over 100 %"}


def designs():
    return {"EHGO": fl.presets.paper_design(), "LS(26)": fl.presets.least_squares_design(26),
            "LS(9)": fl.presets.least_squares_design(9)}


def runs(std: float, duration: float, seeds) -> dict:
    plant = fl.plants.trms_yaw()
    return {name: [fl.simulate(plant, d, fl.Scenario(0.3, duration, noise=fl.Noise(std, seed=s)))
                   for s in seeds] for name, d in designs().items()}


def main(argv=None) -> int:
    args = quick_args(__doc__, "12 s runs, 2 seeds", argv)
    duration, seeds = (12.0, (1, 2)) if args.quick else (30.0, (1, 2, 3, 4, 5))
    free = runs(0.0, duration, (1,))
    print(f"TRMS yaw, 0.3 rad step, {duration:g} s runs (overshoot %, median over seeds "
          f"{list(seeds)})")
    print(f"  {'estimator':<8}{'paper (hardware)':>18}{'no noise':>10}{'std 1e-3':>10}"
          "   std sqrt(1e-3)")
    noisy, loud = runs(1e-3, duration, seeds), runs(float(np.sqrt(1e-3)), duration, seeds[:1])
    med = {n: float(np.median([r.overshoot for r in rs])) for n, rs in noisy.items()}
    for name in designs():
        print(f"  {name:<8}{PAPER[name]:>18}{free[name][0].overshoot:>10.1f}{med[name]:>10.1f}"
              f"   {overshoot_text(loud[name][0])} ({loud[name][0].status})")
    print(f"\nEHGO noise-free verdict: {free['EHGO'][0].verdict()}")
    ok = med["EHGO"] < med["LS(26)"] < med["LS(9)"]
    print(f"ordering EHGO < LS(26) < LS(9) at std 1e-3: {'holds' if ok else 'FAILS'} "
          f"({med['EHGO']:.1f} < {med['LS(26)']:.1f} < {med['LS(9)']:.1f})")
    print("Differences from the paper: the simulated EHGO overshoot (about 45 %) is above the "
          "hardware's 36 % already without noise (the model's friction and actuator differ from "
          "the rig); at std sqrt(1e-3) the noise swamps LS(9), whose output stays near 0: it "
          "does not track, so its overshoot is no measure there.")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
