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
        "samples": 40, "seed": 3, "duration": 5.0, "map_samples": 32,
        "params": {"c": [0.05, 1.0], "b": {"normal": [1.0, 0.1]}}}
    assert cfg.uncertainty.distributions() == {"c": fl.Uniform(0.05, 1.0),
                                               "b": fl.Normal(1.0, 0.1)}
    default = load_config(None).uncertainty
    assert (default.params, default.samples, default.seed, default.duration,
            default.map_samples) == (None, 200, 0, "adaptive", 32)
    with pytest.raises(AttributeError):  # immutable, as every table
        cfg.uncertainty.samples = 3


@pytest.mark.parametrize(("body", "match"), [
    ("[uncertainty]\nsamples = 0", "samples must be in 1"),
    ("[uncertainty]\nseed = -1", "seed must be >= 0"),
    ("[uncertainty]\nmap_samples = -1", "map_samples must be in 0 .. 1000000"),
    ("[uncertainty]\nmap_samples = 2.5", "map_samples"),
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
    worst = [b for b in blocks if b[0] == "table" and b[1][0] == "sample"]
    assert len(worst) == 1 and len(worst[0][2]) == 5


def test_no_params_no_stage():
    job = run_job(load_config(None), quick=True, stages=("robustness",), progress=False)
    assert "robustness" not in job.results and "robustness" not in job.timings


def test_job_robust_map_in_summary_and_report(tmp_path):
    """Quick job with [uncertainty]: the robust map is fl.sweep(..., params=) on the [sweep]
    grid (same seed), in summary.json, the report (figure, eps* beside the nominal's)."""
    import json

    from fl_design.app import write_report
    from fl_design.app._build import build_classifier, build_scenario
    from fl_design.app._job import QUICK

    cfg = parse_config(TOML)
    job = run_job(cfg, quick=True, stages=("derive", "sweep", "robustness"), progress=False)
    rmap, smap = job.results["robust_map"], job.results["sweep"]
    assert isinstance(rmap, fl.RobustMap) and rmap.n == 8 and rmap.seed == 3
    np.testing.assert_array_equal(rmap.eps, smap.eps)  # the nominal map's grid
    np.testing.assert_array_equal(rmap.gamma, smap.gamma)
    direct = fl.sweep(job.plant, job.design,
                      build_scenario(cfg, duration=QUICK["sweep_duration"], noise_std=0.0),
                      eps=np.geomspace(*cfg.sweep.eps, 5), gamma=np.geomspace(*cfg.sweep.gamma, 5),
                      params={"c": (0.05, 1.0), "b": fl.Normal(1.0, 0.1)}, samples=8, seed=3,
                      classifier=build_classifier(cfg), progress=False)
    np.testing.assert_array_equal(rmap.status, direct.status)
    for name in ("c", "b"):
        np.testing.assert_array_equal(rmap.params[name], direct.params[name])
    assert job.design.controller.gamma == 0.01  # the quick grid 0.001 .. 1: 0.00562 nearest
    g = float(smap.gamma[1])
    assert abs(np.log(g / 0.01)) < min(abs(np.log(smap.gamma[[0, 2]] / 0.01)))

    paths = write_report(job, tmp_path / "out")
    assert "robust_map.png" in paths["figures"]
    rm = json.loads((tmp_path / "out" / "summary.json").read_text())["robustness"]["robust_map"]
    assert rm["n"] == 8 and rm["seed"] == 3 and rm["eps"] == list(direct.eps)
    assert rm["fraction"] == direct.fraction.tolist()
    here = rm["at_design_gamma"]
    assert here["gamma"] == g and here["design_gamma"] == 0.01
    assert here["robust_level_1"] == direct.eps_star(g).to_dict()
    assert here["robust_level_0.9"] == direct.eps_star(g, level=0.9).to_dict()
    assert here["nominal"] == smap.eps_star(g).to_dict()
    assert [e["level_1"] for e in rm["eps_star"]] == [direct.eps_star(x).to_dict()
                                                      for x in direct.gamma]
    assert rm["covers"] == "8 plants drawn from c ~ Uniform(0.05, 1), b ~ Normal(1, 0.1), seed 3"
    assert rm["seconds"] == job.timings["robust_map"] > 0
    from fl_design.app._report_render import md as escaped

    md = (tmp_path / "out" / "report.md").read_text()
    assert escaped("every point run against the same 8 plants drawn from c ~ Uniform(0.05, 1), "
                   "b ~ Normal(1, 0.1), seed 3 (200 runs") in md
    assert "](robust_map.png)" in md
    import base64

    png = base64.b64encode((tmp_path / "out" / "robust_map.png").read_bytes()).decode("ascii")
    assert f'src="data:image/png;base64,{png}"' in (tmp_path / "out" / "report.html").read_text()
    _check_figure(job)
    row = f"| every sampled plant converges (8 of 8) | {escaped(direct.eps_star(g))} |"
    assert row in md
    assert (f"| the nominal plant (the stability map above) | {escaped(smap.eps_star(g))} |"
            in md)


def _check_figure(job):
    """The robust map's figure as tests/app/test_figures.py checks the report's others: the
    legend off the data and the colour bar, a short title, the design's point drawn."""
    import matplotlib.pyplot as plt

    from fl_design.app._report_figures import FIGURES, figure_context

    fig = FIGURES["robust_map.png"][0](job, figure_context(job))
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    legend = fig.axes[0].get_legend().get_window_extent(renderer)
    for ax in fig.axes:  # the map and the colour bar
        box = ax.get_window_extent(renderer)
        assert not (legend.x0 < box.x1 and box.x0 < legend.x1 and legend.y0 < box.y1
                    and box.y0 < legend.y1)
    assert fig.axes[0].get_title() == f"{job.plant.name}: robust stability map, 8 plants, seed 3"
    (star,) = [line for line in fig.axes[0].lines if line.get_label() == "this design"]
    assert star.get_xydata().tolist() == [[0.01, job.design.estimator.eps]]
    plt.close(fig)


def test_least_squares_design_no_robust_map_says_why(tmp_path):
    """The robust map runs over eps: a least-squares design still gets its Monte Carlo, and
    the report and summary say why there is no map."""
    from fl_design.app._report_family import blocks
    from fl_design.app._report_family import map_summary as summary

    cfg = parse_config(TOML.replace("[uncertainty]\n", "[design]\nestimator = "
                                    "\"least_squares\"\nT = 0.001\ngains = [1.0, 2.0]\n"
                                    "gamma = 0.01\n[uncertainty]\n", 1))
    job = run_job(cfg, quick=True, stages=("robustness",), progress=False)
    assert job.results["robustness"].n == 16 and "robust_map" not in job.results
    why = ("no robust map: it runs over the observer's eps, and this design's estimator "
           "(LeastSquaresEstimator) has none")
    assert summary(job) == {"skipped": why}
    assert blocks(job, []) == [("p", "N" + why[1:] + ".")]


def test_map_samples_zero_no_robust_map():
    cfg = parse_config(TOML.replace("duration = 5.0", "duration = 5.0\nmap_samples = 0"))
    job = run_job(cfg, quick=True, stages=("robustness",), progress=False)
    assert "robustness" in job.results and "robust_map" not in job.results


def test_cli_sweep_prints_robust_map(tmp_path, capsys):
    from fl_design.app import main

    path = tmp_path / "u.toml"
    path.write_text(TOML)
    assert main(["sweep", str(path), "--quick", "--no-progress", "--samples", "4"]) == 0
    out = capsys.readouterr().out
    cfg = parse_config(TOML)
    from fl_design.app._build import build_classifier, build_plant, build_scenario
    from fl_design.app._job import prepare

    job = prepare(cfg)
    direct = fl.sweep(build_plant(cfg), job.design, build_scenario(cfg, duration=3.0,
                                                                    noise_std=0.0),
                      eps=np.geomspace(*cfg.sweep.eps, 5), gamma=np.geomspace(*cfg.sweep.gamma, 5),
                      params=cfg.uncertainty.distributions(), samples=4, seed=3,
                      classifier=build_classifier(cfg), progress=False)
    assert "Robust stability map 5 x 5 (eps x gamma), 3 s runs, 4 plants drawn from " \
        "c ~ Uniform(0.05, 1), b ~ Normal(1, 0.1), seed 3" in out
    lines = out.split("Robust stability map")[1].splitlines()[2:]
    assert len(lines) == 5
    for line, g in zip(lines, direct.gamma):
        assert line.split()[0] == f"{g:.3g}"
        assert str(direct.eps_star(g)) in line and str(direct.eps_star(g, level=0.9)) in line
    e = int(np.argmin(np.abs(np.log(direct.eps / job.design.estimator.eps))))
    assert [line.split()[-2] for line in lines] == \
        [f"{100 * f:.0f}" for f in direct.fraction[e]]


@pytest.mark.parametrize(("extra", "body", "match"), [
    (["--samples", "4"], "[plant]\nlibrary = \"pendulum\"", "--samples 4 needs a family"),
    (["--samples", "0"], TOML, "--samples must be in 1 .. 1000000, got 0"),
])
def test_cli_sweep_bad_samples(tmp_path, capsys, extra, body, match):
    from fl_design.app import main

    path = tmp_path / "u.toml"
    path.write_text(body)
    assert main(["sweep", str(path), "--quick", "--no-progress", *extra]) == 2
    assert match in capsys.readouterr().err


def test_certificates_cover_the_uncertainty_box():
    """[uncertainty] uniform ranges: the certify stage encloses b over the box (plant_bounds)."""
    from fl_design.analysis import certify_eps, plant_bounds
    from fl_design.app._brief import cert_brief

    cfg = parse_config('[plant]\nlibrary = "pendulum"\n[uncertainty.params]\n'
                       'c = [0.05, 1.0]\nb = [0.8, 1.2]\n')
    job = run_job(cfg, quick=True, stages=("derive", "certify"), progress=False)
    cert = job.results["certify"]
    assert cert["box"]["params"] == {"c": [0.05, 1.0], "b": [0.8, 1.2]}
    assert cert["box"]["b_bounds"] == pytest.approx([0.8, 1.2], rel=1e-9)
    direct = certify_eps(job.design, plant_bounds(job.plant, params={"c": (0.05, 1.0),
                                                                    "b": (0.8, 1.2)}),
                         eps_range=tuple(cfg.certify.eps_range or cfg.sweep.eps))
    assert cert["eps"].eps_star_certified == pytest.approx(direct.eps_star_certified, rel=1e-9)
    assert "c in [0.05, 1]" in str(cert["eps"])
    assert "[uncertainty] box c in [0.05, 1], b in [0.8, 1.2]" in cert_brief(cert).long
    assert "over the [uncertainty] box" in str(cert_brief(cert))
    # the nominal plant (b = 1) certifies a larger eps* than the whole family
    nominal = run_job(parse_config('[plant]\nlibrary = "pendulum"\n'), quick=True,
                      stages=("derive", "certify"), progress=False).results["certify"]
    assert "box" not in nominal
    assert nominal["eps"].eps_star_certified > cert["eps"].eps_star_certified


def test_a_normal_parameter_has_no_box_and_is_named():
    from fl_design.app._uncertainty import UncertaintyTable

    box = UncertaintyTable(params={"c": [0.05, 1.0], "b": {"normal": [1, 0.1]}}).box()
    assert box == {"ranges": {"c": (0.05, 1.0)}, "unbounded": ["b"]}
