"""SymPy constructs a plant cannot hold get a PlantDefinitionError naming them (issue 12)."""

from __future__ import annotations

import pytest
import sympy as sp

import fl_design as fl
from fl_design.errors import PlantDefinitionError

x1, x2, u = sp.symbols("x1 x2 u", real=True)
g = sp.Function("g")


@pytest.mark.parametrize("second, match", [
    (sp.Piecewise((x1, x1 > 0)) + u, r"rhs\[1\] has a Piecewise without an otherwise branch"),
    (sp.zoo * x1 + u, r"rhs\[1\] contains the constant zoo \(complex infinity\)"),
    (sp.oo * x1 + u, r"contains the constant oo \(infinity\)"),
    (-sp.oo * x1 + u, r"contains the constant -oo"),
    (sp.nan * x1 + u, r"contains the constant nan"),
    (1 / x1 + u, (r"rhs\[1\] is singular at the operating point \(x1=0, x2=0\): it evaluates "
                 "to zoo")),
    (sp.log(x1) + u, "singular at the operating point"),
    (sp.sqrt(x1 - 1) + u, r"takes the complex values .* the plant must be real there"),
    (g(x1) + u, r"rhs\[1\] calls the undefined function g\(x1\)"),
    (sp.Derivative(x1 * x2, x1) + u, r"rhs\[1\] contains the unevaluated Derivative .*\.doit\(\)"),
    (sp.Integral(x1, x1) + u, "unevaluated Integral"),
    (sp.gamma(x1 + 2) + u - 1, "the function gamma .* has no CasADi translation; supported"),
])
def test_unsupported_constructs_are_named(second, match):
    with pytest.raises(PlantDefinitionError, match=match):
        fl.Plant.from_ode([x1, x2], u, [x2, second], x1)


def test_the_output_is_checked_too():
    with pytest.raises(PlantDefinitionError, match="output calls the undefined function g"):
        fl.Plant.from_ode([x1, x2], u, [x2, u], g(x1))


def test_strings_name_the_declared_symbols_with_their_assumptions():
    plant = fl.Plant.from_ode([x1, x2], u, ["x2", "-x1 + u"], x1)  # x1, x2, u are real=True
    assert list(plant.rhs) == [x2, -x1 + u] and plant.relative_degree() == 2


def test_sympy_twins_with_other_assumptions_say_why_they_differ():
    plain = sp.Symbol("u")
    with pytest.raises(PlantDefinitionError, match=r"symbol u appears with assumptions \{\} but "
                       r"the state/input/parameter u has \{'real': True\}.*same Symbol objects"):
        fl.Plant.from_ode([x1, x2], u, [x2, -x1 + plain], x1)


def test_strings_with_plain_symbols_still_work():
    a, b, v = sp.symbols("x1 x2 u")
    assert fl.Plant.from_ode([a, b], v, ["x2", "-x1 + u"], "x1").relative_degree() == 2


def test_a_piecewise_with_otherwise_and_a_singularity_away_from_the_point_are_fine():
    pw = sp.Piecewise((x1, x1 > 0), (0, True))
    assert fl.Plant.from_ode([x1, x2], u, [x2, pw + u], x1).relative_degree() == 2
    plant = fl.Plant.from_ode([x1, x2], u, [x2, 1 / x1 - 1 + u], x1, operating_point={x1: 1.0})
    assert plant.u_eq == 0.0
