"""Strict inputs, bounded work and short messages (issue 12): each bad input, its clear error."""

from __future__ import annotations

import math

import numpy as np
import pytest

import fl_design as fl
from fl_design import _validate as V
from fl_design.analysis import _linearization
from fl_design.errors import DimensionError, ParameterError, ResourceLimitError

CTRL = fl.DynamicController((2, 4), 1e-2)


# --- silent coercion is gone -------------------------------------------------------------------
@pytest.mark.parametrize("make, match", [
    (lambda: fl.plants.trms_yaw(motor_lag="no"), "motor_lag must be True or False, got 'no'"),
    (lambda: fl.plants.trms_yaw(motor_lag=1), "motor_lag must be True or False, got 1"),
    (lambda: fl.plants.trms_yaw(T21="1"), r"T21 must be a real number, got '1' \(a str"),
    (lambda: fl.plants.pendulum(g="9.81"), "g must be a real number, got '9.81'"),
    (lambda: fl.plants.flexible_joint(B=None), "B must be a real number, got None"),
    (lambda: fl.plants.pendulum(input_range=("-1", 1)), r"input_range\[0\] must be a real"),
    (lambda: fl.EHGO(2, "0.05", 1e-3), "eps must be a real number, got '0.05'"),
    (lambda: fl.EHGO(2, 0.05, 1e-3, coeffs=("6", 11, 6)), r"coeffs .* entry 0 is '6'"),
    (lambda: fl.EHGO(2, 0.05, 1e-3, coeffs=(True, 11, 6)), "entry 0 is True"),
    (lambda: fl.DynamicController((2, 4), "1e-2"), "gamma must be a real number, got '1e-2'"),
    (lambda: fl.DynamicController("24", 1e-2), "gains"),
    (lambda: fl.LeastSquaresEstimator(2, 1e-3, window=9.0), "window must be an integer"),
    (lambda: fl.Scenario(0.3, "1.0"), "duration must be a real number, got '1.0'"),
    (lambda: fl.Kernel(threads=-5), "threads must be >= 1, got -5"),
    (lambda: fl.Kernel(threads=2.5), "threads must be an integer, got 2.5"),
])
def test_strings_bools_and_non_integers_are_refused(make, match):
    with pytest.raises(ParameterError, match=match):
        make()


def test_numpy_scalars_remain_welcome():
    est = fl.EHGO(np.int64(2), np.float32(0.05), np.float64(1e-3), coeffs=np.array([3, 3, 1]))
    assert (est.rho, est.eps, est.alphas) == (2, np.float32(0.05), (3.0, 3.0, 1.0))
    assert fl.plants.trms_yaw(motor_lag=np.bool_(True)).name == "trms_yaw_motor_lag"
    assert V.real_scalar("x", np.asarray(2.5)) == 2.5


@pytest.mark.parametrize("bad", ["0.5", b"1", True, np.bool_(False), None, 1 + 2j, [1.0], object()])
def test_real_scalar_refuses_everything_but_real_numbers(bad):
    with pytest.raises(ParameterError, match="x must be a real number"):
        V.real_scalar("x", bad)


def test_instance_names_the_expected_and_the_given_type():
    with pytest.raises(ParameterError, match=r"plant must be an fl.Plant .*, got str 'pendulum'"):
        fl.linearized_eps_star("pendulum", fl.presets.paper_design())
    with pytest.raises(ParameterError, match=r"design must be an fl.Design.*, got EHGO"):
        fl.sampled_linearization(fl.plants.pendulum(), fl.EHGO(2, 0.05, 1e-3))


# --- short messages ------------------------------------------------------------------------------
def test_a_nan_in_a_long_vector_names_its_index_in_a_short_message():
    ref = np.zeros(10**6)
    ref[123_456] = np.nan
    ref[200_000] = np.inf
    with pytest.raises(ParameterError) as info:
        V.real_vector("reference", ref)
    msg = str(info.value)
    assert msg == ("reference must be finite: entry 123456 is nan "
                   "(2 non-finite of 1000000 entries)")


def test_a_non_number_in_a_long_sequence_is_named_briefly():
    seq = [0.0] * 10**5 + ["x"]
    with pytest.raises(ParameterError) as info:
        V.real_vector("reference", seq)
    assert "entry 100000 is 'x'" in str(info.value) and len(str(info.value)) < 200
    with pytest.raises(ParameterError, match="got the string '1, 2'"):
        V.real_vector("gains", "1, 2")
    with pytest.raises(DimensionError, match="must have length 3, got 2"):
        V.real_vector("k", np.array([1, 2]), length=3)


# --- bounded work --------------------------------------------------------------------------------
def test_a_huge_least_squares_window_is_refused_up_front(monkeypatch):
    with pytest.raises(ResourceLimitError, match=r"window=1000000 exceeds the limit of 5000 .*"
                       r"1\.49e\+04 GiB.*FL_DESIGN_MAX_WINDOW=1000000"):
        fl.LeastSquaresEstimator(2, 1e-3, window=10**6)
    monkeypatch.setenv("FL_DESIGN_MAX_WINDOW", "20")
    assert fl.LeastSquaresEstimator(2, 1e-3, window=20).window == 20
    with pytest.raises(ResourceLimitError, match="limit of 20 samples"):
        fl.LeastSquaresEstimator(2, 1e-3, window=21)
    monkeypatch.setenv("FL_DESIGN_MAX_WINDOW", "many")
    with pytest.raises(ParameterError, match=r"\$FL_DESIGN_MAX_WINDOW='many' must be a positive number"):
        fl.LeastSquaresEstimator(2, 1e-3, window=21)


def test_a_high_taylor_order_is_refused_unless_asked_for():
    with pytest.raises(ResourceLimitError, match="order=25 exceeds max_order=8.*max_order=25"):
        fl.taylor_discretization(fl.plants.pendulum(), 25)
    with pytest.raises(ResourceLimitError, match="order=41 exceeds max_order=40"):
        fl.taylor_discretization(2, 41)
    assert fl.taylor_discretization(1, 3, max_order=3).order == 3
    with pytest.raises(ResourceLimitError, match="order=4 exceeds max_order=3"):
        fl.taylor_discretization(1, 4, max_order=3)
    with pytest.raises(ParameterError, match="max_order must be an integer"):
        fl.taylor_discretization(1, 4, max_order="9")


def test_linearized_eps_star_refuses_an_unresolvable_rtol_and_ends_at_the_float_limit(monkeypatch):
    plant, design = fl.plants.pendulum(), fl.Design(estimator=fl.EHGO(rho=2, eps=0.02, T=1e-3),
                                                    controller=CTRL)
    with pytest.raises(ParameterError, match=r"rtol=1e-17 is below what float64 can resolve"):
        fl.linearized_eps_star(plant, design, rtol=1e-17)
    finest = fl.linearized_eps_star(plant, design, eps_range=(0.01, 2.0), n_scan=4,
                                    rtol=_linearization.MIN_RTOL)
    coarse = fl.linearized_eps_star(plant, design, eps_range=(0.01, 2.0), n_scan=4)
    assert math.isclose(finest.lower, coarse.lower, rel_tol=1e-6)
    # the finest bracket: adjacent floats, or rtol-narrow (no float strictly between the ends)
    assert finest.upper / finest.lower - 1 <= _linearization.MIN_RTOL or \
        math.sqrt(finest.lower * finest.upper) in (finest.lower, finest.upper)
    monkeypatch.setattr(_linearization, "MAX_BISECTIONS", 3)
    with pytest.raises(fl.errors.ComputationError, match="after 3 bisections"):
        fl.linearized_eps_star(plant, design, eps_range=(0.01, 2.0), n_scan=4)
