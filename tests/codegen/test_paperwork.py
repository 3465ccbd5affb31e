"""The package's paperwork: MISRA C:2012 findings all documented advisory deviations (0 required),
the design hash and version macros, units, test vectors replayed by ``make check``."""

from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pytest

import fl_design as fl
from fl_design import presets
from fl_design._toolchain import find_compiler
from fl_design.codegen import generate_c
from fl_design.codegen._misra import DEVIATIONS, HOST_ONLY
from fl_design.codegen._vectors import expected_inputs

CASES = {"trms": (presets.paper_design, fl.plants.trms_yaw),
         "maglev": (presets.maglev_design, fl.plants.maglev),
         "flexible_joint": (presets.flexible_joint_design, fl.plants.flexible_joint),
         "ls26": (lambda: presets.least_squares_design(26), None)}


@pytest.fixture(scope="module")
def packages(tmp_path_factory):
    root = tmp_path_factory.mktemp("paper")
    out = {}
    for name, (design, plant) in CASES.items():
        for prec in ("double", "float"):
            out[(name, prec)] = generate_c(design(), root / f"{name}_{prec}", precision=prec,
                                           plant=None if plant is None else plant())
    return out


def misra_rules(path) -> set[str]:
    out = subprocess.run(["cppcheck", "--addon=misra", "--quiet", "--template={id}", str(path)],
                         capture_output=True, text=True, timeout=300, check=False)
    return set(re.findall(r"misra-c2012-(\d+\.\d+)", out.stdout + out.stderr))


@pytest.mark.skipif(shutil.which("cppcheck") is None,
                    reason="cppcheck is not installed (apt-get install cppcheck): the MISRA "
                           "C:2012 addon cannot run")
@pytest.mark.slow
@pytest.mark.parametrize("name, precision", [("trms", "double"), ("trms", "float"),
                                             ("ls26", "float")])
def test_misra_only_documented_advisory_deviations(packages, name, precision):
    pkg = packages[(name, precision)]
    found = misra_rules(pkg.sources[0])
    assert found, "cppcheck's MISRA addon reported nothing: is the addon installed?"
    assert found <= set(DEVIATIONS), f"undocumented (or required) rules: {found - set(DEVIATIONS)}"
    text = (pkg.out_dir / "MISRA_DEVIATIONS.md").read_text()
    for rule in found | (misra_rules(pkg.out_dir / "check.c") - set(DEVIATIONS)):
        assert re.search(rf"\| {re.escape(rule)} \|", text), rule
    assert misra_rules(pkg.out_dir / "check.c") <= set(DEVIATIONS) | set(HOST_ONLY) | {"2.5"}


def test_header_has_hash_version_and_units(packages):
    a = packages[("trms", "double")].header.read_text()
    b = packages[("trms", "float")].header.read_text()
    m = packages[("maglev", "double")].header.read_text()
    h = lambda t: re.search(r'#define FL_DESIGN_HASH\s+"([0-9a-f]{16})"', t).group(1)
    assert h(a) != h(b) != h(m)  # precision and design both change it
    assert re.search(r'#define FL_GENERATOR_VERSION "' + re.escape(fl.__version__), a)
    assert "#define FL_API_VERSION_MAJOR" in a and "units of the input" in a
    assert "k_i: 1 / s^(2 - i + 1)" in a


@pytest.mark.skipif(find_compiler() is None or shutil.which("make") is None,
                    reason="no C compiler or no make")
@pytest.mark.slow
@pytest.mark.parametrize("name", list(CASES))
@pytest.mark.parametrize("precision", ["double", "float"])
def test_make_check_replays_the_vectors(packages, name, precision):
    pkg = packages[(name, precision)]
    proc = subprocess.run(["make", "-s", "-C", str(pkg.out_dir), "check"], check=False,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0 and "PASS: 1500 samples, 0 outside" in proc.stdout, proc.stdout


@pytest.mark.skipif(find_compiler() is None or shutil.which("make") is None,
                    reason="no C compiler or no make")
def test_make_check_fails_on_a_wrong_vector(packages, tmp_path):
    pkg = packages[("trms", "double")]
    lines = (pkg.out_dir / "test_vectors.txt").read_text().splitlines()
    k = next(i for i, ln in enumerate(lines) if ln.startswith("tol")) + 700
    y, r, u = lines[k].split()
    lines[k] = f"{y} {r} {float(u) + 1e-6!r}"
    bad = tmp_path / "bad.txt"
    bad.write_text("\n".join(lines) + "\n")
    subprocess.run(["make", "-s", "-C", str(pkg.out_dir), "fl_check"], check=True, timeout=300)
    proc = subprocess.run([str(pkg.out_dir / "fl_check"), str(bad)], capture_output=True,
                          text=True, timeout=60, check=False)
    assert proc.returncode == 1 and "FAIL: 1500 samples, 1 outside" in proc.stdout


def test_vectors_are_design_step_with_the_faults_held():
    d = presets.paper_design()
    from fl_design.codegen._guard import guard_settings

    g = guard_settings(d)
    y, r, u, tol = expected_inputs(d, g, "double", n=400)
    bad = np.flatnonzero(~np.isfinite(y) | (y > g.y_max))
    assert bad.tolist() == [80, 240]
    keep = np.setdiff1d(np.arange(400), bad)
    ref = d.run(y[keep], r[keep], state0=d.initial_state(y0=y[0], u0=g.u_op)).u
    np.testing.assert_allclose(u[keep], ref, rtol=0, atol=1e-15)
    assert u[80] == u[79] and u[240] == u[239] and 0 < tol <= 1e-9 * np.abs(u).max()
