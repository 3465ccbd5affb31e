"""The lanes kernel (W grid points per vector) against the scalar kernel and the interpreter.

With glibc's scalar math (``vector_math=False``) the lanes kernel computes bit for bit what the
scalar compiled kernel and CasADi's interpreter compute; with libmvec's vector math (the
default) every run is classified the same and the metrics agree to the loop's amplification of
a last-bit difference in ``tanh``/``sin``. Every instruction-set level this machine can run is
tested (``fl.Kernel(isa=...)``: AVX-512, AVX2, SSE2 on x86-64; NEON or the portable path
elsewhere); the expected lane width comes from the level, and the grids have a partial last
block (and a grid smaller than one block) for every width, diverging runs, one and many RK4
substeps.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

import fl_design as fl
from fl_design._isa import LEVELS, available_isas
from fl_design._toolchain import find_compiler
from fl_design.sim._grid import parameter_columns
from fl_design.sim._run import prepare_run
from fl_design.sim.kernel._emit import lanes_source, rk4_fold
from fl_design.sim.kernel._lanes import LanesRunner
from fl_design.sim.kernel._runners import make_runner

pytestmark = pytest.mark.skipif(find_compiler() is None, reason="needs a C compiler")


def _pendulum_design():
    return fl.Design(estimator=fl.EHGO(rho=2, eps=0.02, T=1e-3),
                     controller=fl.DynamicController((2, 4), 1e-2))


#: The lanes levels of this machine (the scalar level is the "native" runner below).
ISAS = [name for name in available_isas() if LEVELS[name].lanes]

CASES = {
    # plant, design, duration, eps grid, gamma grid: 5 x 3 = 15 and 3 x 7 = 21 runs, which no
    # lane width (2, 4, 8) divides, each grid with diverging runs
    "pendulum": (fl.plants.pendulum, _pendulum_design, 1.2, np.geomspace(0.01, 1, 5),
                 np.geomspace(1e-3, 1, 3)),
    "trms": (fl.plants.trms_yaw, lambda: fl.presets.paper_design(u_limits=None), 0.6,
             np.geomspace(1e-3, 1, 3), np.geomspace(1e-4, 1.0, 7)),
}


def _runners(run, cache, isa=None):
    loop = run.loop
    sl = loop.layout.slices
    idx = {"k": sl["k"].start, "div": sl["diverged"].start, "N": sl["N"].start}
    mk = lambda **kw: make_runner(loop.accumulate, loop.record, idx, cache_dir=cache, **kw)
    runners = {"native": mk(lanes=False), "interp": mk(compiled=False)}
    for name in ISAS if isa is None else [isa]:
        runners["exact", name] = mk(vector_math=False, isa=name)
        runners["vector", name] = mk(vector_math=True, isa=name)
    return idx, runners


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


CASE_IDS = [(n, s, isa) for n in CASES for s in (1, 4) for isa in ISAS]


@pytest.mark.parametrize("case", CASE_IDS, ids=lambda c: f"{c[0]}-rk{c[1]}-{c[2]}")
def test_exact_lanes_equal_scalar_kernel_and_interpreter_bitwise(results, case):
    name, substeps, isa = case
    _run, idx, runners, accs = results[name, substeps]
    runner = runners["exact", isa]
    assert isinstance(runner, LanesRunner) and runner.library is not None
    assert runner.library.fl_lanes_width() == LEVELS[isa].width  # the level asked for
    exact = accs["exact", isa]
    assert exact.shape[1] % LEVELS[isa].width != 0  # a partial last block
    assert 0 < np.sum(exact[idx["div"]]) < exact.shape[1]  # some diverge
    np.testing.assert_array_equal(accs["native"], accs["interp"])
    np.testing.assert_array_equal(exact, accs["native"])


@pytest.fixture(scope="module")
def small_grid_cache(tmp_path_factory):
    """The kernel cache of the small-grid tests: both grid sizes of a level run the same
    compiled kernels (content-addressed and verified, as in every use of the cache)."""
    return tmp_path_factory.mktemp("small_grid")


@pytest.mark.parametrize("isa", ISAS)
@pytest.mark.parametrize("n_runs", [1, 3])
def test_a_grid_smaller_than_one_block(small_grid_cache, isa, n_runs):
    """Fewer runs than lanes: the unused lanes never write a result (bitwise the scalar)."""
    d = _pendulum_design()
    run = prepare_run(fl.plants.pendulum(), d, fl.Scenario(0.05, 0.3))
    _idx, runners = _runners(run, small_grid_cache, isa)
    acc0 = run.initial_accumulator(parameter_columns(d, [0.02, 0.3, 1.0][:n_runs], [1e-2]))
    np.testing.assert_array_equal(runners["exact", isa].run(acc0, run.D),
                                  runners["native"].run(acc0, run.D))


@pytest.mark.parametrize("case", CASE_IDS, ids=lambda c: f"{c[0]}-rk{c[1]}-{c[2]}")
def test_vector_math_lanes_classify_the_same(results, case):
    name, substeps, isa = case
    run, _idx, _, accs = results[name, substeps]
    fast = run.loop.layout.unpack(accs["vector", isa])
    ref = run.loop.layout.unpack(accs["interp"])
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
    a, out = runners["exact", ISAS[0]].record(acc0, run.D)
    b, ref = runners["interp"].record(acc0, run.D)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(out, ref)


def test_source_does_not_grow_with_substeps(monkeypatch):
    """Beyond the unrolled block, more substeps are a longer C loop: 10,000 and 100,000
    substeps give the same source up to the loop count and the step length constant; 10
    substeps are unrolled (no loop)."""
    monkeypatch.setenv("FL_DESIGN_MAX_SUBSTEPS", "100000")  # above the default cap, on purpose
    plant, d = fl.plants.trms_yaw(), fl.presets.paper_design()
    sources = {}
    for substeps in (10, 10_000, 100_000):
        loop = prepare_run(plant, d, fl.Scenario(0.3, 0.01),
                           integrator=fl.RK4(substeps=substeps)).loop
        assert rk4_fold(loop.accumulate)[1] == substeps
        sl = loop.layout.slices
        sources[substeps] = lanes_source(
            loop.accumulate, {"k": sl["k"].start, "div": sl["diverged"].start,
                              "N": sl["N"].start}, width=8)
    assert abs(len(sources[10_000]) - len(sources[100_000])) < 200
    blocks = {s: re.search(r"for \(sub = 0; sub < (\d+);", sources[s]) for s in sources}
    assert blocks[10] is None
    unroll = 10_000 // int(blocks[10_000].group(1))
    assert int(blocks[100_000].group(1)) == 100_000 // unroll
    assert "XS[" in sources[10_000]  # the state is stored between blocks only


def test_ten_thousand_substeps_compile_and_match_the_interpreter(tmp_path):
    d = _pendulum_design()
    run = prepare_run(fl.plants.pendulum(), d, fl.Scenario(0.05, 0.005),
                      integrator=fl.RK4(substeps=10_000))
    _idx, runners = _runners(run, tmp_path)
    acc0 = run.initial_accumulator(parameter_columns(d, [0.02, 0.05], [1e-2, 3e-2, 0.1]))
    for isa in ISAS:
        np.testing.assert_array_equal(runners["exact", isa].run(acc0, run.D),
                                      runners["interp"].run(acc0, run.D))


def test_serial_blas_gives_the_same_columns():
    from fl_design._blas import _openblas_libraries, serial_blas

    d = fl.presets.paper_design()
    ref = parameter_columns(d, [1e-3, 0.05, 1.0], [1e-4])
    with serial_blas() as n:
        inside = parameter_columns(d, [1e-3, 0.05, 1.0], [1e-4])
        assert all(fn(1) == 1 for fn in _openblas_libraries())  # one thread inside
    np.testing.assert_array_equal(inside, ref)
    assert n == len(_openblas_libraries())


@pytest.mark.parametrize("isa", ISAS)
def test_trms_lanes_kernel_calls_vector_math_in_every_group(tmp_path, isa):
    """The step is written in vector types: every lane group calls libmvec's vector tanh of
    the level's width (no scalar fallback the compiler could choose), and the library links it."""
    from pathlib import Path

    from fl_design.sim.kernel._emit import groups
    from fl_design.sim.kernel._lanes import vector_math

    if not vector_math(LEVELS[isa]):
        pytest.skip(f"no vector math at {isa}")
    run = prepare_run(fl.plants.trms_yaw(), fl.presets.paper_design(), fl.Scenario(0.3, 0.1))
    idx, runners = _runners(run, tmp_path, isa)
    lib = runners["vector", isa].library
    lvl = LEVELS[isa]
    name = f"_ZGV{lvl.mvec}N{lvl.width}v_tanh"
    assert lib is not None and name.encode() in Path(lib._name).read_bytes()
    src = lanes_source(run.loop.accumulate, idx, width=lvl.width, vector_math=("tanh",),
                       variant=lvl.mvec)
    n = groups(lvl.width, 1)
    assert f"#define FL_G {n}" in src and "#pragma omp" not in src
    tanh_calls = re.findall(r"fl_v v\d+_g(\d+) = fl_tanh\(", src)
    assert tanh_calls and sorted(set(tanh_calls)) == [str(g) for g in range(n)]


def test_lanes_compiler_is_cc_when_set_else_clang_if_present(monkeypatch):
    from fl_design.sim.kernel import _lanes

    monkeypatch.setenv("CC", "gcc")
    assert _lanes.preferred_compiler() is None  # $CC is the compiler of everything
    monkeypatch.delenv("CC")
    monkeypatch.setattr(_lanes.shutil, "which", lambda name: f"/opt/{name}")
    assert _lanes.preferred_compiler() == "/opt/clang"


def test_a_clang_that_fails_leaves_the_default_compiler_quietly(tmp_path, monkeypatch):
    """A preferred compiler that cannot compile: the default one builds the kernel, no
    warning, the same results bit for bit."""
    import warnings

    from fl_design.sim.kernel import _lanes

    isa = ISAS[0]
    d = _pendulum_design()
    run = prepare_run(fl.plants.pendulum(), d, fl.Scenario(0.05, 0.3))
    _, runners = _runners(run, tmp_path / "ref", isa)
    acc0 = run.initial_accumulator(parameter_columns(d, [0.02, 0.3, 1.0], [1e-2, 0.1]))
    monkeypatch.setattr(_lanes, "preferred_compiler", lambda: str(tmp_path / "no-such-clang"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _idx, fallback = _runners(run, tmp_path / "fallback", isa)
        assert fallback["exact", isa].library is not None
    np.testing.assert_array_equal(fallback["exact", isa].run(acc0, run.D),
                                  runners["native"].run(acc0, run.D))


@pytest.mark.parametrize("isa", ISAS)
def test_every_operation_in_vector_types_is_bitwise_casadi(tmp_path, isa):
    """Every operation the emitter translates (selects, masks, NaN, -0.0, two-argument and
    one-argument math), iterated 50 times on 13 lanes: the exact kernel equals CasADi's
    interpreter bit for bit (the sign of zero included; NaN where it has NaN)."""
    import casadi as ca

    from fl_design.sim.kernel._lanes import _load, build_lanes

    a, d = ca.SX.sym("a", 7), ca.SX.sym("d", 3)
    x, y = a[3], a[4]
    terms = [ca.power(x, y), ca.atan2(x, y), ca.fmin(x, y), ca.fmax(x, y), ca.sign(x),
             ca.copysign(x, y), ca.fmod(x, y), ca.hypot(x, y), ca.floor(x), ca.ceil(y),
             ca.erf(x), ca.sqrt(ca.fabs(y)), ca.exp(x) + ca.log(ca.fabs(y) + 1),
             ca.sin(x) * ca.cos(y), ca.tan(x), ca.asin(ca.tanh(x)), ca.acos(ca.tanh(y)),
             ca.atan(x), ca.sinh(x), ca.cosh(y), ca.asinh(x), ca.acosh(ca.fabs(y) + 1),
             ca.atanh(ca.tanh(x) * 0.5), ca.log1p(ca.fabs(x)), ca.expm1(y),
             ca.if_else(x < y, x * 2, y / 3), ca.logic_and(x > 0, y > 0)
             + ca.logic_or(x > 1, y < -1) + ca.logic_not(x == y),
             (x <= y) * (x != y) + (x == 0) * 4.0, ca.constpow(x, 3), -x, 1 / y, x * x,
             ca.if_else(x > y, x, y), ca.fabs(x) * ca.sign(y)]
    out = sum(t * (k + 1) for k, t in enumerate(terms))
    f = ca.Function("fl_acc", [a, d], [ca.vertcat(a[0] + 1, a[1], a[2],
                                                  x * 0.999 + 0.01 * ca.sin(out),
                                                  y * 0.999 + 1e-3 * ca.tanh(out), out, a[6])])
    rng = np.random.default_rng(0)
    acc = np.zeros((7, 13))
    acc[2], acc[3], acc[4] = 50, rng.uniform(-2, 2, 13), rng.uniform(-2, 2, 13)
    acc[4, 0], acc[3, 1], acc[3, 2] = 0.0, -0.0, np.nan
    ref, D = acc.copy(), np.zeros((3, 50))
    for k in range(50):
        ref = np.column_stack([np.asarray(f(ref[:, j], D[:, k])).ravel() for j in range(13)])
    lib = _load(str(build_lanes(f, {"k": 0, "div": 1, "N": 2}, isa=LEVELS[isa],
                                cache_dir=tmp_path, vector_math_ok=False)))
    cols = np.ascontiguousarray(acc.T)
    lib.fl_lanes_run(cols, 13, np.ascontiguousarray(D.T), 50, np.zeros(1, np.int64))
    got, number = cols.T, ~np.isnan(ref)
    assert np.isnan(ref[5, 2])  # the NaN lane stays NaN (its sign and payload are the
    np.testing.assert_array_equal(np.isnan(got), ~number)  # compiler's operand order's)
    np.testing.assert_array_equal(got[number].view(np.int64), ref[number].view(np.int64))


def test_trms_map_equals_the_scalar_code_map():
    """The demo map's slow corner (re-runs included) by the vectorised lanes against the
    lanes with glibc's scalar math (bitwise the scalar kernel and the interpreter): the same
    verdicts and run lengths, every metric within 1e-6 of its largest value on the map."""
    plant, design = fl.plants.trms_yaw(), fl.presets.paper_design()
    kw = {"eps": [0.005, 0.7024, 1.0], "gamma": np.geomspace(3e-5, 1.2e-4, 4),
          "progress": False}
    fast = fl.sweep(plant, design, fl.Scenario(0.3), **kw)
    exact = fl.sweep(plant, design, fl.Scenario(0.3), kernel=fl.Kernel(vector_math=False), **kw)
    assert np.any(exact.extended)  # some points re-run longer
    np.testing.assert_array_equal(fast.status, exact.status)
    np.testing.assert_array_equal(fast.durations, exact.durations)
    for name, value in exact.metrics.items():
        scale = np.nanmax(np.abs(value)) if np.any(np.isfinite(value)) else 0.0
        np.testing.assert_allclose(fast.metrics[name], value, rtol=0, atol=1e-6 * scale + 1e-15,
                                   err_msg=name)
