"""certify_step and the sector-multiplier ellipsoids, against independent computation.

* the loop model with its dead-zones (``_sector.loop_channels``) reproduces one sample of the
  real loop (the design's CasADi step + the exact ZOH of ``y'' = b u``) with the clamp and the
  saturation active;
* a certified step converges in ``fl.simulate``; the paper's design on ``y'' = 5 u`` from
  the 0.3 rad step diverges in ``fl.simulate`` and is not certified, while a step below the
  largest certified one converges for b at both ends of the class;
* the re-check refuses a level above the certified one; bad input raises ``fl.errors``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg
import sympy as sp

import fl_design as fl
from fl_design.analysis._sector import loop_channels, recheck
from fl_design.errors import ParameterError


def chain_plant(b: float):
    y, v, u = sp.symbols("y v u", real=True)
    return fl.Plant.from_ode([y, v], u, [v, b * u], y, name=f"chain_b{b:g}",
                             region={y: (-10.0, 10.0), v: (-10.0, 10.0)},
                             input_range=(-2.5, 2.5))


@pytest.fixture(scope="module")
def chain_cert():
    cls = fl.PlantClass.chain(2, b=(3.6, 6.8), T=1e-3)
    return fl.certify_step(cls, fl.presets.paper_design(), fl.Scenario(0.3))


@pytest.mark.parametrize("seed", [0, 1])
def test_channels_reproduce_one_sample_with_limits_active(seed):
    rng = np.random.default_rng(seed)
    design = fl.presets.paper_design()
    b = 5.0
    ch = loop_channels(design, (b, b), None)
    # the real loop: design.step and the exact ZOH of y'' = b u
    step = design.step
    Phi = scipy.linalg.expm(1e-3 * np.array([[0, 1, 0], [0, 0, b], [0, 0, 0.0]]))
    n_active = 0
    for _ in range(20):
        x = rng.normal(size=2) * [0.05, 0.3]
        s = design.initial_state(y0=0.0) + rng.normal(size=design.state_size) * 0.2
        s_next, u = (np.asarray(a, float).ravel() for a in step(s, x[0], 0.0))
        x_next = Phi[:2, :2] @ x + Phi[:2, 2] * u[0]
        X = np.concatenate([x, s])
        # the model: dead-zones of the arguments K X, the clamp's inside the input's
        arg = ch.K @ X
        psi = np.zeros(len(arg))
        psi[0] = arg[0] - np.clip(arg[0], ch.low[0], ch.high[0])
        nu = arg[1] + ch.H[1, 0] * psi[0]
        psi[1] = nu - np.clip(nu, ch.low[1], ch.high[1])
        n_active += bool(psi[0]) + bool(psi[1])
        X_next = ch.Ms[0] @ X + ch.Bs[0] @ psi
        np.testing.assert_allclose(X_next, np.concatenate([x_next, s_next]), rtol=1e-9,
                                   atol=1e-12)
    assert n_active >= 10  # the limits were exercised


def test_chain_step_not_certified_and_diverges_in_simulation(chain_cert):
    assert not chain_cert.certified
    assert chain_cert.start_ratio > 1.0
    assert 0.0 < chain_cert.largest_step < 0.3
    r = fl.simulate(chain_plant(5.0), fl.presets.paper_design(), fl.Scenario(0.3, 30.0))
    assert not r.converged  # the independent check agrees: this step is not safe


@pytest.mark.slow
@pytest.mark.parametrize("b", [3.6, 6.8])
def test_chain_largest_certified_step_converges(chain_cert, b):
    s = 0.95 * chain_cert.largest_step
    r = fl.simulate(chain_plant(b), fl.presets.paper_design(),
                    fl.Scenario(s, 120.0))
    e = np.abs(r.y - s)
    assert np.max(np.abs(r.y)) < 10 * s  # bounded
    assert e[-1000:].max() < 0.05 * s  # converging


@pytest.mark.slow
def test_pendulum_step_certified_and_converges():
    plant, design = fl.plants.pendulum(), fl.presets.pendulum_design()
    c = fl.certify_step(plant, design, fl.Scenario(0.1))
    assert c.certified and c.start_ratio <= 1.0
    assert c.largest_step >= 0.1
    assert "pendulum" in c.argument and "interval enclosures" in c.argument
    r = fl.simulate(plant, design, fl.Scenario(0.1, 20.0))
    assert r.converged
    # a start at the edge of the certified steps (same target) converges too
    s = 0.99 * c.largest_step
    r = fl.simulate(plant, design, fl.Scenario(0.1, 30.0, x0=[0.1 - s, 0.0]))
    assert abs(r.y[-1] - 0.1) < 1e-3


def test_recheck_refuses_a_larger_level(chain_cert):
    design = fl.presets.paper_design()
    ch = loop_channels(design, (3.6, 6.8), None)
    # the certified level re-checks only with its multipliers; a level 100x larger violates
    # the sector's validity region for every multiplier with G = 0 (the linear region)
    from fl_design.analysis._sector import Ellipsoid

    P = np.eye(ch.Ms.shape[1])
    E = Ellipsoid(P, 1e6, 1e-6, 0.0, 0.0, 0.0)
    S = np.eye(ch.K.shape[0])
    worst, _ = recheck(ch, E, S, np.zeros_like(ch.K), {}, np.zeros(ch.Ms.shape[1]))
    assert worst > 0


def test_unbounded_noise_is_not_certified_and_says_why():
    cls = fl.PlantClass.chain(2, b=(1.0, 1.0), T=1e-3)
    design = fl.presets.pendulum_design()
    c = fl.certify_step(cls, design, fl.Scenario(0.1, noise=fl.Noise(1e-3, seed=0)))
    assert not c.certified
    assert "unbounded" in c.uncovered


def test_bounded_noise_gives_an_ultimate_bound():
    cls = fl.PlantClass.chain(2, b=(3.6, 6.8), T=1e-3)
    c = fl.certify_step(cls, fl.presets.paper_design(), fl.Scenario(0.001),
                        noise_bound=1e-8)
    assert c.certified
    assert "ultimate V <=" in c.covered and "|n| <= 1e-08" in c.covered


@pytest.mark.parametrize("bad, match", [
    ({"scenario": fl.Scenario(lambda t: 0.1, 1.0)}, "constant reference"),
    ({"noise_bound": -1.0}, "noise_bound"),
    ({"plant_or_class": "pendulum"}, "fl.Plant or a fl.PlantClass"),
])
def test_bad_input(bad, match):
    args = {"plant_or_class": fl.PlantClass.chain(2, b=(1.0, 2.0), T=1e-3),
                "design": fl.presets.pendulum_design(), "scenario": fl.Scenario(0.1)}
    args.update(bad)
    with pytest.raises(ParameterError, match=match):
        fl.certify_step(**args)


def test_result_is_strict_json(chain_cert):
    import json

    d = json.loads(json.dumps(chain_cert.to_dict(), allow_nan=False))
    assert d["certified"] is False and math.isclose(d["step"], 0.3)


def test_class_with_delay_is_not_certified_and_says_why():
    cls = fl.PlantClass(rho=2, T=1e-3, b=(1.0, 1.0), delay=2)
    c = fl.certify_step(cls, fl.presets.pendulum_design(), fl.Scenario(0.1))
    assert not c.certified and "delay of 2 samples" in c.argument


def test_stated_slope_class_agrees_with_a_member_in_simulation():
    # sigma = -9 y - 0.5 y' + u (a member of the class: a linear pendulum-like plant)
    cls = fl.PlantClass(rho=2, T=1e-3, b=(1.0, 1.0), a_slopes=((-9.81, -9.0), (-0.5, -0.5)),
                        u_eq=0.0)
    design = fl.presets.pendulum_design()
    c = fl.certify_step(cls, design, fl.Scenario(0.1))
    assert c.certified and math.isinf(c.largest_step)  # no limits, no region: global
    y, v, u = sp.symbols("y v u", real=True)
    member = fl.Plant.from_ode([y, v], u, [v, -9.0 * y - 0.5 * v + u], y, name="member",
                               region={y: (-10.0, 10.0), v: (-50.0, 50.0)})
    assert fl.simulate(member, design, fl.Scenario(0.1, 20.0)).converged


@pytest.mark.slow
def test_unstable_design_is_not_certified():
    # pendulum(c=0.05): the linearized loop is unstable above eps = 0.04003 (issue 29)
    plant = fl.plants.pendulum(c=0.05)
    c = fl.certify_step(plant, fl.presets.pendulum_design(eps=0.0405), fl.Scenario(0.1))
    assert not c.certified and c.largest_step == 0.0
    assert "not Schur" in c.argument


@pytest.mark.parametrize("scales", [(), ((0.0, 1.0),), ((1.0, 2.0),), "x"])
def test_bad_region_scales(scales):
    with pytest.raises(ParameterError, match="region_scales"):
        fl.certify_step(fl.plants.pendulum(), fl.presets.pendulum_design(), fl.Scenario(0.1),
                        region_scales=scales)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1])
def test_certified_set_is_invariant_under_switching_b_with_limits_active(chain_cert, seed):
    """Independent of the LMI: the real loop step (clamp, saturation) and the exact ZOH of
    y'' = b_k u with b_k switching at random between 3.6 and 6.8 keep V <= level from starts
    on the certified set's boundary, and V shrinks."""
    rng = np.random.default_rng(seed)
    design = fl.presets.paper_design()
    P, level = np.asarray(chain_cert.P), chain_cert.level
    assert chain_cert.names == ("x_1", "x_2", "xi_0", "xi_1", "xi_2", "u", "z")
    s_eq = design.initial_state(y0=0.0, u0=0.0)
    Phis = {b: scipy.linalg.expm(1e-3 * np.array([[0, 1, 0], [0, 0, b], [0, 0, 0.0]]))
            for b in (3.6, 6.8)}
    step = design.step
    ch = loop_channels(design, (3.6, 6.8), None)
    active = 0
    Pi = np.linalg.inv(P)
    far = Pi @ ch.K[0]  # the start of the set with the largest xhat_2: the clamp acts
    for d in (far, -far, rng.normal(size=7)):
        X = d * math.sqrt(0.999 * level / float(d @ P @ d))
        x, s = X[:2].copy(), s_eq + X[2:]
        v0, vmax = float(X @ P @ X), 0.0
        for _k in range(4000):
            arg = ch.K @ np.concatenate([x, s - s_eq])
            active += int(np.any((arg < ch.low) | (arg > ch.high)))
            s, u = (np.asarray(a, float).ravel() for a in step(s, x[0], 0.0))
            Phi = Phis[3.6 if rng.random() < 0.5 else 6.8]
            x = Phi[:2, :2] @ x + Phi[:2, 2] * u[0]
            Xk = np.concatenate([x, s - s_eq])
            vmax = max(vmax, float(Xk @ P @ Xk))
        assert vmax <= level * (1 + 1e-9)
        assert float(Xk @ P @ Xk) < v0
    assert active > 0  # the clamp or the saturation acted inside the certified set
