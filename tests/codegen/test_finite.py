"""The step's one finiteness test with the fewest terms (codegen._finite): compiled, fed NaN,
infinities and huge values in every input and parameter, it fails whenever a state entry, y, r,
a result or u is not finite, and never on finite inputs and parameters that overflow nothing."""

from __future__ import annotations

import itertools
import math
import subprocess

import casadi as ca
import numpy as np
import pytest

from fl_design import presets
from fl_design._toolchain import find_compiler
from fl_design.codegen._emit import c_body
from fl_design.codegen._finite import check_terms, known_finite
from fl_design.codegen._graph import parameter_fields, parametric_core

pytestmark = pytest.mark.skipif(find_compiler() is None, reason="no C compiler installed")


def test_the_rules_on_a_small_graph():
    nodes = {0: ("input", ()), 1: ("input", ()), 2: ("strict", (0, 1)), 3: ("div", (1, 0)),
             4: ("select", (0, 3)), 5: ("other", (0,)), 6: ("sat", (2, 5, 5))}
    assert known_finite(nodes, [3]) == {3, 1}  # the numerator only (x / inf = 0)
    assert known_finite(nodes, [2]) == {0, 1, 2}
    assert 4 not in known_finite(nodes, [0])  # a select needs every value: 3 unknown
    assert known_finite(nodes, [], [6]) >= {0, 1, 2, 6}  # inside the limits: v finite
    assert check_terms(nodes, [0, 1, 6], [6]) == ([2], {6: (2, 6)})  # v: always a term
    assert check_terms(nodes, [0, 1, 2, 5], [])[0] == [2, 5]  # 2 = 0 + 1 proves both


def _harness(design, real, tmp_path):
    f = parametric_core(design)
    fields = parameter_fields(design)
    n, m = f.size1_in(0), len(fields)
    names = [f"p[{i}]" if fl.name != "antiwindup" else "sw" for i, fl in enumerate(fields)]
    body = c_body(f, [[f"x[{i}]" for i in range(n)], ["y"], ["r"], names],
                  [[f"xn[{i}]" for i in range(n)], ["*u"],
                   [f"xh[{i}]" for i in range(f.size1_out(2))]], real,
                  switches={"sw"}, check="*chk", required=((0, 1, 2), (0, 1)))
    src = tmp_path / f"h_{real}.c"
    src.write_text(f"""#include <stdio.h>
#include <stdbool.h>
static void core(const {real} *x, {real} y, {real} r, const {real} *p, int sw, {real} *xn,
                 {real} *u, {real} *xh, {real} *chk) {{
{body}
}}
int main(void) {{
  {real} x[{n}], p[{m}], xn[{n}], xh[{f.size1_out(2)}], u, chk, y, r;
  double v;
  int i;
  for (;;) {{
    for (i = 0; i < {n}; ++i) {{ if (scanf("%lf", &v) != 1) return 0; x[i] = ({real}) v; }}
    if (scanf("%lf", &v) != 1) return 0; y = ({real}) v;
    if (scanf("%lf", &v) != 1) return 0; r = ({real}) v;
    for (i = 0; i < {m}; ++i) {{ if (scanf("%lf", &v) != 1) return 0; p[i] = ({real}) v; }}
    core(x, y, r, p, 1, xn, &u, xh, &chk);
    for (i = 0; i < {n}; ++i) printf("%.9g ", (double) xn[i]);
    printf("%.9g %.9g\\n", (double) u, (double) chk);
  }}
}}
""")
    exe = tmp_path / f"h_{real}"
    subprocess.run([find_compiler(), "-O2", "-std=c99", "-o", str(exe), str(src)], check=True,
                   timeout=120)
    # the inputs the step reads (an entry it never reads, e.g. the oldest sample of a
    # least-squares window, is overwritten and needs no test)
    args = [ca.SX.sym(k, f.size1_in(i)) for i, k in enumerate(f.name_in())]
    outs = ca.vertcat(*f(*args))
    used = [ca.depends_on(outs, args[0][i]) for i in range(n)] + [True, True]
    return exe, n, [fl.value for fl in fields], [fl.name for fl in fields], np.array(used)


@pytest.mark.parametrize("real", ["float", "double"])
@pytest.mark.parametrize("make", [presets.paper_design, presets.maglev_design,
                                  lambda: presets.least_squares_design(9)],
                         ids=["trms", "maglev", "ls9"])
def test_the_sum_fails_exactly_when_a_required_value_is_not_finite(make, real, tmp_path):
    design = make()
    exe, n, p0, pnames, used = _harness(design, real, tmp_path)
    rng = np.random.default_rng(7)
    y0 = float(np.asarray(design.initial_state()).ravel()[0])
    base = np.asarray(design.initial_state(y0=y0), dtype=float).ravel()
    rows = []
    for _ in range(4):  # finite states near rest, and one beyond the limits
        x = base + 0.01 * rng.standard_normal(n) * (1 + np.abs(base))
        rows.append([*x, y0 + 0.01, y0 + rng.choice([0.05, 50.0]), *p0])
    bad = [math.nan, math.inf, -math.inf, 3e38, -3e38, 1e300]
    width = n + 2 + len(p0)
    for row, slot, value in itertools.product(rows[:2], range(width), bad):
        if slot >= n + 2 and pnames[slot - n - 2] == "antiwindup":
            continue
        r = list(row)
        r[slot] = value
        rows.append(r)
    text = "\n".join(" ".join(repr(float(v)) for v in r) for r in rows) + "\n"
    out = subprocess.run([str(exe)], input=text, capture_output=True, text=True, check=True,
                         timeout=120).stdout.split("\n")
    cast = np.float32 if real == "float" else np.float64
    with np.errstate(over="ignore", invalid="ignore"):
        for r, line in zip(rows, out, strict=False):
            vals = np.array(line.split(), dtype=float)
            xn, u, chk = vals[:n], vals[n], vals[n + 1]
            inputs = np.asarray(r[:n + 2], dtype=float).astype(cast)[used]
            required_ok = np.all(np.isfinite(inputs)) and np.all(np.isfinite(xn)) \
                and math.isfinite(u)
            if not required_ok:
                assert not math.isfinite(chk), (r, line)
            elif all(abs(float(t)) < 1e37 for t in r):  # finite, no overflow: accepted
                assert math.isfinite(chk), (r, line)
    assert math.isfinite(float(out[0].split()[-1]))  # a plain sample passes


@pytest.mark.parametrize("real", ["float", "double"])
def test_an_overflow_inside_the_limits_still_fails_the_sum(real, tmp_path):
    # v = x0 - x1 inside its limits proves x0, x1 finite, not their product: a term
    x = ca.SX.sym("x", 2)
    u = ca.fmin(ca.fmax(x[0] - x[1], -1), 1)
    f = ca.Function("f", [x], [ca.vertcat(x[0] * x[1], u), ca.if_else(u >= 1, x[0], x[1])])
    body = c_body(f, [["x[0]", "x[1]"]], [["o[0]", "o[1]"], ["o[2]"]], real, check="*chk",
                  required=((0,), (0, 1)))
    assert "a_sum" in body
    src = tmp_path / "o.c"
    src.write_text(f"""#include <stdio.h>
#include <stdbool.h>
int main(void) {{
  double a, b;
  {real} x[2], o[3], c;
  {real} *chk = &c;
  while (scanf("%lf %lf", &a, &b) == 2) {{
    x[0] = ({real}) a; x[1] = ({real}) b;
{body}
    printf("%.9g %.9g\\n", (double) o[0], (double) c);
  }}
  return 0;
}}
""")
    exe = tmp_path / "o"
    subprocess.run([find_compiler(), "-O2", "-std=c99", "-o", str(exe), str(src)], check=True,
                   timeout=120)
    big = 1e30 if real == "float" else 1e200
    out = subprocess.run([str(exe)], input=f"{big!r} {big!r}\n0.5 0.25\n", capture_output=True,
                         text=True, check=True, timeout=120).stdout.split()
    assert out[0] == "inf" and not math.isfinite(float(out[1]))  # overflowed: fails
    assert math.isfinite(float(out[3]))
