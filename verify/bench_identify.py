"""Benchmark: ``fl-design identify`` on a 60 s log at 1 kHz, and ``fl.tune(class)``.

A virtual rig (a plant fl_design does not model: ``y'' = -9.81 sin y - 0.1 y' + (3 + 2 cos y) u``,
sensor noise 1e-3, quantization 1e-4, one sample of input delay) runs a design under a square
wave excitation and writes a 60 s log at 1 kHz as CSV. Timed: ``fl.identify`` on that file (read,
noise, delay search, both estimators; the page is written untimed) and ``fl.tune`` of the
class ``rho = 2, T = 1 ms, b in [1, 50], noise 1e-3``. Also checked: the identified class holds
the true ``b`` range of the visited states, and the tuned design is certified.

Also timed: the command ``fl-design identify LOG.csv`` end to end (wall and CPU: start-up,
CSV, identify, page). Targets: identify <= 5 s, tune(class) <= 10 s (2 cores), on the API
calls' wall time. Exits with status 1 on a miss.
``--quick``: a 10 s log and a narrow class, no time target (the tests run it).

    python verify/bench_identify.py [--quick]
"""

from __future__ import annotations

import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import casadi as ca
import numpy as np
from _shared import load_line, quick_args, target

import fl_design as fl
from fl_design.sim._rig import Rig
from fl_design.tuning._tune_class import tune_class

TARGET_IDENTIFY_S = 5.0
TARGET_TUNE_S = 10.0


def _log(duration: float, path: Path):
    rig = Rig(ode=lambda x, u, p: [x[1], -9.81 * ca.sin(x[0]) - 0.1 * x[1]
                                   + (3 + 2 * ca.cos(x[0])) * u],
              x0=(0.0, 0.0), T=1e-3, b=lambda x, p: 3 + 2 * ca.cos(x[0]), noise_std=1e-3,
              quantization=1e-4, delay=1, name="pendulum")
    design = tune_class(fl.PlantClass(rho=2, T=1e-3, b=(2.0, 10.0), u_limits=(-20, 20)),
                        reference=1.0, members=False).design
    log = rig.run(design, lambda t: 0.2 + 0.8 * ((t // 3.0) % 2), duration, seed=1,
                  excitation=lambda t: np.sign(np.sin(2 * np.pi * t / 0.125) + 1e-12))
    log.write_csv(path)
    return log


def main(argv=None) -> int:
    """Run the benchmark; return the exit status."""
    args = quick_args(__doc__, "short log, narrow class", argv)
    ok = True
    tmp = Path(tempfile.mkdtemp())
    duration = 10.0 if args.quick else 60.0
    log = _log(duration, tmp / "rig.csv")
    fl.identify({"t": log.t[:2000], "y": log.y[:2000], "u": log.u[:2000]}, rho=2)  # warm-up
    t0 = time.perf_counter()
    cls = fl.identify(tmp / "rig.csv", rho=2, u_limits=(-20, 20))
    t_id = time.perf_counter() - t0
    lo, hi = log.b_range
    inside = cls.b[0] <= lo and hi <= cls.b[1]
    print(f"identify on a {duration:g} s log at 1 kHz ({log.t.size} rows, CSV): {t_id:.2f} s "
          f"(target <= {TARGET_IDENTIFY_S:g} s)")
    print(f"  {cls.describe()}")
    print(f"  true b over the visited states [{lo:.4g}, {hi:.4g}]: "
          f"{'inside' if inside else 'NOT inside'} the class; delay {cls.delay} (true 1)")
    fl.identification.write_page(cls, tmp / "page")
    ok &= inside
    exe = Path(sys.executable).parent / "fl-design"
    if exe.exists():  # the command end to end: start-up, CSV, identify, page, class.toml
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        proc = subprocess.run([str(exe), "identify", str(tmp / "rig.csv"), "--rho", "2",
                               "--out", str(tmp / "cli")], capture_output=True, text=True,
                              timeout=300, check=False)
        t_cli = time.perf_counter() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
        print(f"`fl-design identify` end to end: {t_cli:.2f} s wall, {cpu:.2f} s CPU "
              f"(exit {proc.returncode})")
        ok &= proc.returncode == 0
    wide = (1.0, 50.0) if not args.quick else (2.0, 10.0)
    c = fl.PlantClass(rho=2, T=1e-3, b=wide, noise_std=1e-3, u_limits=(-10.0, 10.0))
    t0 = time.perf_counter()
    tuned = fl.tune(c)
    t_tune = time.perf_counter() - t0
    print(f"tune(class b in [{wide[0]:g}, {wide[1]:g}]): {t_tune:.2f} s (target <= "
          f"{TARGET_TUNE_S:g} s); {tuned.status}")
    ok &= tuned.certified
    print(load_line())
    target(f"fl.identify on a {duration:g} s log at 1 kHz (CSV)", t_id, TARGET_IDENTIFY_S,
           checked=not args.quick)
    target(f"fl.tune of a stated class, b in [{wide[0]:g}, {wide[1]:g}]", t_tune, TARGET_TUNE_S,
           checked=not args.quick)
    if not args.quick:
        if t_id > TARGET_IDENTIFY_S:
            print(f"MISS: identify {t_id:.2f} s > {TARGET_IDENTIFY_S:g} s")
            ok = False
        if t_tune > TARGET_TUNE_S:
            print(f"MISS: tune(class) {t_tune:.2f} s > {TARGET_TUNE_S:g} s")
            ok = False
    print("holds" if ok else "FAILS")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
