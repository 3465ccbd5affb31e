"""verify/bench_monte_carlo.py --quick runs (the speed itself is checked by the full run)."""

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_bench_monte_carlo_quick_runs():
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, str(ROOT / "verify" / "bench_monte_carlo.py"),
                           "--quick"], capture_output=True, text=True, env=env, timeout=300,
                          check=False)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    out = proc.stdout
    assert out.startswith("isa ") and "ratio t_mc / t_sweep median" in out
    assert "64 samples of 2 s" in out and "quick mode: targets not checked" in out
