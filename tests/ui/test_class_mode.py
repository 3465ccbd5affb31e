"""``fl-design ui --class SPEC``: the class read from numbers only, one member simulated, the
certificates computed for the class (as ``fl.certify_gamma`` gives them for it)."""

from __future__ import annotations

import pytest

import fl_design as fl
from fl_design.app import main, parse_config
from fl_design.app._cli import ui_setup
from fl_design.errors import ParameterError
from fl_design.ui import Tuner
from fl_design.ui._class_mode import class_toml, member_b, parse_class_spec

SPEC = "rho=2,T=1e-3,b=1:50,noise_std=1e-3"


@pytest.fixture(scope="module")
def class_tuner():
    cls = parse_class_spec(SPEC)
    return Tuner(ui_setup(parse_config(class_toml(cls), source=f"--class {SPEC}"),
                          plant_class=cls))


def test_spec_is_the_lead_s_example_class():
    cls = parse_class_spec(SPEC)
    assert cls == fl.PlantClass(rho=2, T=1e-3, b=(1.0, 50.0), noise_std=1e-3)


@pytest.mark.parametrize("spec, words", [
    ("rho=2,T=1e-3,b=1:50,zeta=3", "key of rho, T, b"),
    ("rho=2,T=abc,b=1:50", "T='abc' is not a number"),
    ("rho=2.5,T=1e-3,b=1:50", "rho='2.5' must be an integer"),
    ("rho=2,b=1:50", "missing: T"),
    ("rho=2,T=1e-3,b=1:50,b=2:3", "b given twice"),
    ("rho=2,T=1e-3,b=__import__('os')", "is not a number"),
    ("", "--class is empty"),
])
def test_bad_specs_are_refused_by_name(spec, words):
    with pytest.raises(ParameterError) as err:
        parse_class_spec(spec)
    assert words in str(err.value)


def test_a_b_range_of_both_signs_is_refused_by_the_class():
    with pytest.raises(ParameterError):
        parse_class_spec("rho=2,T=1e-3,b=-1:50")


def test_the_member_is_the_chain_at_the_geometric_mean(class_tuner):
    b = member_b(class_tuner.plant_class)
    assert b == pytest.approx(50 ** 0.5)
    nf = class_tuner.plant.normal_form()  # y'' = b u: a = 0, b the member's value
    assert float(nf.b.subs(class_tuner.plant.params)) == pytest.approx(b)
    assert float(nf.a.subs(class_tuner.plant.params)) == 0.0
    assert class_tuner.cert_target is class_tuner.plant_class
    assert class_tuner.b_bounds == (1.0, 50.0)


def test_class_mode_redraws_and_moves_with_gamma(class_tuner):
    low = class_tuner.redraw({"gamma": 2e-4})
    high = class_tuner.redraw({"gamma": 2e-3})
    assert low["verdict"]["status"] and high["verdict"]["status"]
    assert low["y"] != high["y"]


def test_certificates_cover_the_class(class_tuner):
    from fl_design.ui._background import _gamma

    v = class_tuner.check({"gamma": 5e-4})
    design = class_tuner.design_for(v)
    got = _gamma(class_tuner, design, v)
    # the class's b_max = 50 (1/b_max = 0.02), not the simulated member's b = 7.07 (0.141)
    assert "1/b_max = 0.02," in got["text"] and "b in [1, 50]" in got["words"]
    assert got["words"].startswith(class_tuner.plant_class.describe())


def test_cli_refuses_a_bad_class_and_two_sources(capsys):
    assert main(["ui", "--class", "rho=2,T=1e-3"]) == 2
    assert "missing: b" in capsys.readouterr().err
    assert main(["ui", "--plant", "trms", "--class", SPEC]) == 2
    assert "not two of them" in capsys.readouterr().err
