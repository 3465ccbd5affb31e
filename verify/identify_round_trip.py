"""The model-free round trip on plants fl_design never models: log -> class -> design -> plant.

For each plant (a virtual rig: CasADi right-hand side, sensor noise, quantization, input delay):
a rough first design for a wide guessed class runs a reference square wave with a square-wave
excitation on the input and writes a log; ``fl.identify`` reads it; the check is that the
identified class holds the plant's true ``b`` over the visited states (the rig knows it), and
that ``fl.tune(cls)``'s design converges on the same plant (a step inside the visited range).
Plants: a pendulum (``b`` falls with the angle), a hardening spring (``b`` grows with ``y``), a
first-order tank (``rho = 1``), a plant with ``b < 0``, and a third-order plant (``rho = 3``).

Exits with status 1 when a class misses its plant's ``b`` or a design does not converge, for
``rho <= 2``. The third-order plant is run and reported, not counted: its class is identified
(with a window and excitation period twice as long), but at ``T = 1 ms`` and noise 1e-3 no
candidate of ``fl.tune(cls)`` is certified (the LMIs fail numerically, 6-40 s per attempt) and
the design's noise gain (rms ``u`` per rms noise 1e2 - 1e6) keeps it from converging: a known
limit. ``--quick``: the first two plants, shorter logs.

    python verify/identify_round_trip.py [--quick]
"""

from __future__ import annotations

import argparse
import sys

import casadi as ca
import numpy as np
from _shared import finish

import fl_design as fl
from fl_design.sim._rig import Rig
from fl_design.tuning._class_checks import _metrics
from fl_design.tuning._tune_class import tune_class

PLANTS = [
    # name, rho, ode, b(x), guessed class b, reference (lo, hi), excitation amplitude, delay
    ("pendulum", 2, lambda x, u, p: [x[1], -9.81 * ca.sin(x[0]) - 0.1 * x[1]
                                     + (3 + 2 * ca.cos(x[0])) * u],
     lambda x, p: 3 + 2 * ca.cos(x[0]), (1.0, 20.0), (0.2, 1.0), 1.0, 1),
    ("hardening spring", 2, lambda x, u, p: [x[1], -x[0] - 0.5 * x[0] ** 3 - 0.2 * x[1]
                                             + (2 + x[0] ** 2) * u],
     lambda x, p: 2 + x[0] ** 2, (1.0, 20.0), (0.0, 1.5), 1.0, 0),
    ("tank (rho = 1)", 1, lambda x, u, p: [-0.5 * ca.sqrt(ca.fabs(x[0]) + 0.1)
                                           + u / (1 + x[0])],
     lambda x, p: 1 / (1 + x[0]), (0.1, 5.0), (0.5, 1.5), 0.3, 2),
    ("negative b", 2, lambda x, u, p: [x[1], -2 * ca.sin(x[0]) - (4 + ca.cos(x[0])) * u],
     lambda x, p: -(4 + ca.cos(x[0])), (-20.0, -1.0), (0.0, 0.8), 0.5, 0),
    ("third order", 3, lambda x, u, p: [x[1], x[2], -x[2] - 2 * x[1] - x[0]
                                        + (5 + ca.sin(x[0])) * u],
     lambda x, p: 5 + ca.sin(x[0]), (1.0, 20.0), (0.0, 0.5), 2.0, 0),
]


def main(argv=None) -> int:
    """Run the round trips; return the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    plants = PLANTS[:2] if args.quick else PLANTS
    duration = 15.0 if args.quick else 30.0
    ok = True
    for name, rho, ode, bfun, guess, (r_lo, r_hi), amp, delay in plants:
        rig = Rig(ode=ode, x0=(r_lo,) + (0.0,) * (rho - 1), T=1e-3, b=bfun, noise_std=1e-3,
                  quantization=1e-4, delay=delay, name=name)
        first = tune_class(fl.PlantClass(rho=rho, T=1e-3, b=guess, u_limits=(-50, 50)),
                           reference=r_hi, members=False).design
        log = rig.run(first, lambda t, a=r_lo, b=r_hi: a + (b - a) * ((t // 3.0) % 2),
                      duration, seed=1, u0=0.0,
                      excitation=lambda t, A=amp, P=0.125 * 2.0 ** (rho - 2 if rho > 2 else 0):
                      A * np.sign(np.sin(2 * np.pi * t / P) + 1e-12))
        if not np.all(np.isfinite(log.y)):
            print(f"{name}: the first design's experiment diverged (a rough guess): skipped")
            ok = False
            continue
        lo, hi = log.b_range
        try:
            cls = fl.identify(log.columns(), rho=rho, u_limits=(-50, 50))
        except fl.errors.LogError as err:
            print(f"{name}: identify refused: {err}")
            ok &= rho > 2
            continue
        inside = cls.b[0] <= lo and hi <= cls.b[1]
        r = 0.5 * (r_lo + r_hi)
        tuned = tune_class(cls, reference=r, members=False)
        run = rig.run(tuned.design, r, 20.0, seed=2, u0=float(np.median(log.u)))
        m = _metrics(run, r, r_lo, cls.noise_std, name, lo, hi)
        print(f"{name}: true b [{lo:.4g}, {hi:.4g}] {'inside' if inside else 'NOT inside'} "
              f"the class [{cls.b[0]:.4g}, {cls.b[1]:.4g}] (delay {cls.delay}, true {delay}; "
              f"{cls.evidence.agreement_text.split(':')[0]}); design "
              f"{'certified' if tuned.certified else 'NOT certified'}, on the plant: "
              f"{m.line()}")
        if rho <= 2:
            ok &= inside and m.converged
        else:
            print(f"  ({name}: rho = {rho}, reported, not counted: a known limit)")
    return finish(ok)


if __name__ == "__main__":
    sys.exit(main())
