"""generate_c: files, API, strict compiles (gcc, clang), true single precision, bad input."""

from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pytest

import fl_design as fl
from fl_design import presets
from fl_design._toolchain import find_compiler
from fl_design.codegen import CPackage, generate_c
from fl_design.errors import CompilerNotFoundError, OutputPathError, ParameterError

pytestmark = pytest.mark.skipif(find_compiler() is None, reason="no C compiler installed")
COMPILERS = [c for c in ("gcc", "clang") if shutil.which(c)]


def test_files_and_api(paper_packages):
    pkg = paper_packages["double"]
    assert isinstance(pkg, CPackage)
    assert {str(p.relative_to(pkg.out_dir)) for p in pkg.files} == {
        "fl.h", "fl.c", "main.c", "Makefile", "CMakeLists.txt", "README.md", "pil/pil_main.c",
        "pil/pil_startup.c", "pil/pil_semihost.h", "pil/pil.ld", "check.c", "test_vectors.txt",
        "MISRA_DEVIATIONS.md", "model/startup.c", "model/model.ld"}
    header = pkg.header.read_text()
    for decl in ("} fl_state_t;", "} fl_params_t;", "void fl_init(fl_state_t *s);",
                 "void fl_reset(fl_state_t *s);",
                 "int fl_start(fl_state_t *s, double y0, double u0);",
                 "int fl_set_params(fl_state_t *s, const fl_params_t *p);",
                 "void fl_default_params(fl_params_t *p);",
                 "double fl_step(fl_state_t *s, double y, double r);"):
        assert decl in header
    fheader = paper_packages["float"].header.read_text()
    assert "float fl_step(fl_state_t *s, float y, float r);" in fheader
    assert "double" not in fheader.split("#define FL_STATE_SIZE")[1]
    # the fixed numbers are named constants; the tunable ones are the parameter defaults
    d = presets.paper_design()
    consts = dict(re.findall(r"#define (FL_\w+)\s+(\S+)", header))
    assert float(consts["FL_T"]) == d.T and float(consts["FL_EPS"]) == d.estimator.eps
    defaults = dict(re.findall(r"p->([\w\[\]]+) = (\S+?);", pkg.sources[0].read_text()))
    assert float(defaults["gamma"]) == d.controller.gamma
    assert [float(defaults["k[0]"]), float(defaults["k[1]"])] == list(d.controller.gains)
    assert (float(defaults["u_min"]), float(defaults["u_max"])) == d.controller.u_range
    assert float(defaults["xhat_max[1]"]) == 0.05
    assert "1 kHz" in (pkg.out_dir / "README.md").read_text()
    assert '#include "fl.h"' in pkg.sources[0].read_text()  # the source includes its header


def test_no_heap_no_mutable_globals(paper_packages):
    for pkg in paper_packages.values():
        code = "\n".join(p.read_text() for p in pkg.sources)
        assert not re.search(r"\b(malloc|calloc|realloc|free)\s*\(", code)
        for line in code.splitlines():  # file-scope data must be const
            if re.match(r"^(static\s+)?(const\s+)?\w+\s+\w+\s*\[.*\]\s*=", line):
                assert "const" in line, line


@pytest.mark.parametrize("compiler", COMPILERS)
@pytest.mark.parametrize("precision", ["double", "float"])
def test_strict_compile_no_library_call_one_step_exported(paper_packages, precision, compiler):
    pkg = paper_packages[precision]
    flags = pkg.flags()
    assert {"-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", "-Wmissing-prototypes",
            "-Wfloat-equal", "-Wdouble-promotion"} <= set(flags)
    exe = pkg.build(compiler=compiler)
    objs = []
    for src in pkg.sources:
        obj = src.with_suffix(f".{compiler}.o")
        subprocess.run([compiler, *flags, "-c", str(src), "-o", str(obj)], check=True)
        objs.append(str(obj))
    linked = objs[0]
    nm = lambda *a: subprocess.run(["nm", *a, linked], capture_output=True, text=True,
                                   check=True).stdout
    assert {u for u in nm("-u").split() if u != "U"} == set()  # no libm, not even memcpy
    exported = set(re.findall(r" T (\w+)", nm("-g", "--defined-only")))
    assert exported == {"fl_init", "fl_reset", "fl_start", "fl_step", "fl_set_params",
                        "fl_default_params", "fl_disengage", "fl_manual_input", "fl_engage",
                        "fl_telemetry", "fl_steps", "fl_excitation_init", "fl_excite"}
    assert exe.exists()


def test_float_code_is_single_precision(paper_packages):
    core = (paper_packages["float"].out_dir / "fl.c").read_text()
    body = core.split("static FL_INLINE void fl_core(")[1].split("\n}\n")[0]
    assert not re.search(r"(?<![\w.])\d+\.\d*(e[+-]?\d+)?(?![\w.f])", body)  # no double literal
    assert "double" not in body and not re.search(r"\bf(max|min)f?\(", core)
    assert "-Wdouble-promotion" in paper_packages["float"].flags()


def test_makefile_builds_the_harness(paper_packages, tmp_path):
    if shutil.which("make") is None:
        pytest.skip("make is not installed")
    pkg = paper_packages["float"]
    subprocess.run(["make", "-s", "-C", str(pkg.out_dir)], check=True, capture_output=True)
    out = subprocess.run([str(pkg.out_dir / "fl_main")], input="0.0 0.3\n", text=True,
                         capture_output=True, check=True).stdout
    ref = presets.paper_design().run([0.0], 0.3).u[0]
    assert float(out) == pytest.approx(ref, rel=1e-6)


def test_prefix_names_everything(tmp_path):
    pkg = generate_c(presets.least_squares_design(9), tmp_path, prefix="ls9")
    assert "double ls9_step(ls9_state_t *s, double y, double r);" in pkg.header.read_text()
    assert "#define LS9_WINDOW" in pkg.header.read_text()
    u = pkg.run(np.zeros(12), np.full(12, 0.3))
    np.testing.assert_array_equal(u, presets.least_squares_design(9).run(np.zeros(12), 0.3).u)


# --- bad input ---------------------------------------------------------------------------------
def test_unknown_precision(tmp_path):
    with pytest.raises(ParameterError, match=r"precision='half'.*'double', 'float'"):
        generate_c(presets.paper_design(), tmp_path, precision="half")


@pytest.mark.parametrize("prefix", ["2fl", "my-ctrl", "int", "", "__x", None])
def test_prefix_not_a_c_identifier(tmp_path, prefix):
    with pytest.raises(ParameterError, match=r"prefix=.* is not a usable C identifier"):
        generate_c(presets.paper_design(), tmp_path, prefix=prefix)


def test_folder_that_cannot_be_written(tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    with pytest.raises(OutputPathError, match="a_file/out.*cannot be used") as info:
        generate_c(presets.paper_design(), blocker / "out")
    assert isinstance(info.value, ValueError)


def test_no_c_compiler(tmp_path, monkeypatch):
    pkg = generate_c(presets.paper_design(), tmp_path)  # writing needs no compiler
    monkeypatch.setattr("fl_design.codegen._build.find_compiler", lambda: None)
    with pytest.raises(CompilerNotFoundError, match="no C compiler found: set \\$CC") as info:
        pkg.build()
    assert isinstance(info.value, RuntimeError)


def test_not_a_design(tmp_path):
    with pytest.raises(ParameterError, match="design must be a fl.Design"):
        generate_c(fl.EHGO(2, 0.05, 1e-3), tmp_path)


def test_cmake_builds_the_library_and_harness(paper_packages, tmp_path):
    if shutil.which("cmake") is None:
        pytest.skip("cmake is not installed")
    pkg = paper_packages["float"]
    build = tmp_path / "build"
    for cmd in (["cmake", "-S", str(pkg.out_dir), "-B", str(build), "-DCMAKE_C_FLAGS=-Werror"],
                ["cmake", "--build", str(build)]):
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300, check=False)
        assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    out = subprocess.run([str(build / "fl_main")], input="0.0 0.3\n", text=True,
                         capture_output=True, check=True, timeout=60).stdout
    assert float(out) == pytest.approx(presets.paper_design().run([0.0], 0.3).u[0], rel=1e-6)


@pytest.mark.parametrize("design", ["ls26", "maglev"])
def test_every_estimator_builds_clean_in_both_precisions(tmp_path, design):
    d = presets.least_squares_design(26) if design == "ls26" else presets.maglev_design()
    for precision in ("double", "float"):
        pkg = generate_c(d, tmp_path / precision, precision=precision)
        for cc in COMPILERS:
            pkg.build(compiler=cc)  # -Werror with -Wmissing-prototypes -Wfloat-equal ...
        code = pkg.sources[0].read_text()
        assert not re.search(r"\bf(max|min|abs)f?\(", code)


@pytest.mark.parametrize("prefix", ["main", "check", "Sil"])
def test_a_prefix_naming_a_package_file_is_refused(prefix, tmp_path):
    """``prefix='main'`` wrote the step over main.c: a package that did not link (issue 36)."""
    with pytest.raises(ParameterError, match=rf"prefix='{prefix}'"):
        fl.generate_c(presets.paper_design(), tmp_path / "pkg", prefix=prefix)
    assert not (tmp_path / "pkg" / "main.c").exists()
