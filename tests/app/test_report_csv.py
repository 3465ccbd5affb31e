"""The runs as CSV beside the report: the compared runs always, the main run on request."""

import numpy as np
import pytest

from fl_design.app import load_config, run_job, write_report
from fl_design.app._report_csv import run_csv_name


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


def test_background_writer_during_the_job_gives_the_same_files(tmp_path):
    from fl_design._output import MARKER, claim_output_folder
    from fl_design.app._report_csv import BackgroundCsv

    folder = claim_output_folder(tmp_path / "out")
    writer = BackgroundCsv(folder, main=False)
    job = run_job(load_config(None), quick=True, stages=("derive", "simulate"),
                  progress=False, after=writer.after)
    names = writer.result()
    runs = job.results["simulate"]["runs"]
    assert sorted(names) == sorted(run_csv_name(d, s) for d, s in runs)
    for (design, std), resp in runs.items():
        assert (folder / run_csv_name(design, std)).read_text(encoding="utf-8") == resp.to_csv()
    stamps = {n: (folder / n).stat().st_mtime_ns for n in names}
    paths = write_report(job, folder, csv_written=names)
    assert paths["csv"] == names and job.timings["report_csv"] > 0
    assert {n: (folder / n).stat().st_mtime_ns for n in names} == stamps  # not written again
    assert all(n in (folder / MARKER).read_text(encoding="utf-8") for n in names)


def test_background_writer_error_is_raised_in_the_caller(job, tmp_path):
    from fl_design.app._report_csv import BackgroundCsv

    writer = BackgroundCsv(tmp_path / "missing" / "deeper", main=False)
    writer.after("simulate", job)
    with pytest.raises(OSError):
        writer.result()
