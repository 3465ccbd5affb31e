"""Programs of several files compiled once per content (the SIL driver): keyed, verified, honest.

``build_program`` caches an executable under the hash of every file it was given (headers
included), the compiler and the flags; the software-in-the-loop driver goes through it, so a
warm job's SIL runs without a compiler call, and the executable it runs is the one a fresh
compile of the same files gives.
"""

from __future__ import annotations

import subprocess

import pytest

import fl_design as fl
from fl_design import _toolchain
from fl_design._toolchain import build_program, find_compiler
from fl_design.codegen._sil import build_driver
from fl_design.errors import CompilationError, ParameterError

pytestmark = pytest.mark.skipif(find_compiler() is None, reason="no C compiler")

PROGRAM = {
    "main.c": '#include <stdio.h>\n#include "k.h"\nint twice(int);\n'
              'int main(void) { printf("%d\\n", twice(K)); return 0; }\n',
    "twice.c": "int twice(int);\nint twice(int x) { return 2 * x; }\n",
    "k.h": "#define K 21\n",
}


def _run(data: bytes, folder) -> str:
    exe = folder / "prog"
    exe.write_bytes(data)
    exe.chmod(0o700)
    return subprocess.run([str(exe)], capture_output=True, text=True, check=True,
                          timeout=60).stdout.strip()


@pytest.fixture
def compiles(monkeypatch):
    """Count the compiler runs (the commands with ``-o``; every command runs as usual)."""
    calls = []
    real = _toolchain.subprocess.run

    def run(cmd, *args, **kwargs):
        if "-o" in cmd:
            calls.append(cmd)
        return real(cmd, *args, **kwargs)

    monkeypatch.setattr(_toolchain.subprocess, "run", run)
    return calls


def test_a_program_is_compiled_once_per_content(tmp_path, compiles):
    first = build_program(PROGRAM, "prog", flags=["-O2", "-std=c99", "-I."], cache_dir=tmp_path)
    assert _run(first, tmp_path) == "42" and len(compiles) == 1
    again = build_program(PROGRAM, "prog", flags=["-O2", "-std=c99", "-I."], cache_dir=tmp_path)
    assert again == first and len(compiles) == 1  # read back, verified, no compiler run
    # a header is part of the key: another K is another program
    other = build_program({**PROGRAM, "k.h": "#define K 5\n"}, "prog",
                          flags=["-O2", "-std=c99", "-I."], cache_dir=tmp_path)
    assert _run(other, tmp_path) == "10" and len(compiles) == 2
    # so are the flags
    build_program(PROGRAM, "prog", flags=["-O1", "-std=c99", "-I."], cache_dir=tmp_path)
    assert len(compiles) == 3


def test_a_damaged_cached_program_is_compiled_again(tmp_path, compiles):
    flags = ["-O2", "-std=c99", "-I."]
    good = build_program(PROGRAM, "prog", flags=flags, cache_dir=tmp_path)
    (cached,) = tmp_path.glob("prog_*.bin")
    cached.write_bytes(b"\x7fELF planted" * 8)
    assert build_program(PROGRAM, "prog", flags=flags, cache_dir=tmp_path) == good
    assert len(compiles) == 2


def test_compiler_errors_and_bad_names_are_reported(tmp_path):
    with pytest.raises(CompilationError, match=r"compiling broken failed: .*twice\.c"):
        build_program({**PROGRAM, "twice.c": "int twice(int x) { return x +; }\n"}, "broken",
                      flags=["-std=c99", "-I."], cache_dir=tmp_path)
    for files in ({"../main.c": "int main(void){return 0;}"}, {"k.h": "#define K 1\n"},
                  {"-shared.c": "int main(void){return 0;}"}):
        with pytest.raises(ParameterError, match=r"plain file names \(no folder"):
            build_program(files, "bad", flags=[], cache_dir=tmp_path)


def test_without_any_writable_cache_the_sil_driver_is_compiled_in_place(tmp_path, monkeypatch):
    """Neither the cache nor a temporary folder writable: build_program says so
    (UnusableCache, both reasons) and the SIL compiles its driver in the package's folder."""
    def unwritable():
        raise OSError(13, "Permission denied", "nowhere")

    monkeypatch.setattr(_toolchain, "cache_directory", lambda *a: unwritable())
    monkeypatch.setattr(_toolchain, "_fallback_directory", unwritable)
    with pytest.raises(_toolchain.UnusableCache, match="neither the compiled-kernel cache"):
        build_program(PROGRAM, "prog", flags=["-I."])
    pkg = fl.generate_c(fl.presets.paper_design(), tmp_path / "pkg")
    exe = build_driver(pkg, fl.plants.trms_yaw(), 1)
    assert exe == pkg.out_dir / "build" / "fl_sil" and exe.stat().st_size > 0


def test_the_sil_driver_is_compiled_once_and_is_a_fresh_compile(tmp_path, monkeypatch, compiles):
    """A second driver of the same package and plant runs no compiler; its executable is,
    byte for byte, the same units compiled by hand with the flags the SIL always used."""
    monkeypatch.setenv("FL_DESIGN_CACHE", str(tmp_path / "cache"))
    pkg = fl.generate_c(fl.presets.paper_design(), tmp_path / "pkg")
    plant = fl.plants.trms_yaw()
    exe = build_driver(pkg, plant, 1)
    assert len(compiles) == 1 and exe == pkg.out_dir / "build" / "fl_sil"
    first = exe.read_bytes()
    assert build_driver(pkg, plant, 1).read_bytes() == first and len(compiles) == 1
    build = pkg.out_dir / "build"
    hand = tmp_path / "hand"
    hand.mkdir()
    for src in (build / "sil.c", build / "fl_plant.c", build / "fl_plant.h", pkg.sources[0],
                pkg.header):
        (hand / src.name).write_text(src.read_text())
    (hand / "fl_sil_main.c").write_text((hand / "sil.c").read_text())
    cc = _toolchain.compiler_command()
    with subprocess.Popen([*cc, "-O2", "-std=c99", "-I.", "fl_sil_main.c", "fl_plant.c", "fl.c",
                           "-o", "fl_sil.bin", "-lm"], cwd=hand) as proc:  # not counted
        assert proc.wait(timeout=300) == 0
    assert (hand / "fl_sil.bin").read_bytes() == first
    res = pkg.verify(plant, fl.Scenario(0.3, 0.5))
    # the check itself compiles no driver either (only simulate's kernel, for its verdict)
    assert res.passed and sum("fl_sil_main.c" in cmd for cmd in compiles) == 1


def test_bench_compile_quick(tmp_path):
    """The benchmark's quick mode runs: the one-step kernel records the two-step kernel's bits
    and a warm SIL driver runs no compiler (timings are the benchmark's, not checked here)."""
    import os
    import re
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    env = {**os.environ, "PYTHONPATH": str(root), "FL_DESIGN_CACHE": str(tmp_path)}
    proc = subprocess.run([sys.executable, str(root / "verify" / "bench_compile.py"), "--quick"],
                          capture_output=True, text=True, timeout=600, check=False, env=env)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert "same bits: True" in proc.stdout
    assert re.search(r"compiler CPU median [0-9.]+ s, the old way [0-9.]+ s", proc.stdout)
    assert float(re.search(r"SIL driver warm ([0-9.]+) s", proc.stdout).group(1)) < 0.02
