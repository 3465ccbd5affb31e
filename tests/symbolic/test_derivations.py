"""The derivation scripts run, in-process and as scripts, and print what they promise."""

from __future__ import annotations

import doctest
import importlib.util
import re
import subprocess
import sys
from pathlib import Path

import pytest

from fl_design.errors import ParameterError

ROOT = Path(__file__).resolve().parents[2]


def _load(name):
    path = ROOT / "derivations" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(f"_derivation_{name}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


# --- derivations/discretization_report.py -------------------------------------------------------
@pytest.fixture(scope="module")
def disc_report():
    return _load("discretization_report")


def test_discretization_report_main_prints_rho_2_3_4_text_and_latex(disc_report, capsys):
    assert disc_report.main([]) == 0
    out = capsys.readouterr().out
    for rho in (2, 3, 4):
        assert re.search(rf"^rho = {rho}\b", out, flags=re.MULTILINE), f"no block for rho = {rho}"
        assert f"LaTeX (rho = {rho}):" in out
    assert out.count(r"\begin{bmatrix}") == 3 and out.count(r"\begin{aligned}") == 6
    # rho = 2 block: the paper's F^a in eps and the residual orders eps^3, eps^2, eps
    block2 = out.split("rho = 3")[0]
    assert (r"\begin{bmatrix}1 & \alpha \epsilon & \frac{\alpha^{2} \epsilon^{2}}{2}\\"
            r"0 & 1 & \alpha \epsilon\\0 & 0 & 1\end{bmatrix}") in block2
    orders = re.findall(r"O\(\\epsilon\^\{(\d+)\}\)", block2)
    assert orders == ["3", "2", "1"]


def test_discretization_report_text_table_matches_rule(disc_report):
    out = disc_report.report((2, 3, 4), fmt="text")
    assert r"\begin" not in out
    for block, rho in zip(out.split("=" * 78 + "\nrho = ")[1:], (2, 3, 4)):
        rows = [line.split() for line in block.splitlines()
                if re.match(r"^\s+(x\d|sigma)\s+\S+\s+\d+\s+\d+$", line)]
        names = [r[0] for r in rows]
        assert names == [f"x{i}" for i in range(1, rho + 1)] + ["sigma"]
        # order of x_i is rho - i + 2, sigma's is 1, in T and in eps
        expected = [rho - i + 2 for i in range(1, rho + 1)] + [1]
        assert [int(r[-2]) for r in rows] == expected and [int(r[-1]) for r in rows] == expected


def test_discretization_report_latex_fe_is_the_papers_series(disc_report):
    out = disc_report.report((2,), fmt="latex", order=2)
    assert r"\frac{T^{2} \sigma}{2} + T x_{2} + x_{1}" in out  # x1(k+1), order 2
    assert "LaTeX (rho = 2)" in out and "Residual F^e - F^a per component" not in out  # no text


def test_discretization_report_bad_input(disc_report, capsys):
    with pytest.raises(ParameterError, match=r"fmt must be one of \('text', 'latex', 'both'\), "
                                             r"got 'html'"):
        disc_report.report((2,), fmt="html")
    with pytest.raises(ParameterError, match=r"rho_values must list at least one"):
        disc_report.report(())
    assert disc_report.main(["--rho", "0"]) == 2
    assert "rho must be >= 1, got 0" in capsys.readouterr().err


def test_discretization_report_doctests(disc_report):
    result = doctest.testmod(disc_report, optionflags=doctest.ELLIPSIS)
    assert result.failed == 0 and result.attempted > 0


def test_discretization_report_runs_as_a_script_from_the_repo_root():
    proc = subprocess.run(
        [sys.executable, "derivations/discretization_report.py", "--rho", "2", "--format", "text"],
        cwd=ROOT, capture_output=True, text=True, timeout=120, check=False,
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines()[1].startswith("rho = 2")
