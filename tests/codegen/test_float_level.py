"""Level-independent float: the C state is measured from the start's level (deviation
coordinates), so the float step's error does not grow with the output's level, and the
predicted error (the bit-exact float emulation) stays the measured one."""

from __future__ import annotations

import numpy as np
import pytest

import fl_design as fl
from fl_design import presets
from fl_design._toolchain import find_compiler
from fl_design.codegen import generate_c
from fl_design.codegen._float_check import emulate

pytestmark = pytest.mark.skipif(find_compiler() is None, reason="no C compiler installed")


def _record(level, n=3000):
    k = np.arange(n)
    y = level + 0.05 * (1 - np.exp(-k * 2e-3)) + 1e-3 * np.sin(k / 37.0)
    return y, np.full(n, level + 0.05)


@pytest.fixture(scope="module")
def pkg(tmp_path_factory):
    return generate_c(presets.paper_design(), tmp_path_factory.mktemp("lvl"), precision="float")


def test_float_error_is_flat_in_the_level(pkg):
    used, errs = pkg.step_design, {}
    for level in (0.0, -1.0, -10.0, 100.0):
        y, r = _record(level)
        u_c = pkg.run(y, r, start=True)  # started as firmware starts: y_c = y[0]
        # Design.step fed what the C receives: y and r as floats (a float measurement carries
        # |y| 2^-24 by itself, at any level; the arithmetic adds no level-dependent error)
        y32, r32 = y.astype(np.float32).astype(float), r.astype(np.float32).astype(float)
        ref = used.run(y32, r32, state0=used.initial_state(y0=y32[0], u0=0.0)).u
        errs[level] = float(np.max(np.abs(u_c - ref)) / np.max(np.abs(ref)))
        # the emulation (the prediction's engine) is the compiled float C, bit for bit
        u_e = emulate(used, y, r, used.initial_state(y0=0.0, u0=0.0), y_c=float(y[0]))
        np.testing.assert_array_equal(u_c, u_e.astype(float))
    assert max(errs.values()) < 1e-4, errs  # was 2.5e-4 at y = -10 in absolute coordinates
    assert max(errs.values()) <= 4 * errs[0.0] + 1e-7, errs  # flat: no growth with |y|


@pytest.mark.slow
def test_the_predicted_error_is_the_measured_one_at_a_level(tmp_path):
    """Maglev (y ~ 6 mm) and the flexible joint started away from 0: prediction = SIL."""
    plant, design = fl.plants.maglev(), presets.maglev_design()
    sc = fl.Scenario(float(plant.x_op[0]) + 2e-4, 2.0)
    pkg = generate_c(design, tmp_path, precision="float", plant=plant, scenario=sc)
    res = pkg.verify(plant, sc)
    assert res.passed and res.max_rel_error < 1e-4
    assert 0.5 < pkg.predicted_float_error / res.max_rel_error < 2.0


@pytest.mark.parametrize("name", ["heater", "chain3", "pendulum"])
def test_flat_error_and_bit_exact_emulation_on_unseen_designs(name, tmp_path):
    """The rho = 1 heater (u in [0, 1]), the rho = 3 chain with b < 0 and the pendulum of
    test_faults_unseen: at levels 0, 50 and -150 the float C's error against Design.step
    stays within the float bound and flat in the level, and the emulation behind the
    prediction is the compiled float C bit for bit (u at a limit included)."""
    from .test_faults_unseen import CASES

    design, _, _, _ = CASES[name]()
    pkg = generate_c(design, tmp_path, precision="float")
    used, errs = pkg.step_design, {}
    for level in (0.0, 50.0, -150.0):
        y, r = _record(level)
        u_c = pkg.run(y, r, start=True)
        y32, r32 = y.astype(np.float32).astype(float), r.astype(np.float32).astype(float)
        ref = used.run(y32, r32, state0=used.initial_state(y0=y32[0], u0=0.0)).u
        errs[level] = float(np.max(np.abs(u_c - ref)) / max(np.max(np.abs(ref)), 1e-30))
        u_e = emulate(used, y, r, used.initial_state(y0=0.0, u0=0.0), y_c=float(y[0]))
        np.testing.assert_array_equal(u_c, u_e.astype(float))
    assert max(errs.values()) < 1e-4, errs
    assert max(errs.values()) <= 4 * errs[0.0] + 1e-7, errs
