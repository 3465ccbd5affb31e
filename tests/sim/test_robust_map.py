"""sweep(..., params=...): the robust stability map equals Monte Carlo at each grid point."""

import numpy as np
import pytest

import fl_design as fl
from fl_design.errors import ParameterError

PARAMS = {"c": (0.05, 1.0), "b": fl.Normal(1.0, 0.3)}


@pytest.fixture(scope="module")
def robust():
    plant, design = fl.plants.pendulum(), fl.presets.pendulum_design()
    scenario = fl.Scenario(0.1, 10.0)
    rmap = fl.sweep(plant, design, scenario, eps=[0.02, 0.03, 0.045, 0.06],
                    gamma=[0.005, 0.01, 0.02], params=PARAMS, samples=20, seed=2,
                    progress=False)
    return plant, design, scenario, rmap


def test_each_point_is_the_monte_carlo_of_its_design(robust):
    plant, design, scenario, rmap = robust
    assert isinstance(rmap, fl.RobustMap) and rmap.status.shape == (4, 3, 20)
    for i, j in [(0, 0), (2, 1), (3, 2)]:
        ens = fl.monte_carlo(plant, design.replace(eps=rmap.eps[i], gamma=rmap.gamma[j]),
                             scenario, params=PARAMS, n=20, seed=2, progress=False)
        np.testing.assert_array_equal(ens.params["b"], rmap.params["b"])
        np.testing.assert_array_equal(ens.status, rmap.status[i, j])
        np.testing.assert_allclose(ens.metrics["iae"], rmap.metrics["iae"][i, j],
                                   rtol=1e-12, equal_nan=True)
        assert rmap.fraction[i, j] == ens.convergent_fraction


def test_robust_eps_star_is_the_boundary_of_the_fraction(robust):
    *_, rmap = robust
    frac = rmap.fraction
    assert frac.min() < 1.0 == frac.max() and np.any((frac > 0) & (frac < 1))  # a boundary
    for j, g in enumerate(rmap.gamma):
        star = rmap.eps_star(g)
        ok = frac[:, j] == 1.0
        if ok.all():
            assert star.above_range
            continue
        first_bad = int(np.flatnonzero(~ok)[0])
        assert star.upper == rmap.eps[first_bad]
        assert star.below_range if first_bad == 0 else star.lower == rmap.eps[first_bad - 1]
        half = rmap.eps_star(g, level=0.5)
        assert half.above_range or half.upper >= star.upper
    html = rmap._repr_html_()
    assert html.startswith("<table>") and f">{rmap.eps_star(rmap.gamma[1])}<" in html
    d = rmap.to_dict()
    assert np.array_equal(np.array(d["fraction"]), frac) and len(d["eps_star"]) == 3


def test_robust_map_nominal_sweep_unchanged(robust):
    plant, design, scenario, rmap = robust
    smap = fl.sweep(plant, design, scenario, eps=rmap.eps, gamma=rmap.gamma, progress=False)
    assert isinstance(smap, fl.StabilityMap) and smap.status.shape == (4, 3)


def test_plot(robust):
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    *_, rmap = robust
    fig = rmap.plot()
    assert fig.axes[0].get_ylabel() == "observer time constant eps (s)"


def test_bad_inputs(robust):
    plant, design, scenario, rmap = robust
    with pytest.raises(ParameterError, match="samples"):
        fl.sweep(plant, design, scenario, eps=[0.02], gamma=[0.01], params=PARAMS, samples=0,
                 progress=False)
    with pytest.raises(ParameterError, match="level"):
        rmap.eps_star(rmap.gamma[0], level=1.5)
    with pytest.raises(ParameterError, match="not on the sweep's grid"):
        rmap.eps_star(0.123)
    with pytest.raises(ParameterError, match="unknown verdict"):
        rmap.fraction_of("fine")
