"""noise_gain against what a simulation with sensor noise measures, and its limits."""

from __future__ import annotations

import math

import numpy as np
import pytest

import fl_design as fl
from fl_design.analysis import noise_gain


@pytest.mark.parametrize("plant, design, duration", [
    (fl.plants.trms_yaw(), fl.presets.paper_design(), 60.0),
    (fl.plants.pendulum(), fl.presets.pendulum_design(), 60.0),
    (fl.plants.maglev(), fl.presets.maglev_design(), 5.0)])
def test_noise_gain_predicts_the_simulated_input_jitter(plant, design, duration):
    """std(u) / std(w) of a run held at the operating point, small white noise (seed 1)."""
    y0 = float(plant.casadi().h(plant.x_op))
    std = 1e-6 * max(1.0, abs(y0))
    resp = fl.simulate(plant, design, fl.Scenario(y0, duration, noise=fl.Noise(std, seed=1)))
    u = resp.u[resp.u.size // 4:]  # the start-up transient of the observer left out
    measured = float(np.std(u)) / std
    assert noise_gain(plant, design) == pytest.approx(measured, rel=0.1)


def test_a_slower_observer_amplifies_noise_less_and_an_unstable_loop_has_none():
    plant = fl.plants.trms_yaw()
    gains = [noise_gain(plant, fl.presets.paper_design(eps=e)) for e in (0.02, 0.05, 0.1)]
    assert gains[0] > gains[1] > gains[2] > 0
    bad = fl.presets.maglev_design(gamma=-3e-4)  # |gamma b| too slow for the open-loop pole
    assert noise_gain(fl.plants.maglev(), bad) == math.inf


def test_noise_gain_refuses_what_is_not_a_plant():
    with pytest.raises(fl.errors.ParameterError, match="plant"):
        noise_gain("trms", fl.presets.paper_design())
