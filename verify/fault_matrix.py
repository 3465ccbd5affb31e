"""Fault matrix: bad inputs and environment faults, each in its own subprocess, classified.

Every case runs in a fresh interpreter with a timeout and ends in one class:

* ``clear``   - an exception from :mod:`fl_design.errors` (the message names the problem);
* ``result``  - it ran (for environment faults: the documented fallback, e.g. a
  temporary cache or CasADi's interpreter, with a ``CompilationWarning``);
* ``exec``    - code executed: a payload's marker file (``TMP/pwned``) appeared;
* ``lost``    - files lost: a user's project folder (``TMP/project``: Makefile, README.md,
  main.c, written before every case) changed;
* ``falsediag`` - false diagnosis: a case that must run (a valid, e.g. badly scaled, plant)
  ended in an error;
* ``silent``  - silent acceptance: a case that must be refused ran;
* ``raw``     - any other exception (a raw traceback: a bug);
* ``crash``   - the process died from a signal (SIGBUS, SIGSEGV...);
* ``hang``    - the timeout expired;
* ``skipped`` - the case needs an API not present yet.

Prints the counts per class (and the cases not ``clear``/``result``); exits 1 unless exec,
lost, falsediag, silent, raw, crash and hang are all zero. ``--quick`` runs a representative
subset (the tests run it); ``-v`` prints every case.

    python verify/fault_matrix.py [--quick] [-v] [--timeout SECONDS] [--jobs N]
                                  [--match REGEX] [--issue36] [--heldout]
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
PWNED = TMP / "pwned"
PROJECT = TMP / "project"
VICTIM = TMP / "outside_victim.txt"  # a user's file outside every output folder: must never change
def cli(*args):
    """The command line in-process; exit 2 (one line on stderr) counts as a clear error."""
    from fl_design.app import main
    rc = main([str(a) for a in args])
    if rc == 2:
        raise fl.errors.FlDesignError("fl-design exited 2")
    return rc
def toml(text, name="c.toml"):
    p = TMP / name
    p.write_text(text, encoding="utf-8")
    return p
def custom(second, extra=""):
    return toml('[plant]\nstates = ["x1", "x2"]\ninput = "u"\n'
                f'rhs = ["x2", {json.dumps(second)}]\noutput = "x1"\n' + extra)
def not_me(module=os):
    me = os.geteuid()
    module.geteuid = lambda: me + 4242
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

#: Files of the user's project written before each case (the ``lost`` check).
VICTIM_TEXT = "a user's file outside the output folder\n"
PROJECT_FILES = {"Makefile": "all:\n\techo mine\n", "README.md": "# my project\n",
                 "main.c": "int main(void) { return 0; }\n"}


@dataclass
class Case:
    name: str
    code: str
    kind: str = "input"  # or "env"
    env: dict = field(default_factory=dict)
    quick: bool = False
    expect: str | None = None  # "error" (must be refused), "result" (must run) or either


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


_PAYLOADS = [
    ("__import__ os.system", "__import__('os').system('touch {p}') + u"),
    ("exec", "exec(\"open('{p}', 'w')\") + u"),
    ("eval", "eval(\"open('{p}', 'w')\") + u"),
    ("lambda", "(lambda: open('{p}', 'w'))() + u"),
    ("open().write", "open('{p}', 'w').write('x') + u"),
    ("dunder class walk", "().__class__.__bases__[0].__subclasses__()"),
    ("getattr", "getattr(u, 'func')"),
    ("globals", "globals()['fl']"),
    ("comprehension", "[open('{p}', 'w') for i in (1,)]"),
    ("walrus", "(z := open('{p}', 'w'))"),
    ("f-string", "f\"{{open('{p}', 'w')}}\""),
    ("subscript", "u[0]"),
    ("keyword call", "sin(x=u)"),
    ("starred call", "sin(*[u])"),
    ("Symbol()", "Symbol('{p}')"),
    ("sympify in string", "sympify('u')"),
    ("2**2**40", "2**2**40 + u"),
    ("factorial(10**8)", "factorial(10**8) + u"),
    ("x1**(10**10)", "x1**(10**10) + u"),
    ("10**999*10**999", "10**999 * 10**999 + u"),
    ("(10**64)**64", "(10**64)**64 * u"),
    ("250 nested parentheses", "(" * 250 + "u" + ")" * 250),
    ("5000 unary minus", "-" * 5000 + "u"),
    ("500 chained powers", "x1" + "**x1" * 500 + " + u"),
    ("200 nested sin", "sin(" * 200 + "u" + ")" * 200),
    ("20000 characters", "x1 + " * 4000 + "u"),
    ("1e999", "1e999 * x1 + u"),
    ("True", "True + u"),
    ("1j", "1j * u"),
    ("string literal", "'u'"),
    ("^ for power", "x1 ^ 2 + u"),
    ("// floor division", "x1 // 2 + u"),
    ("conditional", "x1 if u else x2"),
    ("comparison", "(x1 < u) + u"),
    ("typo Al for A1", "-Al * x1 + u"),
    ("unknown function", "gamma(x1) + u"),
    ("empty", ""),
]


def _safety() -> list[Case]:
    """Issue 19: strings, caches, output folders, structure checks, limits."""
    cases = []
    for i, (name, text) in enumerate(_PAYLOADS):
        code = f"ode({text!r}.format(p=PWNED))"
        cases.append(Case(f"string rhs: {name}", code, quick=i < 6, expect="error"))
    for i, (name, text) in enumerate(_PAYLOADS[:17]):
        code = f"cli('derive', custom({text!r}.format(p=PWNED)))"
        cases.append(Case(f"config rhs via derive: {name}", code, quick=i < 3, expect="error"))
    for name, text in [("pendulum-like", "-9.81*sin(x1) - 0.1*x2 + u"),
                       ("atan2/Abs/sign", "atan2(x1, 1) + Abs(x2)*sign(x1) + u"),
                       ("long sum", " + ".join(["x1"] * 1500) + " + u"),
                       ("pi and E", "-pi*x1 - E*x2 + u")]:
        cases.append(Case(f"string rhs valid: {name}", f"ode({text!r}).relative_degree()",
                          expect="result"))
    for name, text in [("-1e10*x1 + u", "-1e10*x1 + u"), ("-x1 + 1e-12*u", "-x1 + 1e-12*u"),
                       ("x1**30 + u", "x1**30 + u"), ("1e8*x1**3 - 1e-9*u", "1e8*x1**3 - 1e-9*u")]:
        cases.append(Case(f"badly scaled plant is actuated: {name}",
                          f"assert ode({text!r}).relative_degree() == 2", quick="1e-12" in text,
                          expect="result"))
        cases.append(Case(f"badly scaled plant via derive: {name}", f"cli('derive', custom({text!r}))",
                          expect="result"))
    e = lambda name, code, env=None, quick=False, expect=None: Case(
        name, code, "env", env or {}, quick, expect)
    boom = ("class Boom:\n    def __reduce__(self):\n        return (open, (str(PWNED), 'w'))\n"
            "import pickle\n")
    cases += [
        e("cache: planted pickles for every derivation",
          "fl.plants.trms_yaw().normal_form()\n" + boom +
          "from fl_design._cache import write_verified\n"
          "for f in (TMP / 'cache').glob('plant_*'):\n"
          "    if not f.name.endswith('.json'):\n"
          "        write_verified(f.name, b'0' * 32 + pickle.dumps(Boom()), cache_dir=f.parent)\n"
          "fl.plants.trms_yaw().normal_form()", {"FL_DESIGN_CACHE": "@TMP@/cache"}, True,
          "result"),
        e("cache: unsigned pickle (old format)",
          "fl.plants.pendulum().normal_form()\n" + boom +
          "from fl_design._cache import write_verified\n"
          "for f in (TMP / 'cache').glob('plant_*'):\n"
          "    if not f.name.endswith('.json'):\n"
          "        write_verified(f.name, pickle.dumps(Boom()), cache_dir=f.parent)\n"
          "fl.plants.pendulum().normal_form()", {"FL_DESIGN_CACHE": "@TMP@/cache"},
          expect="result"),
        e("cache: world-writable folder", "(TMP / 'open').mkdir(); os.chmod(TMP / 'open', 0o777)\n"
          "fl.plants.pendulum().normal_form(); kernel()\n"
          "assert not any(p.name.startswith('plant_') for p in (TMP / 'open').iterdir())",
          {"FL_DESIGN_CACHE": "@TMP@/open"}, True, "result"),
        e("cache: group-writable folder", "(TMP / 'g').mkdir(); os.chmod(TMP / 'g', 0o770)\n"
          "fl.plants.pendulum().normal_form()\n"
          "assert not list((TMP / 'g').iterdir())", {"FL_DESIGN_CACHE": "@TMP@/g"},
          expect="result"),
        e("cache: folder of another user", "(TMP / 'theirs').mkdir(mode=0o700); not_me()\n"
          "fl.plants.pendulum().normal_form()\n"
          "assert not list((TMP / 'theirs').iterdir())", {"FL_DESIGN_CACHE": "@TMP@/theirs"},
          expect="result"),
        e("cache: exposed key (0644)", "fl.plants.pendulum().normal_form()\n"
          "os.chmod(TMP / 'config' / 'fl_design' / 'cache.key', 0o644)\n"
          "fl.plants.maglev().normal_form()", {"FL_DESIGN_CACHE": "@TMP@/c"}, expect="result"),
        e("cache: symlink planted at an entry", "fl.plants.pendulum().normal_form()\n"
          "victim = TMP / 'victim.txt'; victim.write_text('keep')\n"
          "for f in (TMP / 'c').glob('plant_*_chain.pkl'):\n"
          "    f.unlink(); f.symlink_to(victim)\n"
          "fl.plants.pendulum().normal_form()\n"
          "assert victim.read_text() == 'keep'", {"FL_DESIGN_CACHE": "@TMP@/c"},
          expect="result"),
        e("cache: relative XDG_CACHE_HOME", "os.chdir(TMP); fl.plants.pendulum().normal_form()\n"
          "assert not (TMP / 'rel').exists()", {"XDG_CACHE_HOME": "rel", "HOME": "@TMP@/home"},
          expect="result"),
        e("output: generate_c into a project", "from fl_design import presets\n"
          "fl.generate_c(presets.least_squares_design(9), PROJECT)", quick=True, expect="error"),
        e("output: codegen . in a project", "os.chdir(PROJECT); cli('codegen', '.')",
          quick=True, expect="error"),
        e("output: run --out a project", "cli('run', '--quick', '--no-progress', '--out', PROJECT)",
          expect="error"),
        e("output: report into a project", "from fl_design.app import load_config, run_job, "
          "write_report\njob = run_job(load_config(None), quick=True, stages=('derive',), "
          "progress=False)\nwrite_report(job, PROJECT)", expect="error"),
        e("output: a hand-edited fl.c", "from fl_design import presets\n"
          "d = presets.least_squares_design(9); fl.generate_c(d, TMP / 'c')\n"
          "(TMP / 'c' / 'fl.c').write_text('/* edited */')\nfl.generate_c(d, TMP / 'c')",
          expect="error"),
        e("output: generate_c twice into its own folder", "from fl_design import presets\n"
          "d = presets.least_squares_design(9); fl.generate_c(d, TMP / 'c'); "
          "fl.generate_c(d, TMP / 'c')", expect="result"),
        e("output: force=True elsewhere", "from fl_design import presets\n"
          "(TMP / 'o').mkdir(); (TMP / 'o' / 'x.txt').write_text('x')\n"
          "fl.generate_c(presets.least_squares_design(9), TMP / 'o', force=True)",
          expect="result"),
        e("RK4 substeps=10**6", "fl.RK4(substeps=10**6)", quick=True, expect="error"),
        e("RK4 substeps=10**9", "simulate(fl.plants.pendulum(), design(), fl.Scenario(0.1, 0.1),"
          " integrator=fl.RK4(substeps=10**9))", expect="error"),
        e("ClosedLoop substeps=10**7", "from fl_design.sim import ClosedLoop\n"
          "ClosedLoop(fl.plants.pendulum(), design(), substeps=10**7)", expect="error"),
        e("3e7-sample run over a 1.5 GiB cap", "simulate(fl.plants.pendulum(), design(), "
          "fl.Scenario(0.1, 3e4))", {"FL_DESIGN_MAX_MEMORY_GB": "1.5"}, True, "error"),
    ]
    for value in ("inf", "nan", "1e999", "-1", "0", "banana", "0x10", "4 GB"):
        cases.append(e(f"FL_DESIGN_MAX_MEMORY_GB={value}", "from fl_design._limits import "
                       "memory_budget; memory_budget()", {"FL_DESIGN_MAX_MEMORY_GB": value},
                       value == "inf", "error"))
    for var in ("FL_DESIGN_MAX_SAMPLES", "FL_DESIGN_MAX_SUBSTEPS", "FL_DESIGN_MAX_WINDOW"):
        cases.append(e(f"{var}=inf", "fl.RK4(substeps=2); fl.LeastSquaresEstimator(2, 1e-3, "
                       "window=9); fl.Scenario(0.1, 1.0).n_samples(1e-3)", {var: "inf"},
                       expect="error"))
    cases.append(e("FL_DESIGN_VECTOR_MATH=banana", "kernel(TMP / 'cache')",
                   {"FL_DESIGN_VECTOR_MATH": "banana"}, expect="error"))
    configs = [
        ("[sweep] points = 10**30", "[sweep]\npoints = 1000000000000000000000000000000\n"),
        ("[sweep] points = 1", "[sweep]\npoints = 1\n"),
        ("[certify] points = 10**11", "[certify]\npoints = 100000000000\n"),
        ("[scenario] seed = -5", "[scenario]\nseed = -5\n"),
        ("[compare] seed = -5", "[compare]\nseed = -5\n"),
        ("[compare] windows = [0]", "[compare]\nwindows = [0]\n"),
        ("[compare] noise_std = [-1]", "[compare]\nnoise_std = [-1.0]\n"),
        ("[scenario] noise_std = -1", "[scenario]\nnoise_std = -1.0\n"),
        ("[design] eps = 1e400", "[design]\neps = 1e400\n"),
        ("[design] gains = ['a', 1]", "[design]\ngains = ['a', 1]\n"),
    ]
    for name, text in configs:
        cases.append(Case(f"config {name}", f"cli('run', '--quick', '--no-progress', '--out', "
                          f"TMP / 'out', toml({text!r}))", quick="10**30" in name,
                          expect="error"))
    plant_configs = [
        ("region = {x1 = ['a', 1]}", "region = {x1 = ['a', 1]}\n"),
        ("region = {x1 = [1]}", "region = {x1 = [1]}\n"),
        ("input_range = ['a', 1]", "input_range = ['a', 1]\n"),
        ("params = {k = 'one'}", "params = {k = 'one'}\n"),
        ("operating_point = {x1 = 'a'}", "operating_point = {x1 = 'a'}\n"),
        ("params = {'k k' = 1.0}", "params = {'k k' = 1.0}\n"),
    ]
    for name, extra in plant_configs:
        cases.append(Case(f"config [plant] {name}", f"cli('derive', custom('-x1 + u', "
                          f"{extra!r}))", quick="'a', 1" in name and "region" in name,
                          expect="error"))
    cases.append(Case("config with a UTF-8 BOM", "p = TMP / 'bom.toml'; p.write_bytes("
                      "b'\\xef\\xbb\\xbf[design]\\neps = 0.1\\n'); cli('derive', p)",
                      expect="result"))
    cases.append(Case("config states = ['x 1', 'x2']", "cli('derive', toml('[plant]\\nstates = "
                      "[\"x 1\", \"x2\"]\\ninput = \"u\"\\nrhs = [\"x2\", \"u\"]\\n"
                      "output = \"x2\"\\n'))", expect="error"))
    return cases


def _issue36() -> list[Case]:
    """Issue 36: cache folders from someone else, write-through, waits, structure, streams
    (``verify/fault_cases_issue36.py``)."""
    from fault_cases_issue36 import cases

    return [Case(name, code, kind, env, quick, expect)
            for name, code, kind, env, quick, expect in cases()]


def _heldout() -> list[Case]:
    """Held-out variants of issue 36's classes (``verify/fault_cases_heldout.py``)."""
    from fault_cases_heldout import cases

    return [Case(name, code, kind, env, quick, expect)
            for name, code, kind, env, quick, expect in cases()]


def run_case(case: Case, timeout: float) -> dict:
    """Run one case in a fresh interpreter; its class, detail and time."""
    with tempfile.TemporaryDirectory(prefix="fl_fault-") as tmp:
        with open(os.path.join(tmp, "f"), "w") as fh:
            fh.write("a regular file")
        project = os.path.join(tmp, "project")
        os.mkdir(project)
        for name, text in PROJECT_FILES.items():
            with open(os.path.join(project, name), "w") as fh:
                fh.write(text)
        with open(os.path.join(tmp, "outside_victim.txt"), "w") as fh:
            fh.write(VICTIM_TEXT)
        env = dict(os.environ, FAULT_TMP=tmp, FL_DESIGN_CACHE=os.path.join(tmp, "default"),
                   XDG_CONFIG_HOME=os.path.join(tmp, "config"))  # each case its own user key
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
        if os.path.lexists(os.path.join(tmp, "pwned")):
            return {"cls": "exec", "detail": "the payload's marker file appeared",
                    "seconds": seconds}
        lost = [n for n, t in PROJECT_FILES.items() if not _same_text(os.path.join(project, n), t)]
        if not _same_text(os.path.join(tmp, "outside_victim.txt"), VICTIM_TEXT):
            lost.append("outside_victim.txt (outside the output folder)")
        if lost:
            return {"cls": "lost", "detail": f"the user's {', '.join(lost)} changed",
                    "seconds": seconds}
    res = _classify(proc, seconds)
    if case.expect == "result" and res["cls"] == "clear":
        res["cls"] = "falsediag"
    elif case.expect == "error" and res["cls"] == "result":
        res["cls"] = "silent"
    return res


def _same_text(path: str, text: str) -> bool:
    try:
        with open(path, encoding="utf-8") as fh:
            return fh.read() == text
    except OSError:
        return False


def _classify(proc, seconds: float) -> dict:
    if proc.returncode < 0:
        return {"cls": "crash", "detail": f"signal {-proc.returncode}: {proc.stderr[-500:]}",
                "seconds": seconds}
    line = next((ln for ln in proc.stdout.splitlines() if ln.startswith("@@FAULT@@")), None)
    if line is None:
        return {"cls": "raw", "detail": f"exit {proc.returncode}: {proc.stderr[-1500:]}",
                "seconds": seconds}
    return {**json.loads(line[len("@@FAULT@@"):]), "seconds": seconds}


CLASSES = ("clear", "result", "exec", "lost", "falsediag", "silent", "raw", "crash", "hang",
           "skipped")
BAD = ("exec", "lost", "falsediag", "silent", "raw", "crash", "hang")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a representative subset")
    parser.add_argument("-v", "--verbose", action="store_true", help="print every case")
    parser.add_argument("--timeout", type=float, default=None, help="seconds per case")
    parser.add_argument("--jobs", type=int, default=max(2, min(8, os.cpu_count() or 1)))
    parser.add_argument("--match", default=None, metavar="REGEX",
                        help="only the cases whose name matches")
    parser.add_argument("--issue36", action="store_true", help="only the issue-36 cases")
    parser.add_argument("--heldout", action="store_true",
                        help="only the held-out variants of issue 36's classes")
    args = parser.parse_args(argv)
    if args.issue36 or args.heldout:
        cases = (_issue36() if args.issue36 else []) + (_heldout() if args.heldout else [])
    else:
        cases = _inputs() + _envs() + _safety() + _issue36() + _heldout()
    if args.quick:
        cases = [c for c in cases if c.quick]
    if args.match:
        import re

        cases = [c for c in cases if re.search(args.match, c.name)]
    timeout = args.timeout or (60.0 if args.quick else 120.0)
    start = time.perf_counter()
    with ThreadPoolExecutor(max(1, args.jobs)) as pool:
        results = list(pool.map(lambda c: run_case(c, timeout), cases))
    counts = {kind: {cls: 0 for cls in CLASSES} for kind in ("input", "env")}
    for case, res in zip(cases, results):
        counts[case.kind][res["cls"]] += 1
        if args.verbose or res["cls"] not in ("clear", "result", "skipped"):
            first = res["detail"].strip().splitlines()[-1] if res["detail"].strip() else ""
            warn = f" [{res['warnings'][0][:90]}]" if res.get("warnings") else ""
            print(f"{res['cls']:>7}  {case.kind:5}  {case.name}: {first[:160]}{warn}")
    print(f"\n{len(cases)} cases ({sum(c.kind == 'input' for c in cases)} bad inputs, "
          f"{sum(c.kind == 'env' for c in cases)} environment faults) in "
          f"{time.perf_counter() - start:.1f} s")
    print(f"{'':14}" + "".join(f"{cls:>10}" for cls in CLASSES))
    for kind, row in counts.items():
        print(f"{kind:14}" + "".join(f"{row[cls]:>10}" for cls in CLASSES))
    bad = sum(row[cls] for row in counts.values() for cls in BAD)
    print("OK: no code executed, file lost, false diagnosis, silent acceptance, raw traceback, "
          "crash or hang" if not bad else
          f"FAIL: {bad} case(s) ended in {'/'.join(BAD)}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
