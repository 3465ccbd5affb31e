"""Benchmark: certify_eps and certify_gamma where b varies in time (the quartic SOS certificate).

Issue 33 ("answers at the speed of design"): the varying-b certificate of the paper's TRMS design
(``certify_eps(paper_design(gamma), (3.6, 6.8))`` at two gains, ``certify_gamma`` of the same)
solves the quartic sum-of-squares program of :mod:`fl_design.analysis._sos` a few times per call
(rho = 3 loops have 9 states, above ``SOS_MAX_STATES = 8``: no SOS program runs there). Each
case runs in a fresh process after a warm-up call (imports, CasADi compiled, untimed) and is
timed in CPU seconds (``time.process_time``: single-threaded work, the measure that survives a
shared machine's load) and wall seconds, with the conic programs it solved; interleaved, once
with this checkout and once with a baseline commit (``--against``, default the commit before
session 33's SOS work: the SOS program through CVXPY and a bisection of its verdict), extracted
with ``git archive`` into a temporary folder and put first on ``PYTHONPATH``. Prints the
machine, its ISA and the load, the median CPU ratio per case and whether both gave the same
answer (the same verdicts and coverage, every eps* within the bisection's ``rtol``).

Target: CPU ratio baseline / this checkout >= :data:`TARGET_RATIO` on every case (median of
``--repeat`` rounds). ``--quick``: the paper design's certify_eps once, this checkout only, no
target judged (the tests run it).

    python verify/bench_sos.py [--quick] [--repeat N] [--against REF]
"""

from __future__ import annotations

import argparse
import ast
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from _shared import load_line, machine, target

#: The CPU speed-up asked for (issue 33, session 33's brief).
TARGET_RATIO = 3.0
#: The bisection's relative resolution (certify_eps' default).
RTOL = 1e-2
#: The commit before session 33's SOS work.
BASELINE = "a40aae8"
ROOT = Path(__file__).resolve().parents[1]

#: ``name -> python expression`` (each returns a certificate).
CASES = {
    "certify_eps, paper design (gamma 3e-4), b in [3.6, 6.8]":
        "fl.certify_eps(fl.presets.paper_design(), (3.6, 6.8))",
    "certify_eps, paper design (gamma 1e-3), b in [3.6, 6.8]":
        "fl.certify_eps(fl.presets.paper_design(gamma=1e-3), (3.6, 6.8))",
    "certify_gamma, paper design (eps 0.1: SOS), b in [3.6, 6.8]":
        "fl.certify_gamma(fl.presets.paper_design(eps=0.1), (3.6, 6.8))",
}

_PROG = """
import time
import fl_design as fl
from fl_design.analysis._lmi import solve_count
fl.certify_eps(fl.presets.paper_design(), (3.6, 6.8), search=False)
n0, c0, t0 = solve_count(), time.process_time(), time.perf_counter()
c = {code}
cpu, wall, n = time.process_time() - c0, time.perf_counter() - t0, solve_count() - n0
if hasattr(c, "eps_star_certified"):
    ans = (c.certified, c.covers, c.point.kind, c.eps_star_certified,
           tuple((x.covers, x.certified, x.refuted) for x in c.brackets))
else:
    ans = (c.certified, c.point.kind, c.point.covers, c.gamma_min, c.gamma_max)
print(repr((cpu, wall, n, ans)))
"""


def _run(code: str, path: str | None) -> tuple:
    """``(cpu, wall, programs, answer)`` of ``code`` in a fresh process (``path`` first on
    ``PYTHONPATH``: the baseline's package)."""
    env = dict(os.environ)
    if path:
        env["PYTHONPATH"] = path + os.pathsep + env.get("PYTHONPATH", "")
    out = subprocess.run([sys.executable, "-c", _PROG.format(code=code)], capture_output=True,
                         text=True, timeout=600, env=env, check=False, cwd=path or ROOT)
    if out.returncode != 0:
        raise RuntimeError(f"{code} failed: {(out.stderr.strip().splitlines() or ['?'])[-1]}")
    return ast.literal_eval(out.stdout.strip().splitlines()[-1])


def _same(a, b) -> bool:
    """Equal verdicts and words; numbers within the bisection's ``rtol`` (None alike)."""
    if isinstance(a, tuple) and isinstance(b, tuple):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, float) and isinstance(b, float):
        return abs(a / b - 1.0) <= RTOL * 1.0001
    return a == b


def _baseline(ref: str, into: str) -> str:
    """``git archive ref fl_design`` extracted into ``into``; the folder."""
    arch = subprocess.run(["git", "-C", str(ROOT), "archive", ref, "fl_design"],
                          capture_output=True, timeout=120, check=True).stdout
    subprocess.run(["tar", "-x", "-C", into], input=arch, timeout=120, check=True)
    return into


def main(argv=None) -> int:
    """Run the benchmark; return the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="the paper design's certify_eps once, this checkout, no target")
    parser.add_argument("--repeat", type=int, default=3, help="interleaved rounds")
    parser.add_argument("--against", default=BASELINE, help="baseline commit (git ref)")
    args = parser.parse_args(argv)
    print(machine())
    if args.quick:
        name, code = next(iter(CASES.items()))
        cpu, wall, n, ans = _run(code, None)
        print(f"  {name}: CPU {cpu:.2f} s (wall {wall:.2f} s), {n} conic programs; {ans}")
        target(f"SOS certificate, {name}, CPU", cpu, 60.0, checked=False,
               detail="--quick: one run, no baseline")
        print(load_line())
        print("holds (not judged: --quick)")
        return 0
    ok = True
    with tempfile.TemporaryDirectory(prefix="fl_sos_base_") as tmp:
        base = _baseline(args.against, tmp)
        cpu = {(n, p): [] for n in CASES for p in ("new", "base")}
        answers = {}
        for _ in range(max(1, args.repeat)):
            for name, code in CASES.items():
                for p in ("new", "base"):  # interleaved: one run of each in turn
                    c, w, k, ans = _run(code, None if p == "new" else base)
                    cpu[name, p].append(c)
                    answers[name, p] = ans
                    print(f"  {name} [{'this checkout' if p == 'new' else args.against}]: CPU "
                          f"{c:.2f} s (wall {w:.2f} s), {k} conic programs; {ans}", flush=True)
    for name in CASES:
        ratio = statistics.median(b / a for a, b in zip(cpu[name, "new"], cpu[name, "base"]))
        same = _same(answers[name, "new"], answers[name, "base"])
        met = target(f"SOS certificate speed-up (CPU, {args.against} / this): {name}", ratio,
                     TARGET_RATIO, unit="x", at_least=True,
                     detail=f"median of {args.repeat}, fresh processes after a warm-up")
        ok &= met and same
        print(f"{name}: CPU {statistics.median(cpu[name, 'new']):.2f} s vs "
              f"{statistics.median(cpu[name, 'base']):.2f} s, ratio {ratio:.2f}x (target >= "
              f"{TARGET_RATIO:g}x): {'meets' if met else 'MISS'}; same answer: {same}")
    print(load_line())
    print("holds" if ok else "FAILS")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
