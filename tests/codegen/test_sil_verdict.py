"""The SIL fails what does not work: a stalled loop, a verdict mismatch; the CLI says so."""

from __future__ import annotations

import types

import numpy as np
import pytest

import fl_design as fl
from fl_design import presets
from fl_design._toolchain import find_compiler
from fl_design.codegen import SilResult, generate_c


def _result(c_status, sim_status, err=0.0):
    u = np.array([1.0, 2.0])
    from fl_design.codegen._sil import loop_failed

    return SilResult("double", np.zeros(2), u + err, u, 1e-12, c_status, sim_status,
                     c_status in ("converged", "converging"), loop_failed(c_status, [1.0, 1.0]))


@pytest.mark.parametrize("c_status, sim_status, passed", [
    ("converged", "converged", True), ("undecided", "undecided", True),
    ("stalled", "stalled", False), ("undecided", "converged", False),
    ("converging", "converged", False), ("diverged", "diverged", False)])
def test_pass_rule(c_status, sim_status, passed):
    assert _result(c_status, sim_status).passed is passed


@pytest.mark.skipif(find_compiler() is None, reason="no C compiler installed")
def test_an_unreachable_reference_fails(tmp_path):
    # |u| <= 0.5 cannot hold the pendulum at 1 rad (m g l sin(1) is larger): the loop stalls
    plant, sc = fl.plants.pendulum(), fl.Scenario(1.0, 10.0)
    design = presets.pendulum_design(u_limits=(-0.5, 0.5))
    assert fl.simulate(plant, design, sc).status == "stalled"
    res = generate_c(design, tmp_path).verify(plant, sc)
    assert res.matches and res.verdicts_agree and res.c_status == "stalled"
    assert res.c_failed and not res.passed and res.to_dict()["passed"] is False


@pytest.mark.parametrize("passed, code", [(True, 0), (False, 1)])
def test_cli_codegen_verify_exit_code(monkeypatch, tmp_path, capsys, passed, code):
    from fl_design.app import _cli, _console, _job

    sil = _result("converged", "converged" if passed else "undecided")
    fake = types.SimpleNamespace(results={"codegen": {"sil": sil}})
    monkeypatch.setattr(_job, "run_job", lambda *a, **k: fake)
    monkeypatch.setattr(_console, "print_codegen", lambda job: None)
    assert _cli.main(["codegen", "--out", str(tmp_path / "pkg"), "--verify"]) == code
    if not passed:
        assert "software-in-the-loop check failed" in capsys.readouterr().err
