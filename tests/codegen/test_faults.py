"""Faults that recover or report, in C and in Python alike.

A C driver reads commands (a sample, a RAM corruption, a parameter change, manual mode) and
prints the step's ``u`` and fault bits; :class:`fl_design.codegen._guard.FirmwareModel` runs the
same commands in Python around ``Design.step``. Each case checks the C against the model
sample by sample and the behaviour the header states (resume within the stated samples,
u_safe while lost or corrupted, restart at the next good sample).
"""

from __future__ import annotations

import math
import subprocess

import numpy as np
import pytest

import fl_design as fl
from fl_design import presets
from fl_design._toolchain import find_compiler
from fl_design.codegen import generate_c
from fl_design.codegen._guard import FAULT, PARAM_CHECK_PERIOD, FirmwareModel

pytestmark = pytest.mark.skipif(find_compiler() is None, reason="no C compiler installed")

DRIVER = r"""#include <stdio.h>
#include <stdlib.h>
#include "fl.h"
int main(void) {
  fl_state_t s;
  fl_params_t p;
  char c;
  double a, b;
  fl_init(&s);
  while (scanf(" %c", &c) == 1) {
    if (c == 's') {            /* a sample: y r */
      if (scanf("%lf %lf", &a, &b) != 2) return 1;
      double u = (double) fl_step(&s, (fl_real_t) a, (fl_real_t) b);
      printf("%.17g %u\n", u, (unsigned) s.fault);
    } else if (c == 'S') {     /* start: y0 u0 */
      if (scanf("%lf %lf", &a, &b) != 2) return 1;
      printf("start %d\n", fl_start(&s, (fl_real_t) a, (fl_real_t) b));
    } else if (c == 'R') {     /* thresholds: dy_max frozen_after lost_after */
      double l;
      if (scanf("%lf %lf %lf", &a, &b, &l) != 3) return 1;
      fl_default_params(&p);
      p.dy_max = (fl_real_t) a; p.frozen_after = (uint32_t) b; p.lost_after = (uint32_t) l;
      printf("params %d\n", fl_set_params(&s, &p));
    } else if (c == 'X') {     /* RAM corruption of the state: index value */
      if (scanf("%lf %lf", &a, &b) != 2) return 1;
      s.x[(int) a] = (fl_real_t) b;
    } else if (c == 'G') {     /* RAM corruption of the block: gamma k0 u_min u_max */
      double k0, lo, hi;
      if (scanf("%lf %lf %lf %lf", &a, &k0, &lo, &hi) != 4) return 1;
      s.p.gamma = (fl_real_t) a; s.p.k[0] = (fl_real_t) k0;
      s.p.u_min = (fl_real_t) lo; s.p.u_max = (fl_real_t) hi;
    } else if (c == 'D') {
      fl_disengage(&s);
    } else if (c == 'M') {
      if (scanf("%lf", &a) != 1) return 1;
      (void) fl_manual_input(&s, (fl_real_t) a);
    } else if (c == 'E') {
      fl_engage(&s);
    }
  }
  return 0;
}
"""


@pytest.fixture(scope="module")
def pkg(tmp_path_factory):
    root = tmp_path_factory.mktemp("faults")
    p = generate_c(presets.paper_design(), root / "trms", plant=fl.plants.trms_yaw())
    return p, build_driver(p)


def build_driver(p):
    """The fault driver (:data:`DRIVER`) compiled with package ``p``'s sources."""
    (p.out_dir / "build").mkdir(exist_ok=True)
    src = p.out_dir / "build" / "driver.c"
    src.write_text(DRIVER)
    exe = p.out_dir / "build" / "driver"
    subprocess.run([find_compiler(), "-O2", "-std=c99", f"-I{p.out_dir}", "-o", str(exe),
                    str(src), *map(str, p.sources)], check=True, timeout=120)
    return exe


def run_c(exe, commands):
    text = "\n".join(commands) + "\n"
    out = subprocess.run([str(exe)], input=text, capture_output=True, text=True, check=True,
                         timeout=120).stdout.splitlines()
    return out


def run_model(pkg, commands):
    m = FirmwareModel(pkg.step_design, pkg.guard)
    out = []
    for cmd in commands:
        c, *args = cmd.split()
        a = [float(v) for v in args]
        if c == "s":
            u = m.step(a[0], a[1])
            out.append(f"{u!r} {m.fault}")
        elif c == "S":
            out.append(f"start {m.start(a[0], a[1])}")
        elif c == "R":
            m = _with(m, dy_max=a[0], frozen_after=int(a[1]), lost_after=int(a[2]))
            out.append("params 0")
        elif c == "X":
            m.x[int(a[0])] = a[1]
        elif c == "G":
            m.corrupt(gamma=a[0], **{"k[0]": a[1]}, u_min=a[2], u_max=a[3])
        elif c == "D":
            m.disengage()
        elif c == "M":
            m.manual_input(a[0])
        elif c == "E":
            m.engage()
    return out


def _with(m, **changes):
    """The model after ``set_params`` with new thresholds: state, counters kept."""
    new = m.with_settings(**changes)
    for k in ("x", "y_last", "last_known", "faults", "countdown", "n_consecutive"):
        setattr(new, k, getattr(m, k))
    if changes["dy_max"] > 0 and m.settings.dy_max == 0:  # a new rate check: from the next y
        new.last_known = False
    return new


def parse(lines):
    rows = [ln.split() for ln in lines if not ln.startswith(("start", "params"))]
    return np.array([float(r[0]) for r in rows]), np.array([int(r[1]) for r in rows])


def samples(ys, r=0.3):
    return [f"s {float(y)!r} {float(r)!r}" for y in ys]


def same_faults(pkg, exe, commands):
    """The C driver and :class:`FirmwareModel` on ``commands``: the same start and parameter
    answers and the same fault bits on every sample; ``(u_c, f_c, u_model)``."""
    c, py = run_c(exe, commands), run_model(pkg, commands)
    assert [ln for ln in c if ln.startswith(("start", "params"))] == \
        [ln for ln in py if ln.startswith(("start", "params"))]
    u_c, f_c = parse(c)
    u_p, f_p = parse(py)
    np.testing.assert_array_equal(f_c, f_p)
    return u_c, f_c, u_p


def check_alike(pkg, exe, commands):
    u_c, f_c, u_p = same_faults(pkg, exe, commands)
    np.testing.assert_allclose(u_c, u_p, rtol=0, atol=1e-12 * max(1.0, np.abs(u_p).max()))
    return u_c, f_c


def ramp(n, start=0.0, slope=1e-4):
    return list(start + slope * np.arange(n))


def test_a_transient_sample_is_rejected_and_the_next_resumes(pkg):
    p, exe = pkg
    ys = ramp(40)
    ys[10], ys[20], ys[30] = math.nan, 1e30, -math.inf  # NaN, out of range, infinite
    u, f = check_alike(p, exe, ["S 0 0", *samples(ys)])
    assert list(np.flatnonzero(f)) == [10, 20, 30]
    assert f[10] == FAULT["nonfinite"] and f[20] == FAULT["range"] and f[30] == 1
    assert u[10] == u[9] and u[20] == u[19]          # held while rejected
    assert np.all(np.isfinite(u)) and u[11] != u[10]  # resumed at the next sample


def test_a_real_jump_passes_the_rate_check_within_the_stated_samples(pkg):
    """A legitimate 0.05 jump with dy_max = 0.01: ceil(0.05 / 0.01) - 1 = 4 rejections, then
    the loop runs again (it used to reject every later sample); one spike: one rejection."""
    p, exe = pkg
    ys = ramp(30) + [0.05 + v for v in ramp(200, 3e-3)]
    spike = ramp(30)
    spike[15] = 0.5
    _u, f = check_alike(p, exe, ["S 0 0", "R 0.01 0 0", *samples(ys)])
    rejected = np.flatnonzero(f)
    n_rej = math.ceil((ys[30] - ys[29]) / 0.01) - 1  # the stated number
    assert list(rejected) == list(range(30, 30 + n_rej)) and n_rej == 5
    assert np.all(f[rejected] == FAULT["rate"]) and np.all(f[30 + n_rej:] == 0)
    _u2, f2 = check_alike(p, exe, ["S 0 0", "R 0.01 0 0", *samples(spike)])
    assert list(np.flatnonzero(f2)) == [15]


def test_a_corrupted_state_restarts_the_observer_at_the_next_good_sample(pkg):
    p, exe = pkg
    ys = ramp(60)
    cmds = ["S 0 0", *samples(ys[:20]), "X 0 nan", *samples(ys[20:])]
    u, f = check_alike(p, exe, cmds)
    assert f[20] == FAULT["result"] and np.all(f[21:] == 0)
    assert np.all(np.isfinite(u)) and u[21] != u[20]
    # bumpless: the restart holds u; the first step moves it by one increment gamma (v - 0)
    # (the restarted observer at rest: sigmahat = 0), |v| <= k_1 |y - r| + k_I |z| here
    ctrl = p.design.controller
    assert abs(u[21] - u[19]) <= abs(ctrl.gamma) * (ctrl.gains[0] * 0.3 + 1e-3)
    # NaN in u itself: the restart takes u_safe
    u2, f2 = check_alike(p, exe, ["S 0 0", *samples(ys[:20]), "X 3 nan", *samples(ys[20:])])
    assert f2[20] == FAULT["result"] and np.all(np.isfinite(u2))


def test_a_lost_sensor_holds_u_safe_and_recovers(pkg):
    p, exe = pkg
    lost = p.guard.lost_after
    ys = ramp(20) + [math.nan] * (lost + 5) + ramp(30, 0.01)
    u, f = check_alike(p, exe, ["S 0 0.5", *samples(ys)])
    k = 20 + lost - 1  # the lost_after-th rejection in a row
    assert np.all(f[20:k] == FAULT["nonfinite"])
    assert np.all(f[k:20 + lost + 5] == FAULT["nonfinite"] | FAULT["lost"])
    assert np.all(u[k:20 + lost + 5] == p.guard.u_safe)
    assert np.all(f[20 + lost + 5:] == 0)  # back: restarted there


def test_a_frozen_sensor_is_detected(pkg):
    p, exe = pkg
    ys = ramp(20) + [0.002] * 80 + ramp(20, 0.003)
    u, f = check_alike(p, exe, ["S 0 0.5", "R 0 50 0", *samples(ys)])
    first = int(np.flatnonzero(f)[0])
    assert first == 20 + 50 and f[first] == FAULT["frozen"] | FAULT["lost"]
    assert np.all(u[first:100] == p.guard.u_safe) and np.all(f[100:] == 0)


@pytest.mark.parametrize("corruption", ["nan 2 -2.5 2.5", "3e-4 nan -2.5 2.5",
                                        "3e-4 2 2.5 -2.5"])
def test_a_corrupted_parameter_block_gives_u_safe_within_the_period(pkg, corruption):
    p, exe = pkg
    n = 2 * PARAM_CHECK_PERIOD + 10
    cmds = ["S 0 0", *samples(ramp(5)), f"G {corruption}", *samples(ramp(n, 5e-4))]
    u, f = check_alike(p, exe, cmds)
    bad = np.flatnonzero(f & FAULT["params"])
    assert bad.size and bad[0] <= 5 + PARAM_CHECK_PERIOD  # within one period
    assert np.all(u[bad[0]:] == p.guard.u_safe) and np.all(f[bad[0]:] == FAULT["params"])
    # started again on a block changed behind the setter: refused with BAD_CHECKSUM (9)
    assert run_c(exe, [f"G {corruption}", "S 0 0"])[-1] == "start 9"


def test_manual_mode_is_bumpless_both_ways(pkg):
    p, exe = pkg
    ys = ramp(200)
    cmds = ["S 0 0", *samples(ys[:50]), "D", "M 0.8", *samples(ys[50:120]), "E",
            *samples(ys[120:])]
    u, f = check_alike(p, exe, cmds)
    assert np.all(u[50:120] == 0.8) and not f.any()
    assert abs(u[120] - 0.8) < 0.05  # engaged: continues from the manual input


def test_defaults_are_valid_and_the_range_comes_from_the_region(pkg):
    p, exe = pkg
    g = p.guard
    assert g.y_min < -math.pi and g.y_max > math.pi and g.lost_after == 10
    text = p.header.read_text()
    assert "FL_DESIGN_HASH" in text and "FL_API_VERSION_MAJOR" in text and "units" in text
    # a 1e30 sample on the damped double integrator no longer reaches u
    _u, f = check_alike(p, exe, ["S 0 0", *samples([0.0, 1e30, 0.0])])
    assert f.tolist() == [0, FAULT["range"], 0]
