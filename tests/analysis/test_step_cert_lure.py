"""The Lur'e certificate of ``_lure`` against independent computation.

* the exact sampled model's claim: over one sample of ``w' = -a0 w - phi(w) + b u`` (SciPy's
  ODE solver, tight tolerances) the weighted means that make the variation-of-constants formula
  exact lie between ``phi(w_k)`` and ``phi(w_(k+1))``;
* a certificate's ``V = X^T P X + 2 (q+ - q-) int phi/k`` decreases by ``kappa T X^T P X`` at
  every sample of the real nonlinear loop (the design's CasADi step + SciPy's ODE solution of a
  plant of the class), from the 0.3 rad step;
* the re-check refuses a decay faster than the loop's slowest mode (an eigenvalue computation)
  allows; the TRMS's friction slope range (k = 500) is not certified; bad input raises.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.integrate

import fl_design as fl
from fl_design.analysis._lure import lure_certificate, lure_model, recheck_lure
from fl_design.analysis._surrogate import SurrogateLoop
from fl_design.errors import ParameterError

A0, C, DELTA = 5.0, 0.01, 1e-3      # phi(w) = C tanh(w / DELTA): slope in [0, C / DELTA = 10]
K = C / DELTA


def free_design():
    """The paper's EHGO and controller gains without limits (the certificate is then global)."""
    d = fl.presets.paper_design()
    return fl.Design(estimator=d.estimator,
                     controller=fl.DynamicController((2.0, 4.0), 3e-4, ki=1e-3))


def phi(w):
    return C * np.tanh(w / DELTA)


def one_sample(x, u, b, T):
    """Exact (to 1e-13) one sample of ``e' = w, w' = -A0 w - phi(w) + b u``."""
    f = lambda t, z: [z[1], -A0 * z[1] - phi(z[1]) + b * u]
    sol = scipy.integrate.solve_ivp(f, (0.0, T), x, method="DOP853", rtol=1e-13, atol=1e-15)
    return sol.y[:, -1]


@pytest.fixture(scope="module")
def cert():
    c = lure_certificate(free_design(), (3.6, 3.6), A0, K)
    assert c.certified, c.argument
    return c


@pytest.mark.parametrize("seed", [0, 1])
def test_the_means_lie_between_the_end_values(seed):
    rng = np.random.default_rng(seed)
    T, b = 1e-3, 3.6
    beta = (1 - math.exp(-A0 * T)) / A0
    g = (T - beta) / A0
    for _ in range(10):
        x = np.array([rng.normal() * 0.3, rng.normal() * 3e-3])
        u = rng.normal() * 0.02
        x1 = one_sample(x, u, b, T)
        mean_w = (math.exp(-A0 * T) * x[1] + beta * b * u - x1[1]) / beta
        mean_e = (x[0] + beta * x[1] + g * b * u - x1[0]) / g
        lo, hi = sorted((phi(x[1]), phi(x1[1])))
        tol = 1e-9 * C
        assert lo - tol <= mean_w <= hi + tol
        assert lo - 1e-5 * C <= mean_e <= hi + 1e-5 * C   # g ~ T^2/2: the ODE's error / g


def test_v_decreases_along_the_nonlinear_loop(cert):
    design, r, b = free_design(), 0.3, 3.6
    T, keep = design.T, SurrogateLoop(design).keep
    P, qd = np.asarray(cert.P), cert.q_plus - cert.q_minus
    s_eq = design.initial_state(y0=r, u0=0.0)
    s = design.initial_state(y0=0.0, u0=0.0)
    x = np.zeros(2)

    def V(x, s):
        X = np.concatenate([[x[0] - r, x[1]], s - s_eq])[keep]
        integral = C * DELTA * math.log(math.cosh(x[1] / DELTA)) / K  # int_0^w phi / k
        return float(X @ P @ X) + 2.0 * qd * integral, float(X @ P @ X)

    v_prev, quad = V(x, s)
    worst = -math.inf
    for _ in range(600):
        s_next, u = (np.asarray(a, float).ravel() for a in design.step(s, x[0], r))
        x = one_sample(x, float(u[0]), b, T)
        s = s_next
        v, q_next = V(x, s)
        worst = max(worst, (v - v_prev + cert.kappa * T * quad) / abs(v_prev))
        v_prev, quad = v, q_next
    assert worst <= 1e-9, worst


def test_recheck_refuses_a_decay_above_the_slowest_mode(cert):
    design = free_design()
    mod = lure_model(design, (3.6, 3.6), A0, K)
    n = mod.n
    W = np.asarray(cert.W)
    Pt = W.T @ np.asarray(cert.P) @ W
    slow = min(-np.log(np.abs(np.linalg.eigvals(np.eye(n) + mod.T * R[:, :n]))).min() / mod.T
               for R in mod.Rs)
    assert recheck_lure(mod, W, Pt, cert.q_plus, cert.q_minus, cert.tau,
                        cert.s, cert.kappa) < 0
    assert recheck_lure(mod, W, Pt, cert.q_plus, cert.q_minus, cert.tau,
                        cert.s, 4.0 * slow) > 0


def test_trms_friction_range_is_not_certified():
    c = lure_certificate(fl.presets.paper_design(), (3.6, 6.8), 5.0, 500.0)
    assert not c.certified and c.P is None and "no Lur'e certificate" in c.argument


@pytest.mark.parametrize("kw", [{"damping": -1.0}, {"slope": 0.0}, {"slope": math.nan},
                                {"b_bounds": (0.0, 1.0)}, {"b_bounds": "x"}, {"kappa": 0.0}])
def test_bad_input(kw):
    args = {"b_bounds": (3.6, 3.6), "damping": 5.0, "slope": 10.0} | kw
    with pytest.raises(ParameterError):
        lure_certificate(free_design(), **args)


def test_certify_step_uses_the_stated_friction():
    cls = fl.PlantClass.chain(2, b=(3.6, 3.6), T=1e-3)
    c = fl.certify_step(cls, free_design(), fl.Scenario(0.3), friction=(A0, K))
    assert c.certified and c.largest_step == math.inf and "Lur'e certificate" in c.argument
    with pytest.raises(ParameterError):
        fl.certify_step(cls, free_design(), fl.Scenario(0.3), friction="x")
