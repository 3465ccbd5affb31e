"""The certificates' shortcuts give the slow path's answers (issue 33), and their budgets say
what they left (issue 31).

* the stacked gamma scan of :func:`fl_design.certify_gamma` (one eigenvalue call per scan)
  gives the interval of the point-by-point scan;
* the vertex switching tried before the LDI's LMIs (:func:`._ldi.vertex_switching`) refutes
  only what the LMIs cannot certify (checked: the LMIs fail there too), its period grows in an
  independent NumPy product, and the step certificate it speeds up is the slow path's;
* ``time_budget`` of the curve and of the step certificate: the work not done is named.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import fl_design as fl
from fl_design.analysis import _step_cert
from fl_design.analysis._certify import _Loop
from fl_design.analysis._ldi import _vertex_loops, ldi_point, vertex_switching
from fl_design.analysis._search import gamma_interval


def _trms_region_loop(scale):
    """The TRMS's LDI loop over its region scaled about the target r = 0.3 (certify_step's)."""
    plant, design = fl.plants.trms_yaw(), fl.presets.paper_design()
    eq = plant.equilibrium(y=0.3)
    (_, b, box, _, _, _), = _step_cert._plant_tries(plant, design, np.asarray(eq.x, float),
                                                    float(eq.u), [scale])
    return _Loop(design, b, box, 41, 8), design


@pytest.mark.parametrize("b_bounds", [(3.6, 6.8), "trms"])
def test_stacked_gamma_scan_gives_the_pointwise_interval(b_bounds):
    design = fl.presets.paper_design()
    L = _Loop(design, (3.6, 6.8), None if b_bounds != "trms" else [(0.0, 0.0), (-505.0, -5.0)],
              41, 8)
    g_lo, g_hi = 1e-4 * design.T / L.b_hi, 4.0 / L.b_hi
    for eps in (0.01, 0.05, 0.3):
        slow = gamma_interval(lambda g, e=eps: L.frozen_ok(e, g), 3e-4, g_lo, g_hi, 80, 1e-3)
        fast = gamma_interval(lambda g, e=eps: L.frozen_ok(e, g), 3e-4, g_lo, g_hi, 80, 1e-3,
                              lambda gs, e=eps: L.frozen_margins(np.full(len(gs), e), gs) < 0)
        assert fast == slow


def test_vertex_switching_refutes_only_what_the_lmis_cannot_certify():
    L, design = _trms_region_loop((1.0, 1.0))  # friction slopes [-505, -5]: no common P
    eps, gamma = design.estimator.eps, design.controller.gamma
    fast = ldi_point(L, eps, gamma, refute_pairs=8)
    slow = ldi_point(L, eps, gamma)  # the LMIs
    assert not fast.certified and not slow.certified
    assert "no LMI solved" in fast.reason and "no common quadratic P" in slow.reason
    # the growing period, re-built independently: the product of the two vertex loops' runs
    Ms = _vertex_loops(L, eps, gamma)[5]
    i, j, r = vertex_switching(Ms, 8)
    Phi = np.eye(Ms[0].shape[0])
    for k, (t, n) in enumerate(r.runs):
        Phi = np.linalg.matrix_power(Ms[i] if t < 0.5 else Ms[j], n) @ Phi
    assert max(abs(np.linalg.eigvals(Phi))) > 1.0
    assert math.isclose(max(abs(np.linalg.eigvals(Phi))), r.radius, rel_tol=1e-6)


def test_vertex_switching_keeps_a_certified_region_certified():
    L, design = _trms_region_loop((1e-4, 1e-3))  # a region the LDI certifies
    eps, gamma = design.estimator.eps, design.controller.gamma
    fast, slow = ldi_point(L, eps, gamma, refute_pairs=8), ldi_point(L, eps, gamma)
    assert fast.certified and slow.certified
    np.testing.assert_array_equal(fast.lyapunov[0][0], slow.lyapunov[0][0])


@pytest.mark.slow
def test_step_certificate_with_the_shortcut_is_the_slow_paths(monkeypatch):
    plant, design = fl.plants.trms_yaw(), fl.presets.paper_design()
    scales = ((1.0, 1.0), (1e-4, 1e-3))
    fast = fl.certify_step(plant, design, fl.Scenario(0.3), region_scales=scales)
    monkeypatch.setattr(_step_cert, "REFUTE_PAIRS", 0)
    slow = fl.certify_step(plant, design, fl.Scenario(0.3), region_scales=scales)
    assert (fast.certified, fast.region_scale) == (slow.certified, slow.region_scale)
    assert fast.largest_step == slow.largest_step > 0
    np.testing.assert_array_equal(fast.P, slow.P)


def test_step_certificate_budget_names_the_regions_not_tried(monkeypatch):
    plant, design = fl.plants.pendulum(), fl.presets.pendulum_design()
    # every region fails at once (the budget's bookkeeping is what is tested here)
    monkeypatch.setattr(_step_cert, "_one", lambda *a: f"at scales {a[-1]}: no certificate")
    seen = []
    c = fl.certify_step(plant, design, fl.Scenario(0.1), time_budget=0.0,
                        region_scales=((1.0, 1.0), (0.1, 0.1), (0.01, 0.01)),
                        progress=lambda k, n: seen.append((k, n)))
    assert seen == [(0, 3)]  # the first region always, then the budget is spent
    assert not c.certified
    assert ("regions at scales (0.1, 0.1), (0.01, 0.01): not tried, the time budget of 0 s "
            "was spent") in c.uncovered
    monkeypatch.undo()
    with pytest.raises(fl.errors.ParameterError, match="time_budget"):
        fl.certify_step(plant, design, fl.Scenario(0.1), time_budget=-1.0)


def test_curve_budget_keeps_the_frozen_curve_and_names_the_gains_left():
    design, gammas = fl.presets.paper_design(), [3e-4, 1e-3]
    full = fl.eps_star_curve(design, (3.6, 6.8), gammas)
    done = []
    cut = fl.eps_star_curve(design, (3.6, 6.8), gammas, time_budget=0.0,
                            progress=lambda k, n: done.append(k))
    np.testing.assert_array_equal(cut.eps_star_frozen, full.eps_star_frozen)
    assert np.all(np.isnan(cut.eps_star_certified)) and np.all(np.isfinite(full.eps_star_certified))
    assert any("not searched, the time budget of 0 s was spent" in u for u in cut.uncovered)
    assert done == [1, 2]
    with pytest.raises(fl.errors.ParameterError, match="time_budget"):
        fl.eps_star_curve(design, (3.6, 6.8), gammas, time_budget=-1.0)


def test_a_failing_point_solves_each_lmi_once_and_its_verdict_is_the_eigenvalues():
    """Above the frozen boundary of a rho = 3 loop nothing is certified, and no LMI (piece,
    form) is solved twice on the way (the whole interval's P(b) was solved twice); below it
    the same loop is certified."""
    T, rho = 1e-3, 3
    design = fl.Design(estimator=fl.EHGO(rho, 10 * T, T), controller=fl.DynamicController(
        fl.synthesize_gains(rho, decay=1.0).gains, 0.1))
    L = _Loop(design, (1.0, 5.0), None, 41, 8)
    L.lmi_hit = True  # straight to the LMIs (the closed form is tried first otherwise)
    gamma = 0.02
    seen = []
    vertex = L._vertex

    def spy(eps, g, pair, common):
        seen.append((float(pair[0]), float(pair[1]), bool(common)))
        return vertex(eps, g, pair, common)

    L._vertex = spy
    eps_frozen = fl.eps_star_curve(design, fl.PlantClass(rho=rho, T=T, b=(1.0, 5.0)), [gamma],
                                   certified=False).eps_star_frozen[0]
    bad, good = 1.05 * eps_frozen, 0.9 * eps_frozen
    # the eigenvalue refutation: a frozen loop of the b grid is not Schur at 1.05 eps*
    assert L.frozen_margin(bad, gamma) >= 0.0 and L.frozen_margin(good, gamma) < 0.0
    assert not L.point(bad, gamma).certified and not seen  # refuted: no LMI at all
    L.frozen_margin = lambda eps, g: -1.0  # past the screen: the LMIs alone must fail
    assert not L.point(bad, gamma).certified
    assert seen and len(seen) == len(set(seen))
    del L.frozen_margin
    assert L.point(good, gamma).certified
