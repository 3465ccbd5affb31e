"""``fl-design ui --class SPEC``: the class read from numbers only, one member simulated, the
certificates computed for the class (as ``fl.certify_gamma`` gives them for it)."""

from __future__ import annotations

import re

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
    with pytest.raises(ParameterError, match=re.escape(words)):
        parse_class_spec(spec)


def test_a_b_range_of_both_signs_is_refused_by_the_class():
    with pytest.raises(ParameterError, match="contains 0"):
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


# --- a [class] config file (`fl-design init --class`) works as --class does ------------------
@pytest.fixture
def served(monkeypatch):
    """``fl-design ui ...`` up to the server: the setup it would serve (nothing is served)."""
    import fl_design.ui

    got = {}

    def fake_serve(setup, **kw):
        got["setup"], got["kw"] = setup, kw
        return 0

    monkeypatch.setattr(fl_design.ui, "serve", fake_serve)
    return got


def _init_class(capsys, tmp_path, edit=None):
    assert main(["init", "--class"]) == 0
    text = capsys.readouterr().out
    path = tmp_path / "rig_class.toml"
    path.write_text(edit(text) if edit else text)
    return path


def test_a_class_config_from_init_is_tuned_as_its_class(capsys, tmp_path, served):
    from fl_design.app._class_table import load_class_config

    path = _init_class(capsys, tmp_path)
    assert main(["ui", str(path), "--port", "0"]) == 0
    setup, stated = served["setup"], load_class_config(path).plant_class
    assert setup.plant_class == stated  # the file's class, every stated field
    assert setup.config.source == str(path)
    tuner = Tuner(setup)
    assert tuner.cert_target is setup.plant_class and tuner.b_bounds == (1.0, 50.0)
    assert setup.config.design.u_limits == (-10.0, 10.0)  # the file's actuator limits
    assert setup.config.scenario.reference == 1.0  # no [tune] reference: operating point + 1
    # the member is the chain at the geometric mean of b, as --class makes it
    nf = tuner.plant.normal_form()
    assert float(nf.b.subs(tuner.plant.params)) == pytest.approx(50 ** 0.5)
    low, high = tuner.redraw({"gamma": 2e-4}), tuner.redraw({"gamma": 2e-3})
    assert low["y"] != high["y"] and high["verdict"]["status"]
    # the same as --class with the same numbers (the spec has no u_limits: compare without)
    spec = "rho=2,T=1e-3,b=1:50,noise_std=1e-3"
    assert main(["ui", "--class", spec]) == 0
    other = served["setup"]
    assert other.plant_class == fl.PlantClass(**{
        k: getattr(stated, k) for k in ("rho", "T", "b", "noise_std")})
    assert (other.config.design.gains, other.config.design.eps, other.config.design.gamma) == (
        setup.config.design.gains, setup.config.design.eps, setup.config.design.gamma)


def test_a_class_config_s_reference_and_operating_point_are_used(capsys, tmp_path, served):
    path = _init_class(capsys, tmp_path, lambda t: t.replace(
        "# operating_point = 0.0 ", "operating_point = 0.5 ").replace(
        "# reference = 1.0 ", "reference = 0.8 "))
    assert main(["ui", str(path)]) == 0
    setup = served["setup"]
    assert setup.plant_class.operating_point == 0.5
    assert setup.config.scenario.reference == 0.8
    path.write_text(path.read_text().replace("reference = 0.8 ", "# reference = 0.8 "))
    assert main(["ui", str(path)]) == 0
    assert served["setup"].config.scenario.reference == 1.5  # operating point + 1


def test_a_bad_class_config_or_two_sources_are_refused(capsys, tmp_path, served):
    path = _init_class(capsys, tmp_path, lambda t: t.replace("b = [1.0, 50.0]", "b = [1.0, -50.0]"))
    assert main(["ui", str(path)]) == 2
    assert str(path) in capsys.readouterr().err and "setup" not in served
    path = _init_class(capsys, tmp_path)
    assert main(["ui", str(path), "--class", SPEC]) == 2
    assert "not two of them" in capsys.readouterr().err
    assert main(["ui", str(path), "--plant", "trms"]) == 2
    assert "not both" in capsys.readouterr().err
    assert "setup" not in served
