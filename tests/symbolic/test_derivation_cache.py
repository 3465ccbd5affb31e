"""Plant derivations cached on disk by content: identical to a fresh derivation, self-healing."""

from __future__ import annotations

import dataclasses
import math
import pickle
import warnings
from pathlib import Path

import casadi as ca
import numpy as np
import pytest
import sympy as sp

import fl_design as fl
from fl_design._cache import SIDECAR_SUFFIX, write_verified
from fl_design.errors import CacheWarning
from fl_design.symbolic import _derivation_cache as _stored
from fl_design.symbolic import _normal_form, _plant, _plant_derived

QUANTITIES = ("header", "fh", "rho", "chain", "sigma_b", "bounds0", "nf")


def _internal():
    x1, x2, w, u = sp.symbols("x1 x2 w u", real=True)
    return fl.Plant.from_ode([x1, x2, w], u, [x2, -x1 + (2 + sp.cos(w)) * u, -w + x1], x1,
                             region={x1: (-1, 1), x2: (-1, 1), w: (-2, 2)},
                             input_range=(-3, 3), operating_point={"y": 0.2}, name="internal")


PLANTS = {"trms_lag": lambda: fl.plants.trms_yaw(motor_lag=True),
          "flexible_joint": fl.plants.flexible_joint, "internal": _internal,
          "pendulum": fl.plants.pendulum}  # its a = -(c w + g sin(th)/l) regroups when unpickled


def _derive_all(plant) -> dict:
    return {"x_op": plant.x_op, "u_eq": plant.u_eq, "rho": plant.relative_degree(),
            "derivatives": plant.output_derivatives(plant.relative_degree()),
            "casadi": plant.casadi(), "bounds": plant.b_bounds(), "nf": plant.normal_form()}


def _same(a, b, where="") -> None:
    """Equal structure, equal SymPy trees, bitwise equal arrays, CasADi equal on random points."""
    if isinstance(a, ca.Function):
        assert isinstance(b, ca.Function) and a.name() == b.name(), where
        assert [a.size_in(i) for i in range(a.n_in())] == [b.size_in(i) for i in range(b.n_in())]
        rng = np.random.default_rng(1)
        for _ in range(20):
            args = [rng.uniform(-2, 2, a.size_in(i)) for i in range(a.n_in())]
            for i in range(a.n_out()):
                np.testing.assert_array_equal(np.array(a(*args)[i] if a.n_out() > 1 else
                                                       a(*args)), np.array(b(*args)[i] if
                                                       b.n_out() > 1 else b(*args)), where)
    elif dataclasses.is_dataclass(a):
        assert type(a) is type(b), where
        for f in dataclasses.fields(a):
            _same(getattr(a, f.name), getattr(b, f.name), f"{where}.{f.name}")
    elif isinstance(a, sp.Basic):
        assert isinstance(b, sp.Basic) and sp.srepr(a) == sp.srepr(b) and a == b, where
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype, where
        np.testing.assert_array_equal(a, b, where)
    elif isinstance(a, dict):
        assert list(a) == list(b), where
        for k in a:
            _same(a[k], b[k], f"{where}[{k}]")
    elif isinstance(a, (tuple, list)):
        assert type(a) is type(b) and len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b)):
            _same(x, y, f"{where}[{i}]")
    elif isinstance(a, float) and math.isnan(a):
        assert isinstance(b, float) and math.isnan(b), where
    else:
        assert type(a) is type(b) and a == b, (where, a, b)


@pytest.fixture
def cache(tmp_path, monkeypatch) -> Path:
    monkeypatch.setenv("FL_DESIGN_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(_stored, "_WARNED", set())
    return tmp_path / "cache"


def _forbid_derivation(monkeypatch) -> None:
    def fail(*a, **k):
        pytest.fail("derived again although cached")
    monkeypatch.setattr(_plant, "operating_point_and_input", fail)
    for name in ("lie_chain", "derive_normal_form", "b_bounds", "to_casadi"):
        monkeypatch.setattr(_plant_derived, name, fail)


@pytest.mark.parametrize("name", sorted(PLANTS))
def test_cached_derivations_are_identical_to_fresh_ones(name, cache, tmp_path, monkeypatch):
    make = PLANTS[name]
    monkeypatch.setenv("FL_DESIGN_CACHE", str(_regular_file(tmp_path)))  # no cache: computed
    fresh = _derive_all(make())
    monkeypatch.setenv("FL_DESIGN_CACHE", str(cache))
    first = _derive_all(make())  # computed, stored
    stored = sorted(p.name.split("_", 2)[2] for p in cache.glob("plant_*.pkl"))
    assert stored == sorted(q + ".pkl" for q in QUANTITIES)
    with monkeypatch.context() as m:
        _forbid_derivation(m)
        again = _derive_all(make())  # every quantity from the cache
    _same(fresh, first)
    _same(fresh, again)
    assert not again["x_op"].flags.writeable


def _regular_file(tmp_path: Path) -> Path:
    path = tmp_path / "not-a-directory"
    path.write_text("x")
    return path


def test_an_unusable_cache_is_bypassed_silently(tmp_path, monkeypatch):
    monkeypatch.setenv("FL_DESIGN_CACHE", str(_regular_file(tmp_path)))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        plant = fl.plants.trms_yaw()
        assert plant.relative_degree() == 2 and plant.b_bounds()[0] > 3.5


def _corrupt_bytes(path: Path) -> None:
    path.write_bytes(path.read_bytes()[:-7])  # truncated: no longer matches its sidecar


def _not_a_pickle(path: Path) -> None:  # matches its sidecar but does not load
    write_verified(path.name, b"garbage", cache_dir=path.parent)


def _wrong_type(path: Path) -> None:  # loads, but not the quantity's type
    write_verified(path.name, pickle.dumps({"x": 1}), cache_dir=path.parent)


def _no_sidecar(path: Path) -> None:
    Path(str(path) + SIDECAR_SUFFIX).unlink()


@pytest.mark.parametrize("damage", [_corrupt_bytes, _not_a_pickle, _wrong_type, _no_sidecar])
def test_a_corrupted_entry_is_recomputed_with_one_warning(damage, cache, monkeypatch):
    reference = _derive_all(fl.plants.trms_yaw())
    for q in ("chain", "bounds0"):
        damage(next(cache.glob(f"plant_*_{q}.pkl")))
    calls = []
    original = _plant_derived.lie_chain
    monkeypatch.setattr(_plant_derived, "lie_chain", lambda p: calls.append(1) or original(p))
    with pytest.warns(CacheWarning, match="corrupted") as record:
        again = _derive_all(fl.plants.trms_yaw())
    assert len([w for w in record if w.category is CacheWarning]) == 1  # once per process
    assert calls == [1]
    _same(reference, again)
    with warnings.catch_warnings():  # rewritten: a new process reads it again
        warnings.simplefilter("error")
        monkeypatch.setattr(_plant_derived, "lie_chain", lambda p: pytest.fail("not rewritten"))
        monkeypatch.setattr(_normal_form, "_refine", lambda *a: pytest.fail("not rewritten"))
        _same(reference, _derive_all(fl.plants.trms_yaw()))


def test_errors_are_not_cached(cache):
    x, u = sp.symbols("x u")
    plant = fl.Plant.from_ode([x], u, [-x + u * x], x, region={x: (-1, 1)}, input_range=(-1, 1))
    for _ in range(2):
        with pytest.raises(fl.errors.RelativeDegreeError):
            plant.relative_degree()
    assert not list(cache.glob("plant_*_chain.pkl"))


def _definition() -> dict:
    x, v, u = sp.symbols("x v u")
    k = sp.Symbol("k", positive=True)
    return {"states": (x, v), "input": u, "rhs": sp.ImmutableMatrix([v, -k * x + u]),
            "output": x, "params": {k: 2.0}, "name": "p", "input_range": (-1.0, 1.0),
            "region": {x: (-1.0, 1.0)}, "operating_point": None}


def test_the_key_follows_every_part_of_the_definition():
    base = _definition()
    key = _stored.plant_key(**base)
    assert len(key) == 64 and key == _stored.plant_key(**_definition())  # rebuilt: same key
    x, v, u = base["states"] + (base["input"],)
    k = next(iter(base["params"]))
    variants = {"params": {k: 2.0 + 2**-40}, "name": "q", "input_range": (-1.0, 2.0),
                "region": {x: (-1.0, 0.5)}, "operating_point": {x: 0.1},
                "rhs": sp.ImmutableMatrix([v, -k * x + 2 * u]), "output": 2 * x,
                "states": (v, x)}
    for field, value in variants.items():
        assert _stored.plant_key(**{**base, field: value}) != key, field
    kr = sp.Symbol("k", real=True)  # same name, other assumptions
    other = {**base, "rhs": sp.ImmutableMatrix([v, -kr * x + u]), "params": {kr: 2.0}}
    assert _stored.plant_key(**other) != key


def test_the_key_follows_the_code(monkeypatch):
    x, u = sp.symbols("x u")
    args = ((x,), u, sp.ImmutableMatrix([-x + u]), x, {}, "p", None, None, None)
    key = _stored.plant_key(*args)
    monkeypatch.setattr(_stored, "code_version", lambda: "0" * 64)
    assert _stored.plant_key(*args) != key


def test_the_key_is_the_same_in_every_process():
    import os
    import subprocess
    import sys

    code = "import fl_design as fl; print(fl.plants.trms_yaw(motor_lag=True)._store.key)"
    keys = {subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           check=True, env={**os.environ, "PYTHONHASHSEED": seed}).stdout.strip()
            for seed in ("1", "2")}
    assert keys == {fl.plants.trms_yaw(motor_lag=True)._store.key}
