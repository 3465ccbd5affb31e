"""Threads and chunks of a sweep change nothing: results bit for bit, whatever the split.

With several threads the grid runs as a pipeline (:func:`fl_design.sim._grid._run_here`):
the next chunk's columns and the finished chunk's classification on one more thread while
the kernel runs; the kernel shares columns between its threads (:mod:`fl_design.sim.kernel._lanes`).
"""

from __future__ import annotations

import numpy as np
import pytest

import fl_design as fl
from fl_design.sim._adaptive import Assembly, assemble
from fl_design.sim._grid import parameter_columns, run_grid
from fl_design.sim._run import prepare_run

#: A TRMS grid where runs converge, oscillate and diverge within the run (bench_sweep's).
EPS, GAMMA = np.geomspace(1e-3, 3.0, 9), np.geomspace(1e-5, 1.0, 7)
CLASSIFIER = fl.Classifier(tolerance=0.2, divergence_bound=(1.0, 60.0))


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("kernels_threads")


def _sweep(cache, **kernel):
    return fl.sweep(fl.plants.trms_yaw(), fl.presets.paper_design(), fl.Scenario(0.3, 1.5),
                    eps=EPS, gamma=GAMMA, classifier=CLASSIFIER, progress=False,
                    kernel=fl.Kernel(cache_dir=cache, **kernel))


def _assert_same(a, b) -> None:
    np.testing.assert_array_equal(a.status, b.status)
    assert a.metrics.keys() == b.metrics.keys()
    for name in a.metrics:
        np.testing.assert_array_equal(a.metrics[name], b.metrics[name], err_msg=name)


@pytest.mark.parametrize("isa", [None, "scalar"])  # the lanes kernel, the scalar one
def test_two_threads_and_any_chunks_give_one_threads_bits(cache, isa):
    one = _sweep(cache, threads=1, isa=isa)
    labels = set(one.labels.ravel().tolist())
    assert "diverged" in labels and len(labels) >= 3  # the grid mixes verdicts
    for threads, chunk in ((2, None), (2, 7), (2, 16), (3, 5), (1, 11)):
        _assert_same(one, _sweep(cache, threads=threads, chunk_size=chunk, isa=isa))


def test_classification_by_chunk_equals_assemble(cache):
    """``run_grid(finish=Assembly)``, ranges of any length, gives :func:`assemble`'s bits."""
    design = fl.presets.paper_design()
    run = prepare_run(fl.plants.trms_yaw(), design, fl.Scenario(0.3, 1.5),
                      classifier=CLASSIFIER)
    P = parameter_columns(design, EPS, GAMMA)
    calls = []
    parts = Assembly(run, P.shape[1])

    def finish(a, b, acc):
        calls.append((a, b))
        parts(a, b, acc)

    acc = run_grid(run, P, kernel=fl.Kernel(cache_dir=cache, threads=2, chunk_size=10),
                   progress=False, finish=finish)
    bounds = [(a, min(a + 10, P.shape[1])) for a in range(0, P.shape[1], 10)]
    assert calls == bounds  # every range once, in order
    status, metrics = assemble(run, acc, (EPS.size, GAMMA.size))
    got_status, got = parts.result((EPS.size, GAMMA.size))
    np.testing.assert_array_equal(got_status, status)
    assert got.keys() == metrics.keys()
    for name in metrics:
        np.testing.assert_array_equal(got[name], metrics[name], err_msg=name)


def test_an_error_in_finish_is_raised_not_lost(cache):
    design = fl.presets.paper_design()
    run = prepare_run(fl.plants.trms_yaw(), design, fl.Scenario(0.3, 0.2),
                      classifier=CLASSIFIER)

    def finish(a, b, acc):
        raise ZeroDivisionError(f"finish of {a}:{b}")

    with pytest.raises(ZeroDivisionError, match="finish of 0:10"):
        run_grid(run, parameter_columns(design, EPS, GAMMA), progress=False, finish=finish,
                 kernel=fl.Kernel(cache_dir=cache, threads=2, chunk_size=10))


def test_each_runs_verdict_and_metrics_do_not_depend_on_its_batch(cache):
    """The classification of a run alone equals its classification among the grid's runs, bit
    for bit (what finishing a grid by chunks relies on; the envelope fits group runs by width)."""
    design = fl.presets.paper_design()
    run = prepare_run(fl.plants.trms_yaw(), design, fl.Scenario(0.3, 1.5),
                      classifier=CLASSIFIER)
    acc = run_grid(run, parameter_columns(design, EPS, GAMMA), progress=False,
                   kernel=fl.Kernel(cache_dir=cache))
    status, metrics = assemble(run, acc, (acc.shape[1],))
    assert len(np.unique(status)) >= 3
    for j in range(acc.shape[1]):
        s, m = assemble(run, acc[:, j:j + 1], (1,))
        assert s[0] == status[j]
        for name in metrics:
            np.testing.assert_array_equal(m[name][0], metrics[name][j], err_msg=f"{name}, {j}")


@pytest.mark.parametrize("isa", [None, "scalar"])
def test_accumulators_in_another_layout_are_refused(cache, isa):
    """advance_rows runs in place: a transposed, non-contiguous or integer array is refused
    with the layout it needs (never run on a hidden copy whose results would be lost)."""
    from fl_design.errors import DimensionError

    design = fl.presets.paper_design()
    run = prepare_run(fl.plants.trms_yaw(), design, fl.Scenario(0.3, 0.05),
                      classifier=CLASSIFIER)
    runner = run.loop.runner(kernel=fl.Kernel(cache_dir=cache, isa=isa))
    rows = runner if isa is None else runner.scalar
    acc = run.initial_accumulator(parameter_columns(design, EPS[:2], GAMMA[:3]))
    good = np.array(acc.T, order="C")
    for bad in (acc, good[:, :-1], np.asfortranarray(good), good.astype(np.float32)):
        with pytest.raises(DimensionError, match="one run per row"):
            rows.advance_rows(bad, run.D, threads=2)
    rows.advance_rows(good, run.D, threads=2)
    np.testing.assert_array_equal(good.T, runner.run(acc, run.D, threads=1))
