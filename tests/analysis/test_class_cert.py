"""Certificates certify a class (issue 29): a plant is read as its class, never the a = 0 chain;
the bracket's refuted end is a member of the class found unstable; the README's parameter box
holds against the issue's attacks; b in [1, 50] certifies a design; bad classes are refused.

Independent oracle: the sampled loop assembled here from the EHGO's own matrices and SciPy's
``expm`` of the plant ``x' = A(a) x + e_rho b u`` (no fl_design loop code)."""

import json
import math

import numpy as np
import pytest
import scipy.linalg

import fl_design as fl
from fl_design import presets
from fl_design.analysis._plant_class import SlopeRestricted
from fl_design.errors import ParameterError


def loop_matrix(design, eps, b, a_row=(0.0, 0.0)):
    """Frozen sampled loop (plant x, observer xi, u) of a rho = 2, k_I = 0 design (oracle)."""
    ehgo = design.estimator.replace(eps=eps)
    rho, T, g = ehgo.rho, ehgo.T, design.controller.gamma
    k = design.controller.gains
    Ad, Bd, _, _ = ehgo.matrices
    Co, Do = ehgo.output_matrices()
    m = rho + 1
    n = rho + m + 1
    X = np.zeros((rho + 1, rho + 1))
    X[:rho - 1, 1:rho] = np.eye(rho - 1)
    X[rho - 1, :rho] = a_row
    X[rho - 1, rho] = b
    E = scipy.linalg.expm(T * X)
    Px = np.hstack([np.eye(rho), np.zeros((rho, m + 1))])
    Pxi = np.hstack([np.zeros((m, rho)), np.eye(m), np.zeros((m, 1))])
    Y = Px[0]
    Xh = Do.reshape(-1, 1) @ Y[None] + Co @ Pxi
    v = -sum(k[i] * Xh[i] for i in range(rho))
    U = np.eye(n)[rho + m] + g * (v - Xh[rho])
    return np.vstack([E[:rho, :rho] @ Px + E[:rho, rho][:, None] @ U[None], Bd.reshape(-1, 1)
                      @ Y[None] + Ad @ Pxi, U[None]])


def radius(M):
    return float(np.max(np.abs(np.linalg.eigvals(M))))


def switching_growth(A, B, dwells=(1, 3, 10, 30, 100, 300, 1000)):
    """Largest per-sample log growth of periodic switching A^n1 B^n2 (and the frozen ones)."""
    g = max(math.log(radius(A)), math.log(radius(B)))
    for n1 in dwells:
        An = np.linalg.matrix_power(A, n1)
        for n2 in dwells:
            g = max(g, math.log(radius(np.linalg.matrix_power(B, n2) @ An)) / (n1 + n2))
    return g


@pytest.mark.slow
@pytest.mark.parametrize("plant, design", [
    (lambda: fl.plants.pendulum(c=0.05), lambda: presets.pendulum_design(eps=0.0405)),
    (fl.plants.pendulum, presets.pendulum_design),
    (fl.plants.cart_pendulum, lambda: presets.bench_design("cart-pendulum")),
], ids=["pendulum-c0.05", "pendulum", "cart-pendulum"])
def test_plant_headline_below_its_linearized_eps_star(plant, design):
    p, d = plant(), design()
    cert = fl.certify_eps(d, p)
    lin = fl.linearized_eps_star(p, d)
    assert cert.plant_class.source == "plant" and cert.class_description.startswith(
        "class of plant")
    assert cert.eps_star_certified is not None and cert.eps_star_certified <= lin.lower
    head = cert.bracket(cert.covers)
    assert head.refuted is not None and head.refuted >= cert.eps_star_certified
    # the refuted end is a member's instability: the plant's linearization is one member, so
    # the refuted end is at most the linearized boundary (up to the search resolution)
    assert head.refuted <= lin.upper * 1.02
    d2 = json.loads(json.dumps(cert.to_dict(), allow_nan=False))
    assert d2["plant_class"]["source"] == "plant" and d2["class_description"]


def test_pendulum_class_refuted_end_is_a_real_member_instability():
    p = fl.plants.pendulum(c=0.05)
    d = presets.pendulum_design(eps=0.0405)
    cert = fl.certify_eps(d, p)
    ref = cert.bracket("nonlinear").refuted
    # at the refuted eps the frozen corner (the linearization at theta = 0) grows (oracle)
    assert radius(loop_matrix(d, ref, 1.0, (-9.81, -0.05))) > 1.0
    assert radius(loop_matrix(d, 0.99 * cert.eps_star_certified, 1.0, (-9.81, -0.05))) < 1.0


@pytest.mark.slow
def test_readme_box_holds_against_the_issue_attacks():
    """pendulum, c in [0.05, 1], b in [0.8, 1.2]: the issue's c = 0.05, b = 1.2 frozen plant is
    unstable from 0.036094 and b switching 0.8/1.2 grows from 0.034197: the box's certified
    eps* must lie below both, and at it neither attack grows (oracle)."""
    from fl_design.analysis import plant_bounds

    p = fl.plants.pendulum()
    box = plant_bounds(p, params={"c": (0.05, 1.0), "b": (0.8, 1.2)}, T=1e-3)
    d = presets.pendulum_design()
    cert = fl.certify_eps(d, box)
    e = cert.eps_star_certified
    assert e is not None and e < 0.034197 and "c in [0.05, 1]" in cert.class_description
    a = (-9.81, -0.05)
    assert radius(loop_matrix(d, e, 1.2, a)) < 1.0
    assert switching_growth(loop_matrix(d, e, 0.8, a), loop_matrix(d, e, 1.2, a)) <= 1e-12
    # the attacks themselves are found: above them the bracket's refuted end
    assert cert.bracket(cert.covers).refuted <= 0.036094 * 1.02


def test_plant_is_its_class_and_chain_stays_named():
    d = presets.paper_design()
    chain = fl.certify_eps(d, (3.6, 6.8), search=False)
    assert chain.plant_class.source == "chain" and "chain class" in repr(chain)
    assert "a = 0" in chain.class_description
    g = fl.certify_gamma(d, fl.PlantClass.chain(2, b=(3.6, 6.8)))
    assert g.class_description.startswith("chain class") and "certifies the chain" in repr(g)


def test_trms_class_not_certified_says_why_and_names_its_structure():
    cert = fl.certify_eps(presets.paper_design(), fl.plants.trms_yaw())
    assert not cert.certified
    cls = cert.plant_class
    assert {s.variable for s in cls.structure} == {"u", "xi_2"}
    fr = next(s for s in cls.structure if s.variable == "xi_2")
    assert fr.monotone and fr.slope[0] == pytest.approx(-505.0) and fr.slope[1] == pytest.approx(
        -5.0, rel=1e-6)
    if cert.eps_star_certified is None:
        assert "certify_step" in cert.reason or "grows" in cert.reason


def test_wide_b_range_certifies_a_design():
    """rho = 2, T = 1 ms, b in [1, 50] (ratio 50): a design is certified for b varying
    arbitrarily, and the oracle confirms: every frozen b Schur, no switching 1/50 grows."""
    cls = fl.PlantClass(rho=2, T=1e-3, b=(1.0, 50.0), noise_std=1e-3)
    d = presets.pendulum_design(eps=0.0013, gamma=0.005)
    cert = fl.certify_eps(d, cls, search=False)
    assert cert.certified and cert.covers == "varying"
    assert max(radius(loop_matrix(d, 0.0013, b)) for b in np.geomspace(1, 50, 40)) < 1.0
    assert switching_growth(loop_matrix(d, 0.0013, 1.0), loop_matrix(d, 0.0013, 50.0)) <= 1e-12


def test_bad_structure_and_unstabilizable_box_are_refused():
    with pytest.raises(ParameterError, match="xi_3"):
        fl.PlantClass(rho=2, T=1e-3, b=(1, 2), a_slopes=[(0, 0), (-5, -1)],
                      structure=[(3, (-5, -1))])
    with pytest.raises(ParameterError, match="not inside"):
        fl.PlantClass(rho=2, T=1e-3, b=(1, 2), a_slopes=[(0, 0), (-5, -1)],
                      structure=[SlopeRestricted(2, (-9, -1))])
    with pytest.raises(ParameterError, match="lo <= hi"):
        SlopeRestricted(1, (2.0, 1.0))
    cls = fl.PlantClass(rho=2, T=1e-3, b=(1, 2), a_slopes=[(-1e6, 1e6), (0, 0)])
    with pytest.raises(ParameterError, match="a_slopes"):
        fl.certify_eps(presets.pendulum_design(), cls)


def test_theorem1_is_a_sampling_step_bound():
    from fl_design.analysis import theorem1_constants

    c = theorem1_constants((2, 4), 3e-3, (3.6, 6.8), alpha=0.02, T=1e-3, n=60)
    assert c.step_bound == pytest.approx(c.eps_star * 0.02)
    assert c.meets is False and "does NOT meet" in c.verdict()
    ok = theorem1_constants((2, 4), 3e-3, (3.6, 6.8), alpha=0.02, T=0.5 * c.step_bound,
                           n=60)
    assert ok.meets is True and "meets it" in ok.verdict()


def test_region_search_keeps_the_largest_region_that_passes():
    """plant_class_search (opt-in region search) with a stand-in screen: the pendulum's slope
    d sigma/d theta = -(g/l) cos(theta) stays negative only for |theta| < pi/2, reached at the
    room x1e-2 (then once between: x1e-1); the class names its region."""
    from fl_design.analysis._class_region import plant_class_search, scaled_region

    p = fl.plants.pendulum()
    r = scaled_region(p, 1e-2)
    assert r["theta"] == pytest.approx((-math.pi * 1e-2, math.pi * 1e-2))
    seen = []

    def screen(cls):
        seen.append(cls.a_slopes[0])
        return cls.a_slopes[0][1] < 0.0

    cls, _pb, note = plant_class_search(p, presets.pendulum_design(), screen)
    assert cls.a_slopes[0][1] < 0.0 and "shrunk 10x" in note
    assert {n: (lo, hi) for n, lo, hi in cls.region}["theta"] == pytest.approx(
        (-math.pi / 10, math.pi / 10))
    assert "over the region theta in [-0.3142, 0.3142]" in cls.describe()
    assert seen[0][1] > 0.0  # the whole region was tried first
