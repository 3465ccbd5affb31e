"""The Q31 step's cheaper arithmetic: the EHGO's delta update as its recursion, the collapsed
controller, peak-gain bounds, high-word products and 32-bit sums, on tuned and untuned designs."""

from __future__ import annotations

import re
import shutil
import subprocess
import warnings

import casadi as ca
import numpy as np
import pytest

import fl_design as fl
from fl_design import presets
from fl_design._toolchain import find_compiler
from fl_design.codegen import generate_c, step_design
from fl_design.codegen._guard import guard_settings
from fl_design.codegen._misra import DEVIATIONS
from fl_design.codegen._pil import pil_tools
from fl_design.codegen._pil_q31 import q31_on_model
from fl_design.codegen._q31 import _fixed_core, _products, q31_program
from fl_design.codegen._q31_code import _py_op, start_state
from fl_design.codegen._q31_files import ERROR_MARGIN, q31_error, q31_range
from fl_design.codegen._q31_peak import PeakGain
from fl_design.codegen._q31_realize import _delta_recursion, collapse_affine, delta_realization

from ._int32_cases import run_int32_cases, template_helpers

TUNED = {"maglev": (presets.maglev_design, fl.plants.maglev),
         "flexible_joint": (presets.flexible_joint_design, fl.plants.flexible_joint)}


def _untuned():
    """Designs the arithmetic was not tuned on: a rho = 1 heater (no plant: the assumed
    range), the pendulum, a rho = 3 design with a negative gamma (b < 0) and distinct poles,
    forward Euler and ZOH observers."""
    heater = fl.Design(estimator=fl.EHGO(1, 0.5, 0.1),
                       controller=fl.DynamicController((1.0,), 0.05, ki=0.1,
                                                       u_limits=(0.0, 100.0)))
    neg_b = fl.Design(estimator=fl.EHGO(3, 0.01, 1e-3, coeffs=(10.0, 35.0, 50.0, 24.0)),
                      controller=fl.DynamicController((1000.0, 300.0, 30.0), -0.002,
                                                      u_limits=(0.0, 20.0)))
    euler = fl.Design(estimator=fl.EHGO(4, 0.05, 1e-3, method="forward_euler"),
                      controller=presets.flexible_joint_design().controller)
    return {"heater_rho1": (heater, None),
            "pendulum": (presets.pendulum_design(u_limits=(-5.0, 5.0)), fl.plants.pendulum()),
            "rho3_negative_b": (neg_b, fl.plants.maglev()),
            "rho4_forward_euler": (euler, fl.plants.flexible_joint()),
            "trms_zoh": (presets.paper_design(method="zoh"), fl.plants.trms_yaw())}


def _g_closed_form(est) -> np.ndarray:
    """``(I - theta alpha F)^-1 alpha F`` from the coefficients (independent of the library)."""
    theta = {"bilinear": 0.5, "forward_euler": 0.0, "backward_euler": 1.0}[est.method]
    n = est.state_size
    F = np.eye(n, k=1)
    F[:, 0] = -np.asarray(est.alphas)
    return np.linalg.solve(np.eye(n) - theta * est.alpha * F, est.alpha * F)


@pytest.mark.parametrize("method", ["bilinear", "forward_euler", "backward_euler"])
@pytest.mark.parametrize("rho, coeffs", [(1, None), (2, (6.0, 11.0, 6.0)), (3, None),
                                         (4, (15.0, 85.0, 225.0, 274.0, 120.0))])
def test_the_recursion_is_the_delta_matrix(method, rho, coeffs):
    est = fl.EHGO(rho, 0.05, 1e-3, coeffs=coeffs, method=method, realization="delta")
    design = fl.Design(estimator=est, controller=fl.DynamicController(
        tuple(float(k) for k in range(1, rho + 1)), 1e-3, u_limits=(-1.0, 1.0)))
    alpha, beta, kappa, gam, _, _ = _delta_recursion(design)
    n = rho + 1
    G = np.zeros((n, n))
    for j in range(n):
        a = np.zeros(n + 1)
        a[j] = 1.0
        for i in range(n - 2, -1, -1):
            a[i] += beta * a[i + 1]
        G[:, j] = [alpha * a[i + 1] + gam[i] * kappa * a[0] for i in range(n)]
    ref = _g_closed_form(est)
    np.testing.assert_allclose(G, ref, rtol=0, atol=1e-12 * np.max(np.abs(ref)))


def test_the_recursion_is_refused_where_it_does_not_hold():
    zoh = step_design(presets.paper_design(method="zoh"), "q31")
    assert _delta_recursion(zoh) is None
    real = delta_realization(zoh, (-1.0, 1.0))
    assert real.name == "direct" and "bilinear or Euler" in real.why


def test_collapse_affine_keeps_the_values_and_prints_each_functional_once():
    rng = np.random.default_rng(4)
    s = ca.SX.sym("s", 4)
    C = rng.normal(size=(3, 4))
    xhat = [sum(C[i, j] * s[j] for j in range(4)) for i in range(3)]
    v = 2.0 * xhat[0] - 0.7 * xhat[1] + 3.0 * ca.fmin(ca.fmax(xhat[2], -0.5), 0.5)
    f = ca.Function("f", [s], [ca.vertcat(v, xhat[0] - s[3])])
    g = collapse_affine(f)
    for x in rng.normal(size=(20, 4)):
        np.testing.assert_allclose(np.asarray(g(x)).ravel(), np.asarray(f(x)).ravel(),
                                   rtol=1e-13, atol=1e-13)
    muls = lambda h: sum(h.instruction_id(k) == ca.OP_MUL for k in range(h.n_instructions()))
    # the clamped xhat_3 (4 products), v over s and the clamp (4 + 1), the error over s (4)
    assert muls(g) <= 4 + 5 + 4 < muls(f)


@pytest.mark.parametrize("name", list(TUNED))
def test_the_recursion_computes_design_step_with_fewer_products(name):
    design, plant = TUNED[name]
    d = step_design(design(), "q31")
    lo, hi, _ = q31_range(guard_settings(d, plant()))
    real = delta_realization(d, (lo, hi))
    assert real.name == "recursion", real.why
    assert _products(real.core) < _products(_fixed_core(d))
    rng = np.random.default_rng(1)
    y = np.clip(0.5 * (lo + hi) + np.cumsum(rng.normal(0, 0.01 * (hi - lo), 500)), lo, hi)
    x = d.initial_state(y0=y[0])
    xr = np.asarray(x, dtype=float)
    for yk in y:
        x, u_ref = d.step(x, yk, 0.5 * (lo + hi))[:2]
        out, u = real.core(xr, yk, 0.5 * (lo + hi))
        xr = np.asarray(out, dtype=float).ravel()
        assert abs(float(u) - float(u_ref)) <= 1e-9 * max(abs(float(u_ref)), 1.0)
    np.testing.assert_allclose(xr, np.asarray(x, dtype=float).ravel(), rtol=1e-7, atol=1e-12)


def _value_after(y, A, B, xi, c, d):
    for yk in y[:-1]:
        xi = A @ xi + B * yk
    return c @ xi + d * y[-1]


def test_the_peak_gain_bound_is_reached_and_never_exceeded():
    rng = np.random.default_rng(2)
    A = np.array([[0.9, 0.2], [-0.1, 0.7]])
    B = np.array([0.3, -0.5])
    mid, half = 0.2, 1.5
    rest = np.linalg.solve(np.eye(2) - A, B) * mid
    c, d = np.array([2.0, -1.0]), 0.4
    lo, hi = PeakGain(A, B, rest, mid, half).bound(({0: c[0], 1: c[1], "y": d}, 0.0))
    h = [c @ np.linalg.matrix_power(A, j) @ B for j in range(400)]
    worst = np.concatenate([mid + half * np.sign(h[::-1]), [mid + half * np.sign(d)]])
    assert abs(_value_after(worst, A, B, rest, c, d) - hi) <= 1e-9 * abs(hi)
    for _ in range(50):
        value = _value_after(rng.uniform(mid - half, mid + half, 401), A, B, rest, c, d)
        assert lo <= value <= hi


def _run_ops(prog, x, yq, rq):
    """One step of the integer program (as ``emulate_q31``): the next state and the largest
    ``|value|`` of its arithmetic (truth values left out)."""
    from fl_design.codegen._q31_code import _F_of, _py_shift, _sat

    w, xn, peak = {}, list(x), 0
    for kind, k, a, fk, data in prog.ops:
        if kind == "in":
            w[k] = x[a[1]] if a[0] == 0 else (yq if a[0] == 1 else rq)
        elif kind == "op":
            w[k] = _py_op(prog, w, k, a, fk, data)
            if fk != 0:
                peak = max(peak, abs(w[k]))
        elif k[0] == 0:
            xn[k[1]] = _sat(_py_shift(w[a[0]], _F_of(prog, a[0]), fk))
    return xn, peak


@pytest.mark.parametrize("name", ["maglev", "flexible_joint", "rho3_negative_b"])
def test_no_value_overflows_on_bang_bang_records(name):
    """Every value of the integer program stays within ``int32_t``, its headroom bit unused
    (``|q| <= 2^30`` but for the rounding), when ``y`` and ``r`` jump between the range's
    ends: the records that reach the peak-gain bounds the scalings rest on."""
    cases = {**{k: (v[0](), v[1]()) for k, v in TUNED.items()}, **_untuned()}
    design, plant = cases[name]
    d = step_design(design, "q31")
    lo, hi, _ = q31_range(guard_settings(d, plant))
    prog = q31_program(d, (lo, hi))
    rng = np.random.default_rng(5)
    q = lambda v: round(v * 2.0**prog.f_y)
    for dwell in (1, 3, 17):
        y = np.repeat(rng.choice([lo, hi], 300 // dwell + 1), dwell)[:300]
        r = np.repeat(rng.choice([lo, hi], 300 // dwell + 1), dwell)[:300]
        x, peak = start_state(prog, q(y[0]), 0), 0
        for yk, rk in zip(y, r):
            x, p = _run_ops(prog, x, q(yk), q(rk))
            peak = max(peak, p)
        assert peak <= 2**30 + 2**8, (dwell, peak / 2**30)


@pytest.mark.skipif(find_compiler() is None or shutil.which("make") is None,
                    reason="no C compiler or no make")
@pytest.mark.parametrize("name", list(_untuned()))
def test_untuned_designs_build_bit_exact_within_their_stated_error(name, tmp_path):
    """Each untuned design gets a Q31 package whose ``make check`` replays its vectors bit
    for bit, with or without the ARMv6-M products, and whose recorded quantization error
    (measured against ``Design.step`` on the vector record) is within 1 % of max |u| (the
    tuned presets' bounds in test_q31 go from 1e-4 to 2e-2)."""
    design, plant = _untuned()[name]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fl.errors.FloatPrecisionWarning)
        pkg = generate_c(design, tmp_path / "pkg", precision="q31", plant=plant)
    for flags in ("", " -DFL_MUL_HALVES"):
        proc = subprocess.run(["make", "-s", "-C", str(pkg.out_dir),
                               f"CFLAGS=-O2 -std=c99 -pedantic -Wall -Wextra -Werror{flags}",
                               "check"], capture_output=True, text=True, timeout=300,
                              check=False)
        assert proc.returncode == 0 and "PASS: 1500 samples, 0 outside" in proc.stdout
        shutil.rmtree(pkg.out_dir / "build", ignore_errors=True)
        (pkg.out_dir / "fl_check").unlink(missing_ok=True)
    assert 0 < pkg.predicted_float_error < 1e-2
    d = step_design(design, "q31")  # the recursion only where it keeps the precision
    g = guard_settings(d, plant)
    matrix = q31_error(d, q31_program(d, q31_range(g)[:2], update="matrix"), g)
    assert pkg.predicted_float_error <= ERROR_MARGIN * matrix


def test_an_unknown_update_is_refused():
    with pytest.raises(fl.errors.ParameterError, match="update='cascade' is not known"):
        q31_program(step_design(presets.paper_design(), "q31"), (-1.0, 1.0), update="cascade")


@pytest.mark.skipif(shutil.which("cppcheck") is None, reason="cppcheck is not installed")
@pytest.mark.parametrize("name", list(TUNED))
def test_q31_source_has_only_documented_advisory_misra_deviations(name, tmp_path):
    design, plant = TUNED[name]
    pkg = generate_c(design(), tmp_path / "pkg", precision="q31", plant=plant())
    out = subprocess.run(["cppcheck", "--addon=misra", "--quiet", "--template={id}",
                          str(pkg.sources[0])], capture_output=True, text=True, timeout=300,
                         check=False)
    found = set(re.findall(r"misra-c2012-(\d+\.\d+)", out.stdout + out.stderr))
    assert found, "cppcheck's MISRA addon reported nothing: is the addon installed?"
    assert found <= set(DEVIATIONS), found - set(DEVIATIONS)


@pytest.mark.skipif(bool(pil_tools()[2]), reason="arm-none-eabi-gcc or qemu-system-arm missing")
@pytest.mark.parametrize("cpu", ["cortex-m3", "cortex-m0plus"])
def test_the_recursion_is_bit_exact_on_the_fpu_less_models(cpu, tmp_path):
    pkg = generate_c(presets.flexible_joint_design(), tmp_path / "fj", precision="q31",
                     plant=fl.plants.flexible_joint())
    t = np.arange(300) * 1e-3
    y = 0.05 * (1 - np.exp(-t * 20.0))
    r = np.full(y.size, 0.05)
    u, n = q31_on_model(pkg, y, r, cpu=cpu)
    np.testing.assert_array_equal(u, pkg.run(y, r, start=True))
    assert 50 < n < 5000


@pytest.mark.skipif(find_compiler() is None, reason="no C compiler installed")
@pytest.mark.parametrize("halves", [False, True])
def test_mulhi_is_the_floor_of_the_product_over_2_32(halves, tmp_path):
    """The template's high word, on the host and with the ARMv6-M halves, against Python's
    exact ``(a b) >> 32`` on the extremes and random pairs."""
    pkg = generate_c(presets.maglev_design(), tmp_path / "pkg", precision="q31",
                     plant=fl.plants.maglev())
    assert "fl_mulhi(" in pkg.sources[0].read_text()
    rng = np.random.default_rng(6)
    edge = [-(2**31), -(2**31) + 1, -(2**16) - 1, -(2**16), -1, 0, 1, 2**15, 2**16, 2**31 - 1]
    pairs = [(a, b) for a in edge for b in edge]
    pairs += [tuple(int(v) for v in rng.integers(-(2**31), 2**31, 2)) for _ in range(2000)]
    (tmp_path / "pairs.txt").write_text("".join(f"{a} {b}\n" for a, b in pairs))
    main = tmp_path / "mulhi.c"
    main.write_text('#include <stdio.h>\n#include "fl.c"\nint main(void) {\n  long a, b;\n'
                    '  while (scanf("%ld %ld", &a, &b) == 2) {\n'
                    '    printf("%ld\\n", (long) fl_mulhi((int32_t) a, (int32_t) b));\n  }\n'
                    '  return 0;\n}\n')
    exe = tmp_path / "mulhi"
    flags = ["-DFL_MUL_HALVES"] if halves else []
    subprocess.run([find_compiler(), "-O2", "-std=c99", *flags, f"-I{pkg.out_dir}", str(main),
                    "-o", str(exe)], check=True, timeout=120, capture_output=True)
    out = subprocess.run([str(exe)], input=(tmp_path / "pairs.txt").read_text(),
                         capture_output=True, text=True, timeout=60, check=True).stdout.split()
    assert [int(v) for v in out] == [(a * b) >> 32 for a, b in pairs]


@pytest.mark.skipif(find_compiler() is None, reason="no C compiler installed")
def test_the_32_bit_sums_are_the_exact_floor_of_the_aligned_sum(tmp_path):
    """Every 32-bit sum or difference ``_q31_code`` prints (nested floors, modulo 2^32),
    compiled with the template's helpers under UBSan, and its Python twin, against
    ``floor((A 2^(m - F_A) +- B 2^(m - F_B)) / 2^(m - F_k))`` in exact integers, on random
    operands within ``2^30`` whose result fits (the interval analysis' guarantee)."""
    from fl_design.codegen._q31_code import _py_sum32, _sum32

    rng = np.random.default_rng(12)
    cases, funcs = [], []
    while len(cases) < 40:
        fa, fb = (int(v) for v in rng.integers(0, 45, 2))
        fk = int(rng.integers(min(fa, fb) - 8, max(fa, fb) + 8))
        op = ca.OP_ADD if rng.random() < 0.5 else ca.OP_SUB
        text = _sum32(op, (0, 1), {0: fa, 1: fb}, {0: "a", 1: "b"}, fk)
        if text is None:
            continue
        funcs.append(f"static int32_t f{len(cases)}(int32_t a, int32_t b) {{\n"
                     f"  return {text.replace('{PFX}', 'fl')};\n}}")
        cases.append((op, fa, fb, fk))
    lim, lines, expected = 2**30, [], []
    for i, (op, fa, fb, fk) in enumerate(cases):
        m, n = max(fa, fb, fk), 0
        for _ in range(20000):
            if n == 50:
                break
            a, b = (int(v) for v in rng.integers(-lim, lim + 1, 2))
            mode = int(rng.integers(3))
            if mode == 1:  # values of any size
                a, b = a >> int(rng.integers(0, 32)), b >> int(rng.integers(0, 32))
            elif mode == 2:  # a sum that cancels: a result far smaller than its terms
                b = (a << (m - fa) >> (m - fb)) * (1 if op == ca.OP_SUB else -1)
                b = int(np.clip(b + int(rng.integers(-3, 4)), -lim, lim))
            A, B = a << (m - fa), b << (m - fb)
            ref = (A + B if op == ca.OP_ADD else A - B) >> (m - fk)
            if abs(ref) > lim:
                continue  # outside what the analysis admits
            assert _py_sum32(op, (a, b), (fa, fb), fk) == ref, (op, fa, fb, fk, a, b)
            lines.append(f"{i} {a} {b}")
            expected.append(ref)
            n += 1
        assert n == 50, (op, fa, fb, fk)
    assert run_int32_cases(tmp_path, "sums", template_helpers("asr32", "s32"), funcs,
                           lines) == expected
