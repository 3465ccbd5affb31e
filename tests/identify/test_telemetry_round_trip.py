"""The model-free round trip without hardware: the generated C package runs the experiment in
the SIL (its own excitation routine, its telemetry frames), fl.read_telemetry reads the frames,
fl.identify reads the log, and the class it gives contains the plant's b; the design tuned for
that class converges on the plant that wrote the log."""

from __future__ import annotations

import pytest
import sympy as sp

import fl_design as fl
from fl_design._toolchain import find_compiler

pytestmark = pytest.mark.skipif(find_compiler() is None, reason="no C compiler installed")


def test_sil_telemetry_identify_tune_converges(tmp_path):
    y, v, u = sp.symbols("y v u", real=True)
    b_true = 5.0  # unknown to the tool: only the plant simulated in the SIL has it
    plant = fl.Plant.from_ode([y, v], u, [v, -2 * y - sp.Rational(1, 2) * v + b_true * u], y,
                              region={y: (-2, 2), v: (-10, 10)}, input_range=(-10, 10),
                              name="rig")
    # what the rig owner knows before the experiment: rho, T, a wide guess of b, the limits
    guess = fl.PlantClass(rho=2, T=1e-3, b=(1.0, 20.0), noise_std=1e-3, u_limits=(-10, 10))
    first = fl.tune(guess, objective="fastest").design
    pkg = fl.generate_c(first, tmp_path / "pkg", plant=plant)
    frames = tmp_path / "log.bin"
    res = pkg.verify(plant, fl.Scenario(0.0, 20.0, noise=fl.Noise(std=1e-3, seed=1)),
                     telemetry=frames, excitation=("prbs", 0.0, 0.5, 60))
    assert res.matches  # the C loop is Design.step's
    log = fl.read_telemetry(frames)
    cls = fl.identify(str(log.to_csv(tmp_path / "log.csv")), rho=2)
    assert cls.source == "log" and cls.b[0] <= b_true <= cls.b[1]
    assert abs(cls.noise_std - 1e-3) < 2e-4  # the SIL's sensor noise, read back
    tuned = fl.tune(cls)
    assert tuned.certified
    resp = fl.simulate(plant, tuned.design, fl.Scenario(0.5, 60.0))
    assert resp.status in ("converged", "converging"), resp.verdict()
