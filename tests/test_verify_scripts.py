"""Every ``verify/claim_*.py`` (one per paper claim) passes in quick mode and says what it checked."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = sorted((ROOT / "verify").glob("claim_*.py"))


def test_there_is_a_script_per_claim():
    assert len(SCRIPTS) == 12


@pytest.mark.parametrize("script", SCRIPTS, ids=[s.stem for s in SCRIPTS])
def test_claim_script_quick(script):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, str(script), "--quick"], capture_output=True,
                          text=True, env=env, timeout=180, check=False)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    out = proc.stdout
    assert "holds" in out
    assert "FAILS" not in out and "nan" not in out.lower().replace("nanos", "")


def test_scaleout_bench_quick_runs_and_agrees():
    """verify/bench_scaleout.py --quick: executors give the in-process classifications."""
    pytest.importorskip("dask.distributed")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, str(ROOT / "verify" / "bench_scaleout.py"),
                           "--quick"], capture_output=True, text=True, env=env, timeout=240,
                          check=False)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "every executor's map equals the in-process map" in proc.stdout
    assert "isa " in proc.stdout.splitlines()[0]  # the machine and ISA that measured it


def test_predictive_check_quick():
    """verify/predictive_check.py --quick: 6 x 6 grids of the TRMS and the pendulum, verdicts at
    the adaptive duration D against 10 D (the full 12 x 12 check is the same script)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, str(ROOT / "verify" / "predictive_check.py"),
                           "--quick"], capture_output=True, text=True, env=env, timeout=300,
                          check=False)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert proc.stdout.count("6 x 6 grid") == 2
    assert "predictive check: holds" in proc.stdout and "FAILS" not in proc.stdout


def test_predictive_check_full_range_is_the_demo_map_s():
    """``--full-range`` checks the TRMS over the ranges of the demo's map (examples/trms.toml
    [sweep], the default configuration of ``fl-design run``)."""
    import importlib.util
    import tomllib

    spec = importlib.util.spec_from_file_location(
        "predictive_check", ROOT / "verify" / "predictive_check.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    with open(ROOT / "examples" / "trms.toml", "rb") as f:
        sweep = tomllib.load(f)["sweep"]
    assert module.FULL_RANGE == {"trms": (*sweep["eps"], *sweep["gamma"])}
