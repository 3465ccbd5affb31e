"""Benchmark: an unseen plant's full run <= 5 minutes, whatever its T (issue 33).

Two plants the project was not written for, at the ends of the sampling times, each run as a
new user would: ``fl-design run CONFIG.toml`` in a fresh process with an empty cache
(``FL_DESIGN_CACHE`` a new temporary folder):

* **hydraulic**: a valve-controlled cylinder (rho = 3): piston position ``x`` (m), velocity
  ``v`` (m/s), load pressure ``p`` (MPa); 50 kg, piston area 10 cm^2 (1000 N per MPa), bulk
  modulus 1400 MPa in 1 litre (``kb = 4 beta / V = 5.6e6 MPa/m^3``), supply 21 MPa, a valve
  of 20 l/min at 10 V and 7 MPa drop (``Kq = 1.26e-5``), leakage ``1e-11 m^3/(s Pa)``: the
  hydraulic natural frequency is 335 rad/s, ``b = (A/m) kb Kq sqrt(Ps - p)`` lies in
  ``[4.68e3, 7.86e3]`` over ``p in [-10, 10]`` MPa. No ``[design]``: ``fl.tune`` proposes it,
  and at this time scale it samples at its floor, T = 0.1 ms (checked in ``summary.json``);
* **thermal**: a heated block (rho = 1), 500 J/K, 500 W heater on a duty cycle in [0, 1],
  convective and quadratic loss (time constant ~100 s), sampled at T = 0.1 s with the design
  ``fl.tune(plant, T=0.1)`` proposes (a ``[design]`` table: the tool's own T is at most
  10 ms).

For each: the wall time, the CPU time of the process and its children, the megabytes written,
the 1-minute load, and the longest silence on stderr (the time between two progress lines,
and the line before it: issue 33 asks for progress on every step over about 2 s). Target: each
full run <= 300 s (exit status 1 on a miss, or when a run fails or samples at another T).
``--quick`` runs the hydraulic plant with ``fl-design run --quick`` once, its ``[certify]``
and ``[codegen]`` stages off (``fl.tune``'s own certificates stay), and checks no time (the
tests run it).

    python verify/bench_unseen.py [--quick] [--plants hydraulic,thermal]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from _shared import load_line, machine, target

TARGET_S = 300.0
#: With ``--quick``: the stages a first look needs (the design fl.tune proposes, with its
#: certificates; sweep, simulate, compare, report), not the certify and C stages.
QUICK_TABLES = "\n[certify]\nenabled = false\n\n[codegen]\nenabled = false\n"
#: ``name -> (config text, the T its run must sample at)``.
PLANTS = {
    "hydraulic": ('''[plant]
name = "valve_cylinder"
states = ["x", "v", "p"]
input = "u"
rhs = ["v", "(A*p - c*v)/m", "kb*(Kq*u*sqrt(Ps - p) - A*1e-6*v - Cl*p)"]
output = "x"
params = { m = 50.0, A = 1000.0, c = 2000.0, kb = 5.6e6, Kq = 1.26e-5, Ps = 21.0, Cl = 1e-5 }
region = { x = [-0.1, 0.1], v = [-0.3, 0.3], p = [-10.0, 10.0] }
input_range = [-10.0, 10.0]
output_unit = "m"
input_unit = "V"
''', 1e-4),
    "thermal": ('''[plant]
name = "heated_block"
states = ["x"]
input = "u"
rhs = ["(P*u - k*x - k2*x**2)/C"]
output = "x"
params = { C = 500.0, k = 5.0, k2 = 0.02, P = 500.0 }
region = { x = [0.0, 80.0] }
input_range = [0.0, 1.0]
operating_point = { x = 40.0 }
output_unit = "K"
input_unit = "duty"

[design]
estimator = "ehgo"
eps = 3.96
T = 0.1
gains = [0.023664]
gamma = 0.00936
u_limits = [0.0, 1.0]

[scenario]
reference = 44.0
''', 0.1),
}


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run(name: str, quick: bool, timeout: float = 1800.0) -> dict:
    """One ``fl-design run`` of ``name`` in a fresh process with an empty cache."""
    text, T = PLANTS[name]
    fld = str(Path(sys.executable).parent / "fl-design")
    with tempfile.TemporaryDirectory(prefix="bench_unseen_") as tmp:
        cfg, out = Path(tmp) / f"{name}.toml", Path(tmp) / "out"
        cfg.write_text(text + (QUICK_TABLES if quick else ""))
        env = dict(os.environ, FL_DESIGN_CACHE=str(Path(tmp) / "cache"), MPLBACKEND="Agg")
        cmd = [fld, "run", str(cfg), "--out", str(out)] + (["--quick"] if quick else [])
        lines: list[tuple[float, str]] = []
        c0, t0 = _children_cpu(), time.perf_counter()
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                text=True, env=env)  # text mode: "\r" (tqdm) ends a line

        def read():
            for line in proc.stderr:
                if line.strip():
                    lines.append((time.perf_counter() - t0, line.strip()))

        reader = threading.Thread(target=read, daemon=True)
        reader.start()
        try:
            rc = proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=30)
            rc = None
        reader.join(timeout=30)
        wall, cpu = time.perf_counter() - t0, _children_cpu() - c0
        mb = sum(p.stat().st_size for p in out.rglob("*") if p.is_file()) / 1e6 \
            if out.exists() else 0.0
        gaps = [(b[0] - a[0], a[1]) for a, b in zip([(0.0, "(start)")] + lines,
                                                     lines + [(wall, "(end)")])]
        gap = max(gaps) if gaps else (wall, "(no output)")
        found = None
        if rc == 0 and (out / "summary.json").exists():
            design = str(json.loads((out / "summary.json").read_text()).get("design", ""))
            m = re.search(r"T = ([0-9.eE+-]+) s", design)
            found = float(m.group(1)) if m else None
    problem = ("timed out" if rc is None else f"exit status {rc}: {lines[-1][1][:120]}"
               if rc else None if found is not None and abs(found - T) <= 1e-9 * T
               else f"sampled at T = {found}, expected {T:g}")
    return {"wall": wall, "cpu": cpu, "mb": mb, "gap": gap, "T": found,
            "load": os.getloadavg()[0], "problem": problem}


def main(argv=None) -> int:
    """Run the benchmark; return the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="the hydraulic plant with fl-design run --quick, no target")
    parser.add_argument("--plants", default=None, help="comma-separated: hydraulic,thermal")
    args = parser.parse_args(argv)
    names = (args.plants.split(",") if args.plants else
             ["hydraulic"] if args.quick else list(PLANTS))
    unknown = [n for n in names if n not in PLANTS]
    if unknown:
        parser.error(f"unknown plant(s) {unknown}; choose from {sorted(PLANTS)}")
    print(machine())
    ok = True
    mode = "fl-design run --quick" if args.quick else "fl-design run"
    print(f"{mode}, fresh process, empty cache (target <= {TARGET_S:g} s"
          f"{', not checked with --quick' if args.quick else ''}):")
    for n in names:
        r = run(n, args.quick)
        met = target(f"unseen plant, {mode} ({n}, T = {PLANTS[n][1]:g} s)", r["wall"],
                     TARGET_S, checked=not args.quick and r["problem"] is None,
                     detail=r["problem"] or "fresh process, empty cache")
        miss = r["problem"] is not None or (not args.quick and not met)
        ok &= not miss
        print(f"  {n:10s} T = {PLANTS[n][1]:g} s: {r['wall']:6.1f} s wall, CPU {r['cpu']:.1f} s "
              f"(with its children), {r['mb']:.1f} MB written, load {r['load']:.1f}"
              f"{'  MISS' if miss else ''}{'; ' + r['problem'] if r['problem'] else ''}",
              flush=True)
        print(f"    longest silence on stderr: {r['gap'][0]:.1f} s, after: {r['gap'][1][:110]}")
    print(load_line())
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
