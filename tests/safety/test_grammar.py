"""Expression strings never run Python: the grammar of fl_design.symbolic._grammar.

Payloads from issue 19 (``__import__``, exec, eval, lambda, open().write, ``2**2**40``,
``factorial(10**8)``, deep nesting) and our own; each must be a clear ExpressionError, fast,
with no side effect; valid plant expressions must give the same SymPy objects as written in
Python.
"""

from __future__ import annotations

import json
import time

import pytest
import sympy as sp

import fl_design as fl
from fl_design.app import build_plant, parse_config
from fl_design.app._config import ConfigError
from fl_design.errors import ExpressionError, PlantDefinitionError
from fl_design.symbolic._grammar import MAX_DEPTH, MAX_EXPONENT, parse_expression

x1, x2, u, k = sp.symbols("x1 x2 u k", real=True)
NAMES = {"x1": x1, "x2": x2, "u": u, "k": k}

PAYLOADS = [
    ("__import__('os').system('touch {p}') + u", "not an allowed function"),
    ("exec(\"open('{p}', 'w').write('x')\")", "calls exec"),
    ("eval(\"open('{p}', 'w')\")", "calls eval"),
    ("(lambda: open('{p}', 'w'))()", "not an allowed function"),
    ("open('{p}', 'w').write('x')", "not an allowed function"),
    ("x1.__class__.__mro__", "attribute access"),
    ("[c for c in ().__class__.__bases__]", "comprehension"),
    ("x1[0]", "subscript"),
    ("globals()", "calls globals"),
    ("getattr(x1, 'func')", "calls getattr"),
    ("Symbol('{p}')", "calls Symbol"),
    ("sin(x=1)", "positional arguments only"),
    ("sin(*[x1])", "positional arguments only"),
    ("2**2**40", f"exponent 1099511627776 exceeds the limit of {MAX_EXPONENT}"),
    ("factorial(10**8)", "calls factorial"),
    ("x1**(10**10)", "exponent 10000000000 exceeds"),
    ("10**999 * 10**999", "digits exceeds the limit"),
    ("(10**64)**64", "digits, above the limit"),
    ("(" * 250 + "x1" + ")" * 250, "too many nested parentheses"),
    ("-" * 5000 + "x1", "too complex|nested more than"),
    ("x1" + "**x1" * 500, f"nested more than {MAX_DEPTH} levels"),
    ("sin(" * 200 + "x1" + ")" * 200, "nested more than|not a valid expression"),
    ("x1 + " * 3000 + "u", "characters, above the limit"),
    ("1e999", "not finite"),
    ("True + u", "not a real number"),
    ("1j*u", "not a real number"),
    ("'u'", "not a real number"),
    ("x1 ^ 2", r"operator \^ is not allowed"),
    ("x1 // 2", "operator // is not allowed"),
    ("x1 if u else x2", "conditional expression"),
    ("x1 < u", "comparison"),
    ("(y := 1)", "assignment|not a valid"),
    ("f'{{x1}}'", "f-string"),
    ("", "empty expression"),
    ("x1 +", "not a valid expression"),
    ("sin", "used without arguments"),
    ("atan2(x1)", "takes 2 argument"),
]


@pytest.mark.parametrize("text, match", PAYLOADS)
def test_payloads_are_clear_errors_without_side_effects(text, match, tmp_path):
    marker = tmp_path / "pwned"
    t0 = time.perf_counter()
    with pytest.raises(ExpressionError, match=match):
        parse_expression(text.format(p=marker), NAMES, what="rhs[1]")
    assert time.perf_counter() - t0 < 2.0
    assert not marker.exists()


@pytest.mark.parametrize("text, expected", [
    ("-k*sin(x1) + u", -k * sp.sin(x1) + u),
    ("x2", x2),
    ("-1e10*x1 + u", -1e10 * x1 + u),
    ("x1**30 + u", x1**30 + u),
    ("2**3**2 * x1", 512 * x1),
    ("1 - 2 - 3 + x1/2/2", -4 + x1 / 4),
    ("atan2(x1, x2) + Abs(u) + sign(x1)*sqrt(x2**2) + exp(-x1)*log(2)",
     sp.atan2(x1, x2) + sp.Abs(u) + sp.sign(x1) * sp.sqrt(x2**2) + sp.exp(-x1) * sp.log(2)),
    ("pi*E*tanh(x1) + cosh(x2) - sinh(u) + tan(atan(x1))",
     sp.pi * sp.E * sp.tanh(x1) + sp.cosh(x2) - sp.sinh(u) + x1),
    (" + ".join(["x1"] * 1500), 1500 * x1),  # a long sum is one level deep, not 1500
    ("*".join(["x1"] * 50), x1**50),
    ("-(-(-x1))", -x1),
])
def test_valid_expressions_equal_the_python_sympy_ones(text, expected):
    assert sp.simplify(parse_expression(text, NAMES) - expected) == 0


def test_a_typo_names_the_unknown_symbol_the_declared_ones_and_the_closest():
    a1 = sp.Symbol("A1")
    with pytest.raises(ExpressionError, match=r"unknown symbol 'Al' \(did you mean 'A1'\?\); "
                       r"the declared names are \['A1', 'u'\]"):
        parse_expression("Al*u", {"A1": a1, "u": u}, what="rhs[0]")


def test_a_declared_name_shadows_a_constant():
    e = sp.Symbol("E")
    assert parse_expression("E + 1", {"E": e}) == e + 1


def test_plant_strings_use_the_grammar_and_never_run_code(tmp_path):
    marker = tmp_path / "pwned"
    with pytest.raises(PlantDefinitionError, match="rhs\\[1\\].*not an allowed function"):
        fl.Plant.from_ode([x1, x2], u,
                          ["x2", f"__import__('os').system('touch {marker}') + u"], "x1")
    assert not marker.exists()
    plant = fl.Plant.from_ode([x1, x2], u, ["x2", "-k*sin(x1) + u"], "x1", params={"k": 2.0})
    assert plant.relative_degree() == 2


def _config(second: str) -> str:
    return ('[plant]\nstates = ["x1", "x2"]\ninput = "u"\n'
            f'rhs = ["x2", {json.dumps(second)}]\noutput = "x1"\nparams = {{k = 1.0}}\n')


@pytest.mark.parametrize("text", [p for p, _ in PAYLOADS[:8]] + ["Al + u"])
def test_config_strings_are_config_errors(text, tmp_path):
    marker = tmp_path / "pwned"
    with pytest.raises(ConfigError, match=r"\[plant\] rhs\[1\]"):
        build_plant(parse_config(_config(text.format(p=marker))))
    assert not marker.exists()


def test_config_plant_from_strings_equals_the_python_one():
    plant = build_plant(parse_config(_config("-k*sin(x1) + u")))
    s1, _ = plant.states
    assert sp.simplify(plant.rhs[1] - (-sp.Symbol("k", real=True) * sp.sin(s1) + plant.input)) == 0
