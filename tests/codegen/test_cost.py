"""Cost table (operations by kind, stack, size, time), the Cortex-M4F build, CLI, benchmark."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import fl_design as fl
from fl_design import presets
from fl_design._toolchain import find_compiler
from fl_design.app import main
from fl_design.codegen import compare_costs, generate_c, operation_counts
from fl_design.codegen._cost import ARM_FLAGS

ROOT = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.skipif(find_compiler() is None, reason="no C compiler installed")


@pytest.fixture(scope="module")
def table(tmp_path_factory):
    designs = {"EHGO": presets.paper_design(), "LS(9)": presets.least_squares_design(9),
               "LS(26)": presets.least_squares_design(26)}
    return compare_costs(designs, tmp_path_factory.mktemp("cost"), bench_steps=20_000)


def test_operation_counts_follow_the_loop(table):
    rows = {r.name: r for r in table.rows}
    n = 3  # EHGO rho = 2: hand count of the normative loop, the observer in its delta form
    ehgo = rows["EHGO"].operations
    # G (xi - e_1 y), theta g, D^-1 (its first entry is 1); law; conditional integration
    assert ehgo["mul"] == n * n + n + (n - 1) + 5 + 2
    assert ehgo["minmax"] == 4  # clamp of xhat_2 and saturation of u
    # least squares: M @ buffer has (rho + 1) N products and (rho + 1)(N - 1) sums
    ls9, ls26 = rows["LS(9)"].operations, rows["LS(26)"].operations
    assert ls26["mul"] - ls9["mul"] == 3 * (26 - 9)
    assert ls26["add"] - ls9["add"] == 3 * (26 - 9)
    assert 2 * rows["EHGO"].flops <= rows["LS(26)"].flops


def test_delta_realization_costs_fewer_operations():
    d = presets.paper_design()
    from fl_design.codegen import core_function, step_design

    direct = operation_counts(core_function(d, "fl"))
    delta = operation_counts(core_function(step_design(d, "float"), "fl"))
    assert sum(delta.values()) < sum(direct.values())


def test_table_measures_and_serializes(table):
    for row in table.rows:
        assert row.stack_bytes > 0 and row.code_bytes > 0 and row.ns_per_step > 0
    rows = {r.name: r for r in table.rows}
    assert rows["LS(26)"].state_bytes == 8 * (26 + 1 + 2)
    assert rows["EHGO"].code_bytes < rows["LS(26)"].code_bytes
    data = json.loads(json.dumps(table.to_dict(), allow_nan=False))
    assert [r["name"] for r in data["rows"]] == ["EHGO", "LS(9)", "LS(26)"]
    md = table.to_markdown().splitlines()
    # 58: the conditional integration reuses xhat_1 - r of the law (59 with its own copy)
    assert len(md) == 5 and md[2].startswith("| EHGO | double | 58 |")


@pytest.mark.parametrize("precision", ["double", "float"])
def test_the_timed_harness_is_the_measured_object_and_the_package_build(tmp_path, precision):
    """step_cost compiles the package once: its timing harness is main.c linked with the very
    object whose size and stack it measured, byte for byte the executable of CPackage.build
    (which compiles the package again), and -fstack-usage leaves the object's bytes alone."""
    from fl_design.codegen._build import compiler_or_raise
    from fl_design.codegen._cost import _objects, bench_executable

    cc = compiler_or_raise()
    pkg = generate_c(presets.paper_design(), tmp_path / "p", precision=precision)
    objs, frames = _objects(pkg, cc, pkg.flags(), tmp_path / "host")
    assert frames["stack"] > 0
    linked = bench_executable(pkg, objs, compiler=cc).read_bytes()
    plain = tmp_path / "plain.o"
    subprocess.run([cc, *pkg.flags(), "-c", str(pkg.sources[0]), "-o", str(plain)], check=True)
    assert plain.read_bytes() == objs[0].read_bytes()
    assert pkg.build(compiler=cc).read_bytes() == linked


@pytest.mark.skipif(shutil.which("arm-none-eabi-gcc") is None,
                    reason="arm-none-eabi-gcc is not installed (make arm-toolchain)")
def test_cortex_m4f_float_build_calls_no_double_helper(tmp_path):
    cost = generate_c(presets.paper_design(), tmp_path / "f", precision="float").cost(
        bench_steps=10)
    assert cost.arm is not None and cost.arm["double_helpers"] == []
    assert set(cost.arm["undefined"]) <= {"fminf", "fmaxf"}
    # the common path runs in registers (step and run: no frame); the rare path's frames count.
    # The arithmetic is in line twice (the common path and the slow path: no call on the
    # common path): 4288 B measured with gcc 12 (3144 B with one out-of-line copy before).
    assert 0 < cost.arm["code_bytes"] < 5120 and 0 < cost.arm["stack_bytes"] < 1024
    # control: the double package on the same FPU needs the software double helpers
    dbl = generate_c(presets.paper_design(), tmp_path / "d")
    obj = tmp_path / "d.o"
    subprocess.run(["arm-none-eabi-gcc", *ARM_FLAGS, "-c", str(dbl.sources[0]), "-o", str(obj)],
                   check=True, cwd=tmp_path)
    undefined = subprocess.run(["arm-none-eabi-nm", "-u", str(obj)], capture_output=True,
                               text=True, check=True).stdout
    assert "__aeabi_d" in undefined


def test_cli_codegen_writes_the_package(tmp_path, capsys):
    out = tmp_path / "c"
    assert main(["codegen", str(out), "--precision", "float", "--prefix", "trms"]) == 0
    assert "float trms_step(" in (out / "trms.h").read_text()
    printed = capsys.readouterr().out
    assert "wrote 15 files (float, prefix 'trms')" in printed
    assert "\n  model/startup.c\n" in printed and "\n  pil/pil.ld\n" in printed


def test_cli_codegen_q31_package_and_its_range_from_the_plant(tmp_path, capsys):
    """``--precision q31`` writes the Q31 package with the plant's region as its range (no
    "assumed" range warning), and a float package's range check takes the region too."""
    import warnings

    from fl_design.codegen._guard import guard_settings

    with warnings.catch_warnings():
        warnings.simplefilter("error", fl.errors.FloatPrecisionWarning)
        assert main(["codegen", "--out", str(tmp_path / "q"), "--precision", "q31"]) == 0
    assert "wrote 11 files (q31, prefix 'fl')" in capsys.readouterr().out
    assert "int32_t fl_step(" in (tmp_path / "q" / "fl.h").read_text()
    assert main(["codegen", "--out", str(tmp_path / "f"), "--precision", "float"]) == 0
    source = (tmp_path / "f" / "fl.c").read_text()
    written = float(re.search(r"p->y_max = ([-+0-9.eE]+)f;", source).group(1))
    g = guard_settings(presets.paper_design(), fl.plants.trms_yaw())
    assert g.y_max < 1e9  # the region's bound, not the default |y| <= 1e9
    assert written == pytest.approx(g.y_max, rel=1e-6)


@pytest.mark.parametrize("args,needle", [
    (["--precision", "half"], "precision must be one of 'double', 'float', 'q31'"),
    (["--precision", "q31", "--verify"], "--verify: a precision='q31' package has no"),
    (["--prefix", "9x"], "prefix='9x' is not a usable C identifier"),
])
def test_cli_codegen_bad_input_one_line_exit_2(tmp_path, capsys, args, needle):
    assert main(["codegen", str(tmp_path / "c"), *args]) == 2
    err = capsys.readouterr().err.strip()
    assert needle in err and len(err.splitlines()) == 1


def test_bench_codegen_quick():
    env = {**os.environ, "PYTHONPATH": str(ROOT)}  # this tree's fl_design, not an install's
    proc = subprocess.run([sys.executable, str(ROOT / "verify" / "bench_codegen.py"), "--quick"],
                          capture_output=True, text=True, timeout=600, check=False, env=env)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert "[ok] EHGO flops 58 <= 60" in proc.stdout and "| LS(26) | float |" in proc.stdout
