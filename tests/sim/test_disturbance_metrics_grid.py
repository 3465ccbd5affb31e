"""Disturbance metrics of sweeps and Monte Carlo (running accumulators) equal the recorded ones."""

import math

import numpy as np
import pytest

import fl_design as fl

SCENARIO = fl.Scenario(0.1, 20.0, disturbance=fl.Disturbance(input=fl.Step(at=8.0, size=2.0)))


@pytest.fixture(scope="module")
def pendulum():
    return fl.plants.pendulum(), fl.presets.pendulum_design()


def test_sweep_metrics_equal_the_recorded_response(pendulum):
    plant, design = pendulum
    smap = fl.sweep(plant, design, SCENARIO, eps=[0.01, 0.02, 0.06], gamma=[0.005, 0.01],
                    progress=False)
    rec = smap.metrics["recovery_time"]
    assert np.isfinite(rec).sum() >= 2  # most runs recover within the run
    for i, e in enumerate(smap.eps):
        for j, g in enumerate(smap.gamma):
            d = fl.simulate(plant, design.replace(eps=e, gamma=g), SCENARIO).disturbance
            np.testing.assert_allclose(smap.metrics["disturbance_peak"][i, j],
                                       d["disturbance_peak"], rtol=1e-9)
            if math.isfinite(d["recovery_time"]):
                assert abs(rec[i, j] - d["recovery_time"]) < 1e-9
            else:
                assert rec[i, j] == d["recovery_time"] or np.isnan(d["recovery_time"]) and \
                    np.isnan(rec[i, j])


def test_no_disturbance_no_columns(pendulum):
    plant, design = pendulum
    smap = fl.sweep(plant, design, fl.Scenario(0.1, 1.0), eps=[0.02], gamma=[0.01],
                    progress=False)
    assert "recovery_time" not in smap.metrics and "disturbance_peak" not in smap.metrics


def test_monte_carlo_reports_recovery_per_sample(pendulum):
    plant, design = pendulum
    ens = fl.monte_carlo(plant, design, SCENARIO, params={"b": (0.7, 1.3)}, n=3, seed=0,
                         progress=False)
    for i in range(ens.n):
        d = fl.simulate(plant.with_params(**ens.sample(i)), design, SCENARIO).disturbance
        np.testing.assert_allclose(ens.metrics["disturbance_peak"][i], d["disturbance_peak"],
                                   rtol=1e-9)
        np.testing.assert_allclose(ens.metrics["recovery_time"][i], d["recovery_time"],
                                   atol=1e-9)
    assert np.all(np.isfinite(ens.metrics["recovery_time"]))  # the step is rejected
