"""Benchmark: certify_eps and certify_gamma where b varies in time (the quartic SOS certificate).

Issue 33 ("answers at the speed of design"): the varying-b certificate of the paper's TRMS design
(``certify_eps(paper_design(), (3.6, 6.8))``, ``certify_gamma`` of the same) and of a rho = 3
class (:data:`CASES`) solve the quartic sum-of-squares program of :mod:`fl_design.analysis._sos`
a few times per call. Each case is timed in this process after a warm-up (imports, CasADi
compiled), in CPU seconds (``time.process_time``: single-threaded work, the measure that
survives a shared machine's load) and wall seconds, with the SOS programs it solved, twice
per round, interleaved: once with the SOS program handed to Clarabel directly (the default,
:mod:`fl_design.analysis._sdp_sos`) and once through CVXPY (``backend="cvxpy"``, the path
before session 33). Prints the machine, its ISA and the load, the median CPU ratio per case
and whether both paths gave the same answer (eps* within the bisection's ``rtol``, the same
verdict and coverage).

Target: CPU ratio CVXPY / direct >= :data:`TARGET_RATIO` on every case (median of
``--repeat`` rounds). ``--quick``: the paper design's certify_eps once per path, no target
judged (the tests run it).

    python verify/bench_sos.py [--quick] [--repeat N]
"""

from __future__ import annotations

import argparse
import contextlib
import statistics
import sys
import time

from _shared import load_line, machine, target

import fl_design as fl
from fl_design.analysis import _sos

#: The CPU speed-up asked for (issue 33, session 33's brief).
TARGET_RATIO = 3.0
RTOL = 1e-2


def _rho3():
    cls = fl.PlantClass(rho=3, T=1e-3, b=(1.0, 5.0))
    d = fl.Design(estimator=fl.EHGO(3, 1e-2, 1e-3), controller=fl.DynamicController(
        fl.synthesize_gains(3, decay=1.0).gains, 0.05))
    return d, cls


#: ``name -> call`` (each returns a certificate).
CASES = {
    "certify_eps, paper design, b in [3.6, 6.8] varying": lambda: fl.certify_eps(
        fl.presets.paper_design(), (3.6, 6.8), rtol=RTOL),
    "certify_gamma, paper design, b in [3.6, 6.8] varying": lambda: fl.certify_gamma(
        fl.presets.paper_design(), (3.6, 6.8)),
    "certify_eps, rho 3, b in [1, 5] varying": lambda: fl.certify_eps(*_rho3(), rtol=RTOL),
}


@contextlib.contextmanager
def backend(name: str):
    """``sos_lyapunov`` with ``backend=name`` inside the block (the bench's switch only)."""
    original = _sos.sos_lyapunov

    def swapped(deltas, T, **kw):
        return original(deltas, T, backend=name)

    _sos.sos_lyapunov = swapped
    try:
        yield
    finally:
        _sos.sos_lyapunov = original


def _answer(c) -> tuple:
    """What must agree between the paths: verdict, coverage, certified eps* (or interval)."""
    if hasattr(c, "eps_star_certified"):
        return (c.certified, c.covers, c.point.kind, c.point.covers, c.eps_star_certified,
                *(x.certified for x in c.brackets), *(x.refuted for x in c.brackets))
    return (c.certified, c.point.kind, c.point.covers, c.gamma_min, c.gamma_max)


def _same(a: tuple, b: tuple) -> bool:
    for x, y in zip(a, b):
        if isinstance(x, float) and isinstance(y, float):
            if abs(x / y - 1.0) > RTOL * 1.0001:
                return False
        elif x != y:
            return False
    return True


def _timed(call):
    from fl_design.analysis._lmi import solve_count

    n0, c0, t0 = solve_count(), time.process_time(), time.perf_counter()
    out = call()
    return time.process_time() - c0, time.perf_counter() - t0, solve_count() - n0, out


def main(argv=None) -> int:
    """Run the benchmark; return the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="the paper design's certify_eps once per path, no target")
    parser.add_argument("--repeat", type=int, default=3, help="interleaved rounds")
    args = parser.parse_args(argv)
    print(machine())
    names = list(CASES)[:1] if args.quick else list(CASES)
    repeat = 1 if args.quick else max(1, args.repeat)
    fl.certify_eps(fl.presets.paper_design(), (3.6, 6.8), search=False)  # warm-up
    cpu = {(n, p): [] for n in names for p in ("direct", "cvxpy")}
    answers, ok = {}, True
    for _ in range(repeat):
        for n in names:
            for path in ("direct", "cvxpy"):
                with backend("clarabel" if path == "direct" else "cvxpy"):
                    c, w, k, out = _timed(CASES[n])
                cpu[n, path].append(c)
                answers[n, path] = _answer(out)
                print(f"  {n} [{path}]: CPU {c:.2f} s (wall {w:.2f} s), {k} conic programs; "
                      f"{answers[n, path]}", flush=True)
    for n in names:
        ratio = statistics.median(a / b for a, b in zip(cpu[n, "cvxpy"], cpu[n, "direct"]))
        same = _same(answers[n, "direct"], answers[n, "cvxpy"])
        ok &= same
        met = target(f"SOS certificate speed-up (CPU, CVXPY / direct): {n}", ratio,
                     TARGET_RATIO, unit="x", at_least=True, checked=not args.quick,
                     detail=f"median of {repeat}, in process after a warm-up")
        ok &= met or args.quick
        print(f"{n}: CPU direct {statistics.median(cpu[n, 'direct']):.2f} s, CVXPY "
              f"{statistics.median(cpu[n, 'cvxpy']):.2f} s, ratio {ratio:.2f}x (target >= "
              f"{TARGET_RATIO:g}x{', not judged' if args.quick else ''}); same answer: {same}")
    print(load_line())
    print("holds" if ok else "FAILS")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
