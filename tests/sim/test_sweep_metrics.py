"""sweep(metrics=[...]): only the accumulators of the metrics asked for run, results unchanged."""

from __future__ import annotations

import numpy as np
import pytest

import fl_design as fl
from fl_design.errors import ParameterError
from fl_design.sim._metrics import (
    ACCUMULATORS,
    METRIC_ONLY,
    accumulators_for,
    requested_metrics,
)
from fl_design.sim._run import prepare_run

GRID = {"eps": [0.01, 0.03, 0.1, 0.3], "gamma": [3e-3, 1e-2, 3e-2]}


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("kernels")


def _map(pendulum, design, kernel, metrics=None):
    return fl.sweep(pendulum, design, fl.Scenario(0.05, 8.0, noise=fl.Noise(std=1e-4)),
                    **GRID, classifier=fl.Classifier(tolerance=0.1), kernel=kernel,
                    progress=False, metrics=metrics)


@pytest.mark.parametrize("compiled", [False, True])
def test_selected_metrics_equal_the_full_map_bit_for_bit(pendulum, pendulum_design, cache,
                                                         compiled):
    design = pendulum_design()
    kernel = fl.Kernel(compiled=compiled, cache_dir=cache)
    full = _map(pendulum, design, kernel)
    asked = ["overshoot", "estimation_rms", "decay_rate"]
    part = _map(pendulum, design, kernel, metrics=asked)
    assert set(part.metrics) == {*asked, "divergence_time"}
    np.testing.assert_array_equal(part.status, full.status)
    assert len(set(full.labels.ravel())) >= 2  # the grid has more than one verdict
    for name in part.metrics:
        np.testing.assert_array_equal(part.metrics[name], full.metrics[name])
    status_only = _map(pendulum, design, kernel, metrics=[])
    assert set(status_only.metrics) == {"divergence_time"}
    np.testing.assert_array_equal(status_only.status, full.status)


def test_the_kernel_drops_the_accumulators_nobody_asked_for(pendulum, pendulum_design):
    design, scenario = pendulum_design(), fl.Scenario(0.05, 1.0)
    full = prepare_run(pendulum, design, scenario).loop
    status = prepare_run(pendulum, design, scenario, metrics=[]).loop
    iae = prepare_run(pendulum, design, scenario, metrics=["iae"]).loop
    assert full.layout.size == status.layout.size  # same layout: memory and packing unchanged
    sizes = [loop.accumulate.n_instructions() for loop in (status, iae, full)]
    assert sizes[0] < sizes[1] < sizes[2]
    kept = set(accumulators_for(("iae",)))
    assert kept == {a.name for a in ACCUMULATORS} - (METRIC_ONLY - {"abs_e_sum"})


def test_metric_selection_refuses_bad_input(pendulum, pendulum_design):
    assert requested_metrics(None) is None
    assert requested_metrics(("iae", "iae", "overshoot")) == ("iae", "overshoot")
    with pytest.raises(ParameterError, match="unknown metric.*'overshot'.*valid names"):
        requested_metrics(["overshot"])
    with pytest.raises(ParameterError, match=r"list of metric names.*\['iae'\]"):
        requested_metrics("iae")
    with pytest.raises(ParameterError, match="robust map"):
        fl.sweep(pendulum, pendulum_design(), fl.Scenario(0.05, 1.0), eps=[0.1], gamma=[0.01],
                 params={"c": (0.4, 0.6)}, metrics=["iae"], progress=False)
