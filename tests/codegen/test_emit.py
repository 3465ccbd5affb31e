"""The C printer of an SX instruction list: every operation it knows, compiled under the strict
flags (-Wfloat-equal, -Wfloat-conversion, -Wdouble-promotion) and run against CasADi."""

from __future__ import annotations

import subprocess

import casadi as ca
import numpy as np
import pytest

from fl_design._toolchain import find_compiler
from fl_design.codegen._emit import c_body, literal, math_calls
from fl_design.errors import ComputationError

pytestmark = pytest.mark.skipif(find_compiler() is None, reason="no C compiler installed")
FLAGS = ["-O2", "-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", "-Wmissing-prototypes",
         "-Wfloat-equal", "-Wdouble-promotion", "-Wfloat-conversion"]


def _function():
    x = ca.SX.sym("x", 3)
    a, b, c = x[0], x[1], x[2]
    outs = [a + b, a - b, a * c, a / (1 + c * c), -a, ca.fmin(a, b), ca.fmax(a, c),
            ca.if_else(a < b, c, 2 * c), ca.if_else(a == b, 1.0, a), ca.if_else(a != c, b, 3.0),
            ca.if_else(ca.logic_and(a <= b, ca.logic_not(b < c)), a, b),
            ca.if_else(ca.logic_or(a > 0, c > 0), 1.5, -1.5), ca.fabs(b), b * b, 1 / (2 + a * a),
            (a < c) * b + c]
    return ca.Function("f", [x], [ca.vertcat(*outs)])


@pytest.mark.parametrize("real", ["double", "float"])
def test_every_operation_compiles_strict_and_equals_casadi(tmp_path, real):
    f = _function()
    n = f.nnz_out(0)
    body = c_body(f, [[f"x[{i}]" for i in range(3)]], [[f"o[{i}]" for i in range(n)]], real)
    assert "==" not in body and "!=" not in body  # -Wfloat-equal: no float equality tests
    src = tmp_path / "t.c"
    src.write_text(f"""#include <stdio.h>
static void f(const {real} *x, {real} *o) {{
{body}
}}
int main(void) {{
  {real} x[3];
  {real} o[{n}];
  double a, b, c;
  int i;
  while (scanf("%lf %lf %lf", &a, &b, &c) == 3) {{
    x[0] = ({real}) a; x[1] = ({real}) b; x[2] = ({real}) c;
    f(x, o);
    for (i = 0; i < {n}; ++i) printf("%.17g ", (double) o[i]);
    printf("\\n");
  }}
  return 0;
}}
""")
    exe = tmp_path / "t"
    proc = subprocess.run([find_compiler(), *FLAGS, "-o", str(exe), str(src)],
                          capture_output=True, text=True, timeout=120, check=False)
    assert proc.returncode == 0, proc.stderr
    rng = np.random.default_rng(3)
    X = np.round(rng.normal(size=(200, 3)), 1)  # rounded: ties (a == b) happen
    X[:10, 1] = X[:10, 0]
    lines = "\n".join(" ".join(repr(float(v)) for v in row) for row in X) + "\n"
    got = np.array(subprocess.run([str(exe)], input=lines, capture_output=True, text=True,
                                  check=True, timeout=60).stdout.split(), dtype=float)
    ref = np.array([np.asarray(f(row), dtype=float).ravel() for row in X]).ravel()
    rtol = 1e-6 if real == "float" else 1e-15
    np.testing.assert_allclose(got, ref, rtol=rtol, atol=rtol)


def test_literals_and_unsupported_operations():
    assert literal(2.5, "float") == "2.5f" and literal(-1e-3, "double") == "(-0.001)"
    with pytest.raises(ComputationError, match="non-finite constant inf"):
        literal(float("inf"), "double")
    x = ca.SX.sym("x")
    assert math_calls(ca.Function("g", [x], [ca.sin(x) * ca.exp(x)])) == ["exp", "sin"]
    body = c_body(ca.Function("g", [x], [ca.sin(x)]), [["x"]], [["*o"]], "float")
    assert "sinf(x)" in body


def test_a_switch_compared_with_a_constant_is_an_integer_test(tmp_path):
    """Every comparison of a 0/1 switch with a constant (either side) prints as an ``int`` test
    and computes what CasADi computes for both values of the switch; a switch used in
    arithmetic is converted."""
    x, s = ca.SX.sym("x"), ca.SX.sym("s")
    outs = [ca.if_else(s > 0.5, x, 2 * x), ca.if_else(0.5 < s, 3 * x, x),
            ca.if_else(s < 0.5, x, -x), ca.if_else(s <= 1.0, 4 * x, x),  # always true
            ca.if_else(s >= 2.0, x, 5 * x), ca.if_else(s == 1.0, x, 6 * x), s * x]
    f = ca.Function("g", [x, s], [ca.vertcat(*outs)])
    n = f.nnz_out(0)
    body = c_body(f, [["x"], ["on"]], [[f"o[{i}]" for i in range(n)]], "float",
                  switches={"on"})
    assert "(float) on" in body  # the product s * x
    assert "< ((float) on)" not in body and "((float) on) <" not in body  # no float compare
    src = tmp_path / "s.c"
    src.write_text(f"""#include <stdio.h>
static void g(float x, int on, float *o) {{
{body}
}}
int main(void) {{
  float o[{n}];
  int on, i;
  for (on = 0; on <= 1; ++on) {{
    g(1.5f, on, o);
    for (i = 0; i < {n}; ++i) printf("%.9g ", (double) o[i]);
  }}
  return 0;
}}
""")
    exe = tmp_path / "s"
    proc = subprocess.run([find_compiler(), *FLAGS, "-o", str(exe), str(src)],
                          capture_output=True, text=True, timeout=120, check=False)
    assert proc.returncode == 0, proc.stderr
    got = np.array(subprocess.run([str(exe)], capture_output=True, text=True, check=True,
                                  timeout=60).stdout.split(), dtype=float)
    ref = np.concatenate([np.asarray(f(1.5, v), dtype=float).ravel() for v in (0, 1)])
    np.testing.assert_array_equal(got, ref)


def test_a_saturation_tested_against_its_bounds_is_one_branch_exact_for_every_value(tmp_path):
    """``min(max(v, lo), hi)`` followed by ``hi <= u`` / ``u <= lo`` (the conditional
    integration's test) prints as one if/else; it computes what the two ``?:`` selects and the
    two comparisons compute (C semantics, written out in Python below) for every v, lo, hi:
    NaN, infinities, equal and crossed bounds included."""
    v, lo, hi, z = (ca.SX.sym(n) for n in ("v", "lo", "hi", "z"))
    u = ca.fmin(ca.fmax(v, lo), hi)
    hold = ca.logic_or(ca.logic_and(u >= hi, z > 0), ca.logic_and(u <= lo, z < 0))
    f = ca.Function("f", [v, lo, hi, z], [ca.vertcat(u, ca.if_else(hold, 1.0, 2.0),
                                                     ca.if_else(u >= hi, 3.0, 4.0))])
    body = c_body(f, [["v"], ["lo"], ["hi"], ["z"]], [[f"o[{i}]" for i in range(3)]], "double",
                  rare="RARE")
    assert "} else if" in body and "_hi = " in body  # the block, not two selects
    src = tmp_path / "sat.c"
    src.write_text(f"""#include <stdio.h>
#include <stdbool.h>
#define RARE(c) (c)
static void f(double v, double lo, double hi, double z, double *o) {{
{body}
}}
int main(void) {{
  double v, lo, hi, z, o[3];
  while (scanf("%lf %lf %lf %lf", &v, &lo, &hi, &z) == 4) {{
    f(v, lo, hi, z, o);
    printf("%.17g %.17g %.17g\\n", o[0], o[1], o[2]);
  }}
  return 0;
}}
""")
    exe = tmp_path / "sat"
    proc = subprocess.run([find_compiler(), *FLAGS, "-o", str(exe), str(src)],
                          capture_output=True, text=True, timeout=120, check=False)
    assert proc.returncode == 0, proc.stderr
    vals = [-3.0, -1.0, -0.5, 0.0, 0.5, 1.0, 3.0, np.nan, np.inf, -np.inf]
    grid = [(a, b, c, d) for a in vals for b in (-1.0, 1.0, 0.5, np.nan)
            for c in (1.0, -1.0, 0.5, np.nan) for d in (-1.0, 1.0)]
    text = "\n".join(" ".join(repr(float(x)) for x in row) for row in grid) + "\n"
    got = np.array(subprocess.run([str(exe)], input=text, capture_output=True, text=True,
                                  check=True, timeout=60).stdout.split(), dtype=float)

    def c_semantics(a, b, c, d):  # (x > y ? x : y), (x < y ? x : y), IEEE comparisons
        m = a if a > b else b  # noqa: FURB136 - written as the C select (NaN order)
        w = m if m < c else c  # noqa: FURB136
        held = (c <= w and d > 0) or (w <= b and d < 0)
        return [w, 1.0 if held else 2.0, 3.0 if c <= w else 4.0]

    ref = np.array([c_semantics(*row) for row in grid]).ravel()
    np.testing.assert_array_equal(got, ref)  # NaN where NaN, every other value bit for bit
