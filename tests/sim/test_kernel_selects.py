"""Merged selects in the lanes kernel: a select whose chosen value is a select (or an
``fmin``/``fmax``) sharing its other value is written as one select on the combined mask.

The rewrite must be exact: the exact lanes kernel (glibc's scalar math) is compared bit for bit
with CasADi's interpreter on every orientation of the pattern, over steps whose inputs include
``-0.0``, ``+0.0``, NaN and infinities (the cases where ``+ 0.0`` and the extrema's NaN rule
matter).
"""

from __future__ import annotations

import numpy as np
import pytest

from fl_design._isa import LEVELS, available_isas
from fl_design._toolchain import find_compiler

pytestmark = pytest.mark.skipif(find_compiler() is None, reason="needs a C compiler")

ISAS = [name for name in available_isas() if LEVELS[name].lanes]
SPECIAL = np.array([-0.0, 0.0, np.nan, np.inf, -np.inf, 1.5, -2.5, 0.25])


def _step():
    import casadi as ca

    a, d = ca.SX.sym("a", 13), ca.SX.sym("d", 4)
    x, y = d[0], d[1]
    g, n = d[2] > a[12], d[3] > -a[12]  # the guard and the inner condition (NaN: false)
    updates = [
        ca.if_else(g, ca.if_else(n, x, a[3]), a[3]),  # inner else is the outer else
        ca.if_else(g, ca.if_else(n, a[4], x), a[4]),  # inner then is the outer else
        ca.if_else(g, a[5], ca.if_else(n, a[5], y)),  # in the else branch, then shared
        ca.if_else(g, a[6], ca.if_else(n, y, a[6])),  # in the else branch, else shared
        ca.if_else(g, ca.fmax(a[7], x), a[7]),  # extrema on the old value
        ca.if_else(g, ca.fmin(a[8], x), a[8]),
        ca.if_else(g, ca.fmax(x, a[9]), a[9]),
        ca.if_else(g, ca.fmin(y, a[10]), a[10]),
        ca.if_else(g, ca.if_else(n, ca.if_else(x > y, y, a[11]), a[11]), a[11]),  # 3 deep
    ]
    return ca.Function("fl_acc", [a, d], [ca.vertcat(a[0] + 1, a[1], a[2], *updates, a[12])])


def test_merged_selects_are_one_blend_each():
    """Each update above is one ``FL_SEL`` in the emitted step (two or three before)."""
    from fl_design.sim.kernel._emit import lanes_source

    src = lanes_source(_step(), {"k": 0, "div": 1, "N": 2}, width=4, groups=1)
    step = src.split("static void fl_lanes_step")[1]
    assert step.count("FL_SEL(") == 9


@pytest.mark.parametrize("isa", ISAS)
def test_merged_selects_are_bitwise_the_interpreter(tmp_path, isa):
    from fl_design.sim.kernel._lanes import _load, build_lanes

    f, n_lanes, n_steps = _step(), 11, 60
    rng = np.random.default_rng(1)
    acc = np.zeros((13, n_lanes))
    acc[2] = n_steps + 5
    acc[3:12] = rng.choice(SPECIAL, (9, n_lanes))
    acc[12] = rng.uniform(-1, 1, n_lanes)  # each lane its own conditions
    D = rng.choice(SPECIAL, (4, n_steps))
    refs, ref = [], acc.copy()
    for k in range(n_steps):
        ref = np.column_stack([np.asarray(f(ref[:, j], D[:, k])).ravel()
                               for j in range(n_lanes)])
        refs.append(ref)
    lib = _load(str(build_lanes(f, {"k": 0, "div": 1, "N": 2}, isa=LEVELS[isa],
                                cache_dir=tmp_path, vector_math_ok=False)))
    states = np.array(refs)[:, 3:12]  # the special values reach the updates' results
    assert np.any(np.isnan(states)) and np.any(np.isinf(states)) and np.any(states == 0)
    for k, ref in enumerate(refs, start=1):  # after every step
        cols = np.ascontiguousarray(acc.T)
        lib.fl_lanes_run(cols, n_lanes, np.ascontiguousarray(D[:, :k].T), k,
                         np.zeros(1, np.int64))
        got, number = cols.T, ~np.isnan(ref)
        np.testing.assert_array_equal(np.isnan(got), ~number, err_msg=f"step {k}")
        np.testing.assert_array_equal(got[number].view(np.int64), ref[number].view(np.int64),
                                      err_msg=f"step {k}")
