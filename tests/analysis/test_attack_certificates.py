"""The switching attacks on the class certificates (``verify/attack_certificates.py``).

The script's quick mode runs (every class of the bench's spread attacked, the independent loop
agreeing with the library's linearization, no attack beating what a certificate says it
covers); its search tools against closed forms; and the one attack that beats a claim,
minimized: ``eps_star_curve``'s certified eps* is a frozen-``b`` certificate whose result
named a class with ``b`` varying arbitrarily (it now names the class of constant ``b``), and a
raw numpy error from ``certify_eps`` on a rho 3 class (now a result).
"""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import fl_design as fl
from fl_design.analysis._surrogate import SurrogateLoop

ROOT = Path(__file__).resolve().parents[2]
VERIFY = ROOT / "verify"


@pytest.fixture
def verify_modules():
    """The verify folder's helper modules, importable for the test's duration."""
    sys.path.insert(0, str(VERIFY))
    try:
        import _attack_loop
        import _attack_search

        yield _attack_loop, _attack_search
    finally:
        sys.path.remove(str(VERIFY))


def test_attack_quick_runs_and_no_attack_beats_a_stated_coverage():
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, str(VERIFY / "attack_certificates.py"), "--quick",
                           "--seed", "1"], capture_output=True, text=True, env=env,
                          timeout=300, check=False)
    out = proc.stdout
    assert proc.returncode in (0, 1), out + proc.stderr
    assert "disagree" not in out, out  # the independent loop is the library's linearization
    sys.path.insert(0, str(VERIFY))
    try:
        from bench_certify import CURVE_CLASSES
    finally:
        sys.path.remove(str(VERIFY))
    for name in CURVE_CLASSES:  # every class attacked, with a summary line
        if f"=> {name}: gains attacked" in out:
            continue
        # the slope boxes at rho >= 3 certify no gain (bench_certify says why): nothing to attack
        assert f"=> {name}: no certified gain to attack" in out, out
        assert "a-slope box" in name and not name.startswith("rho 2"), out
    stated = [ln for ln in out.splitlines() if "stated coverage: best growth" in ln]
    assert stated and not any("BEATS" in ln for ln in stated), out
    # the exit status says whether any attack (on the named classes too) beat a certificate
    assert (proc.returncode == 1) == ("-> BEATS" in out), out


def test_attack_unknown_class_is_refused_with_the_valid_names():
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, str(VERIFY / "attack_certificates.py"), "--only",
                           "rho 9"], capture_output=True, text=True, env=env, timeout=120,
                          check=False)
    assert proc.returncode == 2
    assert "unknown class(es) ['rho 9']" in proc.stdout and "rho 2, T 1 ms" in proc.stdout


def test_products_reach_the_closed_form_joint_spectral_radius(verify_modules):
    _, search = verify_modules
    A = np.array([[1.0, 1.0], [0.0, 1.0]])
    B = np.array([[1.0, 0.0], [1.0, 1.0]])
    growth, seq = search.products([A, B], 6)
    # JSR{A, B} = golden ratio, reached by the product AB (Jungers, 2009, example 1.1)
    assert growth == pytest.approx((1 + 5 ** 0.5) / 2, rel=1e-12)
    assert sorted(seq[:2]) == [0, 1]
    rng = np.random.default_rng(3)
    C = rng.standard_normal((4, 4))
    g1, _ = search.products([C], 3)
    assert g1 == pytest.approx(np.max(np.abs(np.linalg.eigvals(C))), rel=1e-12)
    # the renormalized long product agrees with the direct one
    seq = list(rng.integers(0, 2, 40))
    P = np.eye(2)
    for i in seq:
        P = [A / 1.6, B / 1.6][i] @ P
    direct = np.max(np.abs(np.linalg.eigvals(P))) ** (1 / 40)
    assert search.product_growth([A / 1.6, B / 1.6], seq) == pytest.approx(direct, rel=1e-10)


@pytest.mark.parametrize(("rho", "ki", "a_row"), [(1, 0.0, None), (2, 1e-3, (0.2, -0.1)),
                                                  (3, 0.0, None)])
def test_independent_loop_is_the_library_linearization(verify_modules, rho, ki, a_row):
    loop, _ = verify_modules
    gains = fl.synthesize_gains(rho, decay=1.0).gains
    d = fl.Design(estimator=fl.EHGO(rho, 0.01, 1e-3),
                  controller=fl.DynamicController(gains, 0.02, ki=ki))
    mine = loop.loop_matrix(rho=rho, T=1e-3, eps=0.005, alphas=d.estimator.alphas,
                            gains=gains, gamma=0.02, b=3.0, ki=ki, a_row=a_row)
    L = SurrogateLoop(d)
    M0, M1 = L.parts(0.005, 0.02, a_row)
    lib = (M0 + 3.0 * M1)[np.ix_(L.keep, L.keep)]
    assert mine.shape == lib.shape
    for j in range(1, lib.shape[0] + 1):  # similar matrices: equal traces of every power
        assert np.trace(np.linalg.matrix_power(mine, j)) == pytest.approx(
            np.trace(np.linalg.matrix_power(lib, j)), rel=1e-10, abs=1e-12)


def test_curve_certified_eps_holds_for_every_member_of_the_class_it_names(verify_modules):
    """eps_star_curve certifies frozen b (a Lyapunov P(b) per piece of b); at its certified
    eps* (0.00117 at gamma 0.0140, rho 2, T 1 ms) the periodic switching b = 50 for 5 samples,
    b = 1 for 2 grows by 1.0167 per sample (found by verify/attack_certificates.py; it beat the
    curve's old label 'b varying arbitrarily' on 8 of 10 classes): the curve names the class
    of constant b it certifies and lists b varying in time as not covered."""
    loop, _ = verify_modules
    cls = fl.PlantClass(rho=2, T=1e-3, b=(1.0, 50.0))  # bench_certify.CURVE_CLASSES' 2nd
    gains = fl.synthesize_gains(2, decay=1.0).gains
    d = fl.Design(estimator=fl.EHGO(2, 1e-2, 1e-3),
                  controller=fl.DynamicController(gains, 0.5 / 50))
    gamma = float(np.geomspace(0.02 / 50, 1.0 / 50, 12)[10])
    curve = fl.eps_star_curve(d, cls, [gamma], eps_range=(1e-3, 1.0))
    eps = float(curve.eps_star_certified[0])
    assert np.isfinite(eps)

    def member(b):  # the loop of b, built from the paper's equations (not the library's)
        return loop.loop_matrix(rho=2, T=1e-3, eps=eps, alphas=d.estimator.alphas,
                                gains=gains, gamma=gamma, b=b)

    P = np.linalg.matrix_power(member(1.0), 2) @ np.linalg.matrix_power(member(50.0), 5)
    growth = float(np.max(np.abs(np.linalg.eigvals(P)))) ** (1 / 7)
    assert growth > 1.0  # the attack is real: the curve's eps* is no varying-b certificate
    assert any(u.startswith("b varying in time") for u in curve.uncovered)
    names_varying = "varying arbitrarily" in curve.class_description
    assert not (names_varying and growth > 1.0), (
        f"{curve.class_description!r} certified at eps = {eps:.6g} (covers {curve.covers}), "
        f"yet switching b = 50 (5 samples), b = 1 (2 samples) grows by {growth:.6f} per sample")


def test_certify_eps_rho3_class_returns_a_result_instead_of_a_numpy_error():
    """certify_eps on rho 3, b in [1, 5] at gamma = 0.0338 raised numpy's LinAlgError from
    sos_certificate's Cholesky of a modal P not positive definite in rounding (found by
    verify/attack_certificates.py); now a result."""
    cls = fl.PlantClass(rho=3, T=1e-3, b=(1.0, 5.0))  # bench_certify.CURVE_CLASSES' 8th
    gamma = float(np.geomspace(0.02 / 5, 1.0 / 5, 12)[6])
    d = fl.Design(estimator=fl.EHGO(3, 1e-2, 1e-3), controller=fl.DynamicController(
        fl.synthesize_gains(3, decay=1.0).gains, gamma))
    c = fl.certify_eps(d, cls, eps_range=(1e-3, 1.0))
    assert c.covers == "varying"
    assert c.eps_star_certified is None or c.eps_star_certified <= c.eps_star_frozen
