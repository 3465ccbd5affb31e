"""verify/bench_job.py --quick: the main job's benchmark runs end to end and reports its stages."""

import os
import subprocess
import sys
from pathlib import Path

import pytest


@pytest.mark.slow
def test_bench_job_quick_times_the_quick_job_cold_and_warm():
    root = Path(__file__).resolve().parents[2]
    env = {**os.environ, "PYTHONPATH": str(root), "MPLBACKEND": "Agg"}  # this tree's fl_design
    proc = subprocess.run([sys.executable, str(root / "verify" / "bench_job.py"), "--quick"],
                          capture_output=True, text=True, timeout=600, cwd=root, check=False,
                          env=env)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    out = proc.stdout
    # each measurement read its stage times back from the run's summary.json
    cold = next(x for x in out.splitlines() if "round 1 cold (--quick)" in x)
    warm = next(x for x in out.splitlines() if "round 1 --quick warm" in x)
    for line in (cold, warm):
        assert "s wall" in line and "stages (s):" in line and "derive" in line
    assert "sweep" in cold and "FAILED" not in out
    assert "main job --quick cold: median" in out and "load average" in out
