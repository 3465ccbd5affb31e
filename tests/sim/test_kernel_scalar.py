"""The scalar compiled kernel (``fl_loop``): one CasADi step in its source, the interpreter's bits.

Its source holds only the recording step ``fl_rec``; ``fl_run`` (grids) calls it without its
output array. Both entry points must give, bit for bit, what CasADi's interpreter gives with
the two steps it was handed (``fl_acc`` folded over the samples for grids, ``fl_rec`` mapped for a
recorded run), on the library's loops: EHGO and least squares, one and several RK4 substeps,
diverging columns included.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

import fl_design as fl
from fl_design._toolchain import find_compiler
from fl_design.errors import ParameterError
from fl_design.sim._run import prepare_run
from fl_design.sim.kernel._runners import (
    InterpretedRunner,
    NativeRunner,
    make_runner,
    runner_source,
)

pytestmark = pytest.mark.skipif(find_compiler() is None, reason="needs a C compiler")

#: plant, design, RK4 substeps, whether fast gains diverge (no input limits) or saturate
CASES = {
    "trms-ehgo": (fl.plants.trms_yaw, lambda: fl.presets.paper_design(u_limits=None), 1, True),
    "trms-ehgo-saturated": (fl.plants.trms_yaw, lambda: fl.presets.paper_design(), 1, False),
    "trms-ls9": (fl.plants.trms_yaw,
                 lambda: fl.presets.least_squares_design(9, u_limits=None), 1, True),
    "pendulum-ehgo-rk3": (fl.plants.pendulum, lambda: fl.presets.pendulum_design(), 3, True),
}


def _indices(loop) -> dict:
    sl = loop.layout.slices
    return {"k": sl["k"].start, "div": sl["diverged"].start, "N": sl["N"].start}


def _bits(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=float).view(np.int64)


@pytest.mark.parametrize("case", list(CASES))
def test_the_one_step_source_runs_and_records_the_interpreters_bits(tmp_path, case):
    plant, design, substeps, diverging = CASES[case]
    d = design()
    run = prepare_run(plant(), d, fl.Scenario(0.1, 0.8, noise=fl.Noise(1e-3, seed=3)),
                      integrator=fl.RK4(substeps=substeps))
    loop, idx = run.loop, _indices(run.loop)
    source = runner_source(loop.accumulate, loop.record, idx)
    assert "int fl_rec(" in source and "int fl_acc(" not in source
    native = make_runner(loop.accumulate, loop.record, idx, cache_dir=tmp_path, lanes=False)
    interp = make_runner(loop.accumulate, loop.record, idx, compiled=False)
    assert isinstance(native, NativeRunner) and isinstance(interp, InterpretedRunner)
    # grids: gains from slow to far too fast (the last columns diverge and freeze early)
    gammas = d.controller.gamma * np.array([0.5, 1.0, 3.0, 1e3, 1e5])
    acc0 = run.initial_accumulator(np.column_stack(
        [d.replace(gamma=g).parameter_vector() for g in gammas]))
    grid_native, grid_interp = native.run(acc0, run.D, threads=2), interp.run(acc0, run.D)
    div = loop.layout.unpack(grid_interp)["diverged"]
    assert (0 < np.sum(div) < len(gammas)) if diverging else np.sum(div) == 0
    np.testing.assert_array_equal(_bits(grid_native), _bits(grid_interp))
    # a recorded run: its final accumulator and every recorded sample
    (a_n, out_n), (a_i, out_i) = (r.record(acc0[:, 1], run.D) for r in (native, interp))
    assert out_n.shape == (loop.record.size1_out(1), run.N)
    np.testing.assert_array_equal(_bits(a_n), _bits(a_i))
    np.testing.assert_array_equal(_bits(out_n), _bits(out_i))
    # and the recorded run's accumulator is that of the grid's column
    np.testing.assert_array_equal(_bits(a_n), _bits(grid_native[:, 1]))


def test_steps_that_disagree_on_the_accumulator_are_refused():
    a, d = ca.SX.sym("a", 4), ca.SX.sym("d", 2)
    acc = ca.Function("fl_acc", [a, d], [a + d[0]])
    b = ca.SX.sym("b", 5)
    rec = ca.Function("fl_rec", [b, d], [b + d[0], b[0]])
    with pytest.raises(ParameterError, match=r"accumulator and samples of accumulate"):
        runner_source(acc, rec, {"k": 0, "div": 1, "N": 2})
    one_out = ca.Function("fl_rec", [a, d], [a + d[0]])
    with pytest.raises(ParameterError, match="got 1 outputs"):
        runner_source(acc, one_out, {"k": 0, "div": 1, "N": 2})
