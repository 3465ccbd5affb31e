"""sampled_linearization / linearized_eps_star against hand-built matrices and simulations."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import scipy.signal
import sympy as sp

import fl_design as fl
from fl_design.errors import DesignMismatchError, ParameterError

T = 1e-3


@pytest.fixture(scope="module")
def oscillator():
    x1, x2, u = sp.symbols("x1 x2 u")
    return fl.Plant.from_ode([x1, x2], u, [x2, -2 * x1 - 0.5 * x2 + 1.5 * u], x1)


@pytest.mark.parametrize("ki", [0.0, 0.7])
def test_linear_plant_matrix_equals_hand_built_loop(oscillator, ki):
    """Linear plant: M equals the loop assembled from scipy's ZOH plant and the EHGO matrices."""
    k1, k2, gamma = 2.0, 4.0, 0.02
    obs = fl.EHGO(rho=2, eps=0.03, T=T)
    design = fl.Design(estimator=obs, controller=fl.DynamicController((k1, k2), gamma, ki=ki))
    lin = fl.sampled_linearization(oscillator, design)

    A = np.array([[0.0, 1.0], [-2.0, -0.5]])
    B = np.array([[0.0], [1.5]])
    C = np.array([[1.0, 0.0]])
    Ad, Bd, *_ = scipy.signal.cont2discrete((A, B, C, np.zeros((1, 1))), T, method="zoh")
    Ao, Bo, _, _ = obs.matrices
    Cu, Du = obs.output_matrices()
    n, m = 2, 3
    size = n + m + 2
    Px = np.hstack([np.eye(n), np.zeros((n, m + 2))])
    Pxi = np.hstack([np.zeros((m, n)), np.eye(m), np.zeros((m, 2))])
    eu, ez = np.eye(size)[n + m], np.eye(size)[n + m + 1]
    L = Du.reshape(-1, 1) @ (C @ Px) + Cu @ Pxi  # xhat_1, xhat_2, sigmahat as rows
    Z = ez + T * L[0]
    U = eu + gamma * (-k1 * L[0] - k2 * L[1] - ki * Z - L[2])
    M = np.vstack([Ad @ Px + Bd @ U[None, :], Bo.reshape(-1, 1) @ (C @ Px) + Ao @ Pxi, U, Z])

    np.testing.assert_allclose(lin.matrix, M, rtol=0, atol=1e-12)
    assert lin.state_names == ("x1", "x2", "xi_0", "xi_1", "xi_2", "u", "z")
    np.testing.assert_allclose(lin.x_eq, [0.0, 0.0], atol=1e-15)


def test_decoupled_integrator_mode_is_exactly_one(pendulum_design, pendulum):
    lin = fl.sampled_linearization(pendulum, pendulum_design())
    assert lin.decoupled == ("z",)
    full = np.linalg.eigvals(lin.matrix)
    one = np.argmin(np.abs(full - 1.0))
    assert full[one] == 1.0
    rest = np.delete(full, one)
    np.testing.assert_allclose(np.sort_complex(rest), np.sort_complex(lin.eigenvalues),
                               atol=1e-12)
    assert lin.spectral_radius == pytest.approx(np.max(np.abs(rest)))
    coupled = fl.sampled_linearization(pendulum, pendulum_design(ki=0.5))
    assert coupled.decoupled == () and coupled.eigenvalues.size == 7
    json.dumps(lin.to_dict())


def test_growth_rate_of_simulation_matches_spectral_radius(pendulum_design, pendulum):
    """Unstable eps: the simulated oscillation grows at log(spectral radius) per sample."""
    design = pendulum_design(eps=0.05)
    lin = fl.sampled_linearization(pendulum, design)
    assert not lin.stable
    rate = math.log(lin.spectral_radius) / T
    resp = fl.simulate(pendulum, design, fl.Scenario(1e-6, 12.0))  # tiny step: linear regime
    err = np.abs(resp.y - 1e-6)
    period = 2 * math.pi / abs(np.angle(lin.eigenvalues[0]) / T)
    w = round(period / T)
    starts = np.arange(0, err.size - w, w)
    envelope = np.array([err[i:i + w].max() for i in starts])
    late = resp.t[starts] > 5.0
    slope = np.polyfit(resp.t[starts][late], np.log(envelope[late]), 1)[0]
    assert slope == pytest.approx(rate, rel=0.03)


def test_equilibrium_at_another_reference(pendulum_design, pendulum):
    design = pendulum_design(ki=0.3)
    lin = fl.sampled_linearization(pendulum, design, r=0.1)
    np.testing.assert_allclose(lin.x_eq, [0.1, 0.0], atol=1e-12)
    lay = design.state_layout
    assert lin.s_eq[lay["u"]][0] == pytest.approx(9.81 * math.sin(0.1), rel=1e-12)
    Cu, Du = design.estimator.output_matrices()
    np.testing.assert_allclose(Cu @ lin.s_eq[lay["estimator"]] + Du.ravel() * 0.1, [0.1, 0.0, 0.0],
                               atol=1e-10)


def test_linearized_eps_star_brackets_the_spectral_radius_crossing(pendulum_design, pendulum):
    """The returned bracket (a, b): eigenvalues of the loop inside the unit circle at a and
    just below it, outside at b and just above it; the bracket is rtol-narrow."""
    design = pendulum_design()
    star = fl.linearized_eps_star(pendulum, design, eps_range=(0.005, 1.0), rtol=1e-7)
    assert isinstance(star, fl.EpsStar) and star.value == star.lower
    a, b = star.lower, star.upper
    assert 0.005 < a < b < 1.0 and b / a - 1.0 <= 1e-7

    def radius(eps):  # numpy eigenvalues of the Jacobian, decoupled z removed by hand
        lin = fl.sampled_linearization(pendulum, design.replace(eps=eps))
        keep = [i for i, n in enumerate(lin.state_names) if n != "z"]
        return np.max(np.abs(np.linalg.eigvals(lin.matrix[np.ix_(keep, keep)])))

    assert radius(a) < 1.0 <= radius(b)
    assert radius(a * (1 - 1e-5)) < 1.0 < radius(b * (1 + 1e-5))
    # every eps below the bracket is stable (eps* is the first crossing)
    for eps in np.geomspace(0.005, a, 12)[:-1]:
        assert radius(eps) < 1.0
    # a larger gamma shrinks eps* (the paper's trade-off)
    assert fl.linearized_eps_star(pendulum, design, gamma=3e-2,
                                  eps_range=(0.005, 1.0)).upper < a
    json.dumps(star.to_dict(), allow_nan=False)


def test_linearized_eps_star_range_ends(pendulum_design, pendulum):
    """Outside the range the result says so: '< lo' (unstable at lo), '> hi' (stable at hi)."""
    design = pendulum_design()
    below = fl.linearized_eps_star(pendulum, design, eps_range=(0.05, 1.0))
    assert below.below_range and below.value is None and str(below) == "< 0.05"
    assert math.isnan(below.lower) and below.upper == 0.05
    assert not fl.sampled_linearization(pendulum, design.replace(eps=0.05)).stable
    above = fl.linearized_eps_star(pendulum, design, eps_range=(0.005, 0.02))
    assert above.above_range and above.value is None and str(above) == "> 0.02"
    assert above.lower == 0.02 and above.upper == math.inf
    assert all(fl.sampled_linearization(pendulum, design.replace(eps=e)).stable
               for e in (0.005, 0.01, 0.02))
    assert json.loads(json.dumps(above.to_dict(), allow_nan=False)) == {
        "lower": 0.02, "upper": None, "upper_status": None, "text": "> 0.02"}


def test_eps_star_plot_marks_brackets_outside_the_range_at_the_edge():
    """Inside-range brackets are a line at their lower end; '> top' an upward triangle at the
    top and '< bottom' a downward one at the bottom, with their own legend text."""
    import matplotlib.pyplot as plt

    from fl_design.plotting import plot_eps_star, plot_stability_map

    stars = [fl.EpsStar(1.0, math.inf), fl.EpsStar(0.1, 0.2), fl.EpsStar(math.nan, 0.005)]
    fig, ax = plt.subplots()
    line, up, down = plot_eps_star(ax, [1e-3, 1e-2, 1e-1], stars, label="lin")
    np.testing.assert_array_equal(line.get_ydata(), [np.nan, 0.1, np.nan])
    assert (up.get_marker(), list(up.get_xdata()), list(up.get_ydata())) == ("^", [1e-3], [1.0])
    assert (down.get_marker(), list(down.get_ydata())) == ("v", [0.005])
    assert "above the range" in up.get_label() and "below the range" in down.get_label()
    with pytest.raises(ParameterError, match="gamma has 2 values but 3 eps"):
        plot_eps_star(ax, [1e-3, 1e-2], stars, label="lin")
    smap = fl.StabilityMap(np.array([0.005, 1.0]), np.array([1e-3, 1e-2, 1e-1]),
                           np.full((2, 3), 2), {}, T, 1.0, 0.1)
    fig = plot_stability_map(smap, curves={"lin": ([1e-3, 1e-2, 1e-1], stars)})
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert "lin: eps* above the range (> top)" in labels
    plt.close("all")


@pytest.mark.parametrize("kwargs, match", [
    ({"eps_range": (0.0, 1.0)}, "eps_range must satisfy 0 < lo < hi"),
    ({"eps_range": (1.0, 0.1)}, "lo < hi"),
    ({"n_scan": 1}, "n_scan must be >= 2"),
    ({"rtol": 0.0}, "rtol must be > 0"),
    ({"gamma": -1.0}, r"gamma=-1 has the sign opposite to b .* give gamma > 0"),
    ({"gamma": 0.0}, "gamma must be nonzero"),
])
def test_linearized_eps_star_bad_input(pendulum_design, pendulum, kwargs, match):
    with pytest.raises(ParameterError, match=match):
        fl.linearized_eps_star(pendulum, pendulum_design(), **kwargs)


def test_linearization_bad_input(pendulum_design, pendulum):
    with pytest.raises(ParameterError, match="r must be finite"):
        fl.sampled_linearization(pendulum, pendulum_design(), r=math.inf)
    d1 = fl.Design(estimator=fl.EHGO(rho=1, eps=0.05, T=T),
                   controller=fl.DynamicController((1,), 1e-2))
    with pytest.raises(DesignMismatchError, match="relative degree 2"):
        fl.sampled_linearization(pendulum, d1)


def test_integrator_sets_the_substeps_of_the_linearized_loop(oscillator):
    """``integrator=fl.RK4(substeps=k)`` linearizes the loop integrated with k RK4 steps: its
    matrix tends to the hand-built one with scipy's exact ZOH as k grows (error ~ (T/k)^4)."""
    Ts, k1, k2, gamma = 0.05, 2.0, 4.0, 0.02
    obs = fl.EHGO(rho=2, eps=0.03, T=Ts)
    design = fl.Design(estimator=obs, controller=fl.DynamicController((k1, k2), gamma))
    A, B, C = np.array([[0.0, 1.0], [-2.0, -0.5]]), np.array([[0.0], [1.5]]), np.eye(1, 2)
    Ad, Bd, *_ = scipy.signal.cont2discrete((A, B, C, np.zeros((1, 1))), Ts, method="zoh")
    Ao, Bo, _, _ = obs.matrices
    Cu, Du = obs.output_matrices()
    Px, Pxi = np.eye(2, 7), np.eye(3, 7, 2)
    eu, ez = np.eye(7)[5], np.eye(7)[6]
    L = Du.reshape(-1, 1) @ (C @ Px) + Cu @ Pxi
    Z = ez + Ts * L[0]
    U = eu + gamma * (-k1 * L[0] - k2 * L[1] - L[2])
    M = np.vstack([Ad @ Px + Bd @ U[None, :], Bo.reshape(-1, 1) @ (C @ Px) + Ao @ Pxi, U, Z])
    errs = [np.abs(fl.sampled_linearization(oscillator, design, integrator=fl.RK4(substeps=k))
                   .matrix - M).max() for k in (1, 4)]
    assert 1e-7 < errs[0] and errs[1] < errs[0] / 100  # RK4's (T/k)^4: 256x smaller
    star = fl.linearized_eps_star(oscillator, design, integrator=fl.RK4(substeps=2),
                                  eps_range=(1e-3, 1.0), n_scan=8, rtol=1e-3)
    assert star.lower <= star.upper
    with pytest.raises(ParameterError, match=r"integrator must be a fl.RK4 .*got Cvodes"):
        fl.sampled_linearization(oscillator, design, integrator=fl.Cvodes())
    with pytest.raises(TypeError, match="substeps"):
        fl.linearized_eps_star(oscillator, design, substeps=4)  # the old keyword is gone


def test_rest_radii_are_the_linearizers_own(pendulum_design, pendulum):
    """The scan's batched radii (one mapped CasADi call) equal ``lin(r, p)``'s, bitwise, at
    the operating point; away from it (the loop at rest is not the equilibrium) none."""
    from fl_design.analysis._linearization import _parameters, _rest_radii
    from fl_design.sim._loop_jacobian import LoopLinearizer
    from fl_design.sim.kernel._loop import ClosedLoop

    design = pendulum_design()
    lin = LoopLinearizer(ClosedLoop(pendulum, design, substeps=4))
    grid = np.geomspace(0.005, 0.5, 7)
    ps = np.stack([_parameters(design, e) for e in grid], axis=1)
    np.testing.assert_array_equal(ps[:, 3], design.replace(
        eps=grid[3]).parameter_vector())
    r0 = float(pendulum.casadi().h(pendulum.x_op))
    fast = _rest_radii(lin, r0, ps)
    assert fast.tolist() == [lin(r0, p).spectral_radius for p in ps.T]
    assert np.all(np.isnan(_rest_radii(lin, r0 + 0.3, ps)))


@pytest.mark.parametrize("gamma", [None, 1e-3, 0.1])
def test_linearized_eps_star_without_the_batched_scan_is_the_same(monkeypatch, pendulum_design,
                                                                  pendulum, gamma):
    from fl_design.analysis import _linearization

    design = pendulum_design()
    fast = fl.linearized_eps_star(pendulum, design, gamma=gamma, eps_range=(0.01, 2.0))
    monkeypatch.setattr(_linearization, "_rest_radii",
                        lambda lin, r, ps: np.full(ps.shape[1], np.nan))
    slow = fl.linearized_eps_star(pendulum, design, gamma=gamma, eps_range=(0.01, 2.0))
    assert (fast.lower, fast.upper) == (slow.lower, slow.upper) or (
        math.isnan(fast.lower) and math.isnan(slow.lower) and fast.upper == slow.upper)
