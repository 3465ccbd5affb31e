"""What a process that only builds a library plant imports (each case in a fresh interpreter)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

_PROBE = """
import json, sys
import fl_design as fl
plant = fl.plants.trms_yaw()
plant.relative_degree(), plant.b_bounds(), plant.casadi()
import pickle
again = pickle.loads(pickle.dumps(plant))  # a recipe plant pickles as its recipe
assert again.relative_degree() == 2 and repr(again) == repr(plant)
assert again.with_params(B1=0.2).b_bounds() == plant.b_bounds()  # cached from the first run
for bad in ({"I2": -1.0}, {"input_range": (1.0, -1.0)}):  # validated without SymPy
    try:
        fl.plants.trms_yaw(**bad)
    except fl.errors.ParameterError:
        pass
    else:
        raise AssertionError(f"trms_yaw(**{bad}) was accepted")
print(json.dumps(sorted(m for m in sys.modules if m.split(".")[0] in
                        ("fl_design", "sympy", "cvxpy", "matplotlib", "control", "jax"))))
"""


def _modules_after_building_the_trms() -> set:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    for _ in range(2):  # the first run may fill the derivation cache; the second loads it
        proc = subprocess.run([sys.executable, "-c", _PROBE], capture_output=True, text=True,
                              env=env, timeout=300, check=False)
        assert proc.returncode == 0, proc.stderr
    return set(json.loads(proc.stdout.splitlines()[-1]))


@pytest.fixture(scope="module")
def loaded():
    return _modules_after_building_the_trms()


def test_building_the_trms_imports_only_its_own_plant_module(loaded):
    plants = {m for m in loaded if m.startswith("fl_design.plants.")}
    assert plants == {"fl_design.plants._rotor", "fl_design.plants._common"}
    # nor the heavy layers it does not use: certificates, plots, python-control
    assert not {m for m in loaded if m.split(".")[0] in ("cvxpy", "matplotlib", "control", "jax")}
    assert not {m for m in loaded if m.startswith(("fl_design.analysis", "fl_design.app"))}


def test_loading_the_cached_trms_does_not_import_sympy(loaded):
    # the plant is known by its recipe; every quantity the probe asks for is in the cache
    assert "sympy" not in loaded
    assert not {m for m in loaded if m.startswith(("fl_design.symbolic._normal_form",
                                                     "fl_design.symbolic._bridge",
                                                     "fl_design.symbolic._definition"))}
