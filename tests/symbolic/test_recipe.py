"""A library plant known by its recipe: the same plant as its SymPy definition built eagerly, a key
that follows every value and the code, with_params and pickling without surprises."""

from __future__ import annotations

import dataclasses
import math
import pickle

import numpy as np
import pytest
import sympy

import fl_design as fl
from fl_design.errors import ParameterError, PlantDefinitionError
from fl_design.symbolic import _derivation_cache as _stored
from fl_design.symbolic import _recipe
from fl_design.symbolic._recipe import Recipe

from .test_derivation_cache import _same

LIBRARY = {"trms_yaw": lambda: fl.plants.trms_yaw(),
           "trms_yaw_motor_lag": lambda: fl.plants.trms_yaw(motor_lag=True),
           "pendulum_c01": lambda: fl.plants.pendulum().with_params(c=0.1),
           "flexible_joint": fl.plants.flexible_joint,
           "cart_pendulum_inverted": lambda: fl.plants.cart_pendulum(inverted=True),
           "maglev": fl.plants.maglev}


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("FL_DESIGN_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(_stored, "_WARNED", set())
    return tmp_path / "cache"


def _eager(plant):
    """The same plant from its SymPy definition, as a user would write it (not a recipe)."""
    kw = plant._recipe.build()
    return fl.Plant(**kw, name=plant.name, input_range=plant.input_range)


def _quantities(plant) -> dict:
    rho = plant.relative_degree()
    out = {"repr": repr(plant), "n": plant.n, "x_op": plant.x_op, "u_eq": plant.u_eq, "rho": rho,
           "params": plant.params, "region": plant.region, "input_range": plant.input_range,
           "states": plant.states, "rhs": plant.rhs, "output": plant.output,
           "derivatives": plant.output_derivatives(rho), "casadi": plant.casadi(),
           "linearization": plant.linearization(), "nf": plant.normal_form(),
           "ranges": plant._state_ranges(), "zero_dynamics": plant._zero_dynamics()}
    if plant.name != "cart_pendulum_inverted":  # b has a known sign on the others' regions
        out["bounds"] = plant.b_bounds()
    return out


@pytest.mark.parametrize("name", sorted(LIBRARY))
def test_a_recipe_plant_derives_what_its_eager_twin_derives(name, cache):
    recipe_plant = LIBRARY[name]()  # an empty cache: the definition is built to derive
    assert recipe_plant._recipe is not None and recipe_plant._def is not None
    eager = _eager(recipe_plant)
    assert eager._recipe is None and eager._store.key != recipe_plant._store.key
    _same(_quantities(eager), _quantities(recipe_plant))
    loaded = LIBRARY[name]()  # from the cache this time: nothing built, the same quantities
    assert loaded._def is None
    _same(_quantities(eager), _quantities(loaded))


@pytest.mark.parametrize("name", sorted(LIBRARY))
def test_the_state_ranges_read_without_sympy_are_the_region(name, cache):
    LIBRARY[name]()
    plant = LIBRARY[name]()  # loaded: the ranges come from the cache, nothing built
    ranges, y = plant._state_ranges()
    assert plant._def is None
    region = plant.region
    assert ranges == {s.name: region.get(s) for s in plant.states}
    assert y == str(plant.output) and plant.output in plant.states
    x, u = sympy.symbols("x u")
    user = fl.Plant.from_ode([x], u, [-x + u], 2 * x, region={x: (-1, 1)})
    assert user._state_ranges() == ({"x": (-1.0, 1.0)}, None)  # the output is not a state


def test_with_params_of_a_recipe_plant_is_the_eager_with_params(cache):
    crane = fl.plants.cart_pendulum()
    for plant in (crane, _eager(crane)):
        q = plant.with_params(c=3.0, m=0.25)
        assert {str(k): v for k, v in q.params.items()}["c"] == 3.0
    _same(_quantities(crane.with_params(c=3.0, m=0.25)),
          _quantities(_eager(crane).with_params(c=3.0, m=0.25)))
    # the maglev holds its old operating point, which is no longer an equilibrium: both refuse
    errors = []
    for plant in (fl.plants.maglev(), _eager(fl.plants.maglev())):
        with pytest.raises(PlantDefinitionError, match="not an equilibrium") as err:
            plant.with_params(m=0.07)
        errors.append(str(err.value))
    assert errors[0] == errors[1]
    for plant in (crane, _eager(crane)):
        with pytest.raises(PlantDefinitionError, match=r"unknown parameter\(s\) \['zz'\]"):
            plant.with_params(zz=1.0)
        with pytest.raises(ParameterError, match=r"params\[c\]"):
            plant.with_params(c=float("nan"))


def test_a_recipe_plant_pickles_as_its_recipe(cache):
    p = fl.plants.maglev(y0=5e-3)
    q = pickle.loads(pickle.dumps(p))
    assert q._recipe == p._recipe and q._def is None
    _same(_quantities(p), _quantities(q))


def test_the_key_follows_every_value_of_the_recipe():
    base = fl.plants.trms_yaw(motor_lag=True)._recipe
    key = base.key()
    assert len(key) == 64 and key == fl.plants.trms_yaw(motor_lag=True)._recipe.key()
    params = dict(base.params)
    variants = {
        "params": tuple({**params, "I2": math.nextafter(params["I2"], 1)}.items()),  # one ulp
        "options": (("motor_lag", False),), "name": "other", "input_range": (-2.5, 2.0),
        "operating_point": (("phi", 0.0), ("phi_dot", 0.0), ("tau", 0.0)),
        "definition": "fl_design.plants._rotor:other"}
    for field, value in variants.items():
        assert dataclasses.replace(base, **{field: value}).key() != key, field
    assert fl.plants.trms_yaw(I2=0.021)._recipe.key() != fl.plants.trms_yaw()._recipe.key()


def test_the_key_follows_the_code_and_the_plant_sources(monkeypatch, tmp_path):
    recipe = fl.plants.pendulum()._recipe
    key = recipe.key()
    assert recipe.key(code="0" * 64) != key != recipe.key(code="1" * 64)
    with monkeypatch.context() as m:  # the deriving code changed
        m.setattr(_recipe, "code_version", lambda: "0" * 64)
        assert recipe.key() != key
    with monkeypatch.context() as m:  # the plants' package changed
        m.setattr(_recipe, "package_version", lambda folder: "0" * 64)
        assert recipe.key() != key
    assert recipe.key() == key
    # an edited source file changes its package's version
    source = tmp_path / "_plant.py"
    source.write_text("A = 1\n")
    before = _recipe.package_version.__wrapped__(str(tmp_path))
    source.write_text("A = 2\n")
    assert _recipe.package_version.__wrapped__(str(tmp_path)) != before


@pytest.mark.parametrize("definition, match", [
    ("os:system", "inside fl_design"), ("fl_design.plants._rotor", "module:function"),
    ("fl_design.plants._rotor:not an identifier", "module:function")])
def test_a_recipe_names_a_function_of_fl_design(definition, match):
    with pytest.raises(PlantDefinitionError, match=match):
        Recipe(definition, ())


def test_a_recipe_holds_plain_values_only():
    with pytest.raises(PlantDefinitionError, match="plain value"):
        Recipe("fl_design.plants._rotor:trms_yaw_definition", (("I2", object()),))


@pytest.mark.parametrize("order", [1, 2, 3])
def test_the_cached_coordinate_function_is_the_output_derivatives(order, cache):
    plant = fl.plants.trms_yaw(motor_lag=True)  # rho = 3: orders below it are unmodeled views
    fn = plant._coordinates_function(order)
    again = fl.plants.trms_yaw(motor_lag=True)._coordinates_function(order)  # from the cache
    rng = np.random.default_rng(3)
    for point in rng.uniform(-2, 2, (10, 3)):
        expected = [float(sympy.N(d.subs(plant.params).subs(dict(zip(plant.states, point)))))
                    for d in plant.output_derivatives(order - 1)]
        np.testing.assert_allclose(fn(point).full().ravel(), expected, rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(fn(point).full(), again(point).full())
    with pytest.raises(ParameterError):
        plant._coordinates_function(0)
