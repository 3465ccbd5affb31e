"""precision="q31": integer code for FPU-less Cortex-M0+/M3, scalings from interval analysis."""

from __future__ import annotations

import math
import re
import shutil
import subprocess
import warnings

import numpy as np
import pytest

import fl_design as fl
from fl_design import presets
from fl_design._toolchain import find_compiler
from fl_design.codegen import generate_c, step_design
from fl_design.codegen._guard import guard_settings
from fl_design.codegen._pil import pil_tools
from fl_design.codegen._pil_q31 import q31_on_model
from fl_design.codegen._q31 import q31_program, state_box
from fl_design.codegen._q31_code import emulate_q31, start_state
from fl_design.errors import FloatPrecisionWarning, ParameterError

from ._int32_cases import run_int32_cases, template_helpers

CASES = {"trms": (presets.paper_design, fl.plants.trms_yaw),
         "maglev": (presets.maglev_design, fl.plants.maglev),
         "flexible_joint": (presets.flexible_joint_design, fl.plants.flexible_joint)}


@pytest.fixture(scope="module")
def packages(tmp_path_factory):
    root = tmp_path_factory.mktemp("q31")
    return {name: generate_c(d(), root / name, precision="q31", plant=p())
            for name, (d, p) in CASES.items()}


def test_no_floating_point_in_the_source(packages):
    for pkg in packages.values():
        code = re.sub(r"/\*.*?\*/", "", pkg.sources[0].read_text(), flags=re.DOTALL)
        assert not re.search(r"\b(float|double)\b", code)
        assert not re.search(r"\b\d+\.\d|\b\d+[eE][+-]?\d", code)  # no real literal


@pytest.mark.skipif(find_compiler() is None or shutil.which("make") is None,
                    reason="no C compiler or no make")
@pytest.mark.parametrize("name", list(CASES))
def test_make_check_is_bit_exact_with_the_integer_model(packages, name):
    proc = subprocess.run(["make", "-s", "-C", str(packages[name].out_dir), "check"],
                          capture_output=True, text=True, timeout=300, check=False)
    assert proc.returncode == 0 and "PASS: 1500 samples, 0 outside" in proc.stdout, proc.stdout


@pytest.mark.skipif(find_compiler() is None or shutil.which("make") is None,
                    reason="no C compiler or no make")
@pytest.mark.parametrize("name", list(CASES))
def test_the_products_by_halves_are_bit_exact_on_the_host(packages, name, tmp_path):
    """The ARMv6-M products (four 16 x 16 -> 32 products, FL_MUL_HALVES) forced on the host:
    the same vectors pass bit for bit."""
    out = shutil.copytree(packages[name].out_dir, tmp_path / "pkg",
                          ignore=shutil.ignore_patterns("build", "fl_check", "fl_main"))
    assert "fl_mulsh(" in (out / "fl.c").read_text()
    flags = "CFLAGS=-O2 -std=c99 -pedantic -Wall -Wextra -Werror -DFL_MUL_HALVES"
    proc = subprocess.run(["make", "-s", "-C", str(out), flags, "check"], capture_output=True,
                          text=True, timeout=300, check=False)
    assert proc.returncode == 0 and "PASS: 1500 samples, 0 outside" in proc.stdout, proc.stdout


@pytest.mark.parametrize("name, bound", [("trms", 1e-4), ("maglev", 2e-3),
                                         ("flexible_joint", 2e-2)])
def test_the_quantization_error_against_design_step(packages, name, bound):
    err = packages[name].predicted_float_error  # measured on the vector record
    assert 0 < err < bound


def test_the_state_stays_inside_its_boxes_on_a_noisy_record():
    """The peak-gain boxes hold (no saturation) under a full-range random y."""
    d = step_design(presets.paper_design(), "q31")
    prog = q31_program(d, (-1.0, 1.0))
    rng = np.random.default_rng(3)
    y = rng.uniform(-1.0, 1.0, 3000)
    yq = np.round(y * 2.0**prog.f_y).astype(np.int64)
    _, xs = emulate_q31(prog, yq, np.zeros_like(yq), start_state(prog, int(yq[0]), 0))
    for i in range(d.state_size - 2):
        lo, hi = prog.state_box[i]
        v = xs[:, i] / 2.0 ** prog.f_state[i]
        assert lo <= v.min() and v.max() <= hi, i
        assert np.max(np.abs(xs[:, i])) < 2**30  # the headroom bit is never used
    boxes, _, _ = state_box(d, (-1.0, 1.0))
    assert boxes[-2] == (-2.5, 2.5)


@pytest.mark.skipif(shutil.which("arm-none-eabi-gcc") is None,
                    reason="arm-none-eabi-gcc is not installed")
@pytest.mark.parametrize("cpu", ["cortex-m0plus", "cortex-m3"])
def test_builds_for_fpu_less_cortex_m_without_float_helpers(packages, cpu, tmp_path):
    pkg = packages["trms"]
    objs = []
    for src in (pkg.sources[0], pkg.out_dir / "check.c"):
        obj = tmp_path / f"{src.stem}.o"
        subprocess.run(["arm-none-eabi-gcc", f"-mcpu={cpu}", "-mthumb", "-O2", "-std=c99",
                        "-Wall", "-Wextra", "-Werror", "-c", f"-I{pkg.out_dir}", str(src), "-o",
                        str(obj)], check=True, timeout=120)
        objs.append(str(obj))
    und = subprocess.run(["arm-none-eabi-nm", "-u", objs[0]], capture_output=True, text=True,
                         check=True).stdout
    assert not re.search(r"__aeabi_[fdi]2|__aeabi_[fd](add|sub|mul|div|cmp)|[sd]f3\b", und), und
    assert "memcpy" not in und


def test_q31_without_plant_says_what_it_assumes_and_refuses_what_it_cannot(tmp_path):
    with pytest.warns(FloatPrecisionWarning, match=r"\|y\| <= 10, assumed"):
        generate_c(presets.paper_design(), tmp_path / "a", precision="q31")
    with pytest.raises(ParameterError, match="q31' is generated for the EHGO"):
        generate_c(presets.least_squares_design(9), tmp_path / "b", precision="q31")
    pkg = generate_c(presets.paper_design(), tmp_path / "q", precision="q31",
                     plant=fl.plants.trms_yaw())
    with pytest.raises(ParameterError, match="q31' package is not available"):
        pkg.verify(fl.plants.trms_yaw(), fl.Scenario(0.3, 1.0))
    d = presets.pendulum_design()  # no u_limits
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(ParameterError, match="needs u_limits"):
            generate_c(d, tmp_path / "c", precision="q31")


@pytest.mark.skipif(find_compiler() is None, reason="no C compiler installed")
def test_host_harness_tracks_design_step(packages):
    pkg = packages["trms"]
    g = guard_settings(pkg.design, fl.plants.trms_yaw())
    y = 0.2 * (1 - np.exp(-np.arange(2000) * 3e-3))
    u_q = pkg.run(y, np.full(y.size, 0.2), start=True)
    ref = pkg.step_design.run(y, 0.2, state0=pkg.step_design.initial_state(y0=y[0],
                                                                        u0=g.u_op)).u
    assert np.max(np.abs(u_q - ref)) <= 1e-4 * np.max(np.abs(ref))


@pytest.mark.skipif(bool(pil_tools()[2]), reason="arm-none-eabi-gcc or qemu-system-arm missing")
@pytest.mark.parametrize("cpu", ["cortex-m3", "cortex-m0plus"])
def test_the_step_on_the_fpu_less_models_is_bit_exact_with_the_host(packages, cpu):
    """The Q31 step on QEMU's Cortex-M3 (mps2-an385) and Cortex-M0 (microbit, running the M0+
    build) computes the host build's u bit for bit; its cost is the bench's concern, here only
    that it was counted (a step of ~100 integer operations: hundreds of instructions)."""
    pkg = packages["trms"]
    y = 0.2 * (1 - np.exp(-np.arange(300) * 3e-3))
    r = np.full(y.size, 0.2)
    u, n = q31_on_model(pkg, y, r, cpu=cpu)
    np.testing.assert_array_equal(u, pkg.run(y, r, start=True))
    assert 50 < n < 5000


def test_q15_is_refused_with_its_predicted_quantization_error(packages, tmp_path):
    """precision='q15': the Q31 program with every word 16 bits shorter, run by the integer
    model on the vector record, misses the bound by orders of magnitude (u's 16-bit
    resolution swallows the controller's per-sample increments): a named refusal with the
    number, nothing written."""
    from fl_design.codegen._compare import FLOAT_BOUND
    from fl_design.errors import PrecisionError

    with pytest.raises(PrecisionError, match="precision='q15' is refused") as info:
        generate_c(presets.paper_design(), tmp_path / "q15", precision="q15",
                   plant=fl.plants.trms_yaw())
    err = float(re.search(r"predicted quantization error is ([0-9.e+-]+)",
                          str(info.value)).group(1))
    assert err > 100 * FLOAT_BOUND and err > 1000 * packages["trms"].predicted_float_error
    assert "u's resolution becomes" in str(info.value) and not (tmp_path / "q15").exists()
    with pytest.raises(ParameterError, match="q31' is generated for the EHGO"):
        generate_c(presets.least_squares_design(9), tmp_path / "ls", precision="q15")


@pytest.mark.skipif(find_compiler() is None, reason="no C compiler installed")
def test_the_int32_min_max_and_comparisons_equal_the_aligned_int64_ones(tmp_path):
    """The narrowed C of min/max/</<= (exact floor identities, ``_q31_code``), compiled with
    the template's ``_asr32``, against the 64-bit reference (both operands aligned to the
    finer one, the result floored to its fraction bits) on random operands within ``2^30``
    whose result fits (the interval analysis' guarantee), boundaries included."""
    import casadi as ca

    from fl_design.codegen._q31_code import _align, _narrow_cmp, _narrow_minmax

    rng = np.random.default_rng(11)
    cases, funcs = [], []
    for op in (ca.OP_FMIN, ca.OP_FMAX, ca.OP_LT, ca.OP_LE):
        for _ in range(12):
            fa, fb = (int(v) for v in rng.integers(0, 40, 2))
            if abs(fa - fb) > 31 or fa == fb and op in (ca.OP_LT, ca.OP_LE):
                fb = fa + int(rng.integers(1, 31))
            fk = int(rng.integers(min(fa, fb) - 5, max(fa, fb) + 1))
            F, name = {0: fa, 1: fb}, {0: "a", 1: "b"}
            text = (_narrow_cmp(op, (0, 1), F, name) if op in (ca.OP_LT, ca.OP_LE)
                    else _narrow_minmax(op, (0, 1), F, name, fk))
            assert text is not None
            funcs.append(f"static int32_t f{len(cases)}(int32_t a, int32_t b) {{\n"
                         f"  return (int32_t) {text.replace('{PFX}', 'fl')};\n}}")
            cases.append((op, fa, fb, fk))
    lines, expected = [], []
    lim = 2**30
    for i, (op, fa, fb, fk) in enumerate(cases):
        fm = _align(fa, fb)
        n = 0
        for _ in range(2000):  # about half the draws fit; 60 of them kept
            if n == 60:
                break
            a, b = (int(v) for v in rng.integers(-lim, lim + 1, 2))
            if n % 3 == 0:  # near the boundary of the comparison
                b = int(np.clip((a << (fm - fa)) >> (fm - fb), -lim, lim)) + int(
                    rng.integers(-2, 3))
            A, B = a << (fm - fa), b << (fm - fb)
            if op in (ca.OP_LT, ca.OP_LE):
                ref = int(A < B) if op == ca.OP_LT else int(A <= B)
            else:
                ref = (min(A, B) if op == ca.OP_FMIN else max(A, B)) >> (fm - fk)
                if abs(ref) > lim or abs(b) > lim:
                    continue  # outside what the analysis admits
            lines.append(f"{i} {a} {b}")
            expected.append(ref)
            n += 1
        assert n == 60, (op, fa, fb, fk)
    assert run_int32_cases(tmp_path, "narrow", template_helpers("asr32"), funcs,
                           lines) == expected


@pytest.mark.parametrize("name", list(CASES))
def test_shared_products_compute_the_same_step(name):
    """The Q31 graph with constants equal up to a power of two sharing one product equals the
    design's step in double (random states and inputs), with fewer products where it applies."""
    import casadi as ca

    from fl_design.codegen._q31 import _fixed_core

    d = step_design(CASES[name][0](), "q31")
    g = _fixed_core(d)  # factored
    n = d.state_size
    x, y, r = ca.SX.sym("x", n), ca.SX.sym("y"), ca.SX.sym("r")
    from fl_design.codegen._graph import parameter_fields, parametric_core

    x_next, u, _ = parametric_core(d)(x, y, r, [f.value for f in parameter_fields(d)])
    f = ca.Function("plain", [x, y, r], [x_next, u])
    rng = np.random.default_rng(11)
    for _ in range(20):
        args = [rng.standard_normal(n), rng.standard_normal(), rng.standard_normal()]
        a, b = (np.concatenate([np.asarray(v, dtype=float).ravel() for v in h(*args)])
                for h in (f, g))
        np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-12 * np.abs(a).max())
    muls = lambda h: sum(h.instruction_id(k) == ca.OP_MUL for k in range(h.n_instructions()))
    assert muls(g) <= muls(f)
    if name == "maglev":  # the observer's rows of gains equal up to powers of two
        def odd(h):  # products by a constant that is not a power of two
            cur, n_odd = {}, 0
            for k in range(h.n_instructions()):
                op, ins, out = h.instruction_id(k), h.instruction_input(k), h.instruction_output(k)
                if op == ca.OP_MUL:
                    n_odd += any(cur.get(i) is not None and math.frexp(abs(cur[i]))[0] != 0.5
                                 for i in ins)
                if op != ca.OP_OUTPUT:
                    cur[out[0]] = h.instruction_constant(k) if op == ca.OP_CONST else None
            return n_odd

        assert odd(g) < odd(f)  # fewer products by constants that are not powers of two
