"""A run's trajectories out: :meth:`Response.columns`, ``to_csv`` and ``to_frame``."""

from __future__ import annotations

import io

import numpy as np
import pytest

import fl_design as fl
from fl_design.errors import MissingDependencyError, OutputPathError


@pytest.fixture(scope="module")
def resp():
    return fl.simulate(fl.plants.pendulum(), fl.presets.pendulum_design(),
                       fl.Scenario(0.1, 0.5, noise=fl.Noise(std=1e-3, seed=2)))


def test_csv_reads_back_exactly(resp):
    text = resp.to_csv()
    table = np.genfromtxt(io.StringIO(text), delimiter=",", names=True)
    assert len(table) == resp.t.size
    for name, column in resp.columns().items():
        np.testing.assert_array_equal(table[name], column)  # repr precision: exact
    np.testing.assert_array_equal(table["x2"], resp.x[:, 1])
    np.testing.assert_array_equal(table["xhat1"], resp.xhat[:, 0])


def test_csv_file_is_not_overwritten_unless_asked(resp, tmp_path):
    target = tmp_path / "run.csv"
    resp.to_csv(target)
    with pytest.raises(OutputPathError, match="exists; pass overwrite=True"):
        resp.to_csv(target)
    target.write_text("someone's data", encoding="utf-8")
    with pytest.raises(OutputPathError):
        resp.to_csv(target)
    assert target.read_text(encoding="utf-8") == "someone's data"
    resp.to_csv(target, overwrite=True)
    assert target.read_text(encoding="utf-8") == resp.to_csv()
    with pytest.raises(OutputPathError, match="folder does not exist"):
        resp.to_csv(tmp_path / "missing" / "run.csv")


def test_diverged_samples_are_nan_in_the_csv():
    cyc = fl.simulate(fl.plants.pendulum(), fl.presets.pendulum_design(eps=0.5),
                      fl.Scenario(0.1, 20.0))
    assert cyc.diverged
    table = np.genfromtxt(io.StringIO(cyc.to_csv()), delimiter=",", names=True)
    assert np.isnan(table["y"][-1]) and np.isfinite(table["y"][0])


def test_to_frame_is_pandas_or_a_clear_error(resp):
    try:
        import pandas  # noqa: F401
    except ImportError:
        with pytest.raises(MissingDependencyError, match="pip install pandas"):
            resp.to_frame()
        return
    frame = resp.to_frame()
    assert list(frame.columns) == list(resp.columns())
    np.testing.assert_array_equal(frame["u"].to_numpy(), resp.u)
