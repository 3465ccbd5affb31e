"""Processor in the loop: the package's step on a Cortex-M4F model under qemu-system-arm
(-M mps2-an386), cross-compiled with arm-none-eabi-gcc; skipped with the reason without them."""

from __future__ import annotations

import numpy as np
import pytest

import fl_design as fl
from fl_design import presets
from fl_design.app import main
from fl_design.codegen import generate_c
from fl_design.codegen._pil import pil_tools, run_on_model
from fl_design.codegen._sil import DOUBLE_BOUND, FLOAT_BOUND
from fl_design.errors import CompilerNotFoundError, ParameterError

REASON = pil_tools()[2]
needs_qemu = pytest.mark.skipif(bool(REASON), reason=REASON or "tools present")


@needs_qemu
@pytest.mark.parametrize("name,precision", [("trms", "float"), ("maglev", "float"),
                                            ("trms", "double")])
def test_step_on_the_cortex_m4_model_equals_design_step(tmp_path, name, precision):
    if name == "trms":
        plant, design, sc = fl.plants.trms_yaw(), presets.paper_design(), fl.Scenario(0.3, 2.0)
    else:
        plant, design = fl.plants.maglev(), presets.maglev_design()
        sc = fl.Scenario(float(plant.x_op[0]) + 2e-4, 1.0)
    pkg = generate_c(design, tmp_path, precision=precision)
    res = pkg.pil(plant, sc, max_samples=1000)
    assert res.u_c.size == 1000 and res.passed, res.to_dict()
    assert res.max_rel_error <= (FLOAT_BOUND if precision == "float" else DOUBLE_BOUND)
    if precision == "float":
        assert res.max_rel_error > 0.0  # single precision on the FPU, not double in disguise
        # a straight-line step of ~60 flops plus its checks: tens to a few hundred instructions
        assert 60 < res.instructions < 400
    else:  # no double FPU: software double costs an order of magnitude more
        assert res.instructions > 1000


@needs_qemu
def test_no_flush_is_the_cortex_m4_default(tmp_path):
    """The M4's FPU computes subnormals in hardware at the instructions' fixed cost: the step
    neither flushes nor touches FPSCR there, so -DFL_NO_FLUSH builds the same step."""
    pkg = generate_c(presets.paper_design(), tmp_path, precision="float")
    sc = fl.Scenario(0.3, 1.0)
    full = pkg.pil(fl.plants.trms_yaw(), sc, max_samples=500)
    lean = pkg.pil(fl.plants.trms_yaw(), sc, max_samples=500, cflags=("-DFL_NO_FLUSH",))
    assert (lean.u_c == full.u_c).all()
    assert full.instructions == pytest.approx(lean.instructions, abs=0.5)
    assert "fpscr" not in (tmp_path / "fl.c").read_text().lower().replace("fpscr alone", "")


@needs_qemu
def test_the_cortex_m4_build_keeps_a_subnormal_state(tmp_path):
    """u started at a subnormal value, y = r = 0 at rest: the step computes u - gamma * 0 and
    the subnormal u stays (IEEE arithmetic on the FPU), as with -DFL_NO_FLUSH on a host; the
    host build without it flushes the stored state (test_firmware)."""
    pkg = generate_c(presets.paper_design(), tmp_path, precision="float")
    zeros, tiny = np.zeros(50), float(np.float32(1e-40))
    assert 0.0 < tiny < np.finfo(np.float32).tiny
    u, _ = run_on_model(pkg, zeros, zeros, 0.0, tiny)
    assert (u == tiny).all()


@needs_qemu
def test_a_replacement_step_is_timed_in_the_same_loop(tmp_path):
    """The empty loop is subtracted: a step that only returns its argument costs ~0."""
    pkg = generate_c(presets.paper_design(), tmp_path, precision="float")
    stub = tmp_path / "stub.c"
    stub.write_text('#include "fl.h"\nfloat stub_step(fl_state_t *s, float y, float r);\n'
                    "float stub_step(fl_state_t *s, float y, float r) {\n"
                    "  (void) s;\n  (void) r;\n  return y;\n}\n")
    y = np.linspace(0.0, 1.0, 600)
    u, instructions = run_on_model(pkg, y, y, 0.0, 0.0, step=(stub, "stub_step"))
    np.testing.assert_array_equal(u, y.astype(np.float32))
    assert abs(instructions) < 0.5


def test_missing_tools_are_named(tmp_path, monkeypatch):
    pkg = generate_c(presets.paper_design(), tmp_path, precision="float")
    monkeypatch.setattr("fl_design.codegen._pil.shutil.which", lambda name: None)
    with pytest.raises(CompilerNotFoundError, match="arm-none-eabi-gcc and qemu-system-arm not "
                                                    "installed.*apt-get install"):
        pkg.pil(fl.plants.trms_yaw(), fl.Scenario(0.3, 0.1))


@needs_qemu
def test_bad_sample_count(tmp_path):
    pkg = generate_c(presets.paper_design(), tmp_path, precision="float")
    with pytest.raises(ParameterError, match="max_samples=0 must be an integer >= 1"):
        pkg.pil(fl.plants.trms_yaw(), fl.Scenario(0.3, 0.1), max_samples=0)


@needs_qemu
def test_cli_codegen_pil(tmp_path, capsys):
    assert main(["codegen", str(tmp_path / "c"), "--precision", "float", "--pil"]) == 0
    out = capsys.readouterr().out
    assert "PIL on a Cortex-M4F (QEMU mps2-an386)" in out and "passed" in out


def test_a_q31_package_is_sent_to_its_own_models(tmp_path):
    """The Cortex-M4F PIL runs double and float packages; a Q31 one gets a clear error naming
    where it runs (before any tool is looked for)."""
    pkg = generate_c(presets.paper_design(), tmp_path / "q", precision="q31",
                     plant=fl.plants.trms_yaw())
    with pytest.raises(ParameterError, match="q31_on_model"):
        pkg.pil(fl.plants.trms_yaw(), fl.Scenario(0.3, 0.1))
