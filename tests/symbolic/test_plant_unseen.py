"""Plants the project had not seen (issue 31): kinks and roots with an operating point, symbols
with any assumptions, a model undefined in its region, and the method's assumptions.

Every number is checked against a closed form (hover thrust ``m g``, ``b = 1/m``, the zero
dynamics' eigenvalue) or an independent evaluation of the user's expression.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

import fl_design as fl
from fl_design.errors import AssumptionError, PlantDefinitionError
from fl_design.symbolic._assumptions import assumption_failures, check_assumptions

M, G, KD = 1.2, 9.81, 0.3


def _drag(kind: str, z, vz, m, g, kd):
    return {"Abs": kd * vz * sp.Abs(vz), "sign": kd * vz ** 2 * sp.sign(vz),
            "sqrt": kd * vz * sp.sqrt(vz ** 2 + 1e-6),
            "Max": kd * (sp.Max(vz, 0) ** 2 - sp.Max(-vz, 0) ** 2),
            "Min": kd * (sp.Min(vz, 0) ** 2) * -1 + kd * sp.Max(vz, 0) ** 2,
            "Piecewise": sp.Piecewise((kd * vz ** 2, vz > 0), (-kd * vz ** 2, True))}[kind]


@pytest.mark.parametrize("kind, assume", [
    *[(k, a) for k in ("Abs", "sign") for a in ({}, {"real": True}, {"positive": True})],
    *[(k, {}) for k in ("sqrt", "Max", "Min", "Piecewise")]])
def test_kinks_and_roots_with_an_operating_point_whatever_the_assumptions(kind, assume):
    """The quadrotor's altitude with quadratic drag: hover thrust m g, b = 1/m, whatever the
    user declared about the symbols (README style: plain ``sp.symbols``)."""
    z, vz, u = sp.symbols("z vz T", **({} if assume.get("positive") else assume))
    m, g, kd = sp.symbols("m g kd", **assume)
    rhs = [vz, u / m - g - _drag(kind, z, vz, m, g, kd) / m]
    plant = fl.Plant.from_ode([z, vz], u, rhs, z, params={m: M, g: G, kd: KD},
                              region={z: (0.0, 20.0), vz: (-10.0, 10.0)},
                              input_range=(0.0, 30.0), operating_point={z: 2.0})
    assert plant.u_eq == pytest.approx(M * G, rel=1e-12)  # hover: thrust = weight
    assert plant.x_op.tolist() == [2.0, 0.0]
    assert plant.b_bounds() == pytest.approx((1 / M, 1 / M), rel=1e-12)
    A = plant.linearization()[0]  # the drag's slope at vz = 0 is 0 (2 kd |vz| / m)
    assert A == pytest.approx(np.array([[0.0, 1.0], [0.0, 0.0]]), abs=1e-3)


def test_an_equilibrium_away_from_the_kink_has_the_drag_slope_of_the_closed_form():
    """Held at vz = 1 (climbing), the Jacobian's drag term is -2 kd |vz| / m (closed form)."""
    z, vz, u = sp.symbols("z vz T")  # no assumptions
    plant = fl.Plant.from_ode([z, vz], u, [vz - 1, u / M - G - KD * vz * sp.Abs(vz) / M], z,
                              region={z: (0.0, 20.0), vz: (-10.0, 10.0)},
                              input_range=(0.0, 30.0), operating_point={z: 2.0})
    assert plant.x_op[1] == pytest.approx(1.0)
    assert plant.u_eq == pytest.approx(M * G + KD, rel=1e-12)
    assert plant.linearization()[0][1, 1] == pytest.approx(-2 * KD / M, rel=1e-9)


def test_a_region_where_the_model_is_undefined_is_named_with_a_failing_point():
    """b ~ sqrt(Ps - p) with the region reaching beyond Ps: refused, and at the point named
    the expression is indeed not a finite real number (evaluated here by the math module)."""
    x, v, p, u = sp.symbols("x v p u")
    ps = 10.0
    with pytest.raises(PlantDefinitionError, match="is not defined at the point") as err:
        fl.Plant.from_ode([x, v, p], u, [v, p - v, u * sp.sqrt(ps - p) - 3 * v - p], x,
                          region={x: (-1, 1), v: (-1, 1), p: (-5, 20)}, input_range=(-1, 1),
                          operating_point={x: 0.5})
    text = str(err.value)
    p_at = float(text.split("p=")[1].split(",")[0].split(")")[0])
    with pytest.raises(ValueError):
        math.sqrt(ps - p_at)  # the point named is outside sqrt's domain
    assert "shrink the region" in text


def test_non_minimum_phase_chain_is_refused_with_its_zero_dynamics_eigenvalue():
    """w' = w + x1, x1' = x2, x2' = u, y = x1: holding y = 0 leaves w' = w, eigenvalue 1."""
    w, x1, x2, u = sp.symbols("w x1 x2 u")
    plant = fl.Plant.from_ode([w, x1, x2], u, [w + x1, x2, u], x1,
                              region={w: (-10, 10), x1: (-1, 1), x2: (-5, 5)},
                              input_range=(-10, 10))
    A, B, C, _ = plant.linearization()  # the transfer numerator C adj(sI - A) B
    num = sp.Poly(sp.simplify((sp.Matrix(C) * (sp.Symbol("s") * sp.eye(3) - sp.Matrix(A))
                               .adjugate() * sp.Matrix(B))[0]), sp.Symbol("s"))
    assert [complex(r) for r in num.nroots()] == [1.0]  # the invariant zero, independently
    with pytest.raises(AssumptionError, match=r"NOT minimum phase.*eigenvalue\(s\) \[1\]"):
        check_assumptions(plant, what="test")
    with pytest.raises(AssumptionError, match="fl.tune refused"):
        fl.tune(plant)


def test_b_changing_sign_is_refused_at_a_point_where_b_has_the_other_sign():
    th, om, u = sp.symbols("th om u")
    plant = fl.Plant.from_ode([th, om], u, [om, -9.81 * sp.sin(th) + sp.cos(th) * u], th,
                              input_range=(-5.0, 5.0), region={th: (-3.0, 3.0), om: (-5.0, 5.0)})
    (msg,) = assumption_failures(plant)
    assert "vanishes or changes sign" in msg
    th_at = float(msg.split("th=")[1].split(",")[0])
    assert math.cos(th_at) < 0 < math.cos(0.0)  # b = cos(th): the other sign there
    assert assumption_failures(fl.plants.trms_yaw()) == ()


def test_the_zero_dynamics_from_the_pencil_agree_with_the_normal_form():
    """The refusal's eigenvalues (Rosenbrock pencil, SciPy) equal the normal form's (kernel of
    the observability chain): the gantry crane's two stable zeros."""
    from fl_design.symbolic._assumptions import zero_dynamics_eigenvalues

    plant = fl.plants.cart_pendulum()
    want = plant.normal_form().zero_dynamics_eigenvalues
    assert zero_dynamics_eigenvalues(plant) == pytest.approx(want, rel=1e-9)
    assert np.all(want.real < 0)
