"""The adaptive map: points ``undecided`` at the map's duration are re-run longer.

The pendulum bench design (input limits +-2) at eps = 0.5, gamma = 1e-3 is undecided at its
adaptive 17.55 s (a swing slower than the window) and oscillating at 1.5 times that; its
neighbour eps = 0.144 is decided at once.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import fl_design as fl
from fl_design.errors import ParameterError
from fl_design.sim import StabilityMap, Status
from fl_design.sim._adaptive import EXTEND, MAX_EXTENSION
from fl_design.sim._sweep import sweep_points

EPS, GAMMA = [0.14426999, 0.5], [1e-3]
REF = 0.1


@pytest.fixture(scope="module")
def design():
    return fl.presets.pendulum_design(u_limits=(-2.0, 2.0))


@pytest.fixture(scope="module")
def maps(pendulum, design):
    adaptive = fl.sweep(pendulum, design, fl.Scenario(REF), eps=EPS, gamma=GAMMA,
                        progress=False)
    plain = fl.sweep(pendulum, design, fl.Scenario(REF), eps=EPS, gamma=GAMMA, extend=1,
                     progress=False)
    return adaptive, plain


def test_undecided_point_is_rerun_longer_and_equals_its_own_simulation(pendulum, design,
                                                                        maps):
    adaptive, plain = maps
    D = adaptive.duration
    assert plain.labels.tolist() == [["oscillating"], ["undecided"]]
    assert np.array_equal(plain.durations, [[D], [D]])
    # only the undecided point is re-run, EXTEND times longer (decided there: no second one)
    assert adaptive.extended.tolist() == [[False], [True]]
    assert adaptive.durations[1, 0] == pytest.approx(EXTEND * D, abs=1e-3)
    assert adaptive.max_duration == pytest.approx(MAX_EXTENSION * D)
    assert adaptive.status[0, 0] == plain.status[0, 0]
    for name, value in plain.metrics.items():  # the point not re-run keeps its run's numbers
        np.testing.assert_array_equal(adaptive.metrics[name][0], value[0])
    # the re-run point is what an independent single run of that length says, metric by metric
    long = float(adaptive.durations[1, 0])
    resp = fl.simulate(pendulum, design.replace(eps=EPS[1], gamma=GAMMA[0]),
                       fl.Scenario(REF, long))
    assert resp.status == adaptive.labels[1, 0] == "oscillating"
    for name, value in resp.metrics.items():
        if name != "status":
            np.testing.assert_allclose(adaptive.metrics[name][1, 0], value, rtol=1e-9,
                                       atol=1e-12, err_msg=name)


def test_map_says_what_was_rerun(maps):
    adaptive, plain = maps
    text = adaptive.extension_text()
    assert text == (f"1 run undecided at {adaptive.duration:g} s re-run at "
                    f"{adaptive.durations[1, 0]:g} s: now 1 oscillating")
    assert plain.extension_text() == "" and math.isnan(plain.max_duration)
    d = json.loads(json.dumps(adaptive.to_dict()))
    assert d["durations"] == adaptive.durations.tolist() and d["extension"] == text
    from fl_design.app._report_map import map_counts

    assert map_counts(adaptive).endswith("; " + text)
    assert "re-runs" in adaptive._repr_html_()


def test_given_duration_is_kept_unless_extend_is_given(pendulum, design, maps):
    adaptive, _ = maps
    D = adaptive.duration
    given = fl.sweep(pendulum, design, fl.Scenario(REF, D), eps=EPS, gamma=GAMMA,
                     progress=False)
    assert given.labels[1, 0] == "undecided" and not given.extended.any()
    asked = fl.sweep(pendulum, design, fl.Scenario(REF, D), eps=EPS, gamma=GAMMA, extend=1.25,
                     max_duration=4 * D, progress=False)
    # x1.25 each time while undecided, up to the cap: 1.25 D was not enough, 1.5625 D is
    once = fl.simulate(pendulum, design.replace(eps=EPS[1], gamma=GAMMA[0]),
                       fl.Scenario(REF, 1.25 * D))
    assert once.status == "undecided"
    assert asked.durations[1, 0] == pytest.approx(1.25 ** 2 * D, abs=1e-3)
    assert asked.labels[1, 0] == "oscillating" and asked.max_duration == pytest.approx(4 * D)
    assert not asked.extended[0, 0]
    capped_only = fl.sweep(pendulum, design, fl.Scenario(REF, D), eps=EPS, gamma=GAMMA,
                           max_duration=4 * D, progress=False)  # a cap asks for re-runs (x2)
    assert capped_only.durations[1, 0] == pytest.approx(EXTEND * D, abs=1e-3)
    capped = fl.sweep(pendulum, design, fl.Scenario(REF, D), eps=EPS, gamma=GAMMA, extend=2,
                      max_duration=1.2 * D, progress=False)  # the cap stops it undecided
    assert capped.labels[1, 0] == "undecided"
    assert capped.durations[1, 0] == pytest.approx(1.2 * D, abs=1e-3)
    assert capped.extension_text().endswith(
        f"now 1 still undecided (at the longest re-run, {1.2 * D:g} s: a longer max_duration "
        "decides)")


def test_sweep_points_runs_only_the_mask(pendulum, design, maps):
    adaptive, _ = maps
    codes, metrics = sweep_points(pendulum, design, fl.Scenario(REF, adaptive.durations[1, 0]),
                                  eps=EPS, gamma=GAMMA, points=[[False], [True]])
    assert codes.tolist() == [int(Status.OSCILLATING)]
    assert metrics["overshoot"][0] == adaptive.metrics["overshoot"][1, 0]
    with pytest.raises(ParameterError, match=r"points must be an \(eps, gamma\) mask"):
        sweep_points(pendulum, design, fl.Scenario(REF, 1.0), eps=EPS, gamma=GAMMA,
                     points=[True, False])


@pytest.mark.parametrize("kw, match", [
    ({"extend": 0.5}, r"extend must be >= 1.*got 0\.5"),
    ({"extend": float("nan")}, "extend"),
    ({"max_duration": -1.0}, "max_duration"),
    ({"max_duration": 0.5}, r"max_duration=0\.5 s must exceed the map's duration 1 s"),
    ({"extend": 1, "max_duration": 4.0}, "extend=1 makes none"),
    ({"extend": 4, "params": {"l": (0.9, 1.1)}}, "robust map"),
])
def test_bad_extension_options(pendulum, design, kw, match):
    with pytest.raises(ParameterError, match=match):
        fl.sweep(pendulum, design, fl.Scenario(REF, 1.0), eps=EPS, gamma=GAMMA,
                 progress=False, **kw)


def test_durations_must_match_the_grid():
    with pytest.raises(ParameterError, match=r"durations must have the status' shape \(1, 2\)"):
        StabilityMap(np.array([0.1]), np.array([1.0, 2.0]), np.array([[2, 1]]), {}, 1e-3, 1.0,
                     0.1, durations=np.array([1.0, 1.0]))


@pytest.mark.parametrize("case", ["pendulum, noise, quantization, input step", "trms demo corner"])
def test_continued_runs_equal_runs_from_the_start_to_the_last_bit(case, pendulum, design):
    """A re-run continues its shorter run (state and whole-run accumulators kept, windowed ones
    restarted): every accumulator equals a run of the longer length from the first sample."""
    from fl_design.sim._adaptive import continue_runs
    from fl_design.sim._grid import parameter_columns, run_grid
    from fl_design.sim._run import prepare_run

    if case.startswith("pendulum"):
        plant, d, D = pendulum, design, 17.549
        scenario = fl.Scenario(REF, noise=fl.Noise(std=1e-3, seed=3), quantization=1e-4,
                               disturbance=fl.Disturbance(input=fl.Step(at=2.0, size=0.3)))
        P = parameter_columns(d, [0.02, 0.5], [1e-3, 0.1])
    else:
        plant, d, D = fl.plants.trms_yaw(), fl.presets.paper_design(), 300.0
        scenario = fl.Scenario(0.3)
        P = parameter_columns(d, [1.0], [3e-5, 7.5e-5])
    short = prepare_run(plant, d, scenario.replace(duration=D))
    long = prepare_run(plant, d, scenario.replace(duration=2 * D))
    first = run_grid(short, P, progress=False)
    continued = continue_runs(short, long, first)
    fresh = run_grid(long, P, progress=False)
    assert continued is not None
    np.testing.assert_array_equal(continued, fresh)
    # the windowed accumulators were restarted, not carried: the short run's differ
    lay = long.loop.layout
    assert not np.array_equal(first[lay["blk_max0"]], fresh[lay["blk_max0"]])
    # a longer run whose window starts before the short run's end cannot continue it
    assert continue_runs(short, prepare_run(plant, d, scenario.replace(duration=1.5 * D)),
                         first) is None


def test_executor_map_equals_in_process_map(pendulum, design, maps):
    """With an executor the re-runs start from the first sample: the same map."""
    from concurrent.futures import ThreadPoolExecutor

    adaptive, _ = maps
    with ThreadPoolExecutor(2) as pool:
        other = fl.sweep(pendulum, design, fl.Scenario(REF), eps=EPS, gamma=GAMMA,
                         executor=pool, progress=False)
    np.testing.assert_array_equal(other.status, adaptive.status)
    np.testing.assert_array_equal(other.durations, adaptive.durations)
    for name, value in adaptive.metrics.items():
        np.testing.assert_array_equal(other.metrics[name], value, err_msg=name)


def test_demo_map_slow_corner_is_decided_without_stripes():
    """The demo map's slowest gains (examples/trms.toml [sweep]: gamma from 3e-5): at the map's
    300 s their swings outlast the window (undecided, and eps* brackets 'undecided at' that
    alternated between columns); re-run at 600 s they are converging, and eps* is '> 1' in
    every column; at 4 times that (2400 s) they are converged or converging (10 times:
    verify/predictive_check.py --full-range)."""
    plant, design = fl.plants.trms_yaw(), fl.presets.paper_design()
    eps, gamma = [0.005, 0.7024, 1.0], np.geomspace(3e-5, 1.2e-4, 4)
    kw = {"eps": eps, "gamma": gamma, "progress": False}
    plain = fl.sweep(plant, design, fl.Scenario(0.3), extend=1, **kw)
    smap = fl.sweep(plant, design, fl.Scenario(0.3), **kw)
    assert smap.duration == 300.0
    assert np.sum(plain.labels == "undecided") >= 6, plain.labels
    assert not np.any(smap.labels == "undecided")
    assert np.all(np.isin(smap.labels, ["converging", "converged"]))
    assert np.array_equal(smap.extended, plain.labels == "undecided")
    assert np.all(smap.durations[smap.extended] == 600.0)
    assert [str(smap.eps_star(g)) for g in gamma] == ["> 1"] * 4
    codes, _ = sweep_points(plant, design, fl.Scenario(0.3, 2400.0), eps=eps, gamma=gamma,
                            points=smap.extended)  # the re-run ones at 4 times their length
    assert set(codes.tolist()) <= {int(Status.CONVERGING), int(Status.CONVERGED)}


@pytest.mark.parametrize("asked", [None, ["overshoot"]])
def test_reruns_ask_for_the_callers_metrics(asked, pendulum, design, maps, monkeypatch):
    """The re-runs of undecided points are prepared with the metrics the caller asked for (the
    same accumulators, so the same compiled kernel as the map's runs), not with the names of
    the map's metrics; the map's status and asked metrics are those of the full map."""
    import fl_design.sim._sweep as sweep_module

    seen, prepare = [], sweep_module.prepare_run

    def spy(*args, **kwargs):
        seen.append(kwargs.get("metrics"))
        return prepare(*args, **kwargs)

    monkeypatch.setattr(sweep_module, "prepare_run", spy)
    smap = fl.sweep(pendulum, design, fl.Scenario(REF), eps=EPS, gamma=GAMMA, metrics=asked,
                    progress=False)
    adaptive, _ = maps
    assert len(seen) == 2 and seen == [asked, asked]  # the map's runs, then one re-run
    np.testing.assert_array_equal(smap.status, adaptive.status)
    np.testing.assert_array_equal(smap.durations, adaptive.durations)
    for name in asked or adaptive.metrics:
        np.testing.assert_array_equal(smap.metrics[name], adaptive.metrics[name], err_msg=name)
