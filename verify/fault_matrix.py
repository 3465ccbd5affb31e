"""Fault matrix: bad inputs and environment faults, each in its own subprocess, classified.

Every case runs in a fresh interpreter with a timeout and ends in one class:

* ``clear``   - an exception from :mod:`fl_design.errors` (the message names the problem);
* ``result``  - it ran (for environment faults: the documented fallback, e.g. a
  temporary cache or CasADi's interpreter, with a ``CompilationWarning``);
* ``raw``     - any other exception (a raw traceback: a bug);
* ``crash``   - the process died from a signal (SIGBUS, SIGSEGV...);
* ``hang``    - the timeout expired;
* ``skipped`` - the case needs an API not present yet (e.g. ``fl.simulate(plant, design,
  fl.Scenario(...))`` while the run functions are being moved to the option objects).

Prints the counts per class (and the non-clear cases); exits 1 unless raw, crash and hang are
all zero. ``--quick`` runs a representative subset in a few seconds (the tests run it);
``-v`` prints every case.

    python verify/fault_matrix.py [--quick] [-v] [--timeout SECONDS] [--jobs N]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import textwrap
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

#: Run in every child before the case: helpers shared by the cases.
PRELUDE = r'''
import errno, inspect, json, os, sys, warnings
from pathlib import Path
import numpy as np, sympy as sp
import fl_design as fl
TMP = Path(os.environ["FAULT_TMP"])

class ApiMissing(Exception):
    """The case needs an API that this version does not have."""

x1, x2, u = sp.symbols("x1 x2 u", real=True)
def ode(second, **kw):
    return fl.Plant.from_ode([x1, x2], u, [x2, second], x1, **kw)
def design(eps=0.02, gamma=1e-2, rho=2):
    return fl.Design(estimator=fl.EHGO(rho=rho, eps=eps, T=1e-3),
                     controller=fl.DynamicController((2, 4), gamma))
def simulate(*args, **kw):
    if "scenario" not in inspect.signature(fl.simulate).parameters:
        raise ApiMissing("fl.simulate(plant, design, scenario)")
    return fl.simulate(*args, **kw)
def sweep(*args, **kw):
    if "scenario" not in inspect.signature(fl.sweep).parameters:
        raise ApiMissing("fl.sweep(plant, design, scenario, ...)")
    return fl.sweep(*args, **kw)
def kernel(cache_dir=None):
    """Compiled record of the pendulum loop; also checked against a clean build."""
    from fl_design.sim._run import prepare_run
    try:
        run = prepare_run(fl.plants.pendulum(), design(), fl.Scenario(0.1, 0.3))
    except TypeError as exc:
        raise ApiMissing(f"prepare_run: {exc}")
    acc0 = run.initial_accumulator(design().parameter_vector())[:, 0]
    runner = run.loop.runner(compiled=True, cache_dir=cache_dir)
    out = runner.record(acc0.copy(), run.D)[1]
    ref = run.loop.runner(compiled=True, cache_dir=TMP / "clean").record(acc0.copy(), run.D)[1]
    if runner.compiled:
        assert np.array_equal(out, ref), "the run differs from a clean build"
    else:
        assert np.allclose(out, ref, rtol=1e-9, atol=1e-12), "interpreter differs"
    return runner
def prebuilt(cache):
    """Build the pendulum kernel into ``cache`` without loading it; its path."""
    from fl_design._toolchain import build
    from fl_design.sim import ClosedLoop
    from fl_design.sim.kernel._runners import runner_source
    loop = ClosedLoop(fl.plants.pendulum(), design(), substeps=1)
    sl = loop.layout.slices
    idx = {"k": sl["k"].start, "div": sl["diverged"].start, "N": sl["N"].start}
    return build(runner_source(loop.accumulate, loop.record, idx), "fl_loop", cache_dir=cache)
def raise_under(module, name, root, code, arg=0):
    real = getattr(module, name)
    def fake(*a, **k):
        if str(a[arg]).startswith(str(root)):
            raise OSError(code, os.strerror(code), str(a[arg]))
        return real(*a, **k)
    setattr(module, name, fake)
def a_file(name="file"):
    p = TMP / name
    p.write_text("not a directory")
    return p
'''

#: Run the case, classify in-process exceptions, print one JSON line.
RUNNER = r'''
import traceback, warnings as _w
_caught = []
_w.simplefilter("always")
_w.showwarning = lambda m, c, *a, **k: _caught.append(f"{c.__name__}: {m}")
try:
    exec(compile(PRELUDE, "<prelude>", "exec"), globals())
    exec(compile(CASE, "<case>", "exec"), globals())
    _out = {"cls": "result", "detail": ""}
except BaseException as exc:
    import fl_design.errors as _e
    if type(exc).__name__ == "ApiMissing":
        _out = {"cls": "skipped", "detail": str(exc)}
    elif isinstance(exc, _e.FlDesignError):
        _out = {"cls": "clear", "detail": f"{type(exc).__name__}: {exc}"}
    else:
        _out = {"cls": "raw", "detail": "".join(traceback.format_exception(exc))[-1500:]}
_out["warnings"] = _caught[:3]
print("@@FAULT@@" + json.dumps(_out))
'''


@dataclass
class Case:
    name: str
    code: str
    kind: str = "input"  # or "env"
    env: dict = field(default_factory=dict)
    quick: bool = False


def _inputs() -> list[Case]:
    c = lambda name, code, quick=False: Case(name, code, "input", quick=quick)
    return [
        # Plant.from_ode: SymPy constructs and definitions
        c("from_ode Piecewise without otherwise", "ode(sp.Piecewise((x1, x1 > 0)) + u)", True),
        c("from_ode zoo", "ode(sp.zoo * x1 + u)"),
        c("from_ode oo", "ode(sp.oo * x1 + u)"),
        c("from_ode nan", "ode(sp.nan * x1 + u)"),
        c("from_ode 1/x1 singular at the point", "ode(1 / x1 + u)"),
        c("from_ode sqrt of negative at the point", "ode(sp.sqrt(x1 - 1) + u)"),
        c("from_ode undefined g(x1)", "ode(sp.Function('g')(x1) + u)"),
        c("from_ode Derivative", "ode(sp.Derivative(x1 * x2, x1) + u)"),
        c("from_ode Integral", "ode(sp.Integral(x1, x1) + u)"),
        c("from_ode unsupported gamma()", "ode(sp.gamma(x1 + 2) + u - 1)"),
        c("from_ode strings vs real symbols",
          "fl.Plant.from_ode([x1, x2], u, ['x2', '-x1 + u'], x1)"),
        c("from_ode states not symbols", "fl.Plant.from_ode(['a', 1], u, [x2, u], x1)"),
        c("from_ode rhs wrong length", "fl.Plant.from_ode([x1, x2], u, [x2], x1)"),
        c("from_ode input among states", "fl.Plant.from_ode([x1, u], u, [u, u], x1)"),
        c("from_ode not actuated", "ode(-x1)"),
        c("from_ode output depends on u", "fl.Plant.from_ode([x1, x2], u, [x2, u], x1 + u)"),
        c("from_ode unknown param", "ode(-x1 + u, params={'k': 1.0})"),
        c("from_ode param value string", "ode(-sp.Symbol('k') * x1 + u, params={'k': '1'})"),
        c("from_ode region reversed", "ode(-x1 + u, region={x1: (1, -1)})"),
        c("from_ode point outside region", "ode(-x1 + u, region={x1: (1, 2)})"),
        c("from_ode b vanishes at the point", "ode(u * x2 + x1).relative_degree()"),
        # plants.*
        c("trms_yaw motor_lag='no'", "fl.plants.trms_yaw(motor_lag='no')"),
        c("trms_yaw I2=-1", "fl.plants.trms_yaw(I2=-1)"),
        c("trms_yaw I2='2e-2'", "fl.plants.trms_yaw(I2='2e-2')"),
        c("trms_yaw T21 string, no lag", "fl.plants.trms_yaw(T21='1')"),
        c("pendulum g=nan", "fl.plants.pendulum(g=float('nan'))"),
        c("pendulum l=0", "fl.plants.pendulum(l=0)"),
        c("pendulum input_range reversed", "fl.plants.pendulum(input_range=(1, -1))"),
        c("flexible_joint k=True", "fl.plants.flexible_joint(k=True)"),
        # EHGO
        c("EHGO rho=0", "fl.EHGO(0, 0.05, 1e-3)"),
        c("EHGO rho=2.0", "fl.EHGO(2.0, 0.05, 1e-3)"),
        c("EHGO eps='0.05'", "fl.EHGO(2, '0.05', 1e-3)"),
        c("EHGO eps=-1", "fl.EHGO(2, -1.0, 1e-3)"),
        c("EHGO T=nan", "fl.EHGO(2, 0.05, float('nan'))"),
        c("EHGO coeffs strings", "fl.EHGO(2, 0.05, 1e-3, coeffs=('6', 11, 6))", True),
        c("EHGO coeffs not Hurwitz", "fl.EHGO(2, 0.05, 1e-3, coeffs=(-6, 11, 6))"),
        c("EHGO coeffs wrong length", "fl.EHGO(2, 0.05, 1e-3, coeffs=(6, 11))"),
        c("EHGO method='foo'", "fl.EHGO(2, 0.05, 1e-3, method='foo')"),
        c("EHGO allow_unstable='yes'", "fl.EHGO(2, 0.05, 1e-3, allow_unstable='yes')"),
        # LeastSquaresEstimator
        c("LS window=10**6", "fl.LeastSquaresEstimator(2, 1e-3, window=10**6)", True),
        c("LS window=2 < degree+1", "fl.LeastSquaresEstimator(2, 1e-3, window=2)"),
        c("LS degree < rho", "fl.LeastSquaresEstimator(2, 1e-3, window=9, degree=1)"),
        c("LS window=9.5", "fl.LeastSquaresEstimator(2, 1e-3, window=9.5)"),
        c("LS T=0", "fl.LeastSquaresEstimator(2, 0, window=9)"),
        # DynamicController
        c("controller gains=()", "fl.DynamicController((), 1e-2)"),
        c("controller gains not Hurwitz", "fl.DynamicController((-2, 4), 1e-2)"),
        c("controller gamma=0", "fl.DynamicController((2, 4), 0.0)"),
        c("controller gamma='1e-2'", "fl.DynamicController((2, 4), '1e-2')"),
        c("controller ki=-1", "fl.DynamicController((2, 4), 1e-2, ki=-1)"),
        c("controller u_limits reversed", "fl.DynamicController((2, 4), 1e-2, u_limits=(1, -1))"),
        c("controller estimate_limits length",
          "fl.DynamicController((2, 4), 1e-2, estimate_limits=(None,))"),
        # Design
        c("Design estimator='x'", "fl.Design(estimator='x', controller=design().controller)"),
        c("Design controller=None", "fl.Design(estimator=fl.EHGO(2, 0.05, 1e-3), controller=None)"),
        c("Design orders differ", "fl.Design(estimator=fl.EHGO(3, 0.05, 1e-3), "
          "controller=fl.DynamicController((2, 4), 1e-2))"),
        c("Design.replace(foo=1)", "design().replace(foo=1)"),
        # taylor_discretization
        c("taylor order 25", "fl.taylor_discretization(fl.plants.pendulum(), 25)", True),
        c("taylor order=0", "fl.taylor_discretization(2, 0)"),
        c("taylor order=2.5", "fl.taylor_discretization(2, 2.5)"),
        c("taylor plant='pendulum'", "fl.taylor_discretization('pendulum', 2)"),
        c("taylor rho=0", "fl.taylor_discretization(0, 2)"),
        # options objects
        c("Scenario duration='1.0'", "fl.Scenario(0.3, '1.0')"),
        c("Scenario duration=-1", "fl.Scenario(0.3, -1.0)"),
        c("Scenario duration=nan", "fl.Scenario(0.3, float('nan'))"),
        c("Scenario array reference, no duration", "fl.Scenario(np.zeros(10))"),
        c("Scenario reference with NaN in 10^6",
          "r = np.zeros(10**6); r[-5] = np.nan; fl.Scenario(r, 1000.0)", True),
        c("Scenario reference='abc'", "fl.Scenario('abc', 1.0)"),
        c("Noise std=-1", "fl.Noise(std=-1)"),
        c("Noise seed=1.5", "fl.Noise(seed=1.5)"),
        c("Classifier tolerance=0", "fl.Classifier(tolerance=0)"),
        c("Classifier tail_fraction=2", "fl.Classifier(tail_fraction=2)"),
        c("RK4 substeps=0", "fl.RK4(substeps=0)"),
        c("Kernel threads=-5", "fl.Kernel(threads=-5)"),
        c("Kernel threads=2.5", "fl.Kernel(threads=2.5)"),
        c("Kernel compiled='no'", "fl.Kernel(compiled='no')"),
        c("Kernel chunk_size=0", "fl.Kernel(chunk_size=0)"),
        # analysis
        c("linearized_eps_star rtol=1e-17",
          "fl.linearized_eps_star(fl.plants.pendulum(), design(), rtol=1e-17)", True),
        c("linearized_eps_star plant='x'", "fl.linearized_eps_star('x', design())"),
        c("linearized_eps_star eps_range=(0, 1)",
          "fl.linearized_eps_star(fl.plants.pendulum(), design(), eps_range=(0, 1))"),
        c("sampled_linearization design=EHGO",
          "fl.sampled_linearization(fl.plants.pendulum(), fl.EHGO(2, 0.05, 1e-3))"),
        # run functions (through the Scenario API when present)
        c("simulate duration 1e9", "simulate(fl.plants.pendulum(), design(), "
          "fl.Scenario(0.1, 1e9))", True),
        c("simulate plant='x'", "simulate('x', design(), fl.Scenario(0.1, 1.0))"),
        c("simulate rho mismatch", "simulate(fl.plants.flexible_joint(), design(), "
          "fl.Scenario(0.1, 1.0))"),
        c("sweep eps=[]", "sweep(fl.plants.pendulum(), design(), fl.Scenario(0.1, 1.0), "
          "eps=[], gamma=[1e-2])"),
    ]


def _envs() -> list[Case]:
    e = lambda name, code, env=None, quick=False: Case(name, code, "env", env or {}, quick)
    corrupt = "lib = prebuilt(TMP / 'cache'); {}; kernel(TMP / 'cache')"
    side = "Path(str(lib) + '.json')"
    return [
        e("cache: truncated library", corrupt.format(
            "lib.write_bytes(lib.read_bytes()[:1000])"), quick=True),
        e("cache: empty library", corrupt.format("lib.write_bytes(b'')")),
        e("cache: garbage library", corrupt.format("lib.write_bytes(b'garbage' * 100)")),
        e("cache: missing sidecar", corrupt.format(f"{side}.unlink()")),
        e("cache: sidecar mismatch", corrupt.format(
            f"{side}.write_text(json.dumps({{'size': 1, 'sha256': '0' * 64}}))")),
        e("cache: FL_DESIGN_CACHE is a file", "kernel()", {"FL_DESIGN_CACHE": "@TMP@/f"},
          quick=True),
        e("cache: FL_DESIGN_CACHE under a file", "kernel()",
          {"FL_DESIGN_CACHE": "@TMP@/f/cache"}),
        e("cache: XDG_CACHE_HOME is a file", "kernel()", {"XDG_CACHE_HOME": "@TMP@/f"}),
        e("cache: read-only file system (EROFS)",
          "raise_under(os, 'mkdir', TMP / 'ro', errno.EROFS); kernel(TMP / 'ro' / 'c')"),
        e("cache: no permission (EACCES)",
          "(TMP / 'd').mkdir(); raise_under(os, 'mkdir', TMP / 'd', errno.EACCES); "
          "kernel(TMP / 'd')"),
        e("cache: full disk (ENOSPC)",
          "(TMP / 'd').mkdir(); raise_under(os, 'replace', TMP / 'd', errno.ENOSPC, 1); "
          "kernel(TMP / 'd')"),
        e("cache and temporary directory unusable (ENOSPC)",
          "import tempfile; real = tempfile.mkdtemp\n"
          "def full(*a, **k):\n"
          "    if k.get('prefix') == 'fl_design-cache-':\n"
          "        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))\n"
          "    return real(*a, **k)\n"
          "tempfile.mkdtemp = full; kernel()",
          {"FL_DESIGN_CACHE": "@TMP@/f"}),
        e("TMPDIR under a regular file", "kernel()",
          {"FL_DESIGN_CACHE": "@TMP@/f", "TMPDIR": "@TMP@/f/tmp"}),
        e("CC='gcc -m64'", "kernel(TMP / 'cache')", {"CC": "gcc -m64"}),
        e("CC names a missing compiler", "kernel(TMP / 'cache')", {"CC": "no-such-cc -O2"}),
        e("CC='false' (compiler fails)", "kernel(TMP / 'cache')", {"CC": "false"}),
        e("CC with an unbalanced quote", "kernel(TMP / 'cache')", {"CC": "gcc '-m64"}),
        e("FL_DESIGN_MAX_WINDOW='many'", "fl.LeastSquaresEstimator(2, 1e-3, window=9)",
          {"FL_DESIGN_MAX_WINDOW": "many"}),
    ]


def run_case(case: Case, timeout: float) -> dict:
    """Run one case in a fresh interpreter; its class, detail and time."""
    with tempfile.TemporaryDirectory(prefix="fl_fault-") as tmp:
        with open(os.path.join(tmp, "f"), "w") as fh:
            fh.write("a regular file")
        env = dict(os.environ, FAULT_TMP=tmp, FL_DESIGN_CACHE=os.path.join(tmp, "default"))
        env.update({k: v.replace("@TMP@", tmp) for k, v in case.env.items()})
        if "XDG_CACHE_HOME" in case.env:
            env.pop("FL_DESIGN_CACHE")
        code = (f"PRELUDE = {PRELUDE!r}\nCASE = {textwrap.dedent(case.code)!r}\n"
                "import json\n" + RUNNER)
        start = time.perf_counter()
        try:
            proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                                  text=True, timeout=timeout, check=False)
        except subprocess.TimeoutExpired:
            return {"cls": "hang", "detail": f"no answer within {timeout:g} s",
                    "seconds": timeout}
        seconds = time.perf_counter() - start
    if proc.returncode < 0:
        return {"cls": "crash", "detail": f"signal {-proc.returncode}: {proc.stderr[-500:]}",
                "seconds": seconds}
    line = next((ln for ln in proc.stdout.splitlines() if ln.startswith("@@FAULT@@")), None)
    if line is None:
        return {"cls": "raw", "detail": f"exit {proc.returncode}: {proc.stderr[-1500:]}",
                "seconds": seconds}
    return {**json.loads(line[len("@@FAULT@@"):]), "seconds": seconds}


CLASSES = ("clear", "result", "raw", "crash", "hang", "skipped")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a representative subset")
    parser.add_argument("-v", "--verbose", action="store_true", help="print every case")
    parser.add_argument("--timeout", type=float, default=None, help="seconds per case")
    parser.add_argument("--jobs", type=int, default=max(2, min(8, os.cpu_count() or 1)))
    args = parser.parse_args(argv)
    cases = _inputs() + _envs()
    if args.quick:
        cases = [c for c in cases if c.quick]
    timeout = args.timeout or (60.0 if args.quick else 120.0)
    start = time.perf_counter()
    with ThreadPoolExecutor(max(1, args.jobs)) as pool:
        results = list(pool.map(lambda c: run_case(c, timeout), cases))
    counts = {kind: {cls: 0 for cls in CLASSES} for kind in ("input", "env")}
    for case, res in zip(cases, results):
        counts[case.kind][res["cls"]] += 1
        if args.verbose or res["cls"] not in ("clear", "result"):
            first = res["detail"].strip().splitlines()[-1] if res["detail"].strip() else ""
            warn = f" [{res['warnings'][0][:90]}]" if res.get("warnings") else ""
            print(f"{res['cls']:>7}  {case.kind:5}  {case.name}: {first[:160]}{warn}")
    print(f"\n{len(cases)} cases ({sum(c.kind == 'input' for c in cases)} bad inputs, "
          f"{sum(c.kind == 'env' for c in cases)} environment faults) in "
          f"{time.perf_counter() - start:.1f} s")
    print(f"{'':14}" + "".join(f"{cls:>9}" for cls in CLASSES))
    for kind, row in counts.items():
        print(f"{kind:14}" + "".join(f"{row[cls]:>9}" for cls in CLASSES))
    bad = sum(row[cls] for row in counts.values() for cls in ("raw", "crash", "hang"))
    print("OK: no raw traceback, crash or hang" if not bad else
          f"FAIL: {bad} case(s) ended in a raw traceback, a crash or a hang")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
