"""The report's summary states the scenario's disturbance and the main run's response to it."""

import pytest

import fl_design as fl
from fl_design.app import parse_config, run_job
from fl_design.app._report_summary import summary_blocks

TOML = """
[plant]
library = "pendulum"
[scenario]
reference = 0.1
duration = 20.0
[scenario.disturbance]
input = { step = { at = 10.0, size = 0.5 } }
"""


def _row(job):
    rows = [r for r in summary_blocks(job, [])[0][1] if r[0] == "Disturbance"]
    return rows[0][1] if rows else None


def test_summary_gives_peak_and_recovery_of_the_main_run():
    job = run_job(parse_config(TOML), stages=("derive", "simulate"), progress=False)
    direct = fl.simulate(fl.plants.pendulum(), fl.presets.pendulum_design(),
                         fl.Scenario(0.1, 20.0,
                                     disturbance=fl.Disturbance(input=fl.Step(10.0, 0.5))))
    m = direct.disturbance
    assert job.results["simulate"]["main"].disturbance == pytest.approx(m, rel=1e-9)
    brief = _row(job)
    text = str(brief)
    assert brief.word == "recovered" and brief.level == "good" and len(text.split()) <= 25
    assert brief.detail.startswith("input step (at 10, size 0.5) at 10 s")
    assert f"peak |y - r| {m['disturbance_peak']:.3g}" in text
    assert f"back in the band {m['recovery_time']:.3g} s later" in text


def test_a_run_that_ends_before_the_disturbance_says_so_and_none_without_one():
    quick = run_job(parse_config(TOML), quick=True, stages=("derive", "simulate"),
                    progress=False)
    assert _row(quick).word == "did not act" and "after this run's 4 s" in str(_row(quick))
    plain = run_job(parse_config('[plant]\nlibrary = "pendulum"\n'), quick=True,
                    stages=("derive", "simulate"), progress=False)
    assert _row(plain) is None
