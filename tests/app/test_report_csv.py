"""The runs as CSV beside the report: the compared runs always, the main run on request."""

import numpy as np
import pytest

from fl_design.app import load_config, run_job, write_report
from fl_design.app._report_write import run_csv_name


@pytest.fixture(scope="module")
def job():
    return run_job(load_config(None), quick=True, stages=("derive", "simulate"), progress=False)


def test_main_run_written_on_request_and_removed_after(job, tmp_path):
    sim = job.results["simulate"]
    main = run_csv_name("main", job.config.scenario.noise_std)
    paths = write_report(job, tmp_path, main_csv=True)
    assert main in paths["csv"] and len(paths["csv"]) == len(sim["runs"]) + 1
    text = (tmp_path / main).read_text(encoding="utf-8")
    assert text == sim["main"].to_csv()  # every sample, exact
    table = np.genfromtxt(tmp_path / main, delimiter=",", names=True)
    assert np.array_equal(table["y"], sim["main"].y)
    # the next report without the main run: our own older main CSV does not stay beside it
    paths = write_report(job, tmp_path)
    assert main not in paths["csv"] and len(paths["csv"]) == len(sim["runs"])
    assert not (tmp_path / main).exists()


def test_a_main_csv_we_did_not_write_is_left_alone(job, tmp_path):
    (tmp_path / "runs").mkdir()
    theirs = tmp_path / run_csv_name("main", job.config.scenario.noise_std)
    theirs.write_text("t,y\n0,1\n", encoding="utf-8")
    write_report(job, tmp_path, force=True)
    assert theirs.read_text(encoding="utf-8") == "t,y\n0,1\n"
