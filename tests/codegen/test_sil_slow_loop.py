"""The SIL's verdict on the C loop uses the same run constants as fl.simulate's (a slow loop)."""

import numpy as np
import pytest

import fl_design as fl
from fl_design._toolchain import find_compiler

pytestmark = pytest.mark.skipif(find_compiler() is None, reason="no C compiler installed")


TANKS = """[plant]
states = ["h1", "h2"]
input = "u"
rhs = ["(k*u - a1*sqrt(2*g*h1))/A1", "(a1*sqrt(2*g*h1) - a2*sqrt(2*g*h2))/A2"]
output = "h2"
params = { k = 3.3e-6, a1 = 1.5e-5, a2 = 1.5e-5, g = 9.81, A1 = 1.5e-3, A2 = 1.5e-3 }
region = { h1 = [0.02, 0.3], h2 = [0.02, 0.3] }
input_range = [0.0, 12.0]
operating_point = { y = 0.15 }

[design]
gains = [0.00155567, 0.078884]
gamma = 96.7885
eps = 0.600335
T = 0.1
u_limits = [0.0, 12.0]

[scenario]
reference = 0.2
"""


def _tanks(tmp_path):
    """Two coupled tanks (rho = 2) and a loop whose time constant (~26 s) is longer than the
    run (the design fl-design proposes for them)."""
    from fl_design.app import load_config
    from fl_design.app._build import build_setup

    path = tmp_path / "tanks.toml"
    path.write_text(TANKS, encoding="utf-8")
    setup = build_setup(load_config(path))
    return setup.plant, setup.design


def test_a_run_shorter_than_the_loop_is_undecided_in_c_as_in_python(tmp_path):
    plant, design = _tanks(tmp_path)
    scenario = fl.Scenario(0.2, 10.0, noise=fl.Noise(1.67e-4, seed=1))
    sim = fl.simulate(plant, design, scenario)
    tau = design.controller.time_constant
    assert tau > 10.0 and sim.status == "undecided"  # 10 s cannot show a stall of this loop
    res = fl.generate_c(design, tmp_path / "c", plant=plant).verify(plant, scenario)
    assert res.matches and res.max_rel_error <= 1e-12
    # it said "stalled" while fl.simulate said "undecided" (the C loop's summary lacked the
    # loop's time constant): the SIL failed a bit-exact step
    assert res.c_status == res.sim_status == "undecided" and res.passed
    assert np.all(np.isfinite(res.u_c))
