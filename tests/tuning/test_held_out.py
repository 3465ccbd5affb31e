"""The held-out user plant of issue 23: the coupled tanks written as expressions, no [design].

The proposed design (fl.tune through the config) must have a certified eps* that covers its
eps, a converging simulation and a C package that passes SIL, each checked here afresh.
"""

from __future__ import annotations

from pathlib import Path

import fl_design as fl
from fl_design.app import load_config
from fl_design.app._job import prepare
from fl_design.app._propose import propose_design

TANKS = Path(__file__).resolve().parents[2] / "examples" / "coupled_tanks.toml"


def test_coupled_tanks_get_a_certified_converging_design_that_passes_sil(tmp_path):
    cfg = propose_design(load_config(TANKS))
    assert "design proposed by fl.tune" in cfg.source and "(certified there)" in cfg.source
    job = prepare(cfg)
    plant, design = job.plant, job.design
    assert plant.relative_degree() == 2 and design.controller.u_range == (0.0, 22.0)
    cert = fl.certify_eps(design, plant.b_bounds(), eps_range=(design.T, 10.0))
    assert cert.certified and cert.covers == "varying"
    assert design.estimator.eps < cert.eps_star_certified
    sc = fl.Scenario(16.0)
    resp = fl.simulate(plant, design, sc)
    assert resp.status == "converged", resp.verdict()
    res = fl.generate_c(design, tmp_path).verify(plant, fl.Scenario(16.0, resp.duration))
    assert res.c_status == res.sim_status == "converged" and res.passed, res.to_dict()
