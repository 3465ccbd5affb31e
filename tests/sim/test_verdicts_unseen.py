"""Verdicts on loops the project had not seen (issue 31): a decaying swing slower than the run
is never "oscillating"; an error inside the band is never "stalled".

The signals run through the accumulator table (:func:`tests.sim.test_swings._run_table`); the
swing's period and the band are re-measured here from the record itself (NumPy).
"""

from __future__ import annotations

import numpy as np

import fl_design as fl
from fl_design.sim import Status
from fl_design.sim._metrics import metrics_from_summary
from fl_design.sim._status import NOISE_P2P
from tests.sim.test_swings import TOL, _run_table

T = np.linspace(0.0, 100.0, 2001)  # 100 s at 0.05 s: the analysis window is the last 50 s


def _status(e, noise=0.0) -> str:
    acc = _run_table(e, int(0.8 * e.size), noise)
    return Status(int(metrics_from_summary(acc, 0.05)["status"])).label


def test_a_decaying_swing_slower_than_the_window_is_not_oscillating():
    e = 0.2 * np.exp(-T / 400) * np.sin(2 * np.pi * T / 55 + 0.3)
    half = e[T >= 50]
    crossings = np.flatnonzero(np.diff(np.sign(half)) != 0)
    assert crossings.size <= 2  # at most one full swing seen in the window (period 55 s)
    a = np.abs(e)
    peaks = a[1:-1][(a[1:-1] > a[:-2]) & (a[1:-1] >= a[2:])]
    assert peaks.size >= 2 and np.all(np.diff(peaks) < 0)  # every swing smaller: it decays
    assert _status(e) in ("converging", "undecided")


def test_a_sustained_swing_seen_several_times_is_still_oscillating():
    e = 0.05 * np.sin(2 * np.pi * T / 9)
    assert _status(e) == "oscillating"


def test_an_error_inside_the_band_is_never_stalled():
    """|e| = 1.5 tol, within the band tol + NOISE_P2P noise / 2 of a noisy run, its mean above
    tol (so not converged): not stalled."""
    noise = 0.005
    rng = np.random.default_rng(0)
    e = 1.5 * TOL + rng.normal(0.0, 0.05 * TOL, T.size)
    band = TOL + NOISE_P2P * noise / 2
    assert np.max(np.abs(e[int(0.8 * e.size):])) <= band
    assert _status(e, noise) != "stalled"
    assert _status(0.3 + 0.0 * T) == "stalled"  # outside the band it still is


def test_a_run_shorter_than_the_designed_loop_is_undecided_not_stalled():
    """Issue 36: a 0.2 s run of the converging pendulum design read 'stalled'. The designed
    loop s^2 + 4 s + 2 has its slowest root at -2 + sqrt(2): time constant 1.707 s (closed
    form); a 0.1 s analysed window cannot show a stall. The full run converges."""
    import math

    plant, design = fl.plants.pendulum(), fl.presets.pendulum_design()
    short = fl.simulate(plant, design, fl.Scenario(0.1, 0.2))
    assert short.status == "undecided"
    tau = 1.0 / (2.0 - math.sqrt(2.0))
    assert f"time constant {tau:.3g} s" in short.verdict()
    assert fl.simulate(plant, design, fl.Scenario(0.1, 20.0)).status == "converged"
