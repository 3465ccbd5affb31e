"""Sampled-plant discretization: F^a against the paper and exp(T N), residual orders against
fitted one-step errors of closed-form and numerically integrated trajectories, F^e of a linear
plant against scipy's exact ZOH discretization, and every bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg
import scipy.signal
import sympy as sp
from scipy.integrate import solve_ivp

import fl_design as fl
from fl_design.errors import DimensionError, ParameterError
from fl_design.symbolic import (
    Discretization,
    approximate_extended_model,
    chain_states,
    lie_series_terms,
    sigma_symbol,
)

T, ALPHA, EPS = sp.symbols("T alpha epsilon", positive=True)


def _slope(h, err):
    return float(np.polyfit(np.log(h), np.log(err), 1)[0])


def _shift(n):
    return sp.Matrix(n, n, lambda i, j: 1 if j == i + 1 else 0)


# --- F^a --------------------------------------------------------------------------------------
def test_approx_rho2_is_the_papers_matrix():
    d = fl.taylor_discretization(2, order=3)
    paper = sp.Matrix([[1, T, T**2 / 2], [0, 1, T], [0, 0, 1]])
    assert sp.simplify(d.approx - paper) == sp.zeros(3, 3)
    ea = EPS * ALPHA
    paper_eps = sp.Matrix([[1, ea, ea**2 / 2], [0, 1, ea], [0, 0, 1]])
    assert sp.simplify(d.approx_in_eps() - paper_eps) == sp.zeros(3, 3)
    assert (d.T, d.alpha, d.eps) == (T, ALPHA, EPS)


@pytest.mark.parametrize("rho", [1, 3, 4, 5])
def test_approx_is_exp_of_shift(rho):
    expected = (T * _shift(rho + 1)).exp()  # independent: SymPy's matrix exponential
    assert sp.simplify(approximate_extended_model(rho) - expected) == sp.zeros(rho + 1, rho + 1)
    assert fl.taylor_discretization(rho, order=2).approx == approximate_extended_model(rho)


def test_approx_numeric_T_matches_scipy_expm():
    Tn = 0.37
    got = np.array(approximate_extended_model(4, T=Tn), dtype=float)
    np.testing.assert_allclose(got, scipy.linalg.expm(Tn * np.eye(5, k=1)), rtol=1e-14)


# --- residual orders ----------------------------------------------------------------------------
@pytest.mark.parametrize(
    "rho,order,expected", [(2, 3, (3, 2, 1)), (2, 1, (3, 2, 1)), (3, 4, (4, 3, 2, 1)),
                           (3, 2, (4, 3, 2, 1)), (4, 6, (5, 4, 3, 2, 1))]
)
def test_residual_orders(rho, order, expected):
    d = fl.taylor_discretization(rho, order=order)
    assert d.residual_orders == expected
    assert d.residual_orders_T == expected
    # general rule O(T^(rho-i+2)) for x_i, O(T) for sigma, leading term T^p/p! sigma_dot
    for i, (p, lead) in enumerate(zip(d.residual_orders_T, d.residual_leading_terms), start=1):
        assert p == (rho - i + 2 if i <= rho else 1)
        assert sp.simplify(lead - T**p / math.factorial(p) * sigma_symbol(1)) == 0


def test_residual_order_table_lists_every_component():
    table = fl.taylor_discretization(3, order=3).residual_order_table().splitlines()
    assert len(table) == 5
    assert [line.split()[0] for line in table[1:]] == ["x1", "x2", "x3", "sigma"]
    assert [int(line.split()[-1]) for line in table[1:]] == [4, 3, 2, 1]


def test_chain_exact_matches_the_stated_formula():
    rho, order = 3, 5
    d = fl.taylor_discretization(rho, order=order)
    x = chain_states(rho)
    for i in range(1, rho + 1):
        # x_i^(j) = x_(i+j) for i+j <= rho, else sigma^(i+j-rho-1)
        want = sum(T**j / sp.factorial(j) * (x[i + j - 1] if i + j <= rho
                                             else sigma_symbol(i + j - rho - 1))
                   for j in range(order + 1))
        assert sp.expand(d.exact[i - 1] - want) == 0
    assert {s.name for s in d.remainder.free_symbols} == {"T", "sigma_d3_mid", "sigma_d4_mid",
                                                          "sigma_d5_mid"}


# --- fitted convergence orders ----------------------------------------------------------------
def _sin_chain(rho, t):
    """Closed form: y = sin t, x_i = y^(i-1), sigma = y^(rho), derivatives sin(t + k pi/2)."""
    return lambda k: math.sin(t + k * math.pi / 2)


@pytest.mark.parametrize("rho", [1, 2, 3, 4])
def test_residual_orders_match_fitted_one_step_error_closed_form(rho):
    d = fl.taylor_discretization(rho, order=2)
    t0, alpha = 0.3, 0.5
    eps = np.geomspace(0.04, 0.4, 7)
    y = _sin_chain(rho, t0)
    xbar0 = np.array([y(k) for k in range(rho + 1)])
    errs = []
    for e in eps:
        Fa = np.array(approximate_extended_model(rho, T=alpha * e), dtype=float)
        xbar1 = np.array([math.sin(t0 + alpha * e + k * math.pi / 2) for k in range(rho + 1)])
        errs.append(np.abs(xbar1 - Fa @ xbar0))
    errs = np.array(errs)
    slopes = [_slope(eps, errs[:, i]) for i in range(rho + 1)]
    np.testing.assert_allclose(slopes, d.residual_orders, atol=0.2)


def test_residual_orders_match_fitted_error_of_integrated_chain():
    """rho = 2 chain driven by sigma(t) = sin t, integrated by solve_ivp at tight tolerance."""
    rho, t0, alpha = 2, 0.3, 0.5
    d = fl.taylor_discretization(rho, order=3)
    xbar0 = np.array([0.2, -0.4, math.sin(t0)])
    eps = np.geomspace(0.05, 0.5, 6)
    errs = []
    for e in eps:
        Tn = alpha * e
        sol = solve_ivp(lambda t, x: [x[1], math.sin(t)], (t0, t0 + Tn), xbar0[:2],
                        method="DOP853", rtol=1e-13, atol=1e-15)
        true = np.array([*sol.y[:, -1], math.sin(t0 + Tn)])
        Fa = np.array(approximate_extended_model(rho, T=Tn), dtype=float)
        errs.append(np.abs(true - Fa @ xbar0))
    errs = np.array(errs)
    slopes = [_slope(eps, errs[:, i]) for i in range(rho + 1)]
    np.testing.assert_allclose(slopes, d.residual_orders, atol=0.2)


@pytest.mark.parametrize("rho,order", [(2, 1), (2, 3), (3, 2)])
def test_exact_series_error_is_order_plus_one_and_within_lagrange_bound(rho, order):
    d = fl.taylor_discretization(rho, order=order)
    t0 = 0.3
    y = _sin_chain(rho, t0)
    values = {x: y(k) for k, x in enumerate(chain_states(rho))}
    values.update({sigma_symbol(j): y(rho + j) for j in range(order + rho + 2)})
    hs = np.geomspace(0.05, 0.4, 6)
    errs = []
    for h in hs:
        got = np.array(d.exact.subs(values).subs(T, h), dtype=float).ravel()
        true = np.array([math.sin(t0 + h + k * math.pi / 2) for k in range(rho)])
        errs.append(np.abs(true - got))
        # Lagrange remainder bound: |x^(N+1)| <= 1 for derivatives of sin
        assert np.all(errs[-1] <= h ** (order + 1) / math.factorial(order + 1) * (1 + 1e-9))
    errs = np.array(errs)
    for i in range(rho):
        assert abs(_slope(hs, errs[:, i]) - (order + 1)) < 0.2


# --- a real plant: linear damped double integrator against scipy's exact ZOH ----------------------
C_DAMP = 0.7


def _damped_double_integrator():
    p, v, u, c = sp.symbols("p v u c", real=True)
    return fl.Plant.from_ode((p, v), u, [v, -c * v + u], p, params={c: C_DAMP}, name="damped")


def _zoh(Tn):
    A = np.array([[0.0, 1.0], [0.0, -C_DAMP]])
    B = np.array([[0.0], [1.0]])
    Ad, Bd, *_ = scipy.signal.cont2discrete((A, B, np.eye(2), np.zeros((2, 1))), Tn, method="zoh")
    return A, B, Ad, Bd


@pytest.mark.parametrize("order", [1, 2, 3, 4])
def test_linear_plant_exact_is_truncated_zoh(order):
    plant = _damped_double_integrator()
    d = fl.taylor_discretization(plant, order=order)
    assert d.states == tuple(plant.states) and d.input == plant.input
    assert d.rho == 2 and d.residual_orders == (3, 2, 1)
    f = d.exact_function()
    x0, u0 = np.array([0.4, -1.1]), 0.8
    hs = np.geomspace(0.02, 0.2, 6)
    errs = []
    for h in hs:
        A, B, Ad, Bd = _zoh(h)
        got = f(x0, u0, h)
        # the truncated series of the ZOH map, computed independently with numpy powers of A
        trunc = sum(np.linalg.matrix_power(A * h, j) / math.factorial(j) @ x0
                    + (np.linalg.matrix_power(A * h, j - 1) * h / math.factorial(j) @ B[:, 0] * u0
                       if j else 0.0)
                    for j in range(order + 1))
        np.testing.assert_allclose(got, trunc, rtol=1e-13, atol=1e-15)
        errs.append(np.linalg.norm(Ad @ x0 + Bd[:, 0] * u0 - got))
    assert abs(_slope(hs, errs) - (order + 1)) < 0.2


def test_linear_plant_remainder_is_next_series_term_at_the_marker():
    plant = _damped_double_integrator()
    order, h = 2, 0.1
    d = fl.taylor_discretization(plant, order=order)
    assert {s.name for s in d.mid_states} <= {"p_mid", "v_mid"}
    x0, u0 = np.array([0.4, -1.1]), 0.8
    at = {sp.Symbol("p_mid", real=True): x0[0], sp.Symbol("v_mid", real=True): x0[1],
          plant.input: u0, T: h, **plant.params}
    got = np.array(d.remainder.subs(at), dtype=float).ravel()
    A, B, *_ = _zoh(h)
    k = order + 1
    want = h**k / math.factorial(k) * (np.linalg.matrix_power(A, k) @ x0
                                       + np.linalg.matrix_power(A, k - 1) @ B[:, 0] * u0)
    np.testing.assert_allclose(got, want, rtol=1e-12)


def test_linear_plant_chain_view_maps_onto_plant_series():
    plant = _damped_double_integrator()
    order = 3
    d = fl.taylor_discretization(plant, order=order)
    chain = fl.taylor_discretization(d.rho, order=order)
    sub = d.chain_substitution(max_derivative=order)
    # coordinates are the states here, so the chain series is the plant series term by term
    assert sp.expand(chain.exact.subs(sub, simultaneous=True) - d.exact) == sp.zeros(2, 1)
    sigma_dot = sub[sigma_symbol(1)]
    c = next(iter(plant.params))
    assert sp.expand(sigma_dot - (-c) * (-c * plant.states[1] + plant.input)) == 0


# --- bad input ---------------------------------------------------------------------------------
@pytest.mark.parametrize("order,match", [(0, r"order must be >= 1, got 0"),
                                         (-2, r"order must be >= 1, got -2"),
                                         (2.5, r"order must be an integer, got 2.5"),
                                         ("3", r"order must be an integer, got '3'"),
                                         (True, r"order must be an integer, got True")])
def test_bad_order(order, match):
    with pytest.raises(ParameterError, match=match):
        fl.taylor_discretization(2, order=order)


@pytest.mark.parametrize("plant,match", [(0, r"rho must be >= 1, got 0"),
                                         ("trms", r"plant must be an fl.Plant .* got 'trms'"),
                                         (2.0, r"plant must be an fl.Plant .* got 2.0")])
def test_bad_plant(plant, match):
    with pytest.raises(ParameterError, match=match):
        fl.taylor_discretization(plant, order=2)


def test_bad_approx_arguments():
    with pytest.raises(ParameterError, match=r"rho must be >= 1, got 0"):
        approximate_extended_model(0)
    with pytest.raises(ParameterError, match=r"T must be > 0, got -0.1"):
        approximate_extended_model(2, T=-0.1)
    with pytest.raises(ParameterError, match=r"T must be a real number, got 'x'"):
        approximate_extended_model(2, T="x")


def test_plant_only_methods_on_a_bare_chain():
    d = fl.taylor_discretization(2, order=2)
    with pytest.raises(ParameterError, match=r"exact_function\(\) needs a discretization of a "
                                             r"Plant; this one is the bare chain rho=2"):
        d.exact_function()
    with pytest.raises(ParameterError, match=r"chain_substitution\(\) needs"):
        d.chain_substitution()


def test_exact_function_checks_its_arguments():
    f = fl.taylor_discretization(_damped_double_integrator(), order=2).exact_function()
    with pytest.raises(DimensionError, match=r"x must have length 2, got 3"):
        f([0.0, 0.0, 0.0], 0.0, 0.01)
    with pytest.raises(ParameterError, match=r"T must be > 0, got 0.0"):
        f([0.0, 0.0], 0.0, 0.0)


def test_discretization_checks_shapes_and_triangularity():
    d = fl.taylor_discretization(2, order=2)
    with pytest.raises(DimensionError, match=r"exact must have shape \(2, 1\), got \(3, 1\)"):
        Discretization(rho=2, order=2, states=d.states, input=None, exact=sp.zeros(3, 1),
                       remainder=d.remainder, extended_exact=d.extended_exact, approx=d.approx)
    bad = sp.Matrix(d.approx)
    bad[2, 0] = T
    with pytest.raises(ParameterError, match=r"approx must be unit upper-triangular"):
        Discretization(rho=2, order=2, states=d.states, input=None, exact=d.exact,
                       remainder=d.remainder, extended_exact=d.extended_exact, approx=bad)
    with pytest.raises(ParameterError, match=r"order must be >= 1, got 0"):
        Discretization(rho=2, order=0, states=d.states, input=None, exact=d.exact,
                       remainder=d.remainder, extended_exact=d.extended_exact, approx=d.approx)


def test_lie_series_terms_checks_rhs_length():
    x1, x2 = sp.symbols("x1 x2")
    with pytest.raises(DimensionError, match=r"rhs must have 2 entries .* got shape \(3, 1\)"):
        lie_series_terms([x1, x2], [x2, x1, 0], 2)


def test_discretization_is_immutable_and_summarizes():
    d = fl.taylor_discretization(3, order=2)
    with pytest.raises(AttributeError):
        d.order = 5
    data = d.to_dict()
    assert data["residual_orders"] == [4, 3, 2, 1] and data["rho"] == 3
    assert len(data["approx"]) == 4 and data["plant"] is None


# --- nonlinear plants: F^e against integration, chain view against the plant's coordinates -------
def _nonlinear_plant():
    """x1' = x2 + x1^2, x2' = -sin(x1) - c x2 + (1 + x1^2/2) u, y = x1: coordinates != states."""
    x1, x2, u, c = sp.symbols("x1 x2 u c", real=True)
    rhs = [x2 + x1**2, -sp.sin(x1) - c * x2 + (1 + x1**2 / 2) * u]
    return fl.Plant.from_ode((x1, x2), u, rhs, x1, params={c: 0.4}, name="nonlinear")


@pytest.mark.parametrize("order", [1, 2, 3])
def test_nonlinear_plant_exact_error_is_order_plus_one_against_solve_ivp(order):
    plant = _nonlinear_plant()
    f = fl.taylor_discretization(plant, order=order).exact_function()
    field = sp.lambdify([plant.states, plant.input], list(plant.rhs.subs(plant.params)))
    x0, u0 = np.array([0.3, -0.2]), 0.5
    hs = np.geomspace(0.02, 0.16, 5)
    errs = []
    for h in hs:
        sol = solve_ivp(lambda t, x: field(x, u0), (0.0, h), x0, method="DOP853",
                        rtol=1e-13, atol=1e-15)
        errs.append(np.linalg.norm(sol.y[:, -1] - f(x0, u0, h)))
    assert abs(_slope(hs, errs) - (order + 1)) < 0.2


@pytest.mark.parametrize("make,order", [(_nonlinear_plant, 3), (fl.plants.trms_yaw, 2),
                                        (fl.plants.pendulum, 3), (fl.plants.flexible_joint, 2)],
                         ids=["nonlinear", "trms_yaw", "pendulum", "flexible_joint"])
def test_chain_view_agrees_with_plant_coordinates_up_to_the_order(make, order):
    plant = make()
    d = fl.taylor_discretization(plant, order=order)
    nf = plant.normal_form()
    sub = d.chain_substitution(max_derivative=order)
    assert [sub[x] for x in chain_states(d.rho)] == list(nf.coordinates)
    chain = fl.taylor_discretization(d.rho, order=order)
    x_next = dict(zip(plant.states, d.exact))
    for i, coord in enumerate(nf.coordinates):
        # z_i(x(k+1)) from the plant's series vs the chain series with sigma^(j) = L_F^j sigma:
        # equal up to T^order (exact arithmetic, parameters symbolic)
        diff = coord.subs(x_next, simultaneous=True) - chain.exact[i].subs(sub, simultaneous=True)
        head = sp.series(diff, T, 0, order + 1).removeO()
        assert sp.simplify(head) == 0, f"component {i + 1} differs below T^{order + 1}: {head}"


# --- the plant library ---------------------------------------------------------------------------
LIBRARY = {
    "trms_yaw": (lambda: fl.plants.trms_yaw(), [0.1, 0.5]),
    "trms_yaw_motor_lag": (lambda: fl.plants.trms_yaw(motor_lag=True), None),
    "pendulum": (lambda: fl.plants.pendulum(), None),
    "flexible_joint": (lambda: fl.plants.flexible_joint(), None),
}


@pytest.mark.parametrize("name", list(LIBRARY))
def test_library_plant_residual_orders_follow_its_relative_degree(name):
    plant = LIBRARY[name][0]()
    d = fl.taylor_discretization(plant, order=2)
    rho = plant.relative_degree()
    assert d.rho == rho and d.states == tuple(plant.states) and d.input == plant.input
    assert d.residual_orders == tuple(range(rho + 1, 1, -1)) + (1,)
    assert d.approx == approximate_extended_model(rho)
    assert d.to_dict()["plant"] == plant.name


@pytest.mark.parametrize("name", list(LIBRARY))
def test_library_plant_exact_error_is_order_plus_one_against_solve_ivp(name):
    make, x_start = LIBRARY[name]
    plant = make()
    order = 2
    f = fl.taylor_discretization(plant, order=order).exact_function()
    field = plant.casadi().f
    x0 = np.array(x_start if x_start is not None else 0.2 + 0.1 * np.arange(plant.n))
    u0 = float(plant.u_eq) + 0.3
    hs = np.geomspace(5e-3, 4e-2, 5)
    errs = []
    for h in hs:
        sol = solve_ivp(lambda t, x: np.asarray(field(x, u0)).ravel(), (0.0, h), x0,
                        method="DOP853", rtol=1e-13, atol=1e-15)
        errs.append(np.linalg.norm(sol.y[:, -1] - f(x0, u0, h)))
    assert abs(_slope(hs, errs) - (order + 1)) < 0.2
