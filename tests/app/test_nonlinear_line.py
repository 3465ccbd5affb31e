"""The certify stage's step line (fl.certify_step on the nonlinear plant): computed in the full
job, said to be skipped in --quick; a plant the step certificate refuses is said, not a crash."""

from __future__ import annotations

import fl_design as fl
from fl_design.app._config import parse_config
from fl_design.app._stages import step_line


def _scenario(r):
    return parse_config(f"[scenario]\nreference = {r}\n").scenario


def test_full_job_certifies_the_pendulum_step():
    plant, design = fl.plants.pendulum(), fl.presets.pendulum_design()
    line, summary = step_line(design, plant, _scenario(0.1), quick=False)
    direct = fl.certify_step(plant, design, fl.Scenario(0.1))  # the same question, directly
    assert direct.certified
    assert summary.startswith("certified the 0.1 step from rest")
    assert "invariant ellipsoid" in line


def test_an_uncertified_step_gives_the_largest_certified_one():
    plant, design = fl.plants.pendulum(), fl.presets.pendulum_design()
    direct = fl.certify_step(plant, design, fl.Scenario(3.0))
    _line, summary = step_line(design, plant, _scenario(3.0), quick=False)
    assert not direct.certified
    assert summary == (f"not certified (the 3 step; largest certified step "
                       f"{direct.largest_step:.3g})")


def test_quick_job_says_the_step_was_not_searched():
    plant, design = fl.plants.pendulum(), fl.presets.pendulum_design()
    line, summary = step_line(design, plant, _scenario(0.1), quick=True)
    assert line.startswith("this step: not certified in --quick")
    assert summary == "not searched in --quick"


def test_a_plant_the_step_certificate_refuses_is_said():
    plant = fl.plants.trms_yaw(motor_lag=True)  # normal-form coordinates are not its states
    design = fl.presets.trms_lag_design()
    line, summary = step_line(design, plant, _scenario(0.05), quick=False)
    assert line.startswith("this step: not analysed:")
    assert summary == "not certified (see Certificates)"
