"""LeastSquaresEstimator: exactness on polynomials, independence from numpy.polyfit, protocol."""

from __future__ import annotations

import casadi
import numpy as np
import pytest
from numpy.polynomial import polynomial as P

import fl_design as fl
from fl_design.errors import DimensionError, ParameterError

CASES = [(1, None, 2, 1e-3), (1, 3, 9, 0.1), (2, None, 9, 1e-3), (2, 4, 26, 1e-3),
         (3, None, 4, 1e-2), (3, 5, 30, 1e-4), (6, None, 12, 1e-3)]


def poly_truth(coeffs, t, rho):
    """Values and derivatives 0..rho of sum coeffs[i] t^i (numpy.polynomial, independent)."""
    return np.stack([P.polyval(t, P.polyder(coeffs, i)) if i else P.polyval(t, coeffs)
                     for i in range(rho + 1)], axis=1)


@pytest.mark.parametrize("rho, degree, window, T", CASES)
def test_exact_on_polynomials_up_to_degree(rho, degree, window, T):
    est = fl.LeastSquaresEstimator(rho, T, window, degree)
    d = est.fit_degree
    rng = np.random.default_rng(rho * 100 + window)
    tau = window * T  # coefficients O(1) in the time unit of the window: no term dominates
    t = np.arange(window + 15) * T
    for deg in range(d + 1):
        coeffs = rng.uniform(-1, 1, deg + 1) / tau ** np.arange(deg + 1)
        truth = poly_truth(coeffs, t, rho)
        est_vals = est.filter(P.polyval(t, coeffs))
        assert np.all(np.isnan(est_vals[: window - 1]))
        # relative to the derivative's own size, in the window's natural unit |y| / tau^i
        y_size = np.max(np.abs(truth[:, 0]))
        scale = np.max(np.abs(truth[window - 1 :]), axis=0) + y_size / tau ** np.arange(rho + 1)
        err = np.abs(est_vals[window - 1 :] - truth[window - 1 :]) / scale
        assert np.max(err) <= 1e-8, (deg, np.max(err, axis=0))


@pytest.mark.parametrize("rho, degree, window, T", [c for c in CASES if c[2] > (c[1] or c[0]) + 1])
def test_not_exact_beyond_degree(rho, degree, window, T):
    est = fl.LeastSquaresEstimator(rho, T, window, degree)
    tau = window * T
    t = np.arange(window + 5) * T
    coeffs = np.zeros(est.fit_degree + 2)
    coeffs[-1] = tau ** -(est.fit_degree + 1)  # ((t)/tau)^(degree+1): O(1) over the window
    truth = poly_truth(coeffs, t, rho)[window - 1 :]
    err = np.abs(est.filter(P.polyval(t, coeffs))[window - 1 :] - truth)
    scale = np.max(np.abs(truth), axis=0) + 1 / tau ** np.arange(rho + 1)
    assert np.max(err / scale) > 1e-4


@pytest.mark.parametrize("rho, degree, window, T", CASES)
def test_matrix_equals_numpy_polyfit(rho, degree, window, T):
    est = fl.LeastSquaresEstimator(rho, T, window, degree)
    y = np.random.default_rng(7).standard_normal(window)
    tj = -(window - 1 - np.arange(window)) * T
    fit = np.polynomial.Polynomial.fit(tj, y, est.fit_degree)  # its own domain scaling
    ref = np.array([fit.deriv(i)(0.0) if i else fit(0.0) for i in range(rho + 1)])
    got = est.matrix @ y
    scale = np.abs(ref) + np.max(np.abs(y)) / (window * T) ** np.arange(rho + 1)
    np.testing.assert_array_less(np.abs(got - ref) / scale, 1e-9)


def test_ready_flag_and_symbolic_equals_filter():
    est = fl.LeastSquaresEstimator(2, 1e-3, window=9)
    n = est.state_size
    xi, ys = casadi.SX.sym("xi", n), casadi.SX.sym("y")
    p = casadi.SX.sym("p", est.parameter_vector().size)
    f = casadi.Function("f", [xi, ys, p], list(est.symbolic_update(xi, ys, p)))
    y = np.sin(np.arange(30) * 0.01) + 0.3
    ref = est.filter(y)
    x, pv = est.initial_state(), est.parameter_vector()
    for k, yk in enumerate(y):
        xhat, x, ready = f(x, yk, pv)
        x = np.asarray(x).ravel()
        assert float(ready) == (1.0 if k >= est.window - 1 else 0.0)
        assert x[-1] == min(k + 1, est.window)  # the count saturates at the window
        np.testing.assert_allclose(x[:-1], np.r_[np.zeros(est.window), y][k + 1 : k + 1 + est.window])
        if k >= est.window - 1:
            np.testing.assert_allclose(np.asarray(xhat).ravel(), ref[k], rtol=1e-12, atol=1e-9)


def test_flops_and_replace():
    est = fl.LeastSquaresEstimator(2, 1e-3, window=9)
    assert est.flops_per_step == 27 and est.replace(window=26).flops_per_step == 78
    assert fl.EHGO(2, 0.05, 1e-3).flops_per_step < est.flops_per_step
    assert est.replace(rho=3).fit_degree == 3
    assert est.replace(T=2e-3) == fl.LeastSquaresEstimator(2, 2e-3, 9)
    with pytest.raises(ParameterError, match="has no eps"):
        est.replace(eps=0.1)


@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        ({"window": 2}, DimensionError, r"window >= degree \+ 1 = 3"),
        ({"window": 4, "degree": 4}, DimensionError, r"window >= degree \+ 1 = 5"),
        ({"degree": 1}, ParameterError, "degree=1 must be >= rho=2"),
        ({"degree": 2.5}, ParameterError, "degree must be an integer"),
        ({"window": 0}, ParameterError, "window must be >= 1"),
        ({"window": 9.0}, ParameterError, "window must be an integer"),
        ({"rho": 0}, ParameterError, "rho must be >= 1"),
        ({"rho": 7}, ParameterError, "rho must be <= 6"),
        ({"T": 0.0}, ParameterError, "T must be > 0"),
        ({"T": -1e-3}, ParameterError, "T must be > 0"),
        ({"T": np.nan}, ParameterError, "T must be finite"),
    ],
)
def test_bad_inputs(kwargs, error, match):
    with pytest.raises(error, match=match):
        fl.LeastSquaresEstimator(**({"rho": 2, "T": 1e-3, "window": 9} | kwargs))


def test_bad_symbolic_lengths():
    est = fl.LeastSquaresEstimator(1, 1e-3, 3)
    with pytest.raises(DimensionError, match="xi must be a vector of length 4"):
        est.symbolic_update(casadi.SX.sym("xi", 3), casadi.SX.sym("y"), est.parameter_vector())
