"""The tuner's model against the library computed independently: the page shows what
``fl.simulate`` and ``fl.analysis.noise_gain`` give for the same numbers."""

from __future__ import annotations

import math

import numpy as np
import pytest

import fl_design as fl
from fl_design.errors import ParameterError
from fl_design.ui._loops import LoopCache, structure_key
from fl_design.ui._model import MAX_POINTS, decimate


@pytest.mark.parametrize("changes", [
    {},
    {"eps": 0.1, "gamma": 1e-3},
    {"gamma": 3e-3, "reference": 0.2, "noise_std": 1e-3},
    {"eps": 0.02, "duration": 5.0},
])
def test_cached_loop_gives_simulate_bit_for_bit(trms_tuner, changes):
    """One compiled loop per structure, eps/gamma through the parameter vector: the same
    Response as fl.simulate (which builds its loop afresh), sample for sample."""
    v = trms_tuner.check(changes | {"duration": changes.get("duration", 8.0)})
    design, scenario = trms_tuner.design_for(v), trms_tuner.scenario_for(v)
    got = trms_tuner.loops.simulate(trms_tuner.plant, design, scenario,
                                    classifier=trms_tuner.classifier)
    ref = fl.simulate(trms_tuner.plant, design, scenario, classifier=trms_tuner.classifier)
    for name in ("y", "u", "sigma", "sigmahat", "r"):
        np.testing.assert_array_equal(getattr(got, name), getattr(ref, name))
    assert got.status == ref.status
    assert got.metrics["overshoot"] == ref.metrics["overshoot"]


@pytest.mark.parametrize("changes", [{}, {"eps": 0.1, "gamma": 1e-3}, {"reference": 0.5},
                                     {"gamma": 3e-3, "eps": 0.02}])
def test_cached_noise_gain_equals_the_library(trms_tuner, changes):
    v = trms_tuner.check(changes)
    design = trms_tuner.design_for(v)
    got = trms_tuner.loops.noise_gain(trms_tuner.plant, design, r=v["reference"])
    want = fl.analysis.noise_gain(trms_tuner.plant, design, r=v["reference"])
    assert got == pytest.approx(want, rel=1e-12)


def test_structure_key_separates_what_is_compiled():
    d = fl.presets.paper_design()
    same = d.replace(eps=0.2, gamma=1e-3)
    assert structure_key(d, 1) == structure_key(same, 1)
    gains = fl.Design(estimator=d.estimator, controller=d.controller.replace(gains=(3.0, 4.0)))
    assert structure_key(d, 1) != structure_key(gains, 1)
    sampled = fl.Design(estimator=d.estimator.replace(T=2e-3), controller=d.controller)
    assert structure_key(d, 1) != structure_key(sampled, 1)
    assert structure_key(d, 1) != structure_key(d, 2)


def test_loop_cache_keeps_a_bounded_number_of_loops(pendulum):
    cache = LoopCache(size=2)
    base = fl.presets.pendulum_design()
    for k in (1.0, 2.0, 3.0):
        d = fl.Design(estimator=base.estimator, controller=base.controller.replace(
            gains=(k, 4.0)))
        cache.simulate(pendulum, d, fl.Scenario(0.1, 0.5))
    assert len(cache._loops) == 2


def test_a_new_structure_runs_interpreted_while_its_kernel_compiles_aside(pendulum):
    base = fl.presets.pendulum_design()
    design = fl.Design(estimator=base.estimator, controller=base.controller.replace(
        gains=(2.345, 4.0)))
    scenario = fl.Scenario(0.1, 1.0)
    cache = LoopCache(compile_aside=True)
    try:
        first = cache.simulate(pendulum, design, scenario)
        assert cache.last_compiled is False
        ref = fl.simulate(pendulum, design, scenario)
        np.testing.assert_allclose(first.y, ref.y, rtol=1e-12, atol=1e-15)
        assert first.status == ref.status
        proc = next(iter(cache._compiling.values()))
        proc.join(timeout=120)
        assert proc.exitcode == 0
        second = cache.simulate(pendulum, design.replace(gamma=2e-2), scenario)
        assert cache.last_compiled is True
        np.testing.assert_array_equal(
            second.y, fl.simulate(pendulum, design.replace(gamma=2e-2), scenario).y)
    finally:
        cache.close()
    assert not cache._compiling


def test_one_compilation_at_a_time_the_latest(pendulum):
    base = fl.presets.pendulum_design()
    cache = LoopCache(compile_aside=True)
    try:
        for k in (2.11, 2.12, 2.13):
            d = fl.Design(estimator=base.estimator, controller=base.controller.replace(
                gains=(k, 4.0)))
            cache.simulate(pendulum, d, fl.Scenario(0.1, 0.2))
            assert cache.last_compiled is False
        assert len(cache._compiling) == 1 and len(cache._loops) == 1
    finally:
        cache.close()


def test_redraw_shows_the_library_verdict_and_noise_gain(trms_tuner):
    view = trms_tuner.redraw({"gamma": 3e-3, "duration": 20.0})
    v = view["values"]
    ref = fl.simulate(trms_tuner.plant, trms_tuner.design_for(v), trms_tuner.scenario_for(v),
                      classifier=trms_tuner.classifier)
    assert view["verdict"]["status"] == ref.status
    assert view["verdict"]["overshoot"] == pytest.approx(ref.overshoot, rel=0, abs=0)
    assert view["verdict"]["text"] == ref.verdict()
    settle = view["verdict"]["settling_time"]
    assert (settle is None and math.isnan(ref.settling_time)) or settle == ref.settling_time
    g = fl.analysis.noise_gain(trms_tuner.plant, trms_tuner.design_for(v), r=0.3)
    assert view["noise_gain"]["value"] == pytest.approx(g, rel=1e-12)
    # the traces: decimated, but the extremes of y are the run's own
    assert len(view["t"]) <= 2 * MAX_POINTS
    assert max(view["y"]) == pytest.approx(float(np.nanmax(ref.y)), rel=0, abs=0)
    assert min(view["u"]) == pytest.approx(float(np.nanmin(ref.u)), rel=0, abs=0)


def test_gamma_moves_the_verdict_as_the_issue_asks(trms_tuner):
    """Moving gamma from 3e-4 to 3e-3 changes the response and the verdict (20 s runs)."""
    low = trms_tuner.redraw({"gamma": 3e-4})
    high = trms_tuner.redraw({"gamma": 3e-3})
    assert low["verdict"]["overshoot"] != high["verdict"]["overshoot"]
    assert low["y"] != high["y"]


def test_decimate_keeps_each_bucket_extremes_against_numpy():
    rng = np.random.default_rng(3)
    t = np.arange(50_000) * 1e-3
    y = np.cumsum(rng.standard_normal(t.size))
    y[12_345] = 1e3  # a spike must survive
    tt, cols = decimate(t, {"y": y}, max_points=400)
    assert cols["y"].max() == y.max() and cols["y"].min() == y.min()
    assert np.all(np.diff(tt) > 0) and tt[0] == t[0] and tt[-1] == t[-1]
    assert tt.size <= 400
    buckets = (400 - 2) // 2  # one column: two points a bucket, plus the first and last
    size = math.ceil(t.size / buckets)
    for b in range(buckets):  # every bucket's min and max are kept
        block = y[b * size:(b + 1) * size]
        assert block.max() in cols["y"] and block.min() in cols["y"]


def test_decimate_of_several_columns_keeps_at_most_max_points():
    rng = np.random.default_rng(5)
    t = np.arange(20_000) * 1e-3
    cols = {k: np.cumsum(rng.standard_normal(t.size)) for k in "abcde"}  # extremes apart
    tt, kept = decimate(t, cols, max_points=300)
    assert tt.size <= 300
    for k, x in cols.items():  # same indices for every column, extremes kept
        assert kept[k].size == tt.size
        assert kept[k].max() == x.max() and kept[k].min() == x.min()
        assert np.array_equal(kept[k], x[np.searchsorted(t, tt)])


def test_decimate_with_nan_after_a_divergence():
    t = np.arange(10_000.0)
    y = np.sin(t / 100)
    y[6000:] = np.nan
    tt, cols = decimate(t, {"y": y}, max_points=200)
    assert np.nanmax(cols["y"]) == pytest.approx(np.nanmax(y))
    assert tt.size <= 200


@pytest.mark.parametrize("bad, words", [
    ({"eps": "x"}, "eps must be a finite number, got 'x'"),
    ({"gamma": float("nan")}, "gamma must be a finite number"),
    ({"gains": [1.0]}, "gains must be a list of 2 numbers"),
    ({"duration": 0.0}, "duration must be in (0, 600] s"),
    ({"noise_std": -1.0}, "noise_std must be >= 0"),
    ({"path": "/etc/passwd"}, "unknown controls ['path']"),
    ({"u_min": None, "u_max": 1.0}, "give both u_min and u_max"),
    ({"T": True}, "T must be a finite number"),
])
def test_bad_controls_are_refused_by_name(trms_tuner, bad, words):
    with pytest.raises(ParameterError) as err:
        trms_tuner.check(bad)
    assert words in str(err.value)


def test_a_value_the_library_refuses_is_a_message(trms_tuner):
    view = trms_tuner.redraw({"gamma": -1e-3})  # the sign of b is positive
    assert "error" in view and "gamma" in view["error"]


def test_controls_cover_the_issue_list(trms_tuner):
    names = [c["name"] for c in trms_tuner.controls()]
    assert names[:2] == ["gamma", "eps"]
    assert {"k1", "k2", "T", "reference", "noise_std", "u_min", "u_max", "duration"} <= set(names)
    for c in trms_tuner.controls():
        zero_end = c["scale"] == "log0" and c["value"] == 0  # the left end: no noise
        assert zero_end or c["min"] <= c["value"] <= c["max"], c
