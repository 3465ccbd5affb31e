"""Bounded derivations and structural tests that scale: size/degree bounds refuse
``(x1 + x2 + u)**1000`` before expanding, a time budget stops a long derivation with a clear
error, names that alias under NFKC are refused, and b != 0 is decided by interval enclosures."""

from __future__ import annotations

import time

import numpy as np
import pytest
import sympy as sp

import fl_design as fl
from fl_design.errors import DerivationTimeoutError, ExpressionError, RelativeDegreeError
from fl_design.symbolic import _normal_form
from fl_design.symbolic._enclosure import enclose
from fl_design.symbolic._grammar import MAX_TERMS, check_size, parse_expression

x1, x2, u = sp.symbols("x1 x2 u", real=True)
NAMES = {"x1": x1, "x2": x2, "u": u}


def _plant(states, rhs, output, **kw):
    return fl.Plant([sp.Symbol(s, real=True) for s in states], u, rhs, output, **kw)


@pytest.mark.parametrize("text", ["(x1 + x2 + u)**1000 - x1", "(x1 + x2 + u + 1)**60",
                                  "sin((x1 + x2 + u)**900)", "(x1 + u)**300",
                                  "((x1 + x2)**40 + u)**40"])
def test_expressions_that_expand_past_the_bounds_are_refused_at_once(text):
    start = time.perf_counter()
    with pytest.raises(ExpressionError, match=r"expands to .* terms|polynomial degree"):
        parse_expression(text, NAMES)
    assert time.perf_counter() - start < 1.0


def test_the_term_count_is_the_number_of_monomials():
    # (a + b + c)**n has C(n + 2, 2) monomials: 5050 for n = 99 (refused), 4950 for n = 98
    parse_expression("(x1 + x2 + u)**98", NAMES)
    with pytest.raises(ExpressionError, match="5050 terms"):
        parse_expression("(x1 + x2 + u)**99", NAMES)
    assert len(sp.Add.make_args(sp.expand((x1 + x2 + u)**20))) == 231
    check_size((x1 + x2 + u)**20)  # 231 terms: fine
    assert MAX_TERMS == 5000


def test_a_sympy_plant_is_bounded_too_and_a_deep_tree_refused():
    with pytest.raises(ExpressionError, match="terms"):
        fl.Plant.from_ode([x1, x2], u, [x2, (x1 + x2 + u)**1000 - x1], x1)
    deep = u
    for _ in range(500):
        deep = sp.sin(deep, evaluate=False)
    with pytest.raises(ExpressionError, match=r"rhs\[1\]: the expression tree is more than 200"):
        fl.Plant.from_ode([x1, x2], u, [x2, deep], x1)


def test_the_plant_with_the_25_character_expression_fails_in_under_a_second():
    start = time.perf_counter()
    with pytest.raises(ExpressionError, match=r"rhs\[1\].*expands to more than 5000 terms"):
        _plant(["x1", "x2"], ["x2", "(x1 + x2 + u)**1000 - x1"], "x1").relative_degree()
    assert time.perf_counter() - start < 1.0


def test_a_derivation_past_its_budget_stops_with_a_clear_error(monkeypatch):
    monkeypatch.setenv("FL_DESIGN_DERIVE_SECONDS", "0.3")
    monkeypatch.setattr(_normal_form, "_lie_chain", lambda plant: time.sleep(30))
    start = time.perf_counter()
    with pytest.raises(DerivationTimeoutError, match=r"relative degree of plant .* budget of "
                                                     r"0.3 s.*FL_DESIGN_DERIVE_SECONDS"):
        _normal_form.lie_chain(fl.plants.pendulum())
    assert time.perf_counter() - start < 3.0


@pytest.mark.parametrize("names", [["h", "\u210e"], ["\uff58", "x"], ["\ufb01", "fi"]])
def test_names_equal_under_nfkc_are_refused(names):
    with pytest.raises(ExpressionError, match="same name once Unicode-normalized"):
        _plant(names, [names[1], "u"], names[0])


def test_a_state_named_like_a_function_is_refused():
    with pytest.raises(ExpressionError, match="'sin' is a function of the expression grammar"):
        _plant(["sin", "x2"], ["x2", "u"], "sin")


@pytest.mark.parametrize("input_range", [None, (-2.0, 2.0), (-3.0, 3.0)])
def test_a_large_b_elsewhere_does_not_hide_b_at_the_operating_point(input_range):
    plant = _plant(["x1"], ["-x1 + u + u**40"], "x1", input_range=input_range)
    assert plant.relative_degree() == 1
    b = plant.normal_form().b
    assert float(b.subs(u, plant.u_eq)) == 1.0  # independent: b = 1 + 40 u^39 at u = 0


def test_b_vanishing_at_the_operating_point_is_still_refused():
    with pytest.raises(RelativeDegreeError, match="relative degree is not defined there"):
        _plant(["x1"], ["-x1 + x1*u"], "x1").relative_degree()


@pytest.mark.parametrize("expr", [1 + 40 * u**39, sp.sin(x1) * sp.exp(u) - x1**3,
                                  sp.atan(x1 * u) + sp.cosh(u) / (2 + sp.cos(x1)),
                                  sp.sqrt(1 + x1**2) * sp.tanh(u) - sp.Abs(x1 - u)])
def test_enclosures_contain_every_sampled_value(expr):
    box = {x1: (-1.5, 0.7), u: (-1.1, 1.3)}
    lo, hi = enclose(expr, box)
    fn = sp.lambdify([x1, u], expr, "numpy")
    rng = np.random.default_rng(3)
    xs, us = rng.uniform(-1.5, 0.7, 20_000), rng.uniform(-1.1, 1.3, 20_000)
    vals = np.concatenate([np.broadcast_to(fn(xs, us), xs.shape),
                           [float(expr.subs({x1: a, u: c})) for a in box[x1] for c in box[u]]])
    assert lo <= vals.min() and vals.max() <= hi
