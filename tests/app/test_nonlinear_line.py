"""The certify stage's nonlinear line: searched in the full job, said to be skipped in --quick."""

from __future__ import annotations

import fl_design as fl
from fl_design.app._stages import nonlinear_line as _nonlinear


def test_full_job_certifies_the_pendulum_in_its_whole_region():
    plant, design = fl.plants.pendulum(), fl.presets.pendulum_design()
    line, summary = _nonlinear(design, plant, None, quick=False)
    assert line.startswith("nonlinear: certified in region")
    assert "covered initial states" in line and "not in the whole region" not in line
    assert summary.startswith("certified in the plant's whole region; covered starts "
                              "|theta - theta_eq| <= 0.3")


def test_quick_job_says_the_region_was_not_searched():
    plant, design = fl.plants.pendulum(), fl.presets.pendulum_design()
    line, summary = _nonlinear(design, plant, None, quick=True)
    assert line.startswith("nonlinear: not searched in --quick")
    assert summary == "not searched in --quick"
