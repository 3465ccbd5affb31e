"""A reference at the operating point's output: the config is warned, the briefs say "no step"."""

import fl_design as fl
from fl_design.app import build_plant, load_config
from fl_design.app._brief import compare_brief
from fl_design.app._build import check_fit
from fl_design.app._text import overshoot_text

TANKS = """[plant]
states = ["h1", "h2"]
input = "u"
rhs = ["(k*u - a1*sqrt(2*g*h1))/A1", "(a1*sqrt(2*g*h1) - a2*sqrt(2*g*h2))/A2"]
output = "h2"
params = {{ k = 3.3e-6, a1 = 1.5e-5, a2 = 1.5e-5, g = 9.81, A1 = 1.5e-3, A2 = 1.5e-3 }}
region = {{ h1 = [0.02, 0.3], h2 = [0.02, 0.3] }}
input_range = [0.0, 12.0]
operating_point = {{ y = 0.15 }}

[design]
gains = [1.0, 2.0]
gamma = 250.0
eps = 0.05
T = 0.01

[scenario]
reference = {r}
"""


def _cfg(tmp_path, r):
    path = tmp_path / "tanks.toml"
    path.write_text(TANKS.format(r=r), encoding="utf-8")
    return load_config(path)


def test_a_reference_at_the_operating_point_is_named_and_one_away_is_not(tmp_path):
    cfg = _cfg(tmp_path, 0.15)
    y_op = float(build_plant(cfg).casadi().h(build_plant(cfg).x_op))
    assert abs(y_op - 0.15) < 1e-12  # the plant's own output at its operating point
    notes = check_fit(cfg, build_plant(cfg))
    assert any(n.startswith("[scenario] reference = 0.15 is the output's value at the "
                            "operating point") for n in notes)
    cfg = _cfg(tmp_path, 0.2)
    assert not any(n.startswith("[scenario]") for n in check_fit(cfg, build_plant(cfg)))


def test_overshoot_text_and_compare_brief_say_no_step_instead_of_nan():
    plant, design = fl.plants.pendulum(), fl.presets.pendulum_design()
    y0 = float(plant.casadi().h(plant.x_op))
    still = fl.simulate(plant, design, fl.Scenario(y0, 2.0))
    assert still.step == 0.0
    assert overshoot_text(still) == "none: no step (the reference is the output's start)"
    moved = fl.simulate(plant, design, fl.Scenario(y0 + 0.1, 20.0))
    assert overshoot_text(moved)[0].isdigit()
    sim = {"stds": [0.0], "designs": {"ehgo": design}, "compare_duration": 2.0,
           "runs": {("ehgo", 0.0): still}}
    assert str(compare_brief(sim)).startswith("overshoot — ehgo: no step")
