"""``fl-design ui`` from the command line: prints its URL, refuses a request without the token,
stops cleanly on Ctrl-C (SIGINT) and on SIGTERM, ending its background process too; the class
mode is tested in test_class_mode.py."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
import urllib.error
import urllib.request
from pathlib import Path

import pytest


def _state(pid: int) -> str:
    """The process's state letter from /proc (R, S, T stopped, Z zombie, ...)."""
    from pathlib import Path

    return Path(f"/proc/{pid}/stat").read_text().split()[2]

from fl_design.app import main


def test_a_config_file_from_init_is_tuned(capsys, tmp_path):
    from fl_design.app import load_config
    from fl_design.app._cli import ui_setup
    from fl_design.ui import Tuner

    assert main(["init", "--plant", "pendulum"]) == 0
    path = tmp_path / "rig.toml"
    path.write_text(capsys.readouterr().out)
    tuner = Tuner(ui_setup(load_config(path)))
    assert tuner.config.source == str(path) and tuner.plant.name == "pendulum"
    assert tuner.redraw({"duration": 2.0})["verdict"]["status"]


def test_config_and_plant_together_are_refused(capsys, tmp_path):
    assert main(["ui", str(tmp_path / "x.toml"), "--plant", "trms"]) == 2
    assert "not both" in capsys.readouterr().err


def _start(*args):
    proc = subprocess.Popen([sys.executable, "-m", "fl_design", "ui", *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    end, url = time.time() + 120, None
    while time.time() < end and url is None:
        line = proc.stdout.readline()
        if not line and proc.poll() is not None:
            break
        m = re.search(r"(http://127\.0\.0\.1:\d+/\S+/)", line)
        url = m.group(1) if m else None
    if url is None:
        os.killpg(proc.pid, signal.SIGKILL)
        pytest.fail(f"no URL printed: {proc.stderr.read()[-2000:]}")
    return proc, url


def _children(pid: int) -> list[int]:
    out = subprocess.run(["ps", "-o", "pid=", "--ppid", str(pid)], capture_output=True,
                         text=True, check=False, timeout=30).stdout
    return [int(x) for x in out.split()]


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_serves_refuses_without_token_and_stops_cleanly(sig, tmp_path):
    proc, url = _start("--plant", "pendulum", "--out", str(tmp_path / "out"))
    try:
        base = re.match(r"(http://[^/]+)", url).group(1)
        with pytest.raises(urllib.error.HTTPError) as err:
            urllib.request.urlopen(base + "/", timeout=30)
        assert err.value.code == 403
        with urllib.request.urlopen(url, timeout=30) as r:
            assert r.status == 200 and b"fl-design tuner" in r.read()
        time.sleep(2.0)  # the background process has started (after 0.6 s of quiet)
        kids = _children(proc.pid)
        os.kill(proc.pid, sig)
        assert proc.wait(timeout=30) == 0
        assert "stopped" in proc.stderr.read()
        end = time.time() + 15  # the background process and its group are gone too
        alive = kids  # (multiprocessing's resource tracker leaves once its pipe closes)
        while alive and time.time() < end:
            alive = [k for k in kids if os.path.exists(f"/proc/{k}") and _state(k) != "Z"]
            time.sleep(0.2)
        assert not alive, [Path(f"/proc/{k}/cmdline").read_bytes() for k in alive]
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(timeout=30)
