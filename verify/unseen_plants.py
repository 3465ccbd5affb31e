"""Five plants the project was not written for, from ``fl-design init --from-ode`` (issue 31).

For each plant of ``examples/unseen/`` (a quadrotor's altitude with quadratic drag, a DC motor
with armature inductance (rho = 3), a hydraulic actuator whose b grows as ``sqrt(Ps - p)``, a
non-minimum-phase chain, a lightly damped pendulum), the script writes the config a new user
would: ``fl-design init --from-ode`` with only its ``[plant]`` table replaced. It then runs
``fl-design run`` (``--quick`` with ``--quick``) in a fresh process with an empty cache and
prints the wall time, the megabytes written and the load; and checks, independently of the
tool:

* the non-minimum-phase chain is refused (exit status 2) with its zero-dynamics eigenvalue 1
  (closed form: holding ``x1 = 0`` leaves ``w' = w``) in a few seconds;
* for the others: exit status 0, the summary's b-range against the closed form of each plant
  (``1/m``; ``Kt/(J L)``; ``(A/m) k Kq sqrt(Ps - p)`` at the region's ends of ``p``; ``1``),
  the equilibrium input against the closed form (hover ``m g``, else 0), and a fresh
  ``fl.simulate`` of the design the run proposed (read back from ``summary.json``) that
  converges.

Targets (exit status 1 on a miss; none with ``--quick``): each full run <= 300 s and < 100 MB
written. Measured times depend on the load (printed).

    python verify/unseen_plants.py [--quick] [--plants quadrotor,dc_motor,...]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
UNSEEN = ROOT / "examples" / "unseen"
PLANTS = ("nmp_chain", "quadrotor", "dc_motor", "hydraulic", "pendulum_c005")
TARGET_S, TARGET_MB = 300.0, 100.0


def b_closed_form(name: str) -> tuple[float, float] | None:
    """The b-range of each plant over its region, by hand (None: refused plant)."""
    if name == "quadrotor":
        return 1 / 1.2, 1 / 1.2
    if name == "dc_motor":
        return (0.05 / (2e-5 * 1e-3),) * 2
    if name == "hydraulic":  # y''' = (A/m) p' + ...: b = (A/m) k Kq sqrt(Ps - p), p in [-15, 15]
        c = 500.0 / 20.0 * 1.4e7 * 1e-5
        return c * math.sqrt(21.0 - 15.0), c * math.sqrt(21.0 + 15.0)
    if name == "pendulum_c005":
        return 1.0, 1.0
    return None


def u_eq_closed_form(name: str) -> float:
    return 1.2 * 9.81 if name == "quadrotor" else 0.0


def config_for(name: str, fld: str, env: dict) -> str:
    """``fl-design init --from-ode`` with its [plant] table replaced by the plant's."""
    base = subprocess.run([fld, "init", "--from-ode"], capture_output=True, text=True, env=env,
                          timeout=120, check=True).stdout
    plant = (UNSEEN / f"{name}.toml").read_text()
    i = base.index("\n[plant]\n")
    j = base.index("\n[", i + 1)
    return base[:i + 1] + plant[plant.index("[plant]"):].rstrip() + "\n" + base[j:]


def megabytes(path: Path) -> float:
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file()) / 1e6 \
        if path.exists() else 0.0


def check_summary(name: str, out: Path) -> list[str]:
    """Independent checks of a finished run; the problems found (empty: none)."""
    import fl_design as fl
    from fl_design.app import build_plant, load_config

    bad = []
    s = json.loads((out / "summary.json").read_text())
    b = s["derivation"]["b_bounds"]
    want = b_closed_form(name)
    if not all(math.isclose(x, y, rel_tol=1e-6) for x, y in zip(b, want)):
        bad.append(f"b-range {b} != closed form {want}")
    cfg = load_config(out.parent / f"{name}.toml")
    plant = build_plant(cfg)
    if not math.isclose(plant.u_eq, u_eq_closed_form(name), rel_tol=1e-9, abs_tol=1e-9):
        bad.append(f"u_eq {plant.u_eq} != {u_eq_closed_form(name)}")
    d = s["config"]["design"]
    design = fl.Design(estimator=fl.EHGO(rho=len(d["gains"]), eps=d["eps"], T=d["T"]),
                       controller=fl.DynamicController(tuple(d["gains"]), d["gamma"],
                                                       u_limits=tuple(d["u_limits"])))
    ref = s["config"]["scenario"]["reference"]
    resp = fl.simulate(plant, design, fl.Scenario(ref))
    if resp.status not in ("converged", "converging"):
        bad.append(f"a fresh simulation of the proposed design is {resp.status}")
    return bad


def main(argv=None) -> int:
    """Run every plant; return the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fl-design run --quick, no targets")
    parser.add_argument("--plants", default=",".join(PLANTS))
    args = parser.parse_args(argv)
    fld = str(Path(sys.executable).parent / "fl-design")
    ok = True
    print(f"{os.cpu_count()} cores, load average " +
          ", ".join(f"{x:.2f}" for x in os.getloadavg()))
    with tempfile.TemporaryDirectory(prefix="unseen_") as tmp:
        tmp = Path(tmp)
        for name in args.plants.split(","):
            env = dict(os.environ, FL_DESIGN_CACHE=str(tmp / f"cache_{name}"), MPLBACKEND="Agg")
            cfg = tmp / f"{name}.toml"
            cfg.write_text(config_for(name, fld, env))
            out = tmp / f"out_{name}"
            cmd = [fld, "run", str(cfg), "--out", str(out), "--no-progress"]
            t0 = time.perf_counter()
            proc = subprocess.run(cmd + (["--quick"] if args.quick else []), capture_output=True,
                                  text=True, env=env, timeout=3600, check=False)
            dt, mb = time.perf_counter() - t0, megabytes(out)
            load = os.getloadavg()[0]
            if name == "nmp_chain":
                good = (proc.returncode == 2 and "NOT minimum phase" in proc.stderr
                        and "[1]" in proc.stderr and dt < 60)
                print(f"{name}: refused in {dt:.1f} s (load {load:.1f}): "
                      f"{proc.stderr.strip()[:160]}{'' if good else '  FAIL'}")
                ok &= good
                continue
            if proc.returncode != 0:
                print(f"{name}: FAIL rc={proc.returncode} after {dt:.0f} s: "
                      f"{(proc.stderr.strip().splitlines() or [''])[-1][:200]}")
                ok = False
                continue
            problems = check_summary(name, out)
            miss = [] if args.quick else [w for w, bad in (
                (f"{dt:.0f} s > {TARGET_S:g} s", dt > TARGET_S),
                (f"{mb:.0f} MB >= {TARGET_MB:g} MB", mb >= TARGET_MB)) if bad]
            print(f"{name}: {dt:.1f} s, {mb:.1f} MB written (load {load:.1f}); checks: "
                  f"{'; '.join(problems) or 'b-range, u_eq, fresh simulation ok'}"
                  + (f"  MISS: {', '.join(miss)}" if miss else ""))
            ok &= not problems and not miss
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
