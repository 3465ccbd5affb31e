"""The C loop's verdict replays the accumulator table by the simulation's own rules.

``c_loop_response`` fed the closed loop that :func:`fl_design.simulate` ran (the same
samples) must give the same metrics and status, the input saturation and the noise level
included (one replay step, :func:`fl_design.sim._simulate.metric_step`, serves both).
"""

from __future__ import annotations

import numpy as np
import pytest

import fl_design as fl
from fl_design import presets
from fl_design.codegen._compare import reference_run
from fl_design.codegen._verdict import c_loop_response
from fl_design.sim import RK4
from fl_design.sim._run import prepare_run


@pytest.mark.parametrize("noise", [0.0, 1e-3])
def test_the_c_verdict_of_simulates_own_loop_is_simulates(noise):
    # |u| <= 0.5 cannot hold the pendulum at 1 rad: the input saturates and the loop stalls
    plant = fl.plants.pendulum()
    design = presets.pendulum_design(u_limits=(-0.5, 0.5))
    sc = fl.Scenario(1.0, 4.0, noise=fl.Noise(noise, seed=3))
    integ = RK4(substeps=4)
    sim = fl.simulate(plant, design, sc, integrator=integ)
    run = prepare_run(plant, design, sc, integrator=integ)
    X = np.asarray(sim.x)
    step = run.loop.plant_step.map(X.shape[0])
    X_next = np.asarray(step(X.T, sim.u[None, :]), dtype=float).T
    state0 = design.initial_state(y0=float(sim.ym[0]), u0=run.u0)
    u_ref, xhat, states = reference_run(design, sim.ym, run.r, state0=state0)
    np.testing.assert_allclose(u_ref, sim.u, rtol=0, atol=1e-9)  # the same loop
    c = c_loop_response(run, sim.y, sim.ym, sim.u, X, X_next, xhat, states)
    assert sim.metrics["saturated_fraction"] > 0.5  # the case exercises the saturation
    assert c.status == sim.status
    for name, value in sim.metrics.items():
        if isinstance(value, str):
            assert c.metrics[name] == value, name
        else:
            np.testing.assert_allclose(c.metrics[name], value, rtol=1e-9, atol=1e-12,
                                       err_msg=name)
