"""The config is built from option objects: one table per object, immutable, `init` from the same
source, the objects' own messages with the table and key, [classifier], [scenario.disturbance]."""

import dataclasses
import re
import tomllib
import warnings

import numpy as np
import pytest

import fl_design as fl
from fl_design.app import build_scenario, parse_config
from fl_design.app._config import TABLES, Config, ConfigError
from fl_design.app._plant_table import LIBRARY
from fl_design.app._tables import field_docs
from fl_design.app._template import config_toml

INITS = [config_toml(name) for name in LIBRARY] + [config_toml(from_ode=True)]


def _fields(cls):
    return [f.name for f in dataclasses.fields(cls) if f.init]


def test_the_config_holds_the_option_objects_and_they_are_immutable():
    cfg = parse_config("")
    assert isinstance(cfg.classifier, fl.Classifier)
    assert [type(getattr(cfg, t)) for t in TABLES] == list(TABLES.values())
    with pytest.raises(dataclasses.FrozenInstanceError):
        cfg.design.eps = -1.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        cfg.sweep.points = 3
    with pytest.raises(AttributeError):  # arrays are tuples
        cfg.design.gains.append(1.0)
    user = parse_config('[plant]\nstates = ["x"]\ninput = "u"\nrhs = ["-x + u"]\noutput = "x"\n'
                        "params = { k = 1.0 }\nregion = { x = [-1.0, 1.0] }")
    with pytest.raises(TypeError):  # tables are read-only mappings
        user.plant.params["k"] = 2.0
    with pytest.raises(TypeError):
        user.plant.region["x"] = (0.0, 1.0)


def test_every_key_init_writes_is_a_field_and_every_field_has_an_init_line():
    for text in INITS:
        data = tomllib.loads(text)
        assert list(data) == list(TABLES)
        for table, cls in TABLES.items():
            written = re.findall(rf"^\[{table}\]\n(.*?)(?:\n\n|\Z)", text, re.DOTALL | re.MULTILINE)[0]
            keys = re.findall(r"^#? ?(\w+) = ", written, re.MULTILINE)
            assert keys == _fields(cls), table  # every field, in order, nothing else
            assert set(data[table]) <= set(_fields(cls))
            docs = field_docs(cls)
            assert set(_fields(cls)) <= set(docs), f"undocumented fields of {cls.__name__}"
        parse_config(text)  # and it parses as is


def test_init_comments_are_the_objects_documentation():
    text = config_toml("trms")
    assert 'tolerance = 0.02  # Relative tolerance of the settling band' in text
    assert "eps = 0.05  # Observer time constant (s); keep it >= T." in text
    line = next(ln for ln in text.splitlines() if ln.startswith("library = "))
    assert all(name in line for name in LIBRARY)  # the list of plants is the registry's


def test_the_objects_message_comes_with_table_and_key():
    cases = {
        "[classifier]\ntolerance = -1.0": "[classifier] tolerance must be > 0, got -1.0",
        "[classifier]\ntail_fraction = 2.0": "[classifier] tail_fraction must be in (0, 1]",
        "[scenario]\nnoise_std = -0.1": "[scenario] noise_std: noise std must be >= 0",
        "[design]\neps = -1.0": "[design] eps must be > 0, got -1.0",
        '[design]\nestimator = "kalman"': "[design] estimator must be one of 'ehgo', ",
        "[codegen]\nprefix = \"2x\"": "[codegen] prefix",
        '[codegen]\nprecision = "half"': "[codegen] precision must be one of 'double', 'float'",
        "[certify]\nenabled = 1": "[certify] enabled must be True or False, got 1",
        '[plant]\nlibrary = "segway"': "[plant] library must be one of 'trms', 'trms-lag', ",
    }
    for text, needle in cases.items():
        with pytest.raises(ConfigError) as err:
            parse_config(text)
        assert f"<string>: {needle}" in str(err.value), (text, str(err.value))
    # a bad eps is worded once, by the EHGO check, whatever the layer
    with pytest.raises(fl.errors.ParameterError) as api:
        fl.EHGO(rho=2, eps=-1.0, T=1e-3)
    assert str(api.value) in str(pytest.raises(ConfigError, parse_config, "[design]\neps = -1.0")
                                 .value)


def test_library_and_expressions_together_are_refused_not_silently_dropped():
    with pytest.raises(ConfigError, match=r'\[plant\] library = .trms. and a plant from '
                       r"expressions .* give one of them"):
        parse_config('[plant]\nlibrary = "trms"\nstates = ["x"]\ninput = "u"\n'
                     'rhs = ["-x + u"]\noutput = "x"')


@pytest.mark.parametrize("key", ["name = \"x\"", "params = { k = 1.0 }", "region = 3",
                                 "input_range = [-1.0, 1.0]", "operating_point = { x = 0.0 }"])
def test_keys_of_an_expression_plant_are_refused_with_a_library_plant(key):
    with pytest.raises(ConfigError, match=r"\[plant\] \w+ is a key of a plant from expressions; "
                       r"the library plant 'maglev' has its own"):
        parse_config(f'[plant]\nlibrary = "maglev"\n{key}')


def test_motor_lag_is_the_trms_option_only():
    from fl_design.app import build_plant

    assert build_plant(parse_config("[plant]\nmotor_lag = true")).relative_degree() == 3
    with pytest.raises(ConfigError, match=r'\[plant\] motor_lag = true applies to library = '
                       r'"trms" only .*got library = .pendulum.'):
        parse_config('[plant]\nlibrary = "pendulum"\nmotor_lag = true')


def test_classifier_table_and_the_deprecated_scenario_tolerance():
    assert parse_config("[classifier]\ntolerance = 0.05").classifier.tolerance == 0.05
    cfg = parse_config("[classifier]\ntail_fraction = 0.5\ndivergence_bound = 3.0")
    assert cfg.classifier == fl.Classifier(tail_fraction=0.5, divergence_bound=3.0)
    with pytest.warns(DeprecationWarning, match=r"\[scenario\] tolerance is deprecated.*"
                      r"\[classifier\] tolerance = 0.05"):
        old = parse_config("[scenario]\ntolerance = 0.05")
    assert old.classifier.tolerance == 0.05
    assert any("[classifier] tolerance = 0.05" in n for n in old.notes)  # the CLI says it too
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        with pytest.raises(ConfigError, match="both given"):
            parse_config("[scenario]\ntolerance = 0.05\n[classifier]\ntolerance = 0.1")
        with pytest.raises(ConfigError, match=r"\[classifier\] tolerance must be > 0"):
            parse_config("[scenario]\ntolerance = 0.0")


def test_scenario_disturbance_table_builds_the_scenario_the_job_runs():
    text = ("[scenario.disturbance]\ninput = { step = { at = 10.0, size = 0.5 } }\n"
            "output = { sine = { amplitude = 0.01, frequency = 2.0 } }\n")
    cfg = parse_config(text)
    sc = build_scenario(cfg, duration=20.0)
    assert sc.disturbance == fl.Disturbance(input=fl.Step(at=10.0, size=0.5),
                                            output=fl.Sine(amplitude=0.01, frequency=2.0))
    d_in, d_out = sc.disturbance.sampled(1e-3, 20_000)
    t = np.arange(20_000) * 1e-3
    np.testing.assert_array_equal(d_in, np.where(t >= 10.0 - 1e-12, 0.5, 0.0))
    np.testing.assert_allclose(d_out, 0.01 * np.sin(2 * np.pi * 2.0 * t), atol=1e-15)
    # written back by init's renderer, it parses to the same scenario
    from fl_design.app._template import render

    again = parse_config(render(cfg, "x"))
    assert again.scenario == cfg.scenario
    assert cfg.to_dict()["scenario"]["disturbance"]["input"] == {"kind": "step", "at": 10.0,
                                                                "size": 0.5}


@pytest.mark.parametrize("text, needle", [
    ("[scenario.disturbance]\ninput = { ramp = { slope = 1.0 } }",
     "[scenario] disturbance.input must be { step = { at = 10.0, size = 0.5 } } or { sine"),
    ("[scenario.disturbance]\ninput = { step = { at = -1.0, size = 0.5 } }",
     "[scenario] disturbance.input.step: Step.at must be >= 0, got -1.0"),
    ("[scenario.disturbance]\noutput = { sine = { amplitude = 1.0 } }",
     "[scenario] disturbance.output.sine takes amplitude, frequency, phase, at, got amplitude"),
    ("[scenario.disturbance]\nmiddle = { step = { at = 1.0, size = 1.0 } }",
     "[scenario] disturbance must be a table with input and/or output"),
])
def test_a_bad_disturbance_names_where(text, needle):
    with pytest.raises(ConfigError) as err:
        parse_config(text)
    assert needle in str(err.value)


def test_a_disturbance_reaches_the_main_run():
    """The configured input step moves the output off the reference, and the loop recovers."""
    from fl_design.app._job import prepare

    text = ('[plant]\nlibrary = "pendulum"\n[scenario]\nduration = 30.0\n'
            "[scenario.disturbance]\ninput = { step = { at = 15.0, size = 2.0 } }\n")
    job = prepare(parse_config(text))
    resp = fl.simulate(job.plant, job.design, build_scenario(job.config))
    quiet = fl.simulate(job.plant, job.design, build_scenario(parse_config(
        '[plant]\nlibrary = "pendulum"\n[scenario]\nduration = 30.0')))
    k = int(15.0 / job.design.T)
    assert np.array_equal(resp.y[:k], quiet.y[:k])  # identical before the step
    assert np.max(np.abs(resp.y[k:] - quiet.y[k:])) > 1e-3  # it acts after
    assert resp.disturbance is not None and resp.status in ("converged", "converging")


def test_a_table_is_one_dataclass_and_one_config_line():
    assert list(TABLES) == [f.name for f in dataclasses.fields(Config)
                            if "table" in f.metadata]
    for cls in TABLES.values():
        assert dataclasses.is_dataclass(cls) and cls.__dataclass_params__.frozen


def test_the_library_names_are_one_registry():
    from fl_design.app import _template
    from fl_design.app._cli import PLANT_CHOICES

    names = set(LIBRARY)
    assert set(PLANT_CHOICES) == names
    from fl_design.app import _library_tables

    assert set(_library_tables.UNITS) == set(_library_tables._RUN_LENGTH) == \
        set(_template._PLANT_DOC) == names
    for name in names:  # each has a bench design and a config
        assert parse_config(f'[plant]\nlibrary = "{name}"').plant.library == name
