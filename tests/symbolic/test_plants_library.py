"""The plant library: relative degrees, zero dynamics, closed-form input coefficients and b ranges,
an independent CasADi Lie-derivative check of sigma, parameter overrides, the TRMS derivation
report. The loops on every plant: ``tests/sim/test_library_loops.py``."""

from __future__ import annotations

import contextlib
import io
import math
import pathlib
import runpy

import casadi as ca
import numpy as np
import pytest
import scipy.signal

import fl_design as fl
from fl_design.errors import NonMinimumPhaseWarning, ParameterError, PlantDefinitionError

REPORT = pathlib.Path(__file__).resolve().parents[2] / "derivations" / "trms_report.py"

LIBRARY = {  # (plant, rho, minimum phase)
    "trms_yaw": (lambda: fl.plants.trms_yaw(), 2, True),
    "trms_yaw_motor_lag": (lambda: fl.plants.trms_yaw(motor_lag=True), 3, True),
    "pendulum": (lambda: fl.plants.pendulum(), 2, True),
    "flexible_joint": (lambda: fl.plants.flexible_joint(), 4, True),
    "cart_pendulum": (lambda: fl.plants.cart_pendulum(), 2, True),
    "cart_pendulum_inverted": (lambda: fl.plants.cart_pendulum(inverted=True), 2, False),
    "maglev": (lambda: fl.plants.maglev(), 3, True),
}


@pytest.fixture(scope="module", params=list(LIBRARY))
def entry(request):
    make, rho, minimum_phase = LIBRARY[request.param]
    return make(), rho, minimum_phase


def test_relative_degree_and_minimum_phase(entry):
    plant, rho, minimum_phase = entry
    nf = plant.normal_form()
    assert plant.relative_degree() == rho == nf.rho
    assert nf.zero_dynamics_eigenvalues.size == plant.n - rho and nf.minimum_phase == minimum_phase
    # the zero dynamics' eigenvalues are the invariant zeros of the linearization: the roots of
    # the numerator of C (sI - A)^-1 B, here from SciPy's state-space-to-transfer-function
    num = scipy.signal.ss2tf(*plant.linearization())[0].ravel()
    zeros = np.roots(np.trim_zeros(np.where(np.abs(num) > 1e-9 * np.max(np.abs(num)), num, 0), "f"))
    np.testing.assert_allclose(np.sort_complex(zeros), nf.zero_dynamics_eigenvalues, atol=1e-6)
    assert plant.input_range is not None and set(plant.region) == set(plant.states)
    box = np.array([plant.region[s] for s in plant.states])
    assert np.all((box[:, 0] <= plant.x_op) & (plant.x_op <= box[:, 1]))  # operating point inside


def test_sigma_equals_casadi_lie_derivatives(entry):
    """y^(rho) by repeated CasADi Jacobian-vector products of f: independent of the SymPy path."""
    plant, rho, _ = entry
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


# --- the pendulum on a cart (internal dynamics) ----------------------------------------------
CRANE = {"M": 1.0, "m": 0.2, "l": 0.3, "J": 6e-3, "c": 2.0, "gamma_p": 0.1, "g": 9.81}


def _cart_accelerations(x, F, *, inverted, M, m, l, J, c, gamma_p, g):
    """Astrom & Murray's balance system, angle from upright ``vartheta``, solved by NumPy."""
    _, v, th, om = x
    vth = th if inverted else th + math.pi
    mass = np.array([[M + m, -m * l * math.cos(vth)], [-m * l * math.cos(vth), J + m * l ** 2]])
    rhs = np.array([F - c * v - m * l * math.sin(vth) * om ** 2,
                    m * g * l * math.sin(vth) - gamma_p * om])
    return np.linalg.solve(mass, rhs), np.linalg.solve(mass, [1.0, 0.0])[0]


@pytest.mark.parametrize("inverted", [False, True])
def test_cart_pendulum_model_and_b_against_the_mass_matrix(inverted):
    plant = fl.plants.cart_pendulum(inverted=inverted)
    fns = plant.casadi()
    rng = np.random.default_rng(3)
    lo, hi = np.array([plant.region[s] for s in plant.states]).T
    for _ in range(20):
        x, F = rng.uniform(lo, hi), rng.uniform(-10, 10)
        (acc_p, acc_th), b = _cart_accelerations(x, F, inverted=inverted, **CRANE)
        np.testing.assert_allclose(fns.f(x, F).full().ravel(), [x[1], acc_p, x[3], acc_th],
                                   rtol=1e-12, atol=1e-12)
        assert float(fns.b(x, F)) == pytest.approx(b, rel=1e-12)
    Jt = CRANE["J"] + CRANE["m"] * CRANE["l"] ** 2
    b_of = lambda th: Jt / ((CRANE["M"] + CRANE["m"]) * Jt - (CRANE["m"] * CRANE["l"] * math.cos(th)) ** 2)
    assert plant.b_bounds() == pytest.approx((b_of(0.6), b_of(0.0)), rel=1e-9)  # |theta| <= 0.6


@pytest.mark.parametrize("inverted,gamma_p", [(False, 0.1), (False, 0.4), (True, 0.1)])
def test_cart_pendulum_zero_dynamics_closed_form(inverted, gamma_p):
    """Cart held still: J_t lambda^2 + gamma_p lambda -+ m g l = 0 (minus: inverted)."""
    plant = fl.plants.cart_pendulum(inverted=inverted, gamma_p=gamma_p)
    nf = plant.normal_form()
    Jt, mgl = CRANE["J"] + CRANE["m"] * CRANE["l"] ** 2, CRANE["m"] * CRANE["g"] * CRANE["l"]
    want = np.sort_complex(np.roots([Jt, gamma_p, -mgl if inverted else mgl]).astype(complex))
    np.testing.assert_allclose(nf.zero_dynamics_eigenvalues, want, rtol=1e-9)
    assert nf.minimum_phase is (not inverted)
    if not inverted and gamma_p ** 2 < 4 * Jt * mgl:  # underdamped sway: exp(-gamma_p t / (2 J_t))
        assert nf.zero_dynamics_eigenvalues.real == pytest.approx([-gamma_p / (2 * Jt)] * 2)


def test_inverted_cart_pendulum_warns_and_its_pendulum_falls(tmp_path):
    """Not minimum phase: the run warns, naming the unstable zero-dynamics eigenvalue; the cart
    settles (the output 'converges') while the pendulum leaves the region and falls."""
    plant = fl.plants.cart_pendulum(inverted=True)
    unstable = float(np.max(plant.normal_form().zero_dynamics_eigenvalues.real))
    with pytest.warns(NonMinimumPhaseWarning, match=f"largest real part {unstable:.4g}"):
        resp = fl.simulate(plant, fl.presets.cart_pendulum_design(), fl.Scenario(0.05, 6.0),
                           kernel=fl.Kernel(cache_dir=tmp_path))
    assert resp.region_exit_time < 3.0 and "left the plant's region" in resp.verdict()
    assert abs(abs(resp.x[-1, 2]) - math.pi) < 0.05  # fallen: hanging below the cart


# --- magnetic levitation (b < 0) -------------------------------------------------------------
MAGLEV = {"m": 0.068, "C": 3.2654e-5, "L": 0.4125, "R": 11.0, "g": 9.81}


def test_maglev_model_operating_point_and_b():
    plant = fl.plants.maglev()
    m, C, L, R, g = MAGLEV.values()
    i0 = 6e-3 * math.sqrt(m * g / C)
    np.testing.assert_allclose(plant.x_op, [6e-3, 0.0, i0], rtol=1e-12)
    assert plant.u_eq == pytest.approx(R * i0, rel=1e-12)
    fns = plant.casadi()
    rng = np.random.default_rng(4)
    lo, hi = np.array([plant.region[s] for s in plant.states]).T
    for _ in range(20):
        (y, v, i), u = rng.uniform(lo, hi), rng.uniform(0, 24)
        np.testing.assert_allclose(fns.f([y, v, i], u).full().ravel(),
                                   [v, g - C * i ** 2 / (m * y ** 2), (u - R * i) / L], rtol=1e-12)
        assert float(fns.b([y, v, i], u)) == pytest.approx(-2 * C * i / (m * L * y ** 2), rel=1e-12)
    b = lambda y, i: -2 * C * i / (m * L * y ** 2)  # monotone in y and i: extremes at corners
    assert plant.b_bounds() == pytest.approx((b(4e-3, 1.2), b(8e-3, 0.5)), rel=1e-9)
    # open loop at the operating point: +-sqrt(2 g / y0) and the coil's -R / L
    eig = np.sort(np.linalg.eigvals(plant.linearization()[0]).real)
    np.testing.assert_allclose(eig, [-math.sqrt(2 * g / 6e-3), -R / L, math.sqrt(2 * g / 6e-3)],
                               rtol=1e-9)


def test_maglev_gamma_takes_the_sign_of_b():
    plant = fl.plants.maglev()
    with pytest.raises(ParameterError, match="sign"):
        fl.simulate(plant, fl.presets.maglev_design(gamma=1e-3), fl.Scenario(6.2e-3, 0.01))


@pytest.mark.parametrize("make,error,match", [
    (lambda: fl.plants.cart_pendulum(gamma_p=-0.1), ParameterError, "gamma_p must be >= 0"),
    (lambda: fl.plants.cart_pendulum(M=0.0), ParameterError, "M must be > 0"),
    (lambda: fl.plants.cart_pendulum(inverted="yes"), ParameterError, "inverted must be"),
    (lambda: fl.plants.maglev(m=-1.0), ParameterError, "m must be > 0"),
    (lambda: fl.plants.maglev(y0=0.02), PlantDefinitionError, r"y=0.02 lies outside the region"),
])
def test_new_plants_bad_overrides_raise(make, error, match):
    with pytest.raises(error, match=match):
        make()
