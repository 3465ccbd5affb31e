"""Disturbances at the plant's input and at the measured output, in every integrator and kernel.

Independent checks: the ``cvodes`` reference integrates the same disturbed loop with an adaptive
solver; before the disturbance a run equals the undisturbed one bit for bit; a constant output
disturbance ``d`` moves the true output to ``r - d`` (the loop regulates what it measures, a
closed form); the input disturbance is the same as shifting the plant's input (a plant whose
input is offset by the same step, simulated without disturbance).
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
import sympy as sp

import fl_design as fl
from fl_design.errors import DimensionError, ParameterError
from fl_design.sim._disturbance import disturbance_metrics


@pytest.fixture(scope="module")
def runs():
    p, d = fl.plants.pendulum(), fl.presets.pendulum_design()
    dist = fl.Disturbance(input=fl.Step(at=10.0, size=0.5))
    sc = fl.Scenario(0.1, 20.0, disturbance=dist)
    return {"plant": p, "design": d, "scenario": sc,
            "rk4": fl.simulate(p, d, sc),
            "cvodes": fl.simulate(p, d, sc, integrator=fl.Cvodes()),
            "clean": fl.simulate(p, d, fl.Scenario(0.1, 20.0))}


def test_a_step_input_disturbance_is_rejected_and_measured(runs):
    resp = runs["rk4"]
    assert resp.status == "converged"
    m = resp.disturbance
    assert m["disturbance_at"] == 10.0
    assert m["disturbance_peak"] > resp.tol  # it did push the output out of the band
    assert 0.0 < m["recovery_time"] < 10.0
    assert abs(resp.y[-1] - 0.1) <= resp.tol


def test_the_disturbed_loop_agrees_with_cvodes(runs):
    a, b = runs["rk4"], runs["cvodes"]
    assert b.status == a.status
    np.testing.assert_allclose(a.y, b.y, atol=1e-7)
    assert abs(a.disturbance["disturbance_peak"] - b.disturbance["disturbance_peak"]) < 1e-7


def test_before_the_disturbance_nothing_changes(runs):
    k = round(10.0 / runs["design"].T)
    np.testing.assert_array_equal(runs["rk4"].y[:k + 1], runs["clean"].y[:k + 1])
    assert not np.array_equal(runs["rk4"].y[k + 2:], runs["clean"].y[k + 2:])
    assert runs["clean"].disturbance is None


def test_an_input_disturbance_equals_an_offset_plant_input():
    """A plant with ``u + d(t)`` written into its equations, undisturbed, is the same loop."""
    x1, x2, u = sp.symbols("x1 x2 u")
    c = 0.5

    def plant(offset):
        return fl.Plant.from_ode([x1, x2], u, [x2, -sp.sin(x1) - c * x2 + u + offset], x1,
                                 name="pend", region={x1: (-3, 3), x2: (-50, 50)})

    d = fl.Design(estimator=fl.EHGO(rho=2, eps=0.02, T=1e-3),  # the same start u in both
                  controller=fl.DynamicController((2, 4), 1e-2, u0=0.0))
    const = fl.Scenario(0.2, 4.0, disturbance=fl.Disturbance(input=fl.Step(0.0, 0.3)))
    a = fl.simulate(plant(0), d, const)
    b = fl.simulate(plant(0.3), d, fl.Scenario(0.2, 4.0))
    np.testing.assert_allclose(a.y, b.y, rtol=0, atol=1e-12)


def test_a_constant_output_disturbance_moves_y_to_r_minus_d():
    p, d = fl.plants.pendulum(), fl.presets.pendulum_design()
    sc = fl.Scenario(0.1, 30.0, disturbance=fl.Disturbance(output=fl.Step(5.0, 0.02)))
    resp = fl.simulate(p, d, sc)
    assert abs(resp.y[-1] - (0.1 - 0.02)) < 1e-4  # the loop holds the *measurement* at r
    assert abs(resp.ym[-1] - 0.1) < 1e-4


@pytest.mark.parametrize("isa", ["interpreted", "scalar", "lanes"])
def test_sweeps_see_the_disturbance_in_every_kernel(tmp_path, isa):
    p, d = fl.plants.pendulum(), fl.presets.pendulum_design()
    dist = fl.Disturbance(input=fl.Sine(amplitude=0.3, frequency=0.5, at=1.0),
                          output=np.linspace(0, 1e-3, 3000))
    sc = fl.Scenario(0.1, 3.0, disturbance=dist)
    kw = {"eps": [0.005, 0.02, 0.2], "gamma": [3e-3, 1e-2, 0.3], "progress": False}
    kernel = {"interpreted": fl.Kernel(compiled=False),
              "scalar": fl.Kernel(cache_dir=tmp_path, isa="scalar"),
              "lanes": fl.Kernel(cache_dir=tmp_path, vector_math=False)}[isa]
    got = fl.sweep(p, d, sc, kernel=kernel, **kw)
    ref = fl.sweep(p, d, sc, kernel=fl.Kernel(compiled=False), **kw)
    clean = fl.sweep(p, d, fl.Scenario(0.1, 3.0), kernel=fl.Kernel(compiled=False), **kw)
    np.testing.assert_array_equal(got.status, ref.status)
    np.testing.assert_allclose(got.metrics["iae"], ref.metrics["iae"], rtol=1e-12)
    assert not np.allclose(ref.metrics["iae"], clean.metrics["iae"], equal_nan=True)


def test_signals_of_every_kind_are_sampled():
    T, N = 0.5, 5
    t = np.arange(N) * T
    cases = {
        "step": (fl.Step(at=1.0, size=2.0), [0, 0, 2, 2, 2]),
        "sine": (fl.Sine(amplitude=1.0, frequency=0.5), np.sin(np.pi * t)),
        "array": (np.arange(7.0), np.arange(5.0)),
        "callable": (lambda tt: tt ** 2, t ** 2),
    }
    tt = ca.SX.sym("t")
    cases["casadi"] = (ca.Function("f", [tt], [3 * tt]), 3 * t)
    for name, (signal, expected) in cases.items():
        d_in, d_out = fl.Disturbance(input=signal).sampled(T, N)
        np.testing.assert_allclose(d_in, expected, atol=1e-15, err_msg=name)
        assert not d_out.any()


@pytest.mark.parametrize("bad, error, words", [
    ({"input": "0.5"}, ParameterError, "fl.Step, fl.Sine"),
    ({"output": [1.0, float("nan")]}, ParameterError, "non-finite"),
    ({"input": np.ones((2, 2))}, DimensionError, "one value per sample"),
])
def test_bad_disturbances_are_refused_when_made(bad, error, words):
    with pytest.raises(error, match=words):
        fl.Disturbance(**bad)


def test_bad_signals_and_scenarios_are_refused():
    with pytest.raises(ParameterError, match="Sine.frequency"):
        fl.Sine(amplitude=1.0, frequency=0.0)
    with pytest.raises(ParameterError, match="Step.at"):
        fl.Step(at=-1.0, size=1.0)
    with pytest.raises(ParameterError, match="fl.Disturbance"):
        fl.Scenario(0.1, 1.0, disturbance=fl.Step(0.0, 1.0))
    with pytest.raises(DimensionError, match="at least 1000"):
        fl.simulate(fl.plants.pendulum(), fl.presets.pendulum_design(),
                    fl.Scenario(0.1, 1.0, disturbance=fl.Disturbance(input=np.zeros(10))))
    with pytest.raises(ParameterError, match="failed on the array"):
        fl.Disturbance(output=lambda t: float(t)).sampled(0.1, 3)


def test_recovery_metrics_against_hand_computed_values():
    t = np.arange(8) * 0.5
    y = np.array([0, 0, 0, 0.4, 0.3, 0.05, 0.0, 0.0])
    m = disturbance_metrics(t, y, np.zeros(8), start=1.0, tol=0.1)
    assert (m["disturbance_peak"], m["recovery_time"]) == (0.4, 1.5)
    never = disturbance_metrics(t, np.r_[y[:-1], 0.5], np.zeros(8), start=1.0, tol=0.1)
    assert never["recovery_time"] == float("inf")
