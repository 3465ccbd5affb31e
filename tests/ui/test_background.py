"""The slow results: computed in a child process, posted when ready, equal to the library's own
answers; paused while the controls move; the process ended on close."""

from __future__ import annotations

import os
import time

import pytest


def _state(pid: int) -> str:
    """The process's state letter from /proc (R, S, T stopped, Z zombie, ...)."""
    from pathlib import Path

    return Path(f"/proc/{pid}/stat").read_text().split()[2]

from fl_design.analysis import loop_margins
from fl_design.ui._background import STAGES, Background, stage_keys


def test_keys_follow_what_each_stage_depends_on(trms_tuner):
    v = trms_tuner.check({})
    base = stage_keys(v)
    moved = stage_keys(trms_tuner.check({"gamma": 1e-3}))
    assert {s for s in STAGES if base[s] != moved[s]} == {"margins", "gamma", "eps"}
    ref = stage_keys(trms_tuner.check({"reference": 0.2}))
    assert {s for s in STAGES if base[s] != ref[s]} == {"map"}
    gains = stage_keys(trms_tuner.check({"gains": [3.0, 4.0]}))
    assert {s for s in STAGES if base[s] != gains[s]} == {"margins", "gamma", "map", "curve",
                                                          "eps"}


def test_disabled_background_computes_nothing(trms_setup, trms_tuner):
    bg = Background(trms_setup, enabled=False)
    bg.submit(trms_tuner.check({}))
    time.sleep(1.0)
    assert {s["state"] for s in bg.snapshot().values()} == {"waiting"}
    bg.close()


@pytest.mark.slow
def test_margins_arrive_from_the_child_and_match_the_library(trms_setup, trms_tuner):
    v = trms_tuner.check({"gamma": 5e-4})
    bg = Background(trms_setup)
    try:
        bg.submit(v)
        end = time.time() + 120
        while time.time() < end and bg.snapshot()["margins"]["state"] != "ready":
            time.sleep(0.2)
        snap = bg.snapshot()
        assert snap["margins"]["state"] == "ready", snap["margins"]
        design = trms_tuner.design_for(v)
        want = [loop_margins(design, b)._repr_lines()[0] for b in trms_tuner.b_bounds]
        assert [r["text"] for r in snap["margins"]["data"]["rows"]] == want
        pid = bg._proc.pid if bg._proc is not None else None
        bg.submit(trms_tuner.check({"gamma": 6e-4}))  # moving: paused at once, then restarted
        if pid is not None and os.path.exists(f"/proc/{pid}"):
            # SIGSTOP is delivered asynchronously: on a loaded machine the child may still read
            # 'R' for a moment; it must read stopped (or finished) within 5 s
            end, state = time.time() + 5.0, _state(pid)
            while state not in ("T", "t", "Z") and time.time() < end and \
                    os.path.exists(f"/proc/{pid}"):
                time.sleep(0.01)
                state = _state(pid) if os.path.exists(f"/proc/{pid}") else "Z"
            assert state in ("T", "t", "Z"), state  # stopped (or already finished)
        state = bg.snapshot()["margins"]["state"]
        assert state in ("stale", "computing", "paused while the controls move"), state
    finally:
        bg.close()
    assert bg._proc is None
    if pid is not None:
        assert not os.path.exists(f"/proc/{pid}") or \
            _state(pid) == "Z"


def test_a_redraw_never_waits_for_the_background_process_to_end(trms_setup, trms_tuner,
                                                                 monkeypatch):
    """Ending (and starting) a background process happens outside the lock the redraws take:
    while a slow end is under way, pause, submit and snapshot answer at once."""
    import threading

    from fl_design.ui import _background

    class OldProcess:  # a process that takes 1.5 s to end
        pid = None

        def is_alive(self):
            return False

    old, ended = OldProcess(), threading.Event()
    real_end = _background._end

    def slow_end(proc, paused):
        if proc is old:
            time.sleep(1.5)
            ended.set()
        else:
            real_end(proc, paused)

    monkeypatch.setattr(_background, "_end", slow_end)
    bg = Background(trms_setup)
    bg._proc, bg._keys = old, {}  # nothing left to compute: _start only ends the old one
    starter = threading.Thread(target=bg._start)
    starter.start()
    try:
        time.sleep(0.2)  # _start is inside the slow end
        assert not ended.is_set()
        t = time.perf_counter()
        bg.pause()
        bg.snapshot()
        waited = time.perf_counter() - t
        assert not ended.is_set() and waited < 1.0, waited  # did not wait for the end
    finally:
        starter.join(timeout=10)
        bg.close()
    assert ended.is_set() and bg._proc is None
