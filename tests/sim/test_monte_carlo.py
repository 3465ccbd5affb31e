"""Monte Carlo over a family of plants: verdicts equal fl.simulate on plant.with_params."""

import numpy as np
import pytest

import fl_design as fl
from fl_design.errors import ParameterError, PlantDefinitionError

PARAMS = {"c": (0.05, 1.0), "b": fl.Normal(1.0, 0.3)}


@pytest.fixture(scope="module")
def setup():
    plant, design = fl.plants.pendulum(), fl.presets.pendulum_design()
    # eps near the edge of stability (empirical eps* about 0.043 at 10 s): a mix of verdicts
    return plant, design.replace(eps=0.0387), fl.Scenario(0.1, 10.0)


@pytest.fixture(scope="module")
def ensemble(setup):
    plant, design, scenario = setup
    return fl.monte_carlo(plant, design, scenario, params=PARAMS, n=12, seed=3,
                          progress=False)


def test_verdicts_match_simulate_sample_by_sample(setup, ensemble):
    plant, design, scenario = setup
    assert len(set(ensemble.labels.tolist())) >= 2, ensemble.labels  # not a trivial family
    for i in range(ensemble.n):
        resp = fl.simulate(plant.with_params(**ensemble.sample(i)), design, scenario)
        assert resp.status == ensemble.labels[i], (i, ensemble.sample(i))
        for name in ("iae", "tail_error", "input_rms", "divergence_time", "settling_time"):
            np.testing.assert_allclose(ensemble.metrics[name][i], resp.metrics[name],
                                       rtol=1e-6, atol=1e-12, err_msg=f"{name} of sample {i}")


def test_draw_is_seeded_and_follows_the_distributions(setup):
    plant, design, _scenario = setup
    short = fl.Scenario(0.1, 0.2)
    a = fl.monte_carlo(plant, design, short, params=PARAMS, n=200, seed=7, progress=False)
    b = fl.monte_carlo(plant, design, short, params=PARAMS, n=200, seed=7, progress=False)
    c = fl.monte_carlo(plant, design, short, params=PARAMS, n=200, seed=8, progress=False)
    np.testing.assert_array_equal(a.params["b"], b.params["b"])
    assert not np.array_equal(a.params["b"], c.params["b"])
    rng = np.random.default_rng(7)  # drawn in the order given, from one generator
    np.testing.assert_array_equal(a.params["c"], rng.uniform(0.05, 1.0, 200))
    np.testing.assert_array_equal(a.params["b"], rng.normal(1.0, 0.3, 200))


def test_family_with_a_varying_equilibrium_input():
    # the operating point theta = 0.3 needs u_eq = (g/l) sin(0.3) / b: it depends on g and b
    *parts, params = _pendulum_parts()
    plant = fl.Plant.from_ode(*parts, params=params, operating_point={"theta": 0.3})
    design = fl.presets.pendulum_design()
    scenario = fl.Scenario(0.35, 4.0)
    ens = fl.monte_carlo(plant, design, scenario, params={"b": (0.8, 1.2), "g": (9.0, 10.0)},
                         n=3, seed=1, progress=False)
    for i in range(ens.n):
        other = plant.with_params(**ens.sample(i))
        resp = fl.simulate(other, design, scenario)
        assert resp.status == ens.labels[i]
        np.testing.assert_allclose(ens.metrics["iae"][i], resp.metrics["iae"], rtol=1e-6)
        np.testing.assert_allclose(ens.metrics["input_rms"][i], resp.metrics["input_rms"],
                                   rtol=1e-6)


def _pendulum_parts():
    import sympy as sp

    th, om, u = sp.symbols("theta theta_dot u", real=True)
    g, b = sp.symbols("g b", positive=True)
    return [th, om], u, [om, -g * sp.sin(th) - 0.5 * om + b * u], th, {g: 9.81, b: 1.0}


def test_ensemble_outputs(ensemble):
    f = ensemble.fractions
    assert abs(sum(f.values()) - 1.0) < 1e-12
    counts = {lab: int(np.sum(ensemble.labels == lab)) for lab in set(ensemble.labels)}
    for lab, c in counts.items():
        assert f[lab] == c / ensemble.n
    worst = ensemble.worst(3)
    order = ["diverged", "solver_failed", "oscillating", "stalled", "undecided", "converging",
             "converged"]
    ranks = [order.index(w["status"]) for w in worst]
    assert ranks == sorted(ranks) and ranks[0] == min(order.index(s) for s in ensemble.labels)
    d = ensemble.to_dict()
    assert d["n"] == 12 and len(d["params"]["c"]) == 12 and d["distributions"]["b"] == \
        "Normal(1, 0.3)"
    import json

    json.dumps(d)  # plain JSON
    html = ensemble._repr_html_()
    assert html.startswith("<table>") and "b ~ Normal(1, 0.3)" in html
    cols = ensemble.columns()
    assert cols["status"].tolist() == ensemble.labels.tolist()
    assert cols["estimation_rms_2"].shape == (12,)
    try:
        import pandas as pd
    except ImportError:
        with pytest.raises(fl.errors.MissingDependencyError, match="pip install pandas"):
            ensemble.to_frame()
        return
    frame = ensemble.to_frame()
    assert isinstance(frame, pd.DataFrame) and len(frame) == 12
    assert list(frame["status"]) == ensemble.labels.tolist()


def test_plot(ensemble):
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    fig = ensemble.plot()
    assert len(fig.axes) == 4 and fig.axes[-1].get_xlabel() == "c"


def test_bad_inputs(setup):
    plant, design, scenario = setup
    with pytest.raises(ParameterError, match="'zz' is not a parameter|not a parameter"):
        fl.monte_carlo(plant, design, scenario, params={"zz": (0, 1)}, n=2, progress=False)
    with pytest.raises(ParameterError, match="lo < hi"):
        fl.monte_carlo(plant, design, scenario, params={"c": (1, 0)}, n=2, progress=False)
    with pytest.raises(ParameterError, match="sigma"):
        fl.Normal(1.0, -0.1)
    with pytest.raises(ParameterError, match="non-empty dict"):
        fl.monte_carlo(plant, design, scenario, params={}, n=2, progress=False)
    with pytest.raises(ParameterError, match="fl.Normal"):
        fl.monte_carlo(plant, design, scenario, params={"c": 0.5}, n=2, progress=False)
    with pytest.raises(ParameterError, match="n"):
        fl.monte_carlo(plant, design, scenario, params={"c": (0, 1)}, n=0, progress=False)
    with pytest.raises(ParameterError, match="sign opposite"):
        fl.monte_carlo(plant, design, scenario, params={"b": (-1.0, 1.0)}, n=20,
                       progress=False)


def test_no_equilibrium_input_is_named():
    import sympy as sp

    x1, x2, u = sp.symbols("x1 x2 u", real=True)
    a = sp.Symbol("a", real=True)
    # x1' = x2 + a: the origin is an equilibrium only for a = 0, whatever u
    plant = fl.Plant.from_ode([x1, x2], u, [x2 + a, -x1 + u], x1, params={a: 0.0})
    design = fl.presets.pendulum_design()
    with pytest.raises(PlantDefinitionError, match=r"sample 0 of the family .*not an equilibrium"):
        fl.monte_carlo(plant, design, fl.Scenario(0.1, 0.5), params={"a": (1.5, 2.0)}, n=3,
                       progress=False)


@pytest.mark.parametrize("substeps", [1, 3])
def test_one_lanes_kernel_for_the_family_same_results_everywhere(setup, substeps):
    from concurrent.futures import ThreadPoolExecutor

    from fl_design._isa import resolve_isa
    from fl_design._toolchain import find_compiler
    from fl_design.sim._family import prepare_family

    plant, design, _ = setup
    scenario = fl.Scenario(0.1, 3.0)
    rk4 = fl.RK4(substeps=substeps)
    fam = prepare_family(plant, design, scenario, {"c": [0.2, 0.4], "b": [0.9, 1.2]},
                         integrator=rk4)
    if find_compiler() is not None and resolve_isa().lanes:
        # the lane emitter translates the parametric step (FL_DESIGN_ISA=scalar: no lanes)
        assert fam.loop.runner().library is not None
    kw = {"params": PARAMS, "n": 10, "seed": 1, "integrator": rk4, "progress": False}
    a = fl.monte_carlo(plant, design, scenario, **kw)
    with ThreadPoolExecutor(2) as ex:
        b = fl.monte_carlo(plant, design, scenario, executor=ex, **kw)
    c = fl.monte_carlo(plant, design, scenario, kernel=fl.Kernel(compiled=False), **kw)
    np.testing.assert_array_equal(a.status, b.status)
    np.testing.assert_array_equal(a.metrics["iae"], b.metrics["iae"])
    np.testing.assert_array_equal(a.status, c.status)
    np.testing.assert_allclose(a.metrics["iae"], c.metrics["iae"], rtol=1e-9)
    resp = fl.simulate(plant.with_params(**a.sample(0)), design, scenario, integrator=rk4)
    assert resp.status == a.labels[0]
    np.testing.assert_allclose(resp.metrics["iae"], a.metrics["iae"][0], rtol=1e-9)


def test_noise_quantization_start_and_estimate_as_simulate(setup):
    plant, design, _ = setup
    scenario = fl.Scenario(0.1, 3.0, x0=[0.05, -0.1], noise=fl.Noise(std=1e-4, seed=4),
                           quantization=1e-4, initial_estimate=[0.04, 0.0, 0.2])
    ens = fl.monte_carlo(plant, design, scenario, params={"b": (0.8, 1.2), "c": (0.1, 0.9)},
                         n=2, seed=5, progress=False)
    for i in range(ens.n):
        resp = fl.simulate(plant.with_params(**ens.sample(i)), design, scenario)
        assert resp.status == ens.labels[i]
        for name in ("iae", "input_tv", "estimation_rms", "overshoot"):
            np.testing.assert_allclose(ens.metrics[name][i], resp.metrics[name], rtol=1e-6)


def test_adaptive_duration_is_chosen_once_on_the_nominal_plant(setup):
    plant, design, _ = setup
    ens = fl.monte_carlo(plant, design, fl.Scenario(0.1), params={"b": (0.9, 1.1)}, n=3,
                         progress=False)
    nominal = fl.simulate(plant, design, fl.Scenario(0.1))
    assert ens.duration == pytest.approx(nominal.t[-1] + design.T)
    assert ens.duration_reason == nominal.duration_reason != "given"


def test_process_pool_gives_the_same_ensemble(setup):
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    plant, design, _ = setup
    kw = {"params": PARAMS, "n": 9, "seed": 2, "progress": False}
    scenario = fl.Scenario(0.1, 2.0)
    local = fl.monte_carlo(plant, design, scenario, **kw)
    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("spawn")) as ex:
        remote = fl.monte_carlo(plant, design, scenario, executor=ex, **kw)
    np.testing.assert_array_equal(local.status, remote.status)
    np.testing.assert_array_equal(local.metrics["iae"], remote.metrics["iae"])


def test_uncertain_names_checked():
    from fl_design.sim import ClosedLoop

    plant, design = fl.plants.pendulum(), fl.presets.pendulum_design()
    with pytest.raises(ParameterError, match="'zz' is not a parameter of plant 'pendulum'"):
        ClosedLoop(plant, design, substeps=1, uncertain=("zz",))
    with pytest.raises(ParameterError, match="repeat a name"):
        ClosedLoop(plant, design, substeps=1, uncertain=("c", "c"))
    with pytest.raises(ParameterError, match="tuple of parameter names"):
        ClosedLoop(plant, design, substeps=1, uncertain="c")
    loop = ClosedLoop(plant, design, substeps=1, uncertain=["b"])
    assert loop.uncertain == ("b",) and loop.layout["theta"] == slice(loop.layout.size - 1,
                                                                      loop.layout.size)


def test_plot_refuses_unknown_names(ensemble):
    with pytest.raises(ParameterError, match="unknown metric"):
        ensemble.plot(metrics=("speed",))
    with pytest.raises(ParameterError, match="not a parameter of the ensemble"):
        ensemble.plot(x="g")
