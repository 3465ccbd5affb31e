"""Run a Python script in a child process of its own session, with a bound on the wait.

Shared by the tests whose child starts pool workers or dies on purpose
(``tests/sim/test_fork_safety.py``, ``tests/sim/test_worker_lost.py``,
``tests/app/test_partial_run.py``): a child still running at ``timeout`` is killed with its
whole process group (its pool workers too), so a hang fails the test instead of the suite.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys


def run_script(script, *args: str, timeout: float = 240.0,
               env: dict | None = None) -> tuple[int | None, str, str]:
    """``(exit code, stdout, stderr)`` of ``python script *args``; the code is None on a hang."""
    proc = subprocess.Popen([sys.executable, str(script), *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True, env=env)
    try:
        out, err = proc.communicate(timeout=timeout)
        return proc.returncode, out, err
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        return None, out, err
