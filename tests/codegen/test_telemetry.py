"""Telemetry frames and the excitation routine: the SIL writes a log, fl.read_telemetry reads it."""

from __future__ import annotations

import csv
import struct

import numpy as np
import pytest

import fl_design as fl
from fl_design import presets
from fl_design._toolchain import find_compiler
from fl_design.codegen import generate_c
from fl_design.codegen._telemetry import MAGIC, excitation_sequence, read_telemetry
from fl_design.errors import ParameterError

needs_cc = pytest.mark.skipif(find_compiler() is None, reason="no C compiler installed")


@needs_cc
@pytest.mark.parametrize("precision", ["double", "float"])
def test_the_sil_log_round_trips(tmp_path, precision):
    plant, design = fl.plants.trms_yaw(), presets.paper_design()
    pkg = generate_c(design, tmp_path / "pkg", precision=precision, plant=plant)
    path = tmp_path / "log.bin"
    sc = fl.Scenario(0.2, 3.0, noise=fl.Noise(std=1e-3, seed=2))
    res = pkg.verify(plant, sc, telemetry=path)
    log = fl.read_telemetry(path)
    n = res.u_c.size
    assert log.n == n and log.rho == 2 and log.precision == precision
    assert path.stat().st_size == n * (16 + 7 * (8 if precision == "double" else 4))
    np.testing.assert_array_equal(log.k, np.arange(1, n + 1))
    np.testing.assert_allclose(log.t, np.arange(n) * design.T, rtol=1e-6, atol=0)
    np.testing.assert_array_equal(log.u, res.u_c)      # the input applied, bit for bit
    np.testing.assert_array_equal(log.y, res.ym.astype(np.float32 if precision == "float"
                                                       else float))
    assert np.all(log.r == log.r[0]) and abs(log.r[0] - 0.2) < 1e-7
    assert not log.fault.any() and not log.sensor_lost.any()
    # the estimates are Design.step's (the same measurements from the same start)
    from fl_design.codegen._compare import reference_run

    used = pkg.step_design
    _, xhat, _ = reference_run(used, res.ym, np.full(n, 0.2),
                               state0=used.initial_state(y0=float(res.ym[0]), u0=0.0))
    tol = 1e-9 if precision == "double" else 1e-3
    np.testing.assert_allclose(log.xhat, xhat[:, :2], rtol=0, atol=tol * np.abs(xhat).max())
    np.testing.assert_allclose(log.sigmahat, xhat[:, 2], rtol=0,
                               atol=tol * np.abs(xhat[:, 2]).max())
    # a CSV-like table with the columns a log identifier reads
    out = log.to_csv(tmp_path / "log.csv")
    rows = list(csv.reader(out.open()))
    assert rows[0][:4] == ["t", "y", "u", "r"] and len(rows) == n + 1
    assert float(rows[-1][2]) == log.u[-1]


@needs_cc
@pytest.mark.slow
def test_the_firmware_excitation_drives_the_sil(tmp_path):
    plant, design = fl.plants.trms_yaw(), presets.paper_design()
    pkg = generate_c(design, tmp_path / "pkg", plant=plant)
    path = tmp_path / "prbs.bin"
    res = pkg.verify(plant, fl.Scenario(0.0, 4.0), telemetry=path,
                     excitation=("prbs", 0.0, 0.1, 200))
    log = read_telemetry(path.read_bytes())
    expected = excitation_sequence("prbs", 0.0, 0.1, 200, log.n)
    np.testing.assert_array_equal(log.r, expected)  # the C routine = the Python mirror
    assert set(np.unique(log.r)) == {-0.1, 0.1}
    assert res.matches and np.ptp(log.u) > 0  # the loop followed an exciting reference
    header = pkg.header.read_text()
    assert "#define FL_EXCITE_HOLD" in header and "FL_EXCITE_AMPLITUDE" in header
    with pytest.raises(ParameterError, match="leaves the plausibility range"):
        pkg.verify(plant, fl.Scenario(0.0, 1.0), excitation=("square", 6.0, 1.0, 10))


def test_excitation_sequences():
    assert excitation_sequence("square", 0.0, 1.0, 3, 7).tolist() == [1, 1, 1, -1, -1, -1, 1]
    prbs = excitation_sequence("prbs", 0.0, 1.0, 1, 2**16 - 1)
    assert abs(prbs.sum()) == 1  # a maximal-length sequence: one more +1 than -1 (or less)
    with pytest.raises(ParameterError, match="kind 'sine' is not known"):
        excitation_sequence("sine", 0.0, 1.0, 1, 3)
    with pytest.raises(ParameterError, match="hold must be a whole number"):
        excitation_sequence("prbs", 0.0, 1.0, 0, 3)


def _frame(magic=MAGIC, version=1, rho=1, size=8, k=1):
    return struct.pack("<IBBBBII" + ("d" if size == 8 else "f") * (5 + rho), magic, version,
                       rho, size, 0, k, 0, *([0.01] * (5 + rho)))


@pytest.mark.parametrize("data, message", [
    (b"", "the data is empty"), (b"abc", "less than one frame's 16-byte header"),
    (_frame(magic=0x12345678), "magic 0x12345678 is not"),
    (_frame(version=9), "version 9"),
    (_frame() + b"\0\0", "not a whole number of 64-byte frames"),
    (_frame() + _frame(version=1, k=2)[:4] + bytes([2]) + _frame(k=2)[5:], "frame 1 .*version 2"),
    (12, "takes bytes or a file path, got int"),
    ("/nonexistent/log.bin", "does not exist"),
])
def test_bad_logs_are_refused_by_name(data, message):
    with pytest.raises(ParameterError, match=message):
        read_telemetry(data)


@needs_cc
def test_the_c_square_wave_is_the_python_one(tmp_path):
    """The C square wave started at the center and stayed there (its first hold took the step
    branch, then -0 = 0): the SIL compares the C routine with excitation_sequence sample by
    sample and would raise."""
    plant, design = fl.plants.trms_yaw(), presets.paper_design()
    pkg = generate_c(design, tmp_path / "pkg", plant=plant)
    path = tmp_path / "sq.bin"
    pkg.verify(plant, fl.Scenario(0.0, 1.0), telemetry=path, excitation=("square", 0.0, 0.1, 100))
    log = read_telemetry(path)
    np.testing.assert_array_equal(log.r, excitation_sequence("square", 0.0, 0.1, 100, log.n))
    assert log.r[0] == np.float64(0.1) and log.r[100] == -log.r[0]
