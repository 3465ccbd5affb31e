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
SNAN = np.array([0x7FF0000000000001], dtype=np.int64).view(np.float64)[0]


#: Updated entries 3..3 + N_UPDATES - 1, then one read-only entry (each lane's conditions).
N_UPDATES = 16
PARAM = 3 + N_UPDATES
NACC = PARAM + 1


def _step():
    import casadi as ca

    a, d = ca.SX.sym("a", NACC), ca.SX.sym("d", 4)
    x, y = d[0], d[1]
    g, n = d[2] > a[PARAM], d[3] > -a[PARAM]  # the guard and the inner condition (NaN: false)
    xq, yq = x * 1.0, y * 1.0  # quiet, but -0.0 when x is
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
        # the + 0.0 of a select: needed for a product (-0.0 * 2 is -0.0), a sum of two
        # values that may be -0.0, a difference from one; not for a sum with a normal entry
        ca.if_else(g, a[12] * xq, a[12]),
        ca.if_else(g, xq + yq, a[13]),
        ca.if_else(g, xq - yq, a[14]),
        ca.if_else(g, a[15] + xq, a[15]),
        ca.if_else(g, a[16] - ca.fabs(xq), a[16]),
        ca.if_else(g, ca.fabs(x), a[17]),  # a sample: neither quiet nor never -0.0 assumed
        ca.if_else(g, a[18] + a[PARAM] * a[PARAM], a[18]),  # a[PARAM]^2: once per run
    ]
    assert len(updates) == N_UPDATES
    return ca.Function("fl_acc", [a, d], [ca.vertcat(a[0] + 1, a[1], a[2], *updates,
                                                     a[PARAM])])


def test_merged_selects_are_one_blend_each():
    """Each update above is one ``FL_SEL`` in the emitted step (two or three before); those
    of normal values only have no ``+ 0.0`` (three here: sums and a difference with the
    entry's own normal value)."""
    from fl_design.sim.kernel._emit import lanes_source

    src = lanes_source(_step(), {"k": 0, "div": 1, "N": 2}, width=4, groups=1)
    step = src.split("static void fl_lanes_step")[1]
    assert step.count("FL_SEL(") == N_UPDATES
    assert step.count("+FL_Z)") == N_UPDATES - 3


@pytest.mark.parametrize("isa", ISAS)
def test_merged_selects_are_bitwise_the_interpreter(tmp_path, isa):
    from fl_design.sim.kernel._lanes import _load, build_lanes

    f, n_lanes, n_steps = _step(), 11, 60
    rng = np.random.default_rng(1)
    acc = np.zeros((NACC, n_lanes))
    acc[2] = n_steps + 5
    acc[3:PARAM] = rng.choice(SPECIAL[1:], (N_UPDATES, n_lanes))  # normal (see below)
    acc[PARAM] = rng.uniform(-1, 1, n_lanes)  # each lane its own conditions
    D = rng.choice(SPECIAL, (4, n_steps))  # (glibc's fmin/fmax of a signalling NaN: NaN)
    refs, ref = [], acc.copy()
    for k in range(n_steps):
        ref = np.column_stack([np.asarray(f(ref[:, j], D[:, k])).ravel()
                               for j in range(n_lanes)])
        refs.append(ref)
    lib = _load(str(build_lanes(f, {"k": 0, "div": 1, "N": 2}, isa=LEVELS[isa],
                                cache_dir=tmp_path, vector_math_ok=False)))
    states = np.array(refs)[:, 3:PARAM]  # the special values reach the updates' results
    assert np.any(np.isnan(states)) and np.any(np.isinf(states)) and np.any(states == 0)
    for k, ref in enumerate(refs, start=1):  # after every step
        cols = np.ascontiguousarray(acc.T)
        lib.fl_lanes_run(cols, n_lanes, np.ascontiguousarray(D[:, :k].T), k,
                         np.zeros(1, np.int64))
        got, number = cols.T, ~np.isnan(ref)
        np.testing.assert_array_equal(np.isnan(got), ~number, err_msg=f"step {k}")
        np.testing.assert_array_equal(got[number].view(np.int64), ref[number].view(np.int64),
                                      err_msg=f"step {k}")


def _runner(tmp_path, isa):
    import casadi as ca

    from fl_design.sim.kernel._runners import make_runner

    f = _step()
    a, d = ca.SX.sym("a", NACC), ca.SX.sym("d", 4)
    record = ca.Function("fl_rec", [a, d], [f(a, d), a[3]])
    return f, make_runner(f, record, {"k": 0, "div": 1, "N": 2}, cache_dir=tmp_path,
                          vector_math=False, isa=isa)


@pytest.mark.parametrize("isa", ISAS)
def test_an_initial_negative_zero_or_signalling_nan_goes_to_the_scalar_kernel(tmp_path, isa):
    """The lanes kernel keeps the updated entries free of -0.0 and signalling NaNs without
    adding 0.0 again; an initial value that is one of them is caught by ``fl_lanes_check``
    and the grid runs on the scalar kernel: the interpreter's bits either way."""
    f, runner = _runner(tmp_path, isa)
    lib = runner.library
    assert lib is not None
    rng = np.random.default_rng(2)
    acc = np.zeros((NACC, 6))
    acc[2], acc[PARAM] = 40, rng.uniform(-1, 1, 6)
    acc[3:PARAM] = rng.choice(SPECIAL[1:], (N_UPDATES, 6))
    D = rng.choice(SPECIAL, (4, 30))
    for entry, value, ok in [(5, -0.0, False), (7, SNAN, False), (PARAM, -0.0, True),
                             (PARAM, SNAN, True), (5, np.nan, True)]:
        bad = acc.copy()
        bad[entry, 3] = value  # a read-only entry is not assumed normal
        assert lib.fl_lanes_check(np.ascontiguousarray(bad.T), 6) == int(ok)
        ref = bad.copy()
        for k in range(D.shape[1]):
            ref = np.column_stack([np.asarray(f(ref[:, j], D[:, k])).ravel() for j in range(6)])
        got, number = runner.run(bad, D), ~np.isnan(ref)
        np.testing.assert_array_equal(np.isnan(got), ~number)
        np.testing.assert_array_equal(got[number].view(np.int64), ref[number].view(np.int64))


@pytest.mark.parametrize("isa", ISAS)
def test_values_of_read_only_entries_are_computed_again_for_each_new_run(tmp_path, isa):
    """``a[PARAM]^2`` is computed once per run (``fl_lanes_init``), not per step: with more
    runs than lanes, every refilled lane gets its own (bitwise the interpreter's results)."""
    from fl_design.sim.kernel._emit import lanes_source
    from fl_design.sim.kernel._lanes import _load, build_lanes

    f, n_cols, n_steps = _step(), 70, 25
    src = lanes_source(f, {"k": 0, "div": 1, "N": 2}, width=4)
    assert "#define FL_N_INIT 2 " in src  # a[PARAM]^2 and -a[PARAM]
    rng = np.random.default_rng(3)
    acc = np.zeros((NACC, n_cols))
    acc[2], acc[PARAM] = n_steps + 5, rng.uniform(-1, 1, n_cols)
    acc[3:PARAM] = rng.choice(SPECIAL[1:], (N_UPDATES, n_cols))
    D = rng.choice(SPECIAL[1:], (4, n_steps))
    ref = acc.copy()
    for k in range(n_steps):
        ref = np.column_stack([np.asarray(f(ref[:, j], D[:, k])).ravel()
                               for j in range(n_cols)])
    lib = _load(str(build_lanes(f, {"k": 0, "div": 1, "N": 2}, isa=LEVELS[isa],
                                cache_dir=tmp_path, vector_math_ok=False)))
    assert n_cols > lib.fl_lanes_width() * 4  # refills (4 lane groups at most)
    cols = np.ascontiguousarray(acc.T)
    lib.fl_lanes_run(cols, n_cols, np.ascontiguousarray(D.T), n_steps, np.zeros(1, np.int64))
    got, number = cols.T, ~np.isnan(ref)
    np.testing.assert_array_equal(np.isnan(got), ~number)
    np.testing.assert_array_equal(got[number].view(np.int64), ref[number].view(np.int64))
