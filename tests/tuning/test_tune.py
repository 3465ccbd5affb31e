"""fl.tune: every library plant gets a certified (or said not to be), converging design.

Each claim is re-checked independently of the tuning: a fresh simulation of the returned
design, a fresh certificate at its numbers, the sign of b from the plant, the noise gain of
the paper's design from its own computation.
"""

from __future__ import annotations

import math

import pytest
import sympy as sp

import fl_design as fl
from fl_design.errors import NoDesignError, ParameterError
from fl_design.presets import BENCH_REFERENCES

PLANTS = {"trms": lambda: fl.plants.trms_yaw(), "trms-lag": lambda: fl.plants.trms_yaw(True),
          "pendulum": fl.plants.pendulum, "flexible-joint": fl.plants.flexible_joint,
          "cart-pendulum": fl.plants.cart_pendulum, "maglev": fl.plants.maglev}
CONVERGENT = ("converged", "converging")


def _tank():
    """One tank, rho = 1, held at h = 15 cm (u_eq = 9.25 V, away from 0)."""
    h, u = sp.symbols("h u", real=True)
    return fl.Plant.from_ode([h], u, [(3.3 * u - 0.178 * sp.sqrt(2 * 981 * h)) / 15.5], h,
                             name="tank", input_range=(0.0, 22.0), region={h: (1.0, 30.0)},
                             operating_point={h: 15.0})


@pytest.fixture(scope="module")
def bench_tuned():
    """``get(name)``: ``fl.tune`` of the library plant ``name`` at its bench reference with the
    default objective ("fastest") and one candidate loop, computed once per module (the same
    call serves the library sweep below and the maglev and pendulum tests)."""
    done = {}

    def get(name):
        if name not in done:
            # one candidate loop each (time); the motor lag has no stable eps at its full time
            # scale (3.3 rad/s: the linearized loop is unstable already at eps = T / 2), half
            # of it works
            done[name] = fl.tune(PLANTS[name](), reference=BENCH_REFERENCES[name],
                                 decays=[0.5 if name == "trms-lag" else 1.0])
        return done[name]

    return get


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(PLANTS))
def test_every_library_plant_gets_a_converging_tuned_design(name, bench_tuned):
    plant, r = PLANTS[name](), BENCH_REFERENCES[name]
    tuned = bench_tuned(name)
    assert tuned.reference == r and tuned.objective == "fastest"
    d = tuned.design
    lo, _ = plant.b_bounds()
    assert d.controller.gamma * lo > 0  # the sign of b
    assert d.controller.u_range == plant.input_range
    assert d.rho == plant.relative_degree()
    resp = fl.simulate(plant, d, fl.Scenario(r))  # an independent run of the same step
    assert resp.status in CONVERGENT and resp.status == tuned.status
    at_design = [s for e, g, s in tuned.sweep_converged
                 if e == d.estimator.eps and g == d.controller.gamma]
    assert len(tuned.sweep_converged) == 6 and at_design[0] in CONVERGENT
    cert = fl.certify_eps(d, plant.b_bounds(), search=False)  # fresh, at the design's numbers
    assert cert.certified == tuned.eps_certificate.certified
    if not tuned.certified:  # said, with the reason
        assert any("NOT certified" in r or "gamma False" in r for r in tuned.reasons)
    assert 0 < tuned.noise_gain < math.inf
    assert tuned.to_dict()["design"]["eps"] == d.estimator.eps


@pytest.mark.slow
def test_trms_tuned_design_is_certified_overshoots_less_and_saves_noise():
    """The paper's TRMS: certified, overshoot <= 45 %, and how much noise it saves."""
    plant = fl.plants.trms_yaw()
    tuned = fl.tune(plant, reference=0.3, objective="least-noise")
    assert tuned.certified and tuned.status in CONVERGENT
    assert tuned.overshoot <= 45.0
    paper = fl.presets.paper_design()
    paper_gain = fl.analysis.noise_gain(plant, paper, r=0.3)
    assert tuned.baseline["noise_gain"] == pytest.approx(paper_gain, rel=1e-12)
    assert tuned.baseline["noise_saved"] == pytest.approx(paper_gain / tuned.noise_gain)
    assert tuned.noise_gain < paper_gain  # least noise: less than the hand-tuned design
    assert any("the paper's design" in r for r in tuned.reasons)
    g = fl.certify_gamma(tuned.design, plant.b_bounds())  # fresh, default grid
    assert g.certified


def test_maglev_b_negative_gets_a_negative_gamma_that_converges(bench_tuned):
    plant = fl.plants.maglev()
    tuned = bench_tuned("maglev")  # reference 6.2e-3, "fastest", decays [1.0]
    assert tuned.reference == 6.2e-3 and tuned.objective == "fastest"
    assert tuned.design.controller.gamma < 0 and tuned.status == "converged"
    assert tuned.baseline is None
    assert fl.simulate(plant, tuned.design, fl.Scenario(6.2e-3)).status == "converged"


def test_rho_one_away_from_zero_with_input_limits():
    plant = _tank()
    tuned = fl.tune(plant, reference=16.0, objective="fastest", decays=[1.0])
    assert tuned.design.rho == 1 and tuned.certified
    assert tuned.design.controller.u_range == (0.0, 22.0)
    assert fl.simulate(plant, tuned.design, fl.Scenario(16.0)).status in CONVERGENT
    rng = tuned.ranges
    assert rng["sweep_eps"][0] >= tuned.design.T * (1 - 1e-9)  # never below the sampling time
    assert rng["certify_gamma"][0] < tuned.design.controller.gamma < rng["certify_gamma"][1]


def test_fastest_settles_no_later_than_least_noise_and_costs_noise(bench_tuned):
    plant = fl.plants.pendulum()
    fast = bench_tuned("pendulum")  # reference 0.1, "fastest", decays [1.0]
    assert fast.reference == 0.1 and fast.objective == "fastest"
    quiet = fl.tune(plant, reference=0.1, objective="least-noise", decays=[1.0])
    assert fast.settling_time <= quiet.settling_time
    assert quiet.noise_gain <= fast.noise_gain


def test_no_design_says_why():
    th, om, u = sp.symbols("th om u", real=True)
    flips = fl.Plant.from_ode([th, om], u, [om, -9.81 * sp.sin(th) + sp.cos(th) * u], th,
                              name="flips", input_range=(-5.0, 5.0),
                              region={th: (-3.0, 3.0), om: (-5.0, 5.0)})
    with pytest.raises(fl.errors.AssumptionError, match="vanishes or changes sign on the region"):
        fl.tune(flips, reference=0.1)
    bare = fl.Plant.from_ode([th, om], u, [om, -9.81 * sp.sin(th) + u], th, name="bare")
    with pytest.raises(NoDesignError, match="no region"):
        fl.tune(bare, reference=0.1)
    with pytest.raises(NoDesignError, match="u_eq = 0 is not inside u_limits"):
        fl.tune(fl.plants.pendulum(), reference=0.1, u_limits=(0.5, 1.0))
    # the maglev sampled 100x too slowly: no gamma at any eps, said per candidate
    with pytest.raises(NoDesignError, match="no gamma down to eps = 0.02") as err:
        fl.tune(fl.plants.maglev(), reference=6.2e-3, T=1e-2, decays=[1.0])
    assert isinstance(err.value, fl.errors.CertificationError)


def test_bad_arguments_are_refused_with_what_is_valid():
    plant = fl.plants.pendulum()
    with pytest.raises(ParameterError, match="'least-noise', 'fastest' or"):
        fl.tune(plant, reference=0.1, objective="quiet")
    with pytest.raises(ParameterError, match="overshoot limit"):
        fl.tune(plant, reference=0.1, objective=("overshoot", -0.1))
    with pytest.raises(ParameterError, match="T"):
        fl.tune(plant, reference=0.1, T=0.0)
    with pytest.raises(ParameterError, match="decays"):
        fl.tune(plant, reference=0.1, decays=[])
    with pytest.raises(ParameterError, match="baseline"):
        fl.tune(plant, reference=0.1, decays=[1.0], baseline="paper")
