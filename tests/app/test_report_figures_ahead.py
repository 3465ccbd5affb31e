"""Figures drawn while the certify stage runs beside the job: the same files, not drawn twice."""

import pytest

from fl_design.app import load_config, run_job, write_report
from fl_design.app._report_figures import AHEAD, FIGURES, FiguresAhead, write_figures


@pytest.fixture(scope="module")
def job():
    return run_job(load_config(None), quick=True, stages=("derive", "simulate"), progress=False)


def test_ahead_draws_the_simulate_figures_only_after_codegen_and_only_while_certify_runs(
        job, tmp_path):
    from fl_design._output import MARKER, claim_output_folder

    folder = claim_output_folder(tmp_path / "out")
    ahead = FiguresAhead(folder)
    ahead.after("simulate", job)  # not the last stage of this process: nothing drawn yet
    assert ahead.drawn is None and not list(folder.glob("*.png"))
    ahead.after("codegen", job)
    written, failed = ahead.drawn
    assert failed == {} and set(written) == {"response.png", "steps.png", "noise_tradeoff.png"}
    assert set(written) <= set(AHEAD) and ahead.seconds > 0
    stamps = {n: (folder / n).stat().st_mtime_ns for n in written}
    paths = write_report(job, folder, figures_ahead=ahead)
    assert sorted(paths["figures"]) == sorted(written)  # the job has no sweep or certify
    assert {n: (folder / n).stat().st_mtime_ns for n in written} == stamps  # not drawn again
    assert job.timings["report_figures"] >= ahead.seconds
    assert all(n in (folder / MARKER).read_text(encoding="utf-8") for n in written)


def test_ahead_waits_for_nothing_when_certify_is_in(job, tmp_path):
    done = type(job)(job.config, plant=job.plant, design=job.design, setup=job.setup)
    done.results = {**job.results, "certify": {}}
    ahead = FiguresAhead(tmp_path)
    ahead.after("codegen", done)
    assert ahead.drawn is None and not list(tmp_path.glob("*.png"))


def test_write_figures_names_and_drawn_select_the_figures(job, tmp_path):
    written, failed = write_figures(job, tmp_path, names=["steps.png"])
    assert (written, failed) == (["steps.png"], {})
    again, _ = write_figures(job, tmp_path, drawn=(written, {}))
    assert again[0] == "steps.png" and set(again) == {n for n in FIGURES if n in {
        "response.png", "steps.png", "noise_tradeoff.png"}}
