"""What "no b0" buys: linear ADRC with a b0 guess against the class design, over a b0-error sweep.

The practitioner's baseline is linear ADRC (Gao's bandwidth parameterization, Euler ESO,
:mod:`fl_design.design._adrc`): it needs ``b0``, a guess of ``b``. The class design
(``fl.tune(PlantClass(rho=2, T=1 ms, b in [1, 50], noise 1e-3, |u| <= 10))``) needs none. Both
run the same scenarios in the virtual rig: a unit step on chains of two integrators at
``b_true`` in {1, 7.07, 50} and ``b`` switching between 1 and 50, sensor noise 1e-3, the
same input limits and run length. ADRC takes ``b0 = f b_true`` for ``f`` in {0.1, 0.2, 0.5, 1,
2, 5, 10} and two bandwidths: ``w_c`` the class design's loop decay (same speed) and ``10x``
that (what a known ``b`` would allow), ``w_o = 10 w_c``.

Prints one row per run (converged, settling time, overshoot, rms u in the last fifth) and the
count of converging ADRC runs per ``f``. Exits with status 1 when the class design does not
converge on every member (the claim: no ``b0`` is needed in the class). ``--quick``: f in
{0.1, 1, 10}, the w_c-matched ADRC only.

    python verify/adrc_b0_sweep.py [--quick]
"""

from __future__ import annotations

import argparse
import math
import sys

import numpy as np
from _shared import finish

import fl_design as fl
from fl_design.design._adrc import LinearADRC
from fl_design.sim._rig import chain_rig
from fl_design.tuning._class_checks import _metrics

FACTORS = (0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0)


def _run(ctrl, b, dur, r=1.0, switching=False):
    rig = chain_rig(2, b=None if switching else b, T=1e-3, noise_std=1e-3)
    N = round(dur / 1e-3)
    p = None
    if switching:
        rng = np.random.default_rng(0)
        p, k = np.empty(N), 0
        while k < N:
            n = int(rng.integers(1, 300))
            p[k:k + n] = 1.0 if rng.random() < 0.5 else 50.0
            k += n
    log = rig.run(ctrl, r, dur, p=p, seed=0)
    m = _metrics(log, r, 0.0, 1e-3, "", b, b)
    tail = log.u[int(0.8 * log.u.size):]
    rms = float(np.std(tail)) if np.all(np.isfinite(tail)) else math.inf
    return m, rms


def main(argv=None) -> int:
    """Run the sweep; return the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    cls = fl.PlantClass(rho=2, T=1e-3, b=(1.0, 50.0), noise_std=1e-3, u_limits=(-10.0, 10.0))
    tuned = fl.tune(cls, reference=1.0)
    wc = tuned.time_scale
    dur = 12.0 / wc
    members = [(1.0, False), (math.sqrt(50.0), False), (50.0, False), (7.07, True)]
    print(f"class design (no b0): {tuned.status}; eps {tuned.design.estimator.eps:.4g} s, "
          f"gamma {tuned.design.controller.gamma:.4g}, loop decay {wc:.3g} rad/s; runs of "
          f"{dur:.3g} s")
    ok = True
    for b, sw in members:
        m, rms = _run(tuned.design, b, dur, switching=sw)
        what = "b switching 1 <-> 50" if sw else f"b = {b:.4g}"
        print(f"  ours   {what:22s} {'converges' if m.converged else 'DOES NOT CONVERGE':18s}"
              f" settling {m.settling_time:7.3g} s, overshoot {m.overshoot:6.3g} %, rms u {rms:.3g}")
        ok &= m.converged
    factors = (0.1, 1.0, 10.0) if args.quick else FACTORS
    speeds = (1.0,) if args.quick else (1.0, 10.0)
    for k in speeds:
        counts = {}
        for f in factors:
            n_ok = 0
            for b, sw in members:
                b0 = f * (b if not sw else math.sqrt(50.0))
                adrc = LinearADRC(rho=2, T=1e-3, b0=b0, wc=k * wc, wo=10 * k * wc,
                                  u_limits=(-10.0, 10.0))
                m, rms = _run(adrc, b, dur, switching=sw)
                n_ok += m.converged
                what = "b switching 1 <-> 50" if sw else f"b = {b:.4g}"
                print(f"  ADRC w_c={k * wc:<5.3g} b0/b={f:<4g} {what:22s} "
                      f"{'converges' if m.converged else 'DOES NOT CONVERGE':18s} settling "
                      f"{m.settling_time:7.3g} s, overshoot {m.overshoot:6.3g} %, rms u {rms:.3g}")
            counts[f] = n_ok
        print(f"ADRC (w_c = {k * wc:.3g} rad/s) converging runs per b0/b: " + ", ".join(
            f"{f:g}: {n}/{len(members)}" for f, n in counts.items()))
    print(f"ours (no b0): {'all' if ok else 'NOT all'} {len(members)} members converge")
    return finish(ok)


if __name__ == "__main__":
    sys.exit(main())
