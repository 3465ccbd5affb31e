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
