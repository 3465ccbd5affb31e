"""The plant library: relative degrees, closed-form input coefficients and b ranges, an independent
CasADi Lie-derivative check of sigma, parameter overrides, and the TRMS derivation report."""

from __future__ import annotations

import contextlib
import io
import math
import pathlib
import runpy

import casadi as ca
import numpy as np
import pytest

import fl_design as fl
from fl_design.errors import ParameterError

REPORT = pathlib.Path(__file__).resolve().parents[2] / "derivations" / "trms_report.py"

LIBRARY = {
    "trms_yaw": (lambda: fl.plants.trms_yaw(), 2),
    "trms_yaw_motor_lag": (lambda: fl.plants.trms_yaw(motor_lag=True), 3),
    "pendulum": (lambda: fl.plants.pendulum(), 2),
    "flexible_joint": (lambda: fl.plants.flexible_joint(), 4),
}


@pytest.fixture(scope="module", params=list(LIBRARY))
def entry(request):
    make, rho = LIBRARY[request.param]
    return make(), rho


def test_relative_degree_and_minimum_phase(entry):
    plant, rho = entry
    nf = plant.normal_form()
    assert plant.relative_degree() == rho == nf.rho
    assert plant.n == rho and nf.minimum_phase and nf.zero_dynamics_eigenvalues.size == 0
    assert plant.input_range is not None and set(plant.region) == set(plant.states)


def test_sigma_equals_casadi_lie_derivatives(entry):
    """y^(rho) by repeated CasADi Jacobian-vector products of f: independent of the SymPy path."""
    plant, rho = entry
    fns = plant.casadi()
    x, u = ca.SX.sym("x", plant.n), ca.SX.sym("u")
    y = fns.h(x)
    for _ in range(rho):
        y = ca.jtimes(y, x, fns.f(x, u))
    ref = ca.Function("ref", [x, u], [y, ca.jacobian(y, u)])
    rng = np.random.default_rng(11)
    lo, hi = np.array([plant.region[s] for s in plant.states]).T
    for _ in range(20):
        xv = rng.uniform(lo, hi)
        uv = rng.uniform(*plant.input_range)
        sig, db = (float(v) for v in ref(xv, uv))
        assert float(fns.sigma(xv, uv)) == pytest.approx(sig, rel=1e-9, abs=1e-9)
        assert float(fns.b(xv, uv)) == pytest.approx(db, rel=1e-9, abs=1e-9)


def _trms_b_closed_form(tau, I2=2e-2, a2=0.02, b2=0.09, k2=0.8, T=1.0):
    return (2 * a2 * abs(tau) + b2) * k2 / (T * I2)


@pytest.mark.parametrize("motor_lag", [False, True])
def test_trms_b_range(motor_lag):
    plant = fl.plants.trms_yaw(motor_lag=motor_lag)
    lo, hi = plant.b_bounds()
    assert lo == pytest.approx(3.6, abs=1e-6) and hi == pytest.approx(6.8, abs=1e-6)
    assert _trms_b_closed_form(0.0) == pytest.approx(3.6) and _trms_b_closed_form(2.0) == pytest.approx(6.8)
    fns = plant.casadi()
    rng = np.random.default_rng(5)
    for _ in range(20):
        uv = rng.uniform(-2.5, 2.5)
        tau = rng.uniform(-2, 2) if motor_lag else 0.8 * uv  # static motor: tau = k2 u / T20
        x = [0.1, 0.2, tau] if motor_lag else [0.1, 0.2]
        assert float(fns.b(x, uv)) == pytest.approx(_trms_b_closed_form(tau), rel=1e-12)


def test_trms_rhs_matches_hand_written_model():
    fns = fl.plants.trms_yaw(motor_lag=True).casadi()
    rng = np.random.default_rng(9)
    for _ in range(10):
        phi, om, tau, uv = rng.uniform(-2, 2, 4)
        acc = (0.02 * tau * abs(tau) + 0.09 * tau - 0.1 * om - 0.01 * math.tanh(om / 1e-3)) / 2e-2
        want = [om, acc, 0.8 * uv - tau]
        assert fns.f([phi, om, tau], uv).full().ravel() == pytest.approx(want, rel=1e-12)


def test_trms_motor_lag_time_constant_scales_b():
    lo, hi = fl.plants.trms_yaw(motor_lag=True, T21=2.0).b_bounds()
    assert (lo, hi) == pytest.approx((1.8, 3.4), abs=1e-9)
    # T21 does not enter the static model, T20 does: b = (2 a2 |k2 u/T20| + b2) k2 / (T20 I2)
    lo, hi = fl.plants.trms_yaw(T20=2.0).b_bounds()
    assert (lo, hi) == pytest.approx((0.09 * 0.4 / 0.02, (0.04 * 1.0 + 0.09) * 0.4 / 0.02), abs=1e-9)


def test_flexible_joint_b_and_model():
    plant = fl.plants.flexible_joint()
    b = 0.18 * 8e-2 / (9.3e-3 * 3.7e-3)
    assert plant.b_bounds() == pytest.approx((b, b), rel=1e-12)
    fns = plant.casadi()
    x = np.array([0.3, -0.2, 0.1, 0.4])
    q1, w1, q2, w2 = x
    want = [w1, (-0.21 * 9.81 * 0.155 * math.sin(q1) - 0.18 * (q1 - q2)) / 9.3e-3,
            w2, (8e-2 * 1.5 - 4.6e-2 * w2 + 0.18 * (q1 - q2)) / 3.7e-3]
    assert fns.f(x, 1.5).full().ravel() == pytest.approx(want, rel=1e-12)


def test_pendulum_overrides_and_linearization():
    plant = fl.plants.pendulum(g=9.81, l=2.0, c=0.1, b=3.0)
    A, B, _, _ = plant.linearization()
    assert A == pytest.approx(np.array([[0.0, 1.0], [-9.81 / 2.0, -0.1]]))
    assert B.ravel() == pytest.approx([0.0, 3.0]) and plant.b_bounds() == (3.0, 3.0)


@pytest.mark.parametrize("make,match", [
    (lambda: fl.plants.pendulum(c=-1.0), "c must be >= 0"),
    (lambda: fl.plants.pendulum(l=0.0), "l must be > 0"),
    (lambda: fl.plants.trms_yaw(I2=float("nan")), "I2 must be finite"),
    (lambda: fl.plants.trms_yaw(motor_lag=True, T21=-1.0), "T21 must be > 0"),
    (lambda: fl.plants.trms_yaw(input_range=(2.5, -2.5)), "reversed or empty"),
    (lambda: fl.plants.flexible_joint(k="stiff"), "k must be a real number"),
    (lambda: fl.plants.flexible_joint(B=-0.1), "B must be >= 0"),
])
def test_bad_overrides_raise(make, match):
    with pytest.raises(ParameterError, match=match):
        make()


def test_trms_report_in_process():
    mod = runpy.run_path(str(REPORT))
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        status = mod["main"]([])
    out = buf.getvalue()
    assert status == 0
    assert "relative degree rho = 2" in out and "relative degree rho = 3" in out
    assert out.count("[b_min, b_max] = [3.6, 6.8]") == 2
    assert r"\begin{align*}" in out and r"\frac{\partial \sigma}{\partial u}" in out
    assert "1.28*Abs(u) + 3.6" in out and "1.6*Abs(tau) + 3.6" in out  # b with numbers
    text = mod["report"](variants=["motor_lag"], fmt="text")
    assert "LaTeX" not in text and "affinely" in text
    with pytest.raises(ParameterError, match="variants must be"):
        mod["report"](variants=["bogus"])
    with pytest.raises(ParameterError, match="fmt must be one of"):
        mod["report"](fmt="html")
