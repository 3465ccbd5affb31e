"""The suite cannot hang: a test stuck in a sleep, a lock or a child wait fails within its limit.

Runs pytest on a throw-away test file in a subprocess (with this project's pytest
configuration options, a 1 s limit instead of the suite's 300 s: the hung tests never end,
so any limit shows it; 1 s keeps the check cheap) and checks that each hung test
is reported failed, with the stack dumped, and that the session goes on to the next test.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
import time

HUNG = textwrap.dedent("""
    import subprocess, sys, threading, time

    def test_sleeps_forever():
        time.sleep(10_000)

    def test_waits_on_a_lock_forever():
        threading.Event().wait()

    def test_waits_on_a_child_forever():
        subprocess.run([sys.executable, "-c", "import time; time.sleep(10_000)"])

    def test_after_the_hung_ones_still_runs():
        assert True
""")


def test_a_hung_test_fails_within_its_limit_and_the_session_goes_on(tmp_path):
    (tmp_path / "test_hung.py").write_text(HUNG)
    started = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                           "--timeout=1", "-o", "timeout_method=signal", "test_hung.py"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=120,
                          check=False)
    elapsed = time.perf_counter() - started
    assert proc.returncode == 1, proc.stdout[-3000:]
    assert "3 failed, 1 passed" in proc.stdout, proc.stdout[-3000:]
    assert proc.stdout.count("Timeout") >= 3  # each failure says why, with its stack
    assert elapsed < 60, f"three 1 s limits took {elapsed:.1f} s"


def test_the_project_configures_a_per_test_limit():
    import tomllib
    from pathlib import Path

    opts = tomllib.loads((Path(__file__).parents[1] / "pyproject.toml").read_text())
    ini = opts["tool"]["pytest"]["ini_options"]
    assert 0 < ini["timeout"] <= 600 and ini["faulthandler_timeout"] < ini["timeout"]
