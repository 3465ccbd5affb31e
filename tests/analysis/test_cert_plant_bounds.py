"""Interval enclosures over a plant's region and parameter box, and certificates covering it.

Every enclosure is checked against independent point evaluations (SymPy ``evalf`` at seeded
random points, the plant's own sampled ``b_bounds``/``jacobian_bounds`` per parameter sample)
and, where the expression is monotone in each variable, for tightness at the box's vertices.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

import fl_design as fl
from fl_design.analysis import plant_bounds
from fl_design.analysis._intervals import interval_range
from fl_design.errors import DesignMismatchError, ParameterError
from tests.oracles import surrogate_loop_matrix

x, y, u = sp.symbols("x y u")


def _values(expr, box, n, seed):
    rng = np.random.default_rng(seed)
    syms = sorted(expr.free_symbols, key=str)
    out = []
    for _ in range(n):
        pt = {s: rng.uniform(*box[s]) for s in syms}
        out.append(float(expr.evalf(subs=pt)))
    return np.array(out)


@pytest.mark.parametrize("expr", [
    -9.81 * sp.sin(x) / (1 + y ** 2) + u * sp.Abs(u),
    (0.1 * y + 0.01 * sp.tanh(y / 1e-3)) * sp.cos(x) ** 2,
    sp.exp(-x) * sp.atan(y) - sp.sqrt(u + 3) + sp.Max(x, y),
    (2 * x + y) ** 3 / (u + 4),
])
def test_enclosure_contains_every_sampled_value(expr):
    box = {x: (-1.5, 2.0), y: (-3.0, 0.5), u: (-2.5, 2.5)}
    lo, hi = interval_range(expr, box, splits=4)
    vals = _values(expr, box, 400, seed=1)
    assert lo <= vals.min() and vals.max() <= hi
    # and it is not vacuous: within 3x the sampled spread
    assert hi - lo <= 3.0 * (vals.max() - vals.min()) + 1e-12


def test_enclosure_is_exact_for_monotone_single_occurrences_and_splits_shrink_dependency():
    assert interval_range(x * sp.exp(y), {x: (1.0, 2.0), y: (0.0, 1.0)}) == pytest.approx(
        (1.0, 2.0 * math.e), rel=1e-15)
    coarse = interval_range(x * (1 - x), {x: (0.0, 1.0)})
    fine = interval_range(x * (1 - x), {x: (0.0, 1.0)}, splits=64)
    assert coarse == (0.0, 1.0) and 0.25 <= fine[1] < 0.26 and fine[0] <= 0.0


def test_one_interval_evaluator_serves_enclose_and_interval_range():
    """``interval_range`` (analysis) encloses each sub-box with the symbolic layer's evaluator:
    on one box the two agree exactly, and both contain every sampled value (a square root
    reaching 0, a Max of three arguments, a rational power)."""
    from fl_design.symbolic._enclosure import enclose

    box = {x: (-1.5, 2.0), y: (-3.0, 0.5)}
    for expr in (sp.Max(x, x ** 2, -y), sp.sqrt(x + 1.5) * sp.cosh(y), (x + 2) ** sp.Rational(1, 3)):
        lo, hi = interval_range(expr, box)
        assert enclose(expr, box) == (lo, hi)
        vals = _values(expr, box, 300, seed=2)
        assert lo <= vals.min() and vals.max() <= hi


def test_enclosure_refuses_what_it_cannot_bound():
    with pytest.raises(ParameterError, match="no range"):
        interval_range(x + y, {x: (0.0, 1.0)})
    with pytest.raises(ParameterError, match="contains 0"):
        interval_range(1 / x, {x: (-1.0, 1.0)})
    with pytest.raises(ParameterError, match="does not support"):
        interval_range(sp.gamma(x), {x: (1.0, 2.0)})
    with pytest.raises(ParameterError, match="negative"):
        interval_range(sp.sqrt(x), {x: (-1.0, 1.0)})


BOX = {"b": (0.8, 1.2), "c": (0.05, 1.0)}
REGION = {"theta": (-0.5, 0.5)}


@pytest.fixture(scope="module")
def pendulum_box():
    return plant_bounds(fl.plants.pendulum(), params=BOX, region=REGION, T=1e-3)


def test_pendulum_box_enclosures_contain_every_sampled_plant_and_are_tight(pendulum_box):
    pb = pendulum_box
    plant = fl.plants.pendulum()
    assert pb.covered() == BOX and pb.b_rate == 0.0
    rng = np.random.default_rng(7)
    for _ in range(12):
        p = plant.with_params(b=rng.uniform(*BOX["b"]), c=rng.uniform(*BOX["c"]))
        bl, bh = p.b_bounds()
        assert pb.b_bounds[0] <= bl <= bh <= pb.b_bounds[1]
        for (lo, hi), (sl, sh) in zip(pb.a_jacobian_bounds,
                                      p.jacobian_bounds(region=REGION, margin=0.0)):
            assert lo <= sl <= sh <= hi
    # monotone in each parameter: the box's vertices attain the ends
    corners = [plant.with_params(b=b, c=c) for b in BOX["b"] for c in BOX["c"]]
    assert pb.b_bounds == pytest.approx((min(p.b_bounds()[0] for p in corners),
                                         max(p.b_bounds()[1] for p in corners)), rel=1e-12)
    damping = [p.jacobian_bounds(region=REGION, margin=0.0)[1] for p in corners]
    assert pb.a_jacobian_bounds[1] == pytest.approx(
        (min(d[0] for d in damping), max(d[1] for d in damping)), rel=1e-12)
    assert pb.a_jacobian_bounds[0] == pytest.approx((-9.81, -9.81 * math.cos(0.5)), rel=1e-12)


def test_trms_friction_slope_is_never_padded_across_zero():
    pb = plant_bounds(fl.plants.trms_yaw(), T=1e-3)
    lo, hi = pb.a_jacobian_bounds[1]
    assert lo == pytest.approx(-505.0, rel=1e-12) and hi == pytest.approx(-5.0, rel=1e-9)
    assert hi < 0.0
    assert pb.b_bounds == pytest.approx((3.6, 6.8), rel=1e-12)


def test_b_rate_from_the_plant_bounds_the_sampled_rate():
    """cart-pendulum: b(theta), |db/dt| = |db/dtheta| |theta_dot| at random states of the box."""
    plant = fl.plants.cart_pendulum()
    T = 1e-3
    pb = plant_bounds(plant, T=T)
    b = plant.normal_form().b.subs(plant.params)
    theta = next(s for s in plant.states if str(s) == "theta")
    rate = sp.diff(b, theta)
    rng = np.random.default_rng(3)
    th = rng.uniform(*plant.region[theta], 300)
    om = rng.uniform(*plant.region[next(s for s in plant.states if str(s) == "theta_dot")], 300)
    sampled = max(abs(float(rate.evalf(subs={theta: a}))) * abs(w) * T for a, w in zip(th, om))
    assert sampled <= pb.b_rate <= 1.5 * sampled
    assert "grad_x b . f" in pb.b_rate_source


def test_b_rate_of_an_input_dependent_b_names_du():
    """TRMS: b = b(|u|), the plant does not bound u's change: the input range's width unless given."""
    pb = plant_bounds(fl.plants.trms_yaw(), T=1e-3)
    slope = 2 * 0.02 * 0.8 ** 2 / 0.02  # 2 a2 k2^2 / (I2 T20^2)
    assert pb.b_rate == pytest.approx(slope * 5.0, rel=1e-12) and "input range" in pb.b_rate_source
    assert plant_bounds(fl.plants.trms_yaw(), T=1e-3, du=2e-3).b_rate == pytest.approx(
        slope * 2e-3, rel=1e-12)


def test_certificate_over_the_pendulum_box_covers_every_sampled_plant(pendulum_box):
    """The box is certified as its class: b AND the slopes (c enters), never the a = 0 chain."""
    import scipy.linalg

    design = fl.presets.pendulum_design()
    cert = fl.certify_eps(design, pendulum_box, b_rate="plant")
    assert cert.covers == "nonlinear" and cert.certified
    assert {n: (lo, hi) for n, lo, hi in cert.params if lo != hi} == BOX
    assert cert.b_rate == 0.0 and cert.b_rate_source.startswith("the plant")
    assert "every plant with b in [0.8, 1.2], c in [0.05, 1]" in repr(cert)
    # every frozen plant of the box, linearized at theta = 0 (a member): the loop at the
    # certified eps* is Schur (oracle: the chain loop with the plant's ZOH of x'' = -g x - c x'
    # + b u replacing the chain's)
    e = cert.eps_star_certified
    ehgo = fl.EHGO(2, e, design.T)
    rng = np.random.default_rng(5)
    for b, c in zip(rng.uniform(*BOX["b"], 12).tolist() + list(BOX["b"]),
                    rng.uniform(*BOX["c"], 12).tolist() + list(BOX["c"])):
        M = surrogate_loop_matrix(ehgo, (2.0, 4.0), design.controller.gamma, 0.0, b)[:-1, :-1]
        E = scipy.linalg.expm(design.T * np.array([[0, 1, 0], [-9.81, -c, b], [0, 0, 0]]))
        U = M[5]  # the row of u_k (state order x_1, x_2, xi_0..xi_2, u)
        M[:2] = E[:2, :2] @ np.eye(2, M.shape[0]) + np.outer(E[:2, 2], U)
        assert np.max(np.abs(np.linalg.eigvals(M))) < 1.0


def test_nonlinear_certificate_over_the_box_holds_in_simulation(pendulum_box):
    design = fl.presets.pendulum_design()
    cert = fl.certify_eps(design, pendulum_box, a_jacobian_bounds="plant")
    assert cert.covers == "nonlinear" and cert.certified and cert.eps_star_certified
    eps = 0.95 * cert.eps_star_certified
    d = fl.presets.pendulum_design(eps=eps)
    for b in BOX["b"]:
        for c in BOX["c"]:
            plant = fl.plants.pendulum().with_params(b=b, c=c)
            resp = fl.simulate(plant, d, fl.Scenario(0.1, 20.0))
            assert resp.status == "converged", (b, c, resp.verdict())


def test_plant_bounds_and_plant_options_refuse_bad_input(pendulum_box):
    plant = fl.plants.pendulum()
    with pytest.raises(ParameterError, match="not a parameter"):
        plant_bounds(plant, params={"mass": (1.0, 2.0)})
    with pytest.raises(ParameterError, match="params"):
        plant_bounds(plant, params={"c": (1.0, 0.1)})
    with pytest.raises(ParameterError, match="not a state"):
        plant_bounds(plant, region={"phi": (0.0, 1.0)})
    with pytest.raises(ParameterError, match="contains 0"):
        plant_bounds(plant, params={"b": (-1.0, 1.0)})
    design = fl.presets.pendulum_design()
    with pytest.raises(ParameterError, match="plant_bounds"):
        fl.certify_eps(design, (0.8, 1.2), b_rate="plant")
    with pytest.raises(ParameterError, match="'plant'"):
        fl.certify_eps(design, pendulum_box, b_rate="fast")
    with pytest.raises(DesignMismatchError, match="T = 0.002"):
        fl.certify_eps(design, plant_bounds(plant, params=BOX, T=2e-3), b_rate="plant")


def test_gamma_interval_and_curve_over_the_box_match_the_plain_b_interval(pendulum_box):
    design = fl.presets.pendulum_design()
    g_box = fl.certify_gamma(design, pendulum_box)
    g_plain = fl.certify_gamma(design, pendulum_box.b_bounds)
    # the box's class has the damping: its stable gammas reach lower than the chain's
    assert g_box.gamma_min <= g_plain.gamma_min and g_box.gamma_min < 0.01 < g_box.gamma_max
    assert g_box.params == pendulum_box.params and g_plain.params == ()
    assert g_plain.class_description.startswith("chain class")
    assert "every plant with b in [0.8, 1.2], c in [0.05, 1]" in repr(g_box)
    c_box = fl.eps_star_curve(design, pendulum_box, [1e-2])
    c_plain = fl.eps_star_curve(design, (0.8, 1.2), [1e-2])
    assert c_box.covers == "nonlinear" and c_plain.covers == "frozen"
    assert c_box.eps_star_certified[0] <= c_box.eps_star_frozen[0]


def test_plant_bounds_and_box_certificates_are_strict_json(pendulum_box):
    import json

    d = json.loads(json.dumps(pendulum_box.to_dict(), allow_nan=False))
    assert d["b_bounds"] == [0.8, 1.2] and ["c", 0.05, 1.0] in d["params"]
    cert = fl.certify_eps(fl.presets.pendulum_design(), pendulum_box, b_rate="plant",
                          search=False)
    d = json.loads(json.dumps(cert.to_dict(), allow_nan=False))
    assert ["b", 0.8, 1.2] in d["params"] and d["b_rate_source"].startswith("the plant")


def test_covered_initial_states_hold_in_simulation_from_their_boundary(pendulum_box):
    """Start the nonlinear plant (corners of the box) and its observer on the boundary of the
    covered set V(X) = level: every run stays in the region and converges."""
    from scipy.optimize import brentq

    design = fl.presets.pendulum_design()
    cert = fl.certify_eps(design, pendulum_box, a_jacobian_bounds="plant", search=False)
    cs = cert.covered_set
    assert cert.certified and cs is not None and cs.level > 0
    assert cs.names == ("x_1", "x_2", "xi_0", "xi_1", "xi_2", "u")
    # theta inside its room, u inside the input range (where b was enclosed); one of them binds
    w = dict(zip(cs.names, cs.half_widths))
    assert w["x_1"] <= 0.5 * (1 + 1e-12) and w["u"] <= 20.0 * (1 + 1e-12)
    assert w[cs.binding] == pytest.approx(0.5 if cs.binding == "x_1" else 20.0, rel=1e-9)
    s_eq = design.initial_state(y0=0.0, u0=0.0)
    for b, c in ((0.8, 0.05), (1.2, 1.0)):
        plant = fl.plants.pendulum().with_params(b=b, c=c)
        for direction in ((1.0, 0.0), (0.3, -1.0), (-0.6, 1.0)):
            def X0(t, d=direction, c=c):
                th, om = t * d[0], t * d[1]
                est = (th, om, -c * om - 9.81 * math.sin(th))  # consistent start, u = u_eq = 0
                s = design.initial_state(estimate=est, u0=0.0) - s_eq
                return np.concatenate([[th, om], s[:4]]), est   # (x, xi, u); z dropped (k_I = 0)

            t = brentq(lambda t: X0(t)[0] @ cs.P @ X0(t)[0] - cs.level, 1e-9, 10.0, xtol=1e-12)
            X, est = X0(t)
            assert cs.contains(X * (1 - 1e-9)) and not cs.contains(X * 1.01)
            resp = fl.simulate(plant, design, fl.Scenario(0.0, 20.0, x0=X[:2],
                                                          initial_estimate=est))
            assert np.max(np.abs(resp.x[:, 0])) <= 0.5, (b, c, direction)
            assert np.max(np.abs(resp.u)) <= 20.0, (b, c, direction)
            assert resp.status == "converged", resp.verdict()
