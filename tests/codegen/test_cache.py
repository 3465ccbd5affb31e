"""The compiled-kernel cache heals itself and falls back when it cannot be written."""

from __future__ import annotations

import errno
import json
import os
import shutil
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pytest

import fl_design as fl
from fl_design import _toolchain as _build
from fl_design._toolchain import build, cache_directory, find_compiler
from fl_design.errors import CompilationWarning, ComputationError
from fl_design.sim._run import prepare_run
from fl_design.sim.kernel import _runners
from fl_design.sim.kernel._runners import InterpretedRunner, NativeRunner, runner_source

needs_cc = pytest.mark.skipif(find_compiler() is None, reason="no C compiler")


@pytest.fixture(scope="module")
def bench():
    """The pendulum loop: its run set-up and the C source of its kernel."""
    design = fl.Design(estimator=fl.EHGO(rho=2, eps=0.02, T=1e-3),
                       controller=fl.DynamicController((2, 4), 1e-2))
    run = prepare_run(fl.plants.pendulum(), design, fl.Scenario(0.1, 0.3))
    sl = run.loop.layout.slices
    indices = {"k": sl["k"].start, "div": sl["diverged"].start, "N": sl["N"].start}
    acc0 = run.initial_accumulator(design.parameter_vector())[:, 0]
    return run, runner_source(run.loop.accumulate, run.loop.record, indices), acc0


def _record(bench, cache_dir):
    run, _, acc0 = bench
    runner = run.loop.runner(kernel=fl.Kernel(cache_dir=cache_dir, lanes=False))
    assert isinstance(runner, NativeRunner)
    return runner.record(acc0.copy(), run.D)  # the native runner writes into its input


@pytest.fixture(scope="module")
def clean(bench, tmp_path_factory):
    return _record(bench, tmp_path_factory.mktemp("clean"))


def _truncate(lib):
    lib.write_bytes(lib.read_bytes()[: lib.stat().st_size // 2])


def _garbage(lib):
    lib.write_bytes(b"\x7fELF not really" * 64)


def _flip_sidecar(lib):
    side = Path(str(lib) + _build.SIDECAR_SUFFIX)
    record = json.loads(side.read_text())
    record["sha256"] = "0" * 64
    side.write_text(json.dumps(record))


CORRUPTIONS = {
    "truncated": _truncate,
    "empty": lambda lib: lib.write_bytes(b""),
    "garbage": _garbage,
    "missing sidecar": lambda lib: Path(str(lib) + _build.SIDECAR_SUFFIX).unlink(),
    "sidecar mismatch": _flip_sidecar,
    "sidecar not json": lambda lib: Path(str(lib) + _build.SIDECAR_SUFFIX).write_text("{"),
    "missing library": lambda lib: lib.unlink(),
}


@needs_cc
@pytest.mark.parametrize("kind", list(CORRUPTIONS))
def test_a_damaged_cached_kernel_is_rebuilt_and_runs_as_a_clean_one(kind, bench, clean, tmp_path):
    lib = build(bench[1], "fl_loop", cache_dir=tmp_path)  # built, never loaded in this process
    good = lib.read_bytes()
    CORRUPTIONS[kind](lib)
    assert not _build.verified(lib)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # healing is silent
        acc, out = _record(bench, tmp_path)
    np.testing.assert_array_equal(acc, clean[0])
    np.testing.assert_array_equal(out, clean[1])
    assert _build.verified(lib) and lib.read_bytes() == good


@needs_cc
def test_an_unverified_library_is_never_loaded(bench, tmp_path, monkeypatch):
    lib = build(bench[1], "fl_loop", cache_dir=tmp_path)
    _truncate(lib)
    monkeypatch.setattr(_build.ctypes, "CDLL", lambda *a: pytest.fail("dlopen of a bad file"))
    with pytest.raises(ComputationError, match="does not match its recorded size and SHA-256"):
        _runners._load(str(lib))


@needs_cc
def test_a_library_changed_after_each_build_ends_in_the_interpreter(bench, tmp_path, monkeypatch):
    run = bench[0]
    monkeypatch.setattr(_build, "verified", lambda path: False)  # the loaders' one check
    with pytest.warns(CompilationWarning, match="after 3 rebuilds") as caught:
        runner = run.loop.runner(kernel=fl.Kernel(cache_dir=tmp_path, lanes=False))
    assert isinstance(runner, InterpretedRunner) and len(caught) == 1


# --- unusable cache directories --------------------------------------------------------------
def _raise_under(monkeypatch, module, name, root: Path, code: int, *, arg: int = 0):
    """Make ``module.name`` raise OSError(code) for paths under ``root`` (argument ``arg``)."""
    real = getattr(module, name)

    def fake(*args, **kw):
        if str(args[arg]).startswith(str(root)):
            raise OSError(code, os.strerror(code), str(args[arg]))
        return real(*args, **kw)

    monkeypatch.setattr(module, name, fake)


def _regular_file(tmp_path):
    path = tmp_path / "a-file"
    path.write_text("not a directory")
    return path


def _unusable(kind: str, tmp: Path, monkeypatch) -> Path:
    """A cache directory that cannot be used, of the given kind (tests may run as root)."""
    if kind == "a regular file":
        return _regular_file(tmp)
    if kind == "under a regular file":
        return _regular_file(tmp) / "cache"
    if kind == "read-only file system":  # os.mkdir of the missing cache raises EROFS
        _raise_under(monkeypatch, os, "mkdir", tmp / "ro", errno.EROFS)
        return tmp / "ro" / "cache"
    (tmp / "dir").mkdir()
    if kind == "no permission":  # existing, but nothing can be created in it
        _raise_under(monkeypatch, os, "mkdir", tmp / "dir", errno.EACCES)
    else:  # full disk: the library cannot be put in place
        _raise_under(monkeypatch, os, "replace", tmp / "dir", errno.ENOSPC, arg=1)
    return tmp / "dir"


UNUSABLE = ["a regular file", "under a regular file", "read-only file system", "no permission",
            "full disk"]


@needs_cc
@pytest.mark.parametrize("kind", UNUSABLE)
def test_an_unusable_cache_falls_back_to_a_temporary_directory_with_one_warning(
        kind, bench, clean, tmp_path, monkeypatch):
    private = tmp_path / "private"
    monkeypatch.setattr(_build, "_FALLBACK", {"dir": private})
    private.mkdir()
    cache = _unusable(kind, tmp_path, monkeypatch)
    with pytest.warns(CompilationWarning, match="private temporary directory") as caught:
        _acc, out = _record(bench, cache)
    assert len(caught) == 1, [str(w.message) for w in caught]
    assert "FL_DESIGN_CACHE" in str(caught[0].message)
    np.testing.assert_array_equal(out, clean[1])
    assert [p.suffix for p in sorted(private.iterdir())] == [".so", ".json"]


def test_when_no_directory_can_be_written_the_interpreter_runs_with_one_warning(
        bench, clean, tmp_path, monkeypatch):
    monkeypatch.setattr(_build, "_FALLBACK", {})
    monkeypatch.setattr(tempfile, "mkdtemp", lambda **kw: (_ for _ in ()).throw(
        OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))))
    run, _, acc0 = bench
    with pytest.warns(CompilationWarning, match="interpreter") as caught:
        runner = run.loop.runner(kernel=fl.Kernel(cache_dir=_regular_file(tmp_path), lanes=False))
    assert len(caught) == 1 and "temporary directory" in str(caught[0].message)
    assert isinstance(runner, InterpretedRunner)
    np.testing.assert_allclose(runner.record(acc0.copy(), run.D)[1], clean[1], rtol=1e-12, atol=1e-14)


def test_cache_location_follows_fl_design_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("FL_DESIGN_CACHE", str(tmp_path / "kernels"))
    assert cache_directory() == tmp_path / "kernels" and (tmp_path / "kernels").is_dir()
    with pytest.raises(ComputationError, match="FL_DESIGN_CACHE"):
        cache_directory(_regular_file(tmp_path))


# --- $CC ---------------------------------------------------------------------------------------
@pytest.mark.skipif(shutil.which("gcc") is None, reason="no gcc")
def test_cc_with_flags_is_a_compiler_and_its_flags(bench, clean, tmp_path, monkeypatch):
    monkeypatch.setenv("CC", "gcc -m64")
    assert _build.compiler_command() == [shutil.which("gcc"), "-m64"]
    assert find_compiler() == shutil.which("gcc")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _acc, out = _record(bench, tmp_path)
    np.testing.assert_array_equal(out, clean[1])


@pytest.mark.parametrize("cc, match", [
    ("no-such-cc -O2", r"\$CC='no-such-cc -O2' names 'no-such-cc', which is not an executable"),
    ("gcc '-m64", r"\$CC=\"gcc '-m64\" is not a valid command line"),
])
def test_a_bad_cc_is_reported_as_such(cc, match, tmp_path, monkeypatch):
    monkeypatch.setenv("CC", cc)
    assert find_compiler() is None
    with pytest.warns(CompilationWarning, match=match):
        assert build("int one(void) { return 1; }", "one", cache_dir=tmp_path) is None
