"""Claim 12 (issue 29): a step from rest is certified (bounded and converging) only when it is.

``fl.certify_step`` (invariant ellipsoid of the sampled loop, input limits and the estimate
clamp inside it as sector-bounded dead-zones, the plant's slopes by interval enclosures, every
inequality re-checked in NumPy) is checked against ``fl.simulate`` (exit 1 on a miss):

1. the pendulum's 0.1 rad step (``fl.plants.pendulum()``, ``fl.presets.pendulum_design()``)
   is certified, and ``fl.simulate`` converges from it and from a start at 0.99 x the largest
   certified step;
2. the paper's design on the class ``y'' = b u``, ``b in [3.6, 6.8]`` (``u`` limited to
   +-2.5, ``xhat_2`` clamped to +-0.05) is NOT certified for the 0.3 rad step, which
   ``fl.simulate`` shows diverging on ``y'' = 5 u``; 0.95 x its largest certified step
   converges for ``b = 3.6`` and ``6.8`` (full mode);
3. the paper's experiment on the nonlinear TRMS (``fl.plants.trms_yaw()``,
   ``fl.presets.paper_design()``, 0.3 rad from rest): the answer is printed as it is (today:
   not certified, with the largest certified step and why); if it is certified,
   ``fl.simulate`` must converge (full mode; its time is printed with the load).

4. the Lur'e argument (``fl_design.analysis._lure``: the friction as a static monotone
   slope-restricted map, Popov/Jury-Lee type ``V``): the largest friction slope ``k`` it
   certifies (bisection) for the paper's EHGO and gains without limits, ``b`` frozen at 3.6 and
   ``b in [3.6, 6.8]``, against the TRMS's ``k = B2/(delta I2) = 500``; a plant of the
   certified class converges in ``fl.simulate`` from the 0.3 rad step; with the paper's limits
   (global sector) nothing is certified. Item 3 passes the TRMS's friction structure to
   ``certify_step`` (``friction=(B1/I2, B2/(delta I2))``).

``--quick``: items 1, 2 and 4 without the b-ends' runs and the simulation of item 4.
"""

from __future__ import annotations

import os
import time

import numpy as np
import sympy as sp
from _shared import claim_verdict, quick_args

import fl_design as fl


def chain_plant(b: float):
    y, v, u = sp.symbols("y v u", real=True)
    return fl.Plant.from_ode([y, v], u, [v, b * u], y, name=f"chain_b{b:g}",
                             region={y: (-10.0, 10.0), v: (-10.0, 10.0)},
                             input_range=(-2.5, 2.5))


def verdict(good: bool) -> str:
    return "holds" if good else "FAILS"


def lure_item(quick: bool) -> bool:
    import math

    from fl_design.analysis._lure import lure_certificate

    paper = fl.presets.paper_design()
    free = fl.Design(estimator=paper.estimator,
                     controller=fl.DynamicController((2.0, 4.0), 3e-4, ki=1e-3))
    good = True
    t0 = time.perf_counter()
    fronts = {}
    for b in ((3.6, 3.6), (3.6, 6.8)):
        lo, hi = 0.0, 500.0
        for _ in range(9):
            mid = hi / 2 if lo == 0 else math.sqrt(lo * hi)
            if lure_certificate(free, b, 5.0, mid).certified:
                lo = mid
            else:
                hi = mid
        fronts[b] = (lo, hi)
    top = lure_certificate(free, (3.6, 6.8), 5.0, 500.0)
    lim = lure_certificate(paper, (3.6, 6.8), 5.0, 0.01)
    secs = time.perf_counter() - t0
    good &= (not top.certified) and (not lim.certified)
    print(f"4. Lur'e (Popov/Jury-Lee) certificate, x_2' = -5 x_2 - phi(x_2) + b u, phi' in [0, k]: "
          f"largest k certified (no limits) {fronts[(3.6, 3.6)][0]:.3g} (b = 3.6; {fronts[(3.6, 3.6)][1]:.3g} "
          f"not), {fronts[(3.6, 6.8)][0]:.3g} (b in [3.6, 6.8]; {fronts[(3.6, 6.8)][1]:.3g} not); "
          f"the TRMS's k = 500: {'certified' if top.certified else 'NOT certified'}; with the "
          f"paper's limits (global sector), k = 0.01: "
          f"{'certified' if lim.certified else 'NOT certified'} ({secs:.1f} s, load "
          f"{os.getloadavg()[0]:.1f}): {verdict(good)}")
    if not quick and fronts[(3.6, 6.8)][0] > 0:
        k = fronts[(3.6, 6.8)][0]
        y, v, u = sp.symbols("y v u", real=True)
        plant = fl.Plant.from_ode([y, v], u, [v, -5 * v - k * 1e-3 * sp.tanh(v / 1e-3) + 3.6 * u],
                                  y, name="lure_member", region={y: (-10.0, 10.0),
                                                                 v: (-10.0, 10.0)})
        r = fl.simulate(plant, free, fl.Scenario(0.3, 300.0))
        e0, e1 = abs(r.y[0] - 0.3), np.abs(r.y[-1000:] - 0.3).max()
        g = bool(r.bounded) and e1 < 0.1 * e0
        good &= g
        print(f"   a member (phi = {k * 1e-3:.3g} tanh(v/1e-3), b = 3.6), 0.3 rad from rest, "
              f"fl.simulate: |y - r| from {e0:.3g} to {e1:.3g} over 300 s: {verdict(g)}")
    return good


def main(argv=None) -> int:
    args = quick_args(__doc__, "items 1 and 2 only", argv)
    ok = True
    load = os.getloadavg()[0]

    plant, design = fl.plants.pendulum(), fl.presets.pendulum_design()
    t0 = time.perf_counter()
    c = fl.certify_step(plant, design, fl.Scenario(0.1))
    secs = time.perf_counter() - t0
    r = fl.simulate(plant, design, fl.Scenario(0.1, 20.0))
    s = 0.99 * c.largest_step
    r2 = fl.simulate(plant, design, fl.Scenario(0.1, 30.0, x0=[0.1 - s, 0.0]))
    good = c.certified and r.converged and abs(r2.y[-1] - 0.1) < 1e-3
    ok &= good
    print(f"1. pendulum 0.1 rad: {'certified' if c.certified else 'NOT certified'} in {secs:.1f} s "
          f"(load {load:.1f}), largest certified step {c.largest_step:.4g} rad; fl.simulate: "
          f"{r.status}, and from 0.99 x the largest ({s:.4g} rad) |y - r| = "
          f"{abs(r2.y[-1] - 0.1):.2g} at 30 s: {verdict(good)}")
    print(f"   {c.argument}")

    cls = fl.PlantClass.chain(2, b=(3.6, 6.8), T=1e-3)
    paper = fl.presets.paper_design()
    t0 = time.perf_counter()
    c = fl.certify_step(cls, paper, fl.Scenario(0.3))
    secs = time.perf_counter() - t0
    r = fl.simulate(chain_plant(5.0), paper, fl.Scenario(0.3, 30.0))
    good = (not c.certified) and not r.converged
    ok &= good
    print(f"2. paper's design on y'' = b u, b in [3.6, 6.8], 0.3 rad: "
          f"{'certified' if c.certified else 'NOT certified'} ({secs:.1f} s; V(start)/level = "
          f"{c.start_ratio:.3g}, largest certified step {c.largest_step:.4g} rad); fl.simulate "
          f"on y'' = 5 u: {r.status} (peak |y| {np.max(np.abs(r.y)):.3g}): {verdict(good)}")
    if not args.quick:
        s = 0.95 * c.largest_step
        for b in (3.6, 6.8):
            r = fl.simulate(chain_plant(b), paper, fl.Scenario(s, 120.0))
            good = np.abs(r.y[-1000:] - s).max() < 0.05 * s
            ok &= good
            print(f"   b = {b:g}, step {s:.4g} rad (0.95 x the largest certified): final "
                  f"|y - r| {abs(r.y[-1] - s):.2g}: {verdict(good)}")

        trms = fl.plants.trms_yaw()
        t0 = time.perf_counter()
        c = fl.certify_step(trms, paper, fl.Scenario(0.3), friction=(5.0, 500.0))
        secs = time.perf_counter() - t0
        print(f"3. TRMS yaw (nonlinear), paper's design, 0.3 rad from rest: "
              f"{'certified' if c.certified else 'NOT certified (not claimed)'} in {secs:.1f} s "
              f"(load {os.getloadavg()[0]:.1f}); largest certified step {c.largest_step:.3g} rad")
        print(f"   {c.argument}")
        print(f"   not covered: {c.uncovered}")
        if c.certified:
            r = fl.simulate(trms, paper, fl.Scenario(0.3, 300.0))
            good = bool(r.bounded)
            ok &= good
            print(f"   fl.simulate: {r.status}: {verdict(good)}")
        else:
            s = 0.9 * c.largest_step
            r = fl.simulate(trms, paper, fl.Scenario(s, 300.0))
            good = np.abs(r.y[-1000:] - s).max() <= np.abs(r.y[:1000] - s).max()
            ok &= good
            print(f"   0.9 x the largest certified step ({s:.3g} rad): |y - r| from "
                  f"{abs(r.y[0] - s):.3g} to {np.abs(r.y[-1000:] - s).max():.3g} over 300 s: "
                  f"{verdict(good)}")
    ok &= lure_item(args.quick)
    return claim_verdict(12, "certified steps converge; the chain's 0.3 rad step is not claimed",
                         ok)


if __name__ == "__main__":
    raise SystemExit(main())
