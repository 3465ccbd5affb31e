"""Swings in the tail: the reversal counter of the accumulator table and the ``undecided`` status.

The counter is checked against :func:`tests.oracles.count_reversals` (a plain Python zigzag
over the recorded tail) on synthetic error signals run through the table's step, and on closed
loops (interpreter, compiled scalar and lanes kernels).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import fl_design as fl
from fl_design.sim import EpsStar, EpsStarEstimate, StabilityMap, Status
from fl_design.sim._metrics import initial_values, metric_layout, metrics_from_summary
from fl_design.sim._simulate import _metric_step
from fl_design.sim._status import classify
from tests.oracles import count_reversals

TOL = 0.01


def _run_table(e: np.ndarray, k_tail: int) -> dict:
    """Every accumulator of the table after the error samples ``e`` (rho = 1, interpreted)."""
    n, lay = e.size, metric_layout(1)
    m0 = lay.pack(**initial_values(1))[:, 0]
    k = np.arange(n, dtype=float)
    sig = np.vstack([e, np.zeros(n), np.zeros(n), k, e, np.zeros(n), np.zeros((2, n))])
    c = np.tile([[0.0], [1.0], [TOL], [k_tail], [k_tail + (n - k_tail) // 2]], (1, n))
    m = np.asarray(_metric_step(1).mapaccum(n)(m0, sig, c), dtype=float)[:, -1]
    out = {name: np.asarray(v).ravel() for name, v in lay.unpack(m).items()}
    out = {name: (v if name == "est2_sum" else float(v[0])) for name, v in out.items()}
    return out | {"N": n, "k_tail": k_tail, "k_mid": k_tail + (n - k_tail) // 2, "y0": 0.0, "step": 1.0,
                      "tol": TOL, "diverged": 0, "k_div": -1}


def _signals() -> dict:
    t = np.linspace(0.0, 100.0, 2001)
    jitter = np.random.default_rng(3).normal(0.0, 0.05 * TOL, t.size)  # peak-to-peak < tol / 2
    return {
        "decaying sine": (0.2 * np.exp(-t / 60) * np.sin(2 * np.pi * t / 7), "converging"),
        "sustained sine": (0.05 * np.sin(2 * np.pi * t / 9) + jitter, "oscillating"),
        "slow sine": (0.05 * np.sin(2 * np.pi * t / 300), "undecided"),  # period >> tail (20 s)
        "ramp": (0.02 + 1e-4 * t, "undecided"),
        "noisy constant": (0.03 + jitter, "undecided"),
    }


@pytest.mark.parametrize("name", list(_signals()))
def test_reversal_counter_equals_a_numpy_zigzag_on_synthetic_errors(name):
    e, status = _signals()[name]
    k_tail = int(0.8 * e.size)
    acc = _run_table(e, k_tail)
    expected = count_reversals(e[k_tail:], TOL / 2)
    assert acc["tail_reversals"] == expected
    if name in ("ramp", "noisy constant"):
        assert expected == 0  # a creep, or jitter below the hysteresis
    elif name == "slow sine":
        assert expected <= 1  # part of one swing
    else:
        assert expected >= 2
    assert Status(int(metrics_from_summary(acc, 0.05)["status"])).label == status
    # the same signal negated counts the same reversals
    assert _run_table(-e, k_tail)["tail_reversals"] == expected


def test_classify_gives_every_status_from_accumulators():
    base = {"diverged": 0, "tol": TOL, "tail_abs_e_max": 0.1, "tail_e_max": 0.1, "tail_e_min": -0.1,
                "env1_max": 0.1, "env2_max": 0.1, "tail_reversals": 0}
    cases = {
        "converged": {"tail_abs_e_max": 0.005, "tail_e_max": 0.005, "tail_e_min": 0.0},
        "converging": {"env2_max": 0.05},
        "oscillating": {"tail_reversals": 2},
        "undecided": {"tail_reversals": 1},
        "diverged": {"diverged": 1, "tail_reversals": 5},
        "solver_failed": {"solver_failed": 1},
    }
    for label, change in cases.items():
        assert Status(int(classify(base | change))) == Status.from_label(label), label
    assert Status.UNDECIDED.bounded and not Status.UNDECIDED.convergent
    # codes of the other statuses keep their meaning
    assert [int(Status.from_label(s)) for s in
            ("solver_failed", "diverged", "oscillating", "converging", "converged")] == list(
        range(-2, 3))


def test_eps_star_says_undecided_at_its_upper_end():
    status = np.array([[2, 3, 2], [1, 2, 2], [3, 0, -1]])
    smap = StabilityMap(np.array([0.1, 0.2, 0.4]), np.array([1.0, 2.0, 3.0]), status, {},
                        1e-3, 10.0, 0.01)
    first, below, failed = (smap.eps_star(g) for g in (1.0, 2.0, 3.0))
    assert (first.lower, first.upper, first.upper_status) == (0.2, 0.4, "undecided")
    assert str(first) == "0.2 (undecided at 0.4: run longer)"
    assert str(below) == "< 0.1 (undecided at 0.1: run longer)" and below.below_range
    assert str(failed) == "0.2 (fails at 0.4)" and failed.upper_status == "diverged"
    text = json.dumps(smap.to_dict(), allow_nan=False)  # strict JSON
    assert '"upper_status": "undecided"' in text
    assert EpsStar(1.0, math.inf).to_dict()["upper_status"] is None
    est = EpsStarEstimate(0.2, (0.2, 0.25), 3, ((0.1, "converged", math.nan),
                                                (0.3, "oscillating", math.nan),
                                                (0.25, "undecided", math.nan)), False)
    assert str(est) == "0.2 (undecided at 0.25: run longer)"
    assert json.loads(json.dumps(est.to_dict(), allow_nan=False))["upper_status"] == "undecided"


def test_the_kernels_count_the_recorded_tails_reversals(tmp_path):
    """Interpreter and compiled scalar kernel on a pendulum limit cycle, the lanes kernel on
    the TRMS: the counter equals the zigzag of the recorded tail."""
    pend = fl.plants.pendulum()
    cyc = fl.presets.pendulum_design(eps=0.2, u_limits=(-1.2, 1.2))
    for kernel in (fl.Kernel(compiled=False), fl.Kernel(cache_dir=tmp_path)):
        resp = fl.simulate(pend, cyc, fl.Scenario(0.05, 30.0), kernel=kernel)
        e = resp.y[resp.k_tail:] - resp.r[resp.k_tail:]
        assert resp.metrics["tail_reversals"] == count_reversals(e, resp.tol / 2) >= 2
        assert resp.status == "oscillating"
    plant, design = fl.plants.trms_yaw(), fl.presets.paper_design()
    smap = fl.sweep(plant, design, fl.Scenario(0.3, 30.0), eps=[0.05, 0.5], gamma=[3e-4, 3e-2],
                    progress=False)
    for i, j, label in ((0, 0, "undecided"), (1, 1, "oscillating")):
        resp = fl.simulate(plant, design.replace(eps=smap.eps[i], gamma=smap.gamma[j]),
                           fl.Scenario(0.3, 30.0))
        e = resp.y[resp.k_tail:] - resp.r[resp.k_tail:]
        assert smap.labels[i, j] == label == resp.status
        assert smap.metrics["tail_reversals"][i, j] == count_reversals(e, resp.tol / 2)
