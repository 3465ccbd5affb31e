"""Plant construction and validation, relative degree, normal form, zero dynamics, bounds, bridge.

The mathematics is checked against independent computations: transfer-function zeros of the
linearization (scipy.signal.ss2zpk) and the Rosenbrock pencil (scipy.linalg.eigvals), closed-form
coefficients, and NumPy evaluations of the SymPy expressions against the CasADi functions.
"""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest
import scipy.linalg
import scipy.signal
import sympy as sp

import fl_design as fl
from fl_design.errors import (
    ParameterError,
    PlantDefinitionError,
    RelativeDegreeError,
)
from fl_design.symbolic import to_casadi

x1, x2, x3, w, u, k = sp.symbols("x1 x2 x3 w u k")


def chain3(wdot, **kw):
    return fl.Plant.from_ode([x1, x2, w], u, [x2, u, wdot], x1, **kw)


# --- construction ------------------------------------------------------------------------------
def test_attributes_and_params_by_name_or_symbol():
    p = fl.Plant.from_ode([x1, x2], u, sp.Matrix([x2, -k * x1 + u]), x1, params={"k": 2.0},
                          name="spring", input_range=3.0, region={"x1": (-1, 1), x2: (-2, 2)})
    assert p.states == (x1, x2) and p.input == u and p.n == 2 and p.name == "spring"
    assert p.rhs.shape == (2, 1) and p.rhs[1] == -k * x1 + u  # parameters stay symbolic
    assert p.params == {k: 2.0}
    assert p.input_range == (-3.0, 3.0)
    assert p.region == {x1: (-1.0, 1.0), x2: (-2.0, 2.0)}
    assert p.x_op.tolist() == [0.0, 0.0] and p.u_eq == 0.0
    q = fl.Plant.from_ode(np.array([x1, x2]), u, np.array([x2, -k * x1 + u]), x1, params={k: 2.0})
    assert q.params == p.params and q.states == p.states


def test_immutable():
    p = fl.plants.pendulum()
    with pytest.raises(AttributeError, match="immutable"):
        p.name = "x"
    with pytest.raises(ValueError):
        p.x_op[0] = 1.0
    p.params[next(iter(p.params))] = 99.0  # a copy: the plant is unchanged
    assert 99.0 not in p.params.values()


def test_equilibrium_input_is_solved():
    p = fl.Plant.from_ode([x1, x2], u, [x2, -k * sp.sin(x1) + u**3], x1, params={k: 2.0},
                          operating_point={x1: 0.5})
    assert p.u_eq == pytest.approx(np.cbrt(2.0 * math.sin(0.5)), abs=1e-10)
    fns = p.casadi()
    assert np.allclose(fns.f(p.x_op, p.u_eq).full().ravel(), 0.0, atol=1e-12)


def test_pickle_round_trip():
    p = fl.plants.trms_yaw(motor_lag=True)
    p.casadi()  # cached CasADi objects must not break pickling
    q = pickle.loads(pickle.dumps(p))
    assert q.relative_degree() == 3 and q.params == p.params and q.region == p.region


def test_with_params():
    p = fl.plants.pendulum()
    q = p.with_params(b=2.0)
    assert q.b_bounds() == (2.0, 2.0) and p.b_bounds() == (1.0, 1.0)
    with pytest.raises(PlantDefinitionError, match=r"unknown parameter\(s\) \['zz'\]"):
        p.with_params(zz=1.0)


BAD_DEFINITIONS = [
    ({"states": [x1, x2], "input": u, "rhs": [x2, u + k], "output": x1}, PlantDefinitionError,
     r"unknown symbol\(s\) \['k'\]"),
    ({"states": [x1, x2], "input": u, "rhs": [x2], "output": x1}, PlantDefinitionError,
     "rhs has 1 entries but there are 2 states"),
    ({"states": [x1, x1], "input": u, "rhs": [x1, u], "output": x1}, PlantDefinitionError,
     r"duplicate state\(s\) \['x1'\]"),
    ({"states": [], "input": u, "rhs": [], "output": x1}, PlantDefinitionError, "at least one state"),
    ({"states": x1, "input": u, "rhs": [u], "output": x1}, PlantDefinitionError, "sequence of sympy"),
    ({"states": [x1, "x2"], "input": u, "rhs": [x2, u], "output": x1}, PlantDefinitionError,
     "must be sympy Symbols"),
    ({"states": [x1, x2], "input": "u", "rhs": [x2, u], "output": x1}, PlantDefinitionError,
     "input must be a sympy Symbol"),
    ({"states": [x1, u], "input": u, "rhs": [u, u], "output": x1}, PlantDefinitionError,
     "also listed among the states"),
    ({"states": [x1, x2], "input": u, "rhs": [x2, u], "output": x1 + u}, PlantDefinitionError,
     "depends on the input u"),
    ({"states": [x1, x2], "input": u, "rhs": [x2, u], "output": sp.Integer(3)}, PlantDefinitionError,
     "not a function of the states"),
    ({"states": [x1, x2], "input": u, "rhs": [x2, -x1], "output": x1}, PlantDefinitionError,
     "does not appear in rhs"),
    ({"states": [x1, x2], "input": u, "rhs": [x2, u], "output": x1, "params": {"k": 1.0}},
     PlantDefinitionError, "params key 'k' does not appear"),
    ({"states": [x1, x2], "input": u, "rhs": [x2, u], "output": x1, "params": {"x1": 1.0}},
     PlantDefinitionError, "is a state or the input"),
    ({"states": [x1, x2], "input": u, "rhs": [x2, k * u], "output": x1, "params": {k: float("nan")}},
     ParameterError, r"params\[k\] must be finite"),
    ({"states": [x1, x2], "input": u, "rhs": [x2, k * u], "output": x1, "params": [1.0]},
     PlantDefinitionError, "params must be a dict"),
    ({"states": [x1, x2], "input": u, "rhs": [x2, u], "output": x1, "input_range": (1.0, -1.0)},
     ParameterError, "reversed or empty"),
    ({"states": [x1, x2], "input": u, "rhs": [x2, u], "output": x1, "region": {x1: (2.0, 1.0)}},
     ParameterError, "reversed or empty"),
    ({"states": [x1, x2], "input": u, "rhs": [x2, u], "output": x1, "region": {"q": (0.0, 1.0)}},
     PlantDefinitionError, "region key 'q' is not one of"),
    ({"states": [x1, x2], "input": u, "rhs": [x2, u], "output": x1, "region": {x1: (0.5, 1.0)}},
     PlantDefinitionError, "outside the region"),
    ({"states": [x1, x2], "input": u, "rhs": [x2, u**2 + 1], "output": x1}, PlantDefinitionError,
     "not an equilibrium for any input"),
    ({"states": [x1, x2], "input": u, "rhs": [x2 + 1, u], "output": x1}, PlantDefinitionError,
     "not an equilibrium for any input"),
    ({"states": [x1, x2], "input": u, "rhs": [x2, x1 + u], "output": x1, "operating_point": {x1: 2.0},
          "input_range": (-1.0, 1.0)}, PlantDefinitionError, r"u_eq=-2, outside the input range"),
    ({"states": [x1, x2], "input": u, "rhs": [x2, u], "output": x1, "operating_point": {x1: math.inf}},
     ParameterError, "must be finite"),
    ({"states": [x1, x2], "input": u, "rhs": [x2, u], "output": x1, "name": 3}, PlantDefinitionError,
     "name must be a string"),
]


@pytest.mark.parametrize("kwargs,error,match", BAD_DEFINITIONS)
def test_bad_definitions_raise(kwargs, error, match):
    with pytest.raises(error, match=match):
        fl.Plant.from_ode(**kwargs)


# --- relative degree and normal form ------------------------------------------------------------
def test_non_affine_input():
    p = fl.Plant.from_ode([x1, x2], u, [x2, -x1 + u + u**3 / 3], x1)
    nf = p.normal_form()
    assert p.relative_degree() == 2 and not nf.affine
    assert sp.simplify(nf.b - (1 + u**2)) == 0
    assert sp.simplify(nf.a + u**3 / sp.Integer(3) * 2 + x1) == 0  # a = sigma - b u
    assert sp.simplify(nf.a + nf.b * u - nf.sigma) == 0
    assert nf.coordinates == (x1, x2)


def test_b_vanishing_at_operating_point_names_point_and_coefficient():
    p = fl.Plant.from_ode([x1, x2], u, [x2, x1 * u], x1)
    with pytest.raises(RelativeDegreeError, match=r"b = d y\^\(2\)/du = x1 .*x1=0, x2=0, u=0"):
        p.relative_degree()
    q = fl.Plant.from_ode([x1, x2], u, [x2, x1 * u - 1], x1, operating_point={x1: 1.0})
    assert q.relative_degree() == 2 and q.u_eq == pytest.approx(1.0)


def test_input_never_appears():
    p = fl.Plant.from_ode([x1, x2, w], u, [x2, -x1, u], x1)
    with pytest.raises(RelativeDegreeError, match=r"does not appear in y, y', \.\.\., y\^\(3\)"):
        p.relative_degree()


def test_relative_degree_cancellation_detected_numerically_and_symbolically():
    # d y'/du = sin^2 + cos^2 - 1 = 0 identically: the input really enters at order 2.
    p = fl.Plant.from_ode([x1, x2], u, [x2 + (sp.sin(x2)**2 + sp.cos(x2)**2 - 1) * u, u], x1)
    assert p.relative_degree() == 2


def _zeros_by_pencil(A, B, C):
    n = A.shape[0]
    M = np.block([[A, B], [C, np.zeros((1, 1))]])
    N = np.block([[np.eye(n), np.zeros((n, 1))], [np.zeros((1, n + 1))]])
    ev = scipy.linalg.eigvals(M, N)
    return np.sort_complex(ev[np.isfinite(ev)])


@pytest.mark.filterwarnings("ignore::scipy.signal.BadCoefficients")
@pytest.mark.parametrize("wdot,expected,mp", [(w + x1, 1.0, False), (-w + x1, -1.0, True),
                                              (x1, 0.0, False)])
def test_zero_dynamics_against_transfer_function_zeros(wdot, expected, mp):
    p = chain3(wdot)
    nf = p.normal_form()
    A, B, C, D = p.linearization()
    z, _, _ = scipy.signal.ss2zpk(A, B, C, D)
    # the y-path does not see w, so the TF has a pole-zero cancellation at the w-pole: the invariant
    # zero is the w-eigenvalue; compare with the Rosenbrock pencil (independent) and w's pole.
    pencil = _zeros_by_pencil(A, B, C)
    assert nf.zero_dynamics_eigenvalues.real == pytest.approx([expected], abs=1e-9)
    assert pencil.real == pytest.approx([expected], abs=1e-9)
    assert z.size == 0 or z.real == pytest.approx([expected], abs=1e-6)
    assert nf.minimum_phase is mp
    report = nf.zero_dynamics_report()
    assert ("NOT minimum phase" in report) is (not mp)
    if expected > 0:
        assert "UNSTABLE" in report and "minimum_phase=False" in repr(nf)
    if expected == 0:
        assert "marginal" in report


@pytest.mark.filterwarnings("ignore::scipy.signal.BadCoefficients")
def test_zero_dynamics_of_random_linear_plants_match_ss2zpk():
    rng = np.random.default_rng(7)
    xs = sp.symbols("z0:4")
    for rho in (1, 2, 3):
        # build a system with relative degree rho in controllable canonical-like coordinates
        T = rng.normal(size=(4, 4))
        num = np.poly(rng.uniform(-3, 2, size=4 - rho))  # zeros
        den = np.poly(rng.uniform(-2, 1, size=4))
        Ac, Bc, Cc, _Dc = scipy.signal.tf2ss(num, den)
        A = np.linalg.solve(T, Ac @ T)
        B = np.linalg.solve(T, Bc)
        C = Cc @ T
        rhs = [sum(sp.Float(A[i, j]) * xs[j] for j in range(4)) + sp.Float(B[i, 0]) * u
               for i in range(4)]
        out = sum(sp.Float(C[0, j]) * xs[j] for j in range(4))
        p = fl.Plant.from_ode(list(xs), u, rhs, out)
        nf = p.normal_form()
        z, _, _ = scipy.signal.ss2zpk(A, B, C, np.zeros((1, 1)))
        assert nf.rho == rho
        assert np.sort_complex(nf.zero_dynamics_eigenvalues) == pytest.approx(np.sort_complex(z),
                                                                              abs=1e-6)
        assert nf.minimum_phase is bool(np.all(z.real < 0))


def test_internal_dynamics_symbolic():
    nf = chain3(-w + x1**2).normal_form()
    idyn = nf.internal_dynamics
    xi1 = idyn.xi[0]
    assert idyn.eta == (w,) and not idyn.depends_on_input
    assert sp.simplify(idyn.rhs[0] - (-w + xi1**2)) == 0
    assert sp.simplify(idyn.zero_dynamics[0] + w) == 0
    # eta is an original state whose derivative contains u: zero dynamics use u = -a/b.
    p = fl.Plant.from_ode([x1, x2, w], u, [x2 + w, u, -w + u], x1)
    idyn = p.normal_form().internal_dynamics
    assert idyn.depends_on_input
    assert idyn.zero_dynamics[0] == -idyn.eta[0] / 2  # linear zero at -1/2, cf. TF (2s+1)/...
    assert p.normal_form().zero_dynamics_eigenvalues.real == pytest.approx([-0.5])
    full = fl.plants.pendulum().normal_form()
    assert full.internal_dynamics is None and "equals the state dimension" in full.internal_dynamics_reason


# --- b bounds -----------------------------------------------------------------------------------
def test_b_bounds_two_variable_closed_form():
    p = fl.Plant.from_ode([x1, x2], u, [x2, (2 + sp.sin(x1) * sp.cos(x2)) * u], x1,
                          region={x1: (-2.0, 2.0), x2: (-1.0, 1.0)})
    lo, hi = p.b_bounds()
    # sin(x1) reaches -1 and +1 inside x1 in [-2, 2] (at -+pi/2, interior points), cos(x2) <= 1
    assert lo == pytest.approx(1.0, abs=1e-9)
    assert hi == pytest.approx(3.0, abs=1e-9)


def test_b_bounds_missing_ranges_and_sign_change():
    p = fl.Plant.from_ode([x1, x2], u, [x2, (1 + x1 + x2) * u], x1, region={x1: (-0.5, 0.5)})
    with pytest.raises(ParameterError, match="state x2 but the region .* no range"):
        p.b_bounds()
    q = fl.Plant.from_ode([x1, x2], u, [x2, u + u**3], x1)
    with pytest.raises(ParameterError, match="no input_range"):
        q.b_bounds()
    r = fl.Plant.from_ode([x1, x2], u, [x2, (1 + x1) * u], x1, region={x1: (-2.0, 2.0)})
    with pytest.raises(RelativeDegreeError, match=r"ranges over \[-1, 3\] .*changes sign"):
        r.b_bounds()
    assert r.b_bounds(allow_sign_change=True) == pytest.approx((-1.0, 3.0))


# --- CasADi vs SymPy ------------------------------------------------------------------------------
def _check_casadi(plant, n_points=25, seed=1):
    rng = np.random.default_rng(seed)
    fns = plant.casadi()
    nf = plant.normal_form()
    syms = [*plant.states, plant.input]
    f_np = sp.lambdify(syms, list(plant.rhs.subs(plant.params)), "numpy")
    h_np = sp.lambdify(syms, plant.output.subs(plant.params), "numpy")
    s_np = sp.lambdify(syms, nf.sigma.subs(plant.params), "numpy")
    b_np = sp.lambdify(syms, nf.b.subs(plant.params), "numpy")
    a_np = sp.lambdify(syms, nf.a.subs(plant.params), "numpy")
    for _ in range(n_points):
        x = rng.uniform(-1.5, 1.5, plant.n)
        v = float(rng.uniform(-2, 2))
        args = (*x, v)
        assert fns.f(x, v).full().ravel() == pytest.approx(np.asarray(f_np(*args), float), rel=1e-12, abs=1e-12)
        assert float(fns.h(x)) == pytest.approx(float(h_np(*args)), rel=1e-12, abs=1e-12)
        assert float(fns.sigma(x, v)) == pytest.approx(float(s_np(*args)), rel=1e-10, abs=1e-10)
        assert float(fns.b(x, v)) == pytest.approx(float(b_np(*args)), rel=1e-12, abs=1e-12)
        assert float(nf.b_fn(x, v)) == pytest.approx(float(b_np(*args)), rel=1e-12, abs=1e-12)
        assert float(nf.a_fn(x, v)) == pytest.approx(float(a_np(*args)), rel=1e-10, abs=1e-10)


@pytest.mark.parametrize("make", [
    lambda: fl.plants.trms_yaw(), lambda: fl.plants.trms_yaw(motor_lag=True),
    lambda: fl.plants.pendulum(), lambda: fl.plants.flexible_joint(),
    lambda: fl.Plant.from_ode([x1, x2], u, [x2, -x1 + u + u**3 / 3], x1),
])
def test_casadi_matches_sympy(make):
    _check_casadi(make())


def test_casadi_function_signatures():
    fns = fl.plants.flexible_joint().casadi()
    assert fns.f.name_in() == ["x", "u"] and fns.f.size1_in(0) == 4 and fns.f.size1_out(0) == 4
    assert fns.h.n_in() == 1 and fns.sigma.name() == "sigma" and fns.b.name() == "b"
    assert fl.plants.flexible_joint().casadi() is not fns  # a new plant: a new cache


def test_linearization_against_sympy_jacobian():
    p = fl.plants.flexible_joint()
    A, B, C, D = p.linearization()
    J = p.rhs.subs(p.params).jacobian(p.states).subs(dict(zip(p.states, p.x_op)))
    assert A == pytest.approx(np.array(J, dtype=float))
    assert B.ravel() == pytest.approx([0, 0, 0, 8e-2 / 3.7e-3])
    assert C.ravel().tolist() == [1.0, 0.0, 0.0, 0.0] and D.tolist() == [[0.0]]


# --- bridge -------------------------------------------------------------------------------------
def test_bridge_functions_match_numpy():
    a, b = sp.symbols("a b", real=True)
    exprs = [sp.Abs(a) * sp.sign(b), sp.tanh(a) + sp.sin(b) * sp.cos(a), sp.exp(a / 3),
             sp.log(1 + a**2), sp.sqrt(1 + b**2), 1 / sp.sqrt(2 + a**2), sp.atan(a), sp.atan2(a, b),
             sp.Heaviside(a), sp.Heaviside(b, 0), sp.Min(a, b, 0.3), sp.Max(a, b),
             sp.Piecewise((a, a > b), (b**2, sp.And(a <= b, b > 0)), (-1, True)),
             sp.pi * a**3 - (1 + b**2)**-2, sp.asinh(a), sp.cosh(b) - sp.sinh(a), sp.erf(a), sp.floor(a),
             sp.Piecewise((1, sp.Or(sp.Eq(a, 0), sp.Not(b < 0))), (0, True)), a**sp.Rational(3, 2) * 0 + sp.E]
    fn = to_casadi(exprs, [a, b], "many")
    ref = sp.lambdify([a, b], exprs, modules=["numpy", "scipy"])
    rng = np.random.default_rng(3)
    for va, vb in [*rng.normal(size=(30, 2)), (0.0, 0.5), (0.0, -0.5), (0.7, 0.0)]:
        got = fn(va, vb).full().ravel()
        want = np.array(ref(va, vb), dtype=float)
        assert got == pytest.approx(want, rel=1e-12, abs=1e-12), (va, vb)


def test_bridge_errors():
    a, b = sp.symbols("a b")
    with pytest.raises(PlantDefinitionError, match="function gamma"):
        to_casadi(sp.gamma(a), [a], "g")
    with pytest.raises(PlantDefinitionError, match=r"symbol\(s\) \['b'\]"):
        to_casadi(a + b, [a], "g")
    with pytest.raises(PlantDefinitionError, match="more than once"):
        to_casadi(a, [[a], [a]], "g")
    with pytest.raises(PlantDefinitionError, match="must be sympy Symbols"):
        to_casadi(a, [[a, 2]], "g")
    with pytest.raises(PlantDefinitionError, match="no otherwise branch"):
        to_casadi(sp.Piecewise((a, a > 0)), [a], "g")
    with pytest.raises(PlantDefinitionError, match="not a finite real"):
        to_casadi(a + sp.I, [a], "g")
    assert float(to_casadi(a * b, [a], "g", subs={b: 2.0})(3.0)) == 6.0


def test_unsupported_function_in_plant_is_named():
    with pytest.raises(PlantDefinitionError, match="besselj"):  # at construction (issue 12)
        fl.Plant.from_ode([x1, x2], u, [x2, sp.besselj(0, x1) + u], x1)
