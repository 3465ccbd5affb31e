"""The plant class (fl.PlantClass): validation, the chain, from_plant, and its use by certify_eps."""

import json

import numpy as np
import pytest

import fl_design as fl
from fl_design import presets
from fl_design.errors import DesignMismatchError, ParameterError


@pytest.mark.parametrize("b, words", [((2.0, 1.0), "reversed"), ((-1.0, 2.0), "contains 0"),
                                      ((0.0, 1.0), "contains 0"), (None, "required"),
                                      ((1.0, float("inf")), "finite"), ("x", "pair")])
def test_bad_b_named(b, words):
    with pytest.raises(ParameterError, match=words):
        fl.PlantClass(rho=2, T=1e-3, b=b)


def test_bad_fields_named():
    with pytest.raises(ParameterError, match="rho"):
        fl.PlantClass(rho=None, T=1e-3, b=(1, 2))
    with pytest.raises(ParameterError, match="ms"):
        fl.PlantClass(rho=2, T=1000.0, b=(1, 2))  # milliseconds given as seconds
    with pytest.raises(ParameterError, match="a_slopes"):
        fl.PlantClass(rho=2, T=1e-3, b=(1, 2), a_slopes=[(0, 1)])
    with pytest.raises(ParameterError, match="lo <= hi"):
        fl.PlantClass(rho=1, T=1e-3, b=(1, 2), a_slopes=[(1, 0)])
    with pytest.raises(ParameterError, match="u_limits"):
        fl.PlantClass(rho=1, T=1e-3, b=(1, 2), u_limits=(1, 1))


def test_describe_and_json():
    c = fl.PlantClass(rho=2, T=1e-3, b=(1.0, 50.0), noise_std=1e-3, u_limits=(-10, 10))
    d = json.loads(json.dumps(c.to_dict(), allow_nan=False))
    assert d["b"] == [1.0, 50.0] and "varying arbitrarily" in d["description"]
    assert any("saturation" in u for u in c.uncovered())
    assert fl.PlantClass.chain(2, b=(1, 2)).describe().startswith("chain class")


def test_T_mismatch_refused():
    with pytest.raises(DesignMismatchError, match="T"):
        fl.certify_eps(presets.paper_design(), fl.PlantClass(rho=2, T=2e-3, b=(3.6, 6.8)),
                       search=False)


def test_from_plant_pendulum_slopes_match_model():
    # pendulum: x2' = -(g/l) sin(x1) - c x2 + b u: slopes -(g/l) cos(x1) and -c, enclosed
    p = fl.plants.pendulum(c=0.05)
    c = fl.PlantClass.from_plant(p)
    assert c.source == "plant" and c.rho == 2
    (a1lo, a1hi), (a2lo, a2hi) = c.a_slopes
    assert a2lo <= -0.05 <= a2hi and a2hi - a2lo < 1e-9
    # independent: d sigma/d theta = -(g/l) cos(theta) over the region theta in [-pi, pi]
    theta = np.linspace(-np.pi, np.pi, 2001)
    slope = -9.81 / 1.0 * np.cos(theta)
    assert a1lo <= slope.min() + 1e-12 and a1hi >= slope.max() - 1e-12
    assert a1hi - a1lo <= 1.01 * (slope.max() - slope.min())  # an enclosure, not a loose box


def test_class_certificate_below_linearized_eps_star():
    """The issue's counterexample: the pendulum c = 0.05 is unstable above 0.04003 (linearized),
    the chain surrogate 'certified' 0.0413; the class from the plant must stay below."""
    p = fl.plants.pendulum(c=0.05)
    d = presets.pendulum_design(eps=0.0405)
    lin = fl.linearized_eps_star(p, d)
    cert = fl.certify_eps(d, fl.PlantClass.from_plant(p))
    assert not cert.certified
    assert cert.eps_star_certified is not None
    assert cert.eps_star_certified <= lin.lower
