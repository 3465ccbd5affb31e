"""verify/bench_step_cert.py --quick: the pendulum's step certificate and the certify stage's
tail, timed in process; the answer (certified) checked, the time printed, not judged."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_bench_step_cert_quick_runs():
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    env.pop("FL_DESIGN_TARGETS", None)
    proc = subprocess.run([sys.executable, str(ROOT / "verify" / "bench_step_cert.py"),
                           "--quick"], capture_output=True, text=True, env=env, timeout=240,
                          check=False)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    out = proc.stdout
    assert "load average" in out and "conic programs" in out
    assert "answer: certified" in out and "holds" in out
