"""Instruction-set levels: read from the machine, forced narrower by an override, refused when
the CPU lacks them, part of the kernel's cache key, and reported."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

import fl_design as fl
from fl_design._isa import ISA_ENV, LEVELS, available_isas, resolve_isa
from fl_design._toolchain import find_compiler
from fl_design.errors import ParameterError
from fl_design.sim._run import prepare_run
from fl_design.sim.kernel._lanes import build_lanes

needs_cc = pytest.mark.skipif(find_compiler() is None, reason="needs a C compiler")


def test_the_default_is_the_widest_level_available(monkeypatch):
    monkeypatch.delenv(ISA_ENV, raising=False)
    have = available_isas()
    assert have[-1] == "scalar"
    assert resolve_isa().name == have[0]
    widths = [LEVELS[n].width for n in have]
    assert widths == sorted(widths, reverse=True)


def test_levels_agree_with_the_cpu_flags():
    """What the compiler's -march=native says against the kernel's own /proc/cpuinfo flags."""
    try:
        with open("/proc/cpuinfo") as f:
            flags = f.read().split()
    except OSError:
        pytest.skip("no /proc/cpuinfo on this system")
    if find_compiler() is None or "__x86_64__" not in fl._toolchain.native_macros():
        pytest.skip("x86-64 with a C compiler only")
    have = available_isas()
    assert ("avx512" in have) == ("avx512f" in flags)
    assert ("avx2" in have) == ("avx2" in flags)


@pytest.mark.parametrize("name", ["banana", "AVX3", ""])
def test_an_unknown_level_is_refused(name):
    if not name:
        with pytest.raises(ParameterError, match="instruction-set level"):
            fl.Kernel(isa=name)
        return
    with pytest.raises(ParameterError, match=r"valid: avx512, avx2, sse2, neon, portable"):
        fl.Kernel(isa=name)


def test_a_level_this_cpu_lacks_is_refused_with_the_ones_it_has():
    missing = [n for n in LEVELS if n not in available_isas()]
    assert missing  # no machine has every level (x86-64 never has neon)
    with pytest.raises(ParameterError, match="not available on this machine") as info:
        fl.Kernel(isa=missing[0])
    assert all(n in str(info.value) for n in available_isas())


def test_the_environment_override_is_read_and_reported(monkeypatch):
    monkeypatch.setenv(ISA_ENV, "scalar")
    info = fl.Kernel().describe()
    assert (info["isa"], info["lanes"], info["isa_source"]) == ("scalar", 1, "$FL_DESIGN_ISA")
    assert fl.Kernel(isa="native").describe()["isa"] == available_isas()[0]  # argument wins
    monkeypatch.setenv(ISA_ENV, "banana")
    with pytest.raises(ParameterError, match=r"\$FL_DESIGN_ISA = 'banana'"):
        fl.Kernel().describe()


def test_describe_is_strict_json_and_names_the_machine():
    info = fl.Kernel().describe()
    assert json.loads(json.dumps(info, allow_nan=False)) == info
    assert info["isa"] in info["available"] and info["cpu"]
    assert info["lanes"] == LEVELS[info["isa"]].width
    # the lanes kernel's compiler: clang unless $CC names one (then that one for everything)
    if info["lanes_compiler"] is not None:
        assert info["lanes_compiler"] in (shutil.which("clang"), info["compiler"])


def test_cc_set_means_the_lanes_kernel_uses_it_too(monkeypatch):
    from fl_design._toolchain import find_compiler

    monkeypatch.setenv("CC", "gcc")
    info = fl.Kernel().describe()
    assert info["lanes_compiler"] in (None, find_compiler())


@needs_cc
def test_the_level_is_part_of_the_cache_key(tmp_path):
    d = fl.presets.pendulum_design()
    loop = prepare_run(fl.plants.pendulum(), d, fl.Scenario(0.05, 0.01)).loop
    sl = loop.layout.slices
    idx = {"k": sl["k"].start, "div": sl["diverged"].start, "N": sl["N"].start}
    paths = {n: build_lanes(loop.accumulate, idx, isa=LEVELS[n], cache_dir=tmp_path)
             for n in available_isas() if LEVELS[n].lanes}
    assert len(set(paths.values())) == len(paths)
    for name, path in paths.items():
        assert path.name.startswith(f"fl_lanes_{name}_")
    assert build_lanes(loop.accumulate, idx, isa=LEVELS["scalar"], cache_dir=tmp_path) is None


@needs_cc
@pytest.mark.parametrize("isa", available_isas())
def test_every_level_gives_the_sweep_the_same_classifications(tmp_path, isa):
    """The override in the suite: each level this machine has runs a whole fl.sweep."""
    d = fl.presets.pendulum_design()
    kw = {"eps": [0.005, 0.03, 0.3], "gamma": [1e-2, 0.3, 1.0], "progress": False}
    sc = fl.Scenario(0.05, 1.0)
    got = fl.sweep(fl.plants.pendulum(), d, sc, kernel=fl.Kernel(cache_dir=tmp_path, isa=isa),
                   **kw)
    ref = fl.sweep(fl.plants.pendulum(), d, sc, kernel=fl.Kernel(compiled=False), **kw)
    np.testing.assert_array_equal(got.status, ref.status)
    assert len(set(np.ravel(ref.status))) > 1  # the grid is not trivially one verdict


@needs_cc
def test_the_override_reaches_a_fresh_process(tmp_path):
    code = ("import fl_design as fl; from fl_design.sim.kernel._lanes import LanesRunner\n"
            "d = fl.presets.pendulum_design()\n"
            "r = fl.sim.ClosedLoop(fl.plants.pendulum(), d, substeps=1).runner()\n"
            "print(r.isa.name, r.library.fl_lanes_width() if r.library else 1)")
    narrowest = [n for n in available_isas() if LEVELS[n].lanes][-1:] or ["scalar"]
    env = dict(os.environ, FL_DESIGN_ISA=narrowest[0], FL_DESIGN_CACHE=str(tmp_path))
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         timeout=300, check=True).stdout.split()
    assert out == [narrowest[0], str(LEVELS[narrowest[0]].width)]
