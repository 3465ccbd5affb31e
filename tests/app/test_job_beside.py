"""The certify stage run in a thread beside the later stages (issue 33): the same certificates
as run alone, its time recorded, its progress on stderr, its error re-raised."""

from __future__ import annotations

import json

import pytest

from fl_design.app import _stages, load_config, run_job
from fl_design.errors import CertificationError


def _certificates(job) -> str:
    c = job.results["certify"]
    return json.dumps({k: c[k].to_dict() for k in ("lyapunov", "gamma", "eps", "curve")},
                      sort_keys=True, default=str)


@pytest.mark.slow
def test_certify_beside_the_sweep_gives_the_certificates_of_certify_alone(tmp_path, monkeypatch,
                                                                          capsys):
    monkeypatch.setenv("FL_DESIGN_CACHE", str(tmp_path / "a"))
    beside = run_job(load_config(None), quick=True, stages=("certify", "sweep", "simulate"))
    err = capsys.readouterr().err
    # it starts once the sweep is done, beside simulate
    assert err.index("3/4 sweep done") < err.index("2/4 certify ... (in a thread beside the")
    assert "certify: the eps* brackets" in err and "2/4 certify done in" in err
    assert beside.timings["certify"] > 0 and "certify" not in beside.cached
    monkeypatch.setenv("FL_DESIGN_CACHE", str(tmp_path / "b"))  # computed again, alone
    alone = run_job(load_config(None), quick=True, stages=("certify",), progress=False)
    assert "certify" not in alone.cached
    assert _certificates(beside) == _certificates(alone)


def test_an_error_of_the_certify_thread_is_raised_by_the_job(tmp_path, monkeypatch):
    monkeypatch.setenv("FL_DESIGN_CACHE", str(tmp_path))  # nothing cached: the stage runs

    def fails(*args, **kwargs):
        raise CertificationError("stub: the certificate failed")

    monkeypatch.setattr(_stages, "certify", fails)
    ran = []
    with pytest.raises(CertificationError, match="stub"):
        run_job(load_config(None), quick=True, stages=("certify", "sweep", "simulate"),
                progress=False, after=lambda stage, job: ran.append(stage))
    assert "certify" not in ran and ran[:2] == ["derive", "sweep"]
