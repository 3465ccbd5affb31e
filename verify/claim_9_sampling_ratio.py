"""Claim 9 (paper, Sec. 5): with ``T = alpha eps`` and ``alpha <= 1`` the sampling terms are
``O(eps)`` (``||f|| <= H T ||x|| = H alpha eps ||x|| <= H eps ||x||``), which the proof of
Theorem 1 needs; what happens at ``alpha > 1``, which the bilinear EHGO and the certificate
search (``certify_eps(eps_range=...)`` below ``T``) allow?

Measured at the paper's T = 1 ms with the paper's EHGO (rho = 2, coefficients 6, 11, 6),
alpha = T/eps from 0.01 to 30 (eps from 0.1 s to 33 us):

1. the noise-free estimation error of ``sigmahat`` on a smooth signal (``y = sin 2t``, its
   second derivative known) over the second half of a 20 s run: checked, it stays ``O(eps)``
   on both sides of ``alpha = 1`` (fitted log-log slopes in ``[0.9, 1.1]`` for alpha <= 1 and
   for alpha >= 1): the bilinear discretization keeps the estimate's accuracy when ``T > eps``;
2. the TRMS closed loop (the paper's controller) at alpha = 0.02 (paper), 1, 2 and 10:
   checked, the surrogate is certified for varying b at each (``certify_eps(search=False)``)
   and the nonlinear loop converges in a 400 s simulation;
3. the price: the input's noise gain (:func:`fl_design.analysis.noise_gain`) grows by a
   fitted power of eps steeper than ``eps^-1`` (checked) — so ``alpha <= 1`` is a condition of
   the proof, not of stability; at ``alpha > 1`` what fails is noise, not the loop.

Exit 1 when a check fails. ``--quick``: fewer alphas (the same checks).
"""

from __future__ import annotations

import numpy as np
from _shared import claim_verdict, quick_args, slope

import fl_design as fl

T = 1e-3
OMEGA = 2.0


def sigma_error(alpha: float) -> float:
    """max |sigmahat - y''| over the second half of a 20 s run of ``y = sin(OMEGA t)``."""
    t = np.arange(0.0, 20.0, T)
    est = fl.presets.paper_design().estimator.replace(eps=T / alpha)
    h = est.filter(np.sin(OMEGA * t))
    k = t.size // 2
    return float(np.max(np.abs(h[k:, 2] + OMEGA ** 2 * np.sin(OMEGA * t[k:]))))


def main(argv=None) -> int:
    args = quick_args(__doc__, "fewer alphas", argv)
    ok = True
    print("Paper (Sec. 5): 'we show O_x(T) = O_x(eps) when, in T = alpha eps, alpha <= 1'.")
    below = [0.01, 0.1, 1.0] if args.quick else [0.01, 0.03, 0.1, 0.3, 1.0]
    above = [1.0, 3.0, 30.0] if args.quick else [1.0, 2.0, 5.0, 10.0, 30.0]
    print(f"\n1. estimation error of sigmahat on y = sin({OMEGA:g} t), T = {T:g} s:")
    for alphas, side in ((below, "alpha <= 1"), (above, "alpha >= 1")):
        err = [sigma_error(a) for a in alphas]
        eps = [T / a for a in alphas]
        s = slope(eps, err)
        good = 0.9 <= s <= 1.1
        ok &= good
        print(f"   {side}: " + ", ".join(f"alpha {a:g}: {e:.3g}" for a, e in zip(alphas, err))
              + f"; slope against eps {s:.3f} (O(eps): 1): {'holds' if good else 'FAILS'}")

    plant, design = fl.plants.trms_yaw(), fl.presets.paper_design()
    b = plant.b_bounds()
    alphas = [0.02, 1.0, 2.0, 10.0]
    print(f"\n2. TRMS closed loop (gamma = {design.controller.gamma:g}, b in "
          f"[{b[0]:.3g}, {b[1]:.3g}]):")
    gains = []
    for a in alphas:
        d = design.replace(eps=T / a)
        cert = fl.certify_eps(d, b, search=False)
        run = fl.simulate(plant, d, fl.Scenario(0.3, 400.0))
        gains.append(fl.analysis.noise_gain(plant, d))
        good = bool(cert.point.certified and cert.point.covers_time_varying_b
                    and run.status in ("converged", "converging"))
        ok &= good
        print(f"   alpha {a:5g} (eps {T / a:.3g} s): surrogate certified for varying b "
              f"{cert.point.certified}; simulation {run.status} (overshoot "
              f"{run.overshoot:.1f} %); input noise gain {gains[-1]:.4g}: "
              f"{'holds' if good else 'FAILS'}")
    s = slope([T / a for a in alphas], gains)
    good = s < -1.0
    ok &= good
    print(f"\n3. input noise gain against eps: fitted slope {s:.3f} (steeper than -1: "
          f"{'holds' if good else 'FAILS'}); {gains[-1] / gains[0]:.0f}x the paper's at "
          f"alpha = {alphas[-1]:g}")
    return claim_verdict(9, "alpha <= 1 for O(T) = O(eps); beyond it: stable, noisy", ok,
                         meaning="alpha <= 1 is what the proof's O(T) = O(eps) step needs; the "
                         "bilinear loop stays stable and accurate beyond it, and the cost of "
                         "alpha > 1 is the noise the input carries.")


if __name__ == "__main__":
    raise SystemExit(main())
