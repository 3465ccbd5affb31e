"""The [uncertainty] table: parsed and checked, the robustness stage, the report section."""

import numpy as np
import pytest

import fl_design as fl
from fl_design.app import ConfigError, load_config, parse_config, run_job

TOML = """
[plant]
library = "pendulum"
[uncertainty]
samples = 40
seed = 3
duration = 5.0
[uncertainty.params]
c = [0.05, 1.0]
b = { normal = [1.0, 0.1] }
"""


def test_table_parsed_with_defaults():
    cfg = parse_config(TOML)
    assert cfg.to_dict()["uncertainty"] == {
        "samples": 40, "seed": 3, "duration": 5.0,
        "params": {"c": [0.05, 1.0], "b": {"normal": [1.0, 0.1]}}}
    assert cfg.uncertainty.distributions() == {"c": fl.Uniform(0.05, 1.0),
                                               "b": fl.Normal(1.0, 0.1)}
    default = load_config(None).uncertainty
    assert (default.params, default.samples, default.seed, default.duration) == \
        (None, 200, 0, "adaptive")
    with pytest.raises(AttributeError):  # immutable, as every table
        cfg.uncertainty.samples = 3


@pytest.mark.parametrize(("body", "match"), [
    ("[uncertainty]\nsamples = 0", "samples must be in 1"),
    ("[uncertainty]\nseed = -1", "seed must be >= 0"),
    ('[uncertainty]\nduration = "long"', "duration must be"),
    ("[uncertainty]\nn = 5", "unknown key 'n' in \\[uncertainty\\]"),
    ("[uncertainty.params]\nc = [1.0, 0.5]", "params.c: Uniform needs lo < hi"),
    ("[uncertainty.params]\nc = [1.0]", "params.c must hold two finite numbers"),
    ("[uncertainty.params]\nc = { lognormal = [1.0, 0.5] }", "params.c must be \\[lo, hi\\]"),
    ("[uncertainty.params]\nb = { normal = [1.0, -0.1] }", "sigma"),
])
def test_bad_tables_refused(body, match):
    with pytest.raises(ConfigError, match=match):
        parse_config('[plant]\nlibrary = "pendulum"\n' + body)


def test_robustness_stage_and_report(tmp_path):
    from fl_design.app._report_sections import sections

    cfg = parse_config(TOML)
    job = run_job(cfg, quick=True, stages=("derive", "simulate", "robustness"), progress=False)
    ens = job.results["robustness"]
    assert isinstance(ens, fl.Ensemble) and ens.n == 16 and ens.seed == 3
    # the stage is fl.monte_carlo of the job's design and scenario
    from fl_design.app._build import build_classifier, build_scenario

    again = fl.monte_carlo(job.plant, job.design,
                           build_scenario(cfg, duration=4.0, noise_std=0.0),
                           params={"c": (0.05, 1.0), "b": fl.Normal(1.0, 0.1)}, n=16, seed=3,
                           classifier=build_classifier(cfg), progress=False)
    np.testing.assert_array_equal(ens.status, again.status)
    titles = [t for t, _ in sections(job, [])]
    assert "Robustness: a family of plants" in titles
    blocks = dict(sections(job, []))["Robustness: a family of plants"]
    assert "16 plants drawn from c ~ Uniform(0.05, 1), b ~ Normal(1, 0.1)" in blocks[0][1]
    assert blocks[-1][0] == "table" and len(blocks[-1][2]) == 5


def test_no_params_no_stage():
    job = run_job(load_config(None), quick=True, stages=("robustness",), progress=False)
    assert "robustness" not in job.results and "robustness" not in job.timings
