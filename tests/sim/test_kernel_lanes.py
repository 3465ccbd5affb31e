"""The lanes kernel (W grid points per vector) against the scalar kernel and the interpreter.

With glibc's scalar math (``vector_math=False``) the lanes kernel computes bit for bit what the
scalar compiled kernel and CasADi's interpreter compute; with libmvec's vector math (the
default) every run is classified the same and the metrics agree to the loop's amplification of
a last-bit difference in ``tanh``/``sin``. Grids include diverging runs and sizes that the lane
width does not divide, with one and with many RK4 substeps.
"""

from __future__ import annotations

import numpy as np
import pytest

import fl_design as fl
from fl_design.codegen import find_compiler
from fl_design.sim import parameter_columns, prepare_run
from fl_design.sim._lanes import LanesRunner, lane_width
from fl_design.sim._lanes_emit import lanes_source, rk4_fold
from fl_design.sim._runners import make_runner

pytestmark = pytest.mark.skipif(find_compiler() is None, reason="needs a C compiler")


def _pendulum_design():
    return fl.Design(estimator=fl.EHGO(rho=2, eps=0.02, T=1e-3),
                     controller=fl.DynamicController((2, 4), 1e-2))


CASES = {
    # plant, design, duration, eps grid, gamma grid: 5 x 4 = 20 runs (W = 8 or 4 does not
    # divide 20 - 8k... and 3 x 7 = 21 runs), each grid with diverging runs
    "pendulum": (fl.plants.pendulum, _pendulum_design, 1.2, np.geomspace(0.01, 1, 5),
                 np.geomspace(1e-3, 1, 4)),
    "trms": (fl.plants.trms_yaw, lambda: fl.presets.paper_design(u_limits=None), 0.6,
             np.geomspace(1e-3, 1, 3), np.geomspace(1e-4, 1.0, 7)),
}


def _runners(run, cache):
    loop = run.loop
    sl = loop.layout.slices
    idx = {"k": sl["k"].start, "div": sl["diverged"].start, "N": sl["N"].start}
    mk = lambda **kw: make_runner(loop.accumulate, loop.record, idx, cache_dir=cache, **kw)
    return idx, {"exact": mk(vector_math=False), "vector": mk(vector_math=True),
                 "native": mk(lanes=False), "interp": mk(compiled=False)}


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    cache = tmp_path_factory.mktemp("lanes")
    out = {}
    for name, (plant, design, duration, eps, gamma) in CASES.items():
        for substeps in (1, 4):
            d = design()
            run = prepare_run(plant(), d, fl.Scenario(0.05, duration),
                              integrator=fl.RK4(substeps=substeps))
            idx, runners = _runners(run, cache)
            acc0 = run.initial_accumulator(parameter_columns(d, eps, gamma))
            accs = {key: r.run(acc0, run.D, threads=2) for key, r in runners.items()}
            out[name, substeps] = run, idx, runners, accs
    return out


@pytest.mark.parametrize("case", [(n, s) for n in CASES for s in (1, 4)])
def test_exact_lanes_equal_scalar_kernel_and_interpreter_bitwise(results, case):
    _run, idx, runners, accs = results[case]
    assert isinstance(runners["exact"], LanesRunner) and runners["exact"].library is not None
    assert accs["exact"].shape[1] % lane_width() != 0
    assert 0 < np.sum(accs["exact"][idx["div"]]) < accs["exact"].shape[1]  # some diverge
    np.testing.assert_array_equal(accs["native"], accs["interp"])
    np.testing.assert_array_equal(accs["exact"], accs["native"])


@pytest.mark.parametrize("case", [(n, s) for n in CASES for s in (1, 4)])
def test_vector_math_lanes_classify_the_same(results, case):
    run, _idx, _, accs = results[case]
    fast, ref = run.loop.layout.unpack(accs["vector"]), run.loop.layout.unpack(accs["interp"])
    for name in ("diverged", "k_div", "k"):
        np.testing.assert_array_equal(fast[name], ref[name])
    ok = ref["diverged"] == 0
    for name in ("x", "s", "e_max", "abs_e_sum", "u2_sum"):
        np.testing.assert_allclose(np.asarray(fast[name])[..., ok], np.asarray(ref[name])[..., ok],
                                   rtol=1e-8, atol=1e-12)


def test_sweep_default_kernel_is_lanes_and_classifies_like_interpreter(tmp_path):
    d = _pendulum_design()
    kw = {"eps": [0.01, 0.1, 0.5], "gamma": [1e-2, 0.5], "progress": False}
    sc = fl.Scenario(0.05, 1.0)
    fast = fl.sweep(fl.plants.pendulum(), d, sc, kernel=fl.Kernel(cache_dir=tmp_path), **kw)
    slow = fl.sweep(fl.plants.pendulum(), d, sc, kernel=fl.Kernel(compiled=False), **kw)
    np.testing.assert_array_equal(fast.status, slow.status)


def test_record_goes_to_the_scalar_kernel(results):
    run, _, runners, _ = results["pendulum", 1]
    acc0 = run.initial_accumulator(run.loop.design.parameter_vector())[:, 0]
    a, out = runners["exact"].record(acc0, run.D)
    b, ref = runners["interp"].record(acc0, run.D)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(out, ref)


def test_source_does_not_grow_with_substeps():
    """10,000 substeps are a loop: the same source as 10 (up to the step length constant)."""
    plant, d = fl.plants.trms_yaw(), fl.presets.paper_design()
    sources = {}
    for substeps in (10, 10_000):
        loop = prepare_run(plant, d, fl.Scenario(0.3, 0.01),
                           integrator=fl.RK4(substeps=substeps)).loop
        assert rk4_fold(loop.accumulate)[1] == substeps
        sl = loop.layout.slices
        sources[substeps] = lanes_source(
            loop.accumulate, {"k": sl["k"].start, "div": sl["diverged"].start,
                              "N": sl["N"].start}, width=8)
    assert abs(len(sources[10]) - len(sources[10_000])) < 200
    assert "sub < 10000" in sources[10_000]


def test_ten_thousand_substeps_compile_and_match_the_interpreter(tmp_path):
    d = _pendulum_design()
    run = prepare_run(fl.plants.pendulum(), d, fl.Scenario(0.05, 0.005),
                      integrator=fl.RK4(substeps=10_000))
    _idx, runners = _runners(run, tmp_path)
    acc0 = run.initial_accumulator(parameter_columns(d, [0.02, 0.05], [1e-2, 3e-2, 0.1]))
    np.testing.assert_array_equal(runners["exact"].run(acc0, run.D),
                                  runners["interp"].run(acc0, run.D))


def test_serial_blas_gives_the_same_columns():
    from fl_design.sim._lanes_blas import _openblas_libraries, serial_blas

    d = fl.presets.paper_design()
    ref = parameter_columns(d, [1e-3, 0.05, 1.0], [1e-4])
    with serial_blas() as n:
        inside = parameter_columns(d, [1e-3, 0.05, 1.0], [1e-4])
        assert all(fn(1) == 1 for fn in _openblas_libraries())  # one thread inside
    np.testing.assert_array_equal(inside, ref)
    assert n == len(_openblas_libraries())
