"""``make check-m4 / check-m3 / check-m0plus``: the package's own test vectors replayed by
check.c cross-compiled for a Cortex-M model and run under qemu-system-arm (semihosting file I/O),
for the TRMS, maglev and flexible-joint designs: float (and double) on the Cortex-M4F, Q31 on
the Cortex-M3 and the ARMv6-M (M0+) model. Skipped with the reason without the tools."""

from __future__ import annotations

import shutil
import subprocess

import pytest

import fl_design as fl
from fl_design import presets
from fl_design.codegen import generate_c
from fl_design.codegen._pil import pil_tools

REASON = pil_tools()[2] or ("" if shutil.which("make") else "make is not installed")
pytestmark = [pytest.mark.skipif(bool(REASON), reason=REASON or "tools present"),
              pytest.mark.slow]
DESIGNS = {"trms": (presets.paper_design, fl.plants.trms_yaw),
           "maglev": (presets.maglev_design, fl.plants.maglev),
           "flexible_joint": (presets.flexible_joint_design, fl.plants.flexible_joint)}
TARGETS = {"float": ("check-m4",), "q31": ("check-m3", "check-m0plus")}


@pytest.fixture(scope="module")
def packages(tmp_path_factory):
    root = tmp_path_factory.mktemp("model_check")
    return {(name, prec): generate_c(design(), root / f"{name}_{prec}", precision=prec,
                                     plant=plant())
            for name, (design, plant) in DESIGNS.items() for prec in TARGETS}


def make(pkg, target):
    return subprocess.run(["make", "-s", "-C", str(pkg.out_dir), target], capture_output=True,
                          text=True, timeout=600, check=False)


@pytest.mark.parametrize("name", list(DESIGNS))
@pytest.mark.parametrize("precision, target", [(p, t) for p, ts in TARGETS.items() for t in ts])
def test_the_vectors_pass_on_the_model(packages, name, precision, target):
    proc = make(packages[(name, precision)], target)
    assert proc.returncode == 0, proc.stdout + proc.stderr[-2000:]
    assert "PASS: 1500 samples, 0 outside" in proc.stdout, proc.stdout
    if precision == "q31":  # bit-exact with the host's integer model on every target
        assert "max |u - u_expected| = 0 " in proc.stdout, proc.stdout


def test_a_wrong_vector_fails_on_the_model(tmp_path):
    """One expected u moved by 1e-3 of its scale: the model's run says FAIL and make fails."""
    pkg = generate_c(presets.paper_design(), tmp_path / "p", precision="float")
    path = pkg.out_dir / "test_vectors.txt"
    lines = path.read_text().splitlines()
    k = next(i for i, line in enumerate(lines)
             if not line.startswith(("#", "tol")) and len(line.split()) == 3)
    k += 100
    y, r, u = lines[k].split()
    lines[k] = f"{y} {r} {float(u) + 1e-3!r}"
    path.write_text("\n".join(lines) + "\n")
    proc = make(pkg, "check-m4")
    assert proc.returncode != 0 and "FAIL: 1500 samples, 1 outside" in proc.stdout, proc.stdout


def test_double_package_on_the_m4_model(tmp_path):
    """Software double on the M4F (no double FPU): the same vectors within the double bound."""
    pkg = generate_c(presets.paper_design(), tmp_path / "d", precision="double")
    proc = make(pkg, "check-m4")
    assert proc.returncode == 0 and "PASS: 1500 samples, 0 outside" in proc.stdout, proc.stdout
