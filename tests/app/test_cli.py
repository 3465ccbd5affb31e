"""The command line and the main job (``make demo``) in quick mode, and the examples."""

from __future__ import annotations

import json
import runpy
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fl_design.app import main

ROOT = Path(__file__).resolve().parents[2]


def test_derive_prints_relative_degree_and_b_range(capsys):
    assert main(["derive", "--plant", "trms"]) == 0
    out = capsys.readouterr().out
    assert "relative degree rho = 2" in out
    assert "b-range over the region: [3.6, 6.8]" in out
    assert "x1         T**3*sigma_dot/6           3           3" in out


def test_derive_latex_for_flexible_joint(capsys):
    assert main(["derive", "--plant", "flexible-joint", "--latex"]) == 0
    out = capsys.readouterr().out
    assert "relative degree rho = 4" in out and "LaTeX F^a: \\left[" in out


def test_unknown_plant_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["derive", "--plant", "cartpole"])
    assert exc.value.code == 2
    assert "invalid choice: 'cartpole'" in capsys.readouterr().err


def test_demo_quick_writes_summary_and_figures(tmp_path, capsys):
    assert main(["demo", "--quick", "--out", str(tmp_path), "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "Sampled linearized loop at eps = 0.05" in out
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["b_bounds"] == pytest.approx([3.6, 6.8], rel=1e-9)
    assert summary["spectral_radius"] < 1.0
    rows = summary["noise-free"]
    assert [r["design"] for r in rows] == ["EHGO eps=0.05", "LS window=9", "LS window=26"]
    # the computational cost per sample: EHGO 2n^2+2n = 24 (n = 3); LS (rho+1)*window
    assert [r["flops_per_step"] for r in rows] == [24, 27, 78]
    status = np.array(summary["stability_map"]["status"])
    assert status.shape == (5, 5)
    assert (tmp_path / "response.png").stat().st_size > 10_000
    assert (tmp_path / "stability_map.png").stat().st_size > 10_000


def test_python_dash_m_entry_point(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "fl_design", "derive", "--plant", "pendulum"],
                          capture_output=True, text=True, check=True, cwd=tmp_path)
    assert "Plant: pendulum" in proc.stdout


def test_paper_comparison_example_quick(capsys):
    module = runpy.run_path(str(ROOT / "examples" / "paper_comparison.py"))
    assert module["main"](["--quick"]) == 0
    out = capsys.readouterr().out
    assert out.count("EHGO eps=0.05") == 2 and out.count("LS N=26") == 2
