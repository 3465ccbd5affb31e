"""The certify stage run in a child process beside the later stages (issue 33): the same
certificates as run alone, its time recorded, its progress on stderr, its error re-raised, a
child that dies or hangs reported (never a crash of the job, never a hang), and no child left
behind. A process, not a thread: CasADi is not thread safe (a thread crashed a CI run with
SIGSEGV; ``fl_design.app._beside``)."""

from __future__ import annotations

import json
import os
import signal
import time

import pytest

from fl_design.app import _beside, load_config, run_job
from fl_design.app._beside import Beside
from fl_design.errors import CertificationError, WorkerLostError


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
    # it starts once derive is done, beside the sweep and simulate
    assert (err.index("1/4 derive done") < err.index("2/4 certify ... (in a process beside the")
            < err.index("3/4 sweep ..."))
    assert "certify: the eps* brackets" in err and "2/4 certify done in" in err
    assert beside.timings["certify"] > 0 and "certify" not in beside.cached
    monkeypatch.setenv("FL_DESIGN_CACHE", str(tmp_path / "b"))  # computed again, alone
    alone = run_job(load_config(None), quick=True, stages=("certify",), progress=False)
    assert "certify" not in alone.cached
    assert _certificates(beside) == _certificates(alone)


def _fails(*args, progress=None):  # runs in the child process
    progress("stub: about to fail")
    raise CertificationError("stub: the certificate failed")


def _dies(*args, progress=None):  # runs in the child process
    os.kill(os.getpid(), signal.SIGSEGV)


def _sleeps(seconds, progress=None):  # runs in the child process
    time.sleep(seconds)
    return "late", False


def _pid(*args, progress=None):  # runs in the child process
    return os.getpid(), False


def _recorded(base=Beside):
    """A subclass of ``base`` keeping every instance made (to check each child ended)."""
    made = []

    class Recorded(base):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            made.append(self)

    return Recorded, made


def test_an_error_of_the_certify_process_is_raised_by_the_job(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("FL_DESIGN_CACHE", str(tmp_path))  # nothing cached: the stage runs
    monkeypatch.setitem(_beside.TARGETS, "certify", f"{__name__}:_fails")
    ran = []
    with pytest.raises(CertificationError, match="stub: the certificate failed"):
        run_job(load_config(None), quick=True, stages=("certify", "sweep", "simulate"),
                after=lambda stage, job: ran.append(stage))
    assert "certify" not in ran and ran[:2] == ["derive", "sweep"]
    assert "stub: about to fail" in capsys.readouterr().err  # its progress forwarded


def test_the_stage_runs_in_another_process_and_leaves_none_behind(tmp_path, monkeypatch):
    b = Beside("demo", "1/1", f"{__name__}:_pid", (), say=None)
    pid, hit = b.wait(limit=120)
    assert pid != os.getpid() and hit is False
    assert b.proc.poll() is not None  # ended, reaped


def test_a_child_that_dies_is_a_worker_lost_error_naming_the_signal():
    b = Beside("demo", "1/1", f"{__name__}:_dies", (), say=None)
    with pytest.raises(WorkerLostError, match=f"died \\(signal {int(signal.SIGSEGV)}\\)"):
        b.wait(limit=120)


def test_a_child_over_its_limit_is_killed_and_reported():
    start = time.perf_counter()
    b = Beside("demo", "1/1", f"{__name__}:_sleeps", (600,), say=None)
    with pytest.raises(WorkerLostError, match="ran over 3 s; its process was killed"):
        b.wait(limit=3)
    assert time.perf_counter() - start < 60 and b.proc.poll() is not None


def test_a_setup_that_cannot_be_sent_runs_the_stage_in_turn(tmp_path, monkeypatch, capsys):
    from fl_design.app import _job

    monkeypatch.setenv("FL_DESIGN_CACHE", str(tmp_path))
    Recorded, made = _recorded()

    class NoSend(Recorded):
        def submit(self, spec, args):
            self.close()
            raise TypeError("cannot pickle 'generator' object")

    monkeypatch.setattr(_job, "Beside", NoSend)
    job = run_job(load_config(None), quick=True, stages=("certify", "sweep", "simulate"))
    err = capsys.readouterr().err
    assert "2/4 certify: runs in turn (no child process: cannot pickle" in err
    assert job.results["certify"]["eps"].covers == "nonlinear"
    assert len(made) == 1 and made[0].proc.poll() is not None  # the early child ended


def test_no_child_process_runs_the_stage_in_turn(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("FL_DESIGN_CACHE", str(tmp_path))

    def no_process(*args, **kwargs):
        raise OSError("Resource temporarily unavailable (stub)")

    monkeypatch.setattr(_beside, "_start_process", no_process)
    job = run_job(load_config(None), quick=True, stages=("certify", "sweep", "simulate"))
    assert "certify: runs in turn (no child process: Resource temporarily" in \
        capsys.readouterr().err
    assert job.results["certify"]["eps"].covers == "nonlinear"


def test_a_child_that_cannot_start_runs_the_stage_in_turn(tmp_path, monkeypatch, capsys):
    """A child that exits at once (a frozen application's executable is not a Python)."""
    import subprocess
    import sys

    monkeypatch.setenv("FL_DESIGN_CACHE", str(tmp_path))

    def exits(env):
        return subprocess.Popen([sys.executable, "-c", "import sys; sys.exit(3)"],
                                stdin=subprocess.PIPE, stdout=subprocess.PIPE, env=env)

    monkeypatch.setattr(_beside, "_start_process", exits)
    job = run_job(load_config(None), quick=True, stages=("certify", "sweep", "simulate"))
    err = capsys.readouterr().err
    assert "2/4 certify: runs in turn (no child process: the certify stage's process exited " \
        "(status 3) before its work was sent)" in err
    assert job.results["certify"]["eps"].covers == "nonlinear"


def test_a_job_stopped_early_leaves_no_child(tmp_path, monkeypatch):
    from fl_design.app import _job, _stages

    monkeypatch.setenv("FL_DESIGN_CACHE", str(tmp_path))
    Kept, made = _recorded()

    def sweep_fails(*args, **kwargs):
        raise CertificationError("stub: the sweep failed")

    monkeypatch.setattr(_job, "Beside", Kept)
    monkeypatch.setattr(_stages, "sweep", sweep_fails)
    with pytest.raises(CertificationError, match="stub: the sweep failed"):
        run_job(load_config(None), quick=True, stages=("certify", "sweep", "simulate"),
                progress=False)
    assert len(made) == 1 and made[0].proc.poll() is not None  # started early, then ended


@pytest.mark.slow
def test_a_cached_certify_is_read_without_a_process(tmp_path, monkeypatch, capsys):
    from fl_design.app import _job

    monkeypatch.setenv("FL_DESIGN_CACHE", str(tmp_path))
    first = run_job(load_config(None), quick=True, stages=("certify", "sweep", "simulate"),
                    progress=False)
    started = []
    monkeypatch.setattr(_job, "Beside", lambda *a, **k: started.append(a))
    again = run_job(load_config(None), quick=True, stages=("certify", "sweep", "simulate"))
    assert started == [] and "certify" in again.cached
    assert "2/4 certify done in" in capsys.readouterr().err
    assert _certificates(again) == _certificates(first)


def test_a_child_that_answered_is_joined_after_the_stage_it_ran_beside(tmp_path, monkeypatch):
    """Its results are in the job (and its ``after`` hook called) as soon as the stage that
    finds it done ends, not only at the end: the report's figures ahead see them."""
    from fl_design.app import _job, _stages

    monkeypatch.setenv("FL_DESIGN_CACHE", str(tmp_path))
    monkeypatch.setitem(_beside.TARGETS, "certify", f"{__name__}:_pid")
    Recorded, made = _recorded()
    monkeypatch.setattr(_job, "Beside", Recorded)
    real = _stages.simulate

    def simulate(setup, quick):  # the last stage ends only once the child has answered
        deadline = time.perf_counter() + 120.0
        while not made[0].done() and time.perf_counter() < deadline:
            time.sleep(0.05)
        return real(setup, quick)

    monkeypatch.setattr(_stages, "simulate", simulate)
    ran = []
    job = run_job(load_config(None), quick=True, stages=("certify", "sweep", "simulate"),
                  progress=False, after=lambda stage, j: ran.append((stage, "certify" in
                                                                      j.results)))
    assert ran == [("derive", False), ("sweep", False), ("certify", True), ("simulate", True)]
    assert job.results["certify"] == made[0].proc.pid and made[0].proc.poll() is not None
