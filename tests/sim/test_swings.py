"""The classifier's evidence: swings, envelope fit and input limits of the accumulator table.

The streaming measurements are checked against :func:`tests.oracles.evidence_from_errors`
(a NumPy zigzag and SciPy's ``linregress`` over the whole record) on synthetic error signals
run through the table's step, and on closed loops (interpreter, compiled scalar and lanes
kernels).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import fl_design as fl
from fl_design.sim import EpsStar, EpsStarEstimate, StabilityMap, Status
from fl_design.sim._metrics import initial_values, metric_layout, metrics_from_summary
from fl_design.sim._simulate import metric_step
from fl_design.sim._status import classify, evidence
from tests.oracles import evidence_from_errors, status_from_trajectories

TOL = 0.01


def _run_table(e: np.ndarray, k_tail: int, noise: float = 0.0, u=None,
               u_range=None) -> dict:
    """Every accumulator of the table after the error samples ``e`` (rho = 1, interpreted)."""
    n, lay = e.size, metric_layout(1)
    m0 = lay.pack(**initial_values(1))[:, 0]
    k = np.arange(n, dtype=float)
    u = np.zeros(n) if u is None else u
    sig = np.vstack([e, u, np.zeros(n), k, e, np.zeros(n), np.zeros((2, n))])
    k_mid = k_tail + (n - k_tail) // 2
    c = np.tile([[0.0], [1.0], [TOL], [k_tail], [k_mid], [noise]], (1, n))
    m = np.asarray(metric_step(1, u_range).mapaccum(n)(m0, sig, c), dtype=float)[:, -1]
    out = {name: np.asarray(v).ravel() for name, v in lay.unpack(m).items()}
    out = {name: (v if name == "est2_sum" else float(v[0])) for name, v in out.items()}
    return out | {"N": n, "k_tail": k_tail, "k_mid": k_mid, "y0": 0.0, "step": 1.0,
                  "tol": TOL, "noise": noise, "diverged": 0, "k_div": -1}


def _signals() -> dict:
    """Error records (100 s at 0.05 s), the noise level they carry, and their status."""
    t = np.linspace(0.0, 100.0, 2001)
    rng = np.random.default_rng(3)
    jitter = rng.normal(0.0, 0.05 * TOL, t.size)  # peak-to-peak < tol / 2
    noise = 0.02  # std of a measurement noise: ripple of this size is no oscillation
    ripple = rng.normal(0.0, 0.5 * noise, t.size)
    return {
        "decaying sine": (0.2 * np.exp(-t / 30) * np.sin(2 * np.pi * t / 7), 0.0, "converging"),
        "decaying offset": (0.3 * np.exp(-t / 40), 0.0, "converging"),
        "decay to an offset": (0.05 + 0.3 * np.exp(-t / 15), 0.0, "stalled"),
        "sustained sine": (0.05 * np.sin(2 * np.pi * t / 9) + jitter, 0.0, "oscillating"),
        "growing sine": (0.01 * np.exp(t / 60) * np.sin(2 * np.pi * t / 9), 0.0, "undecided"),
        "slow sine": (0.05 * np.sin(2 * np.pi * t / 500), 0.0, "undecided"),  # rises: no swing
        "slow hump": (0.05 * np.sin(2 * np.pi * t / 300), 0.0, "undecided"),  # half a swing
        "ramp away": (0.02 + 1e-3 * t, 0.0, "undecided"),
        # a slow decay (tau 600 s, 9 % over the window) seen through a 6 % wobble: the fit's
        # t (-3.9) is short of T_SIGNIFICANT but confident at 95 %: converging
        "slow wobbly decay": (0.05 * np.exp(-t / 600) * (1 + 0.06 * np.sin(2 * np.pi * t / 17)),
                              0.0, "converging"),
        # a decaying swing slower than the window crossing the reference once (t = -3.6): |e|
        # dips at the crossing, a V rather than an envelope: undecided
        "slow crossing": (0.05 * np.exp(-t / 200) * np.cos(2 * np.pi * t / 120), 0.0,
                          "undecided"),
        "noisy offset": (0.03 + jitter, 0.0, "stalled"),
        "noise ripple": (ripple, noise, "converged"),
        "ripple at an offset": (0.3 + ripple, noise, "stalled"),
    }


@pytest.mark.parametrize("name", list(_signals()))
def test_accumulated_evidence_equals_the_record_s_and_names_the_status(name):
    """Reversals, swings, period and the envelope's fitted rate from the table's streaming
    accumulators equal those of the whole record (NumPy zigzag, SciPy linregress)."""
    e, noise, status = _signals()[name]
    k_tail = int(0.8 * e.size)
    acc = _run_table(e, k_tail, noise)
    ev = evidence(acc)
    want = evidence_from_errors(e, k_tail=k_tail, tol=TOL, noise=noise)
    assert ev["reversals"] == want["reversals"]
    for key in ("period", "amplitude", "swing_ratio", "rate", "rate_se", "change", "asymptote",
                "curvature_t"):
        if key == "curvature_t" and abs(want[key]) < 1e-3:
            # an envelope with no curvature (an exact exponential): its t is rounding over
            # rounding on both sides (+-1e-6, either sign); what decides is that both are far
            # below T_SIGNIFICANT (4), where a hump would count
            assert abs(float(ev[key])) < 1e-3, key
            continue
        assert float(ev[key]) == pytest.approx(want[key], rel=1e-9, abs=1e-15, nan_ok=True), key
    assert Status(int(metrics_from_summary(acc, 0.05)["status"])).label == status
    # the same record negated gives the same evidence
    assert evidence(_run_table(-e, k_tail, noise))["reversals"] == want["reversals"]


def test_the_confidence_table_is_student_s_one_sided_95_percent_quantile():
    from scipy.stats import t as student

    from fl_design.sim._status import NBLOCKS, T_CONFIDENT

    assert len(T_CONFIDENT) == NBLOCKS - 1 and math.isnan(T_CONFIDENT[0])
    for dof in range(1, NBLOCKS - 1):
        assert T_CONFIDENT[dof] == pytest.approx(student.ppf(0.95, dof), abs=1e-4), dof


@pytest.mark.parametrize("name, slow_tier", [("slow wobbly decay", True),
                                             ("slow crossing", False)])
def test_a_slow_decay_is_converging_only_when_confident_and_its_envelope_is_measured(
        name, slow_tier):
    """Both records have a fit t between -T_SIGNIFICANT and -T_CONFIDENT (so only the 95 %
    rule can call them converging); the one on one side of the reference is converging, the
    one crossing it with no reversal is not (its |e| dips at the crossing)."""
    from fl_design.sim._status import T_CONFIDENT, T_SIGNIFICANT

    e, noise, status = _signals()[name]
    acc = _run_table(e, int(0.8 * e.size), noise)
    ev = evidence(acc)
    t = float(ev["rate"] / ev["rate_se"])
    assert -T_SIGNIFICANT < t < -T_CONFIDENT[int(ev["fit_points"]) - 2]
    assert float(ev["change"]) < -0.05
    one_sided = acc["win_e_min"] > -float(ev["band"]) or acc["win_e_max"] < float(ev["band"])
    assert one_sided == slow_tier and ev["reversals"] < 2
    m = metrics_from_summary(acc, 0.05)
    assert Status(int(m["status"])).label == status
    if slow_tier:  # the fitted time constant and the time to the band it gives
        tau = 1 / float(m["decay_rate"])
        assert tau == pytest.approx(-1 / float(ev["rate"]) * 0.05, rel=1e-12)
        more = math.log(acc["tail_abs_e_max"] / float(ev["band"])) * tau
        assert float(m["time_to_tolerance"]) == pytest.approx(e.size * 0.05 + more, rel=1e-9)


def test_time_at_the_input_limits_is_counted_over_the_window():
    e = np.full(400, 0.3)
    u = np.where(np.arange(400) % 4 == 0, 2.5, 1.0)  # at the upper limit one sample in four
    acc = _run_table(e, 320, u=u, u_range=(-2.5, 2.5))
    assert float(evidence(acc)["saturated"]) == 0.25
    assert float(evidence(_run_table(e, 320, u=u))["saturated"]) == 0.0  # no limits: never


def test_classify_gives_every_status_from_accumulators():
    flat = 0.1 * np.ones(8)
    base = {"diverged": 0, "tol": TOL, "k_tail": 800, "k_mid": 900, "tail_abs_e_max": 0.1,
            "tail_e_max": 0.1, "tail_e_min": 0.09, "tail_e_sum": 19.0, "reversals": 0,
            "swing_sum": 0.0, "k_rev_first": -1, "k_rev_last": -1, "win_e_min": 0.0,
            "win_e_max": 0.1, **{f"blk_max{j}": flat[j] for j in range(8)},
            **{f"blk_min{j}": 0.09 for j in range(8)}}
    low = {f"blk_min{j}": 0.0 for j in range(8)}
    decay = low | {f"blk_max{j}": 0.1 * np.exp(-j / 3) for j in range(8)}
    grow = low | {f"blk_max{j}": 0.1 * np.exp(j / 3) for j in range(8)}
    swings = {"reversals": 6, "swing_sum": 1.0, "k_rev_first": 520, "k_rev_last": 960}
    cases = {
        "converged": {"tail_abs_e_max": 0.005, "tail_e_max": 0.005, "tail_e_min": 0.0,
                      "tail_e_sum": 0.5},
        "converging": decay,
        "oscillating": swings,
        "stalled": {},
        "undecided": grow,
        "diverged": {"diverged": 1, "reversals": 5},
        "solver_failed": {"solver_failed": 1},
    }
    for label, change in cases.items():
        assert Status(int(classify(base | change))) == Status.from_label(label), label
    assert Status.UNDECIDED.bounded and not Status.UNDECIDED.convergent
    assert Status.STALLED.bounded and not Status.STALLED.convergent
    # codes of the other statuses keep their meaning
    assert [int(Status.from_label(s)) for s in
            ("solver_failed", "diverged", "oscillating", "converging", "converged", "undecided",
             "stalled")] == list(range(-2, 5))


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


def test_the_kernels_measure_the_recorded_runs_evidence(tmp_path):
    """Interpreter and compiled scalar kernel on a pendulum limit cycle, the lanes kernel on
    the TRMS: the accumulated evidence equals that of the recorded error, and the status that
    of :func:`tests.oracles.status_from_trajectories`."""
    pend = fl.plants.pendulum()
    cyc = fl.presets.pendulum_design(eps=0.2, u_limits=(-1.2, 1.2))
    for kernel in (fl.Kernel(compiled=False), fl.Kernel(cache_dir=tmp_path)):
        resp = fl.simulate(pend, cyc, fl.Scenario(0.05, 30.0), kernel=kernel)
        want = evidence_from_errors(resp.y - resp.r, k_tail=resp.k_tail, tol=resp.tol)
        assert resp.metrics["reversals"] == want["reversals"] >= 2
        assert resp.metrics["oscillation_period"] == pytest.approx(want["period"] * resp.T)
        assert resp.status == "oscillating" == status_from_trajectories(resp)
    plant, design = fl.plants.trms_yaw(), fl.presets.paper_design()
    smap = fl.sweep(plant, design, fl.Scenario(0.3, 30.0), eps=[0.05, 0.5], gamma=[3e-4, 3e-2],
                    progress=False)
    for i, j in ((0, 0), (1, 1)):
        resp = fl.simulate(plant, design.replace(eps=smap.eps[i], gamma=smap.gamma[j]),
                           fl.Scenario(0.3, 30.0))
        want = evidence_from_errors(resp.y - resp.r, k_tail=resp.k_tail, tol=resp.tol)
        assert smap.labels[i, j] == resp.status == status_from_trajectories(resp)
        assert smap.metrics["reversals"][i, j] == want["reversals"]
    assert smap.labels[1, 1] == "oscillating"
