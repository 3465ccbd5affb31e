"""The adaptive run length of fl.Scenario(r) against time constants computed independently:
eigenvalues of a finite-difference Jacobian of the sample map; the clamps and the fallback
with their reasons; an explicit duration unchanged; bad durations refused."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import fl_design as fl
from fl_design.app import ConfigError, build_scenario, parse_config
from fl_design.errors import ParameterError
from fl_design.sim import ClosedLoop
from fl_design.sim import _duration as D
from fl_design.sim._run import prepare_run
from fl_design.sim.kernel._loop import default_substeps
from tests.oracles import fd_jacobian

T = 1e-3


def _multiple(tolerance=0.02, tail=0.2):
    """Classifier: converged = |e| <= tolerance |step| over the last `tail` of the run; the
    slow mode may start at 10 x the step."""
    return math.log(10.0 / tolerance) / (1.0 - tail)


def _fd_tau(plant, design, r):
    """Slowest time constant from central differences of ClosedLoop.sample at the equilibrium
    (located by sampled_linearization; its F(X) = X is tested in test_linearize.py)."""
    lin = fl.sampled_linearization(plant, design, r=r)
    loop = ClosedLoop(plant, design, substeps=default_substeps(plant, design.T))
    X = np.concatenate([lin.x_eq, lin.s_eq])
    M = fd_jacobian(loop, X, r, design.parameter_vector())
    unit = [j for j in range(X.size) if np.allclose(M[:, j], np.eye(X.size)[:, j], atol=1e-12)]
    keep = [j for j in range(X.size) if j not in unit]  # the decoupled integrator of ki = 0
    radius = np.max(np.abs(np.linalg.eigvals(M[np.ix_(keep, keep)])))
    return -design.T / math.log(radius), radius


def test_default_duration_is_the_multiple_of_the_slowest_time_constant(pendulum, pendulum_design):
    design = pendulum_design()
    tau, _ = _fd_tau(pendulum, design, 0.1)
    resp = fl.simulate(pendulum, design, fl.Scenario(0.1))
    expected = math.ceil(_multiple() * tau / T) * T
    assert resp.duration == pytest.approx(expected, abs=1.01 * T)
    assert resp.t.size == round(resp.duration / T)
    assert resp.adaptive_duration and resp.duration_reason.startswith(
        f"{_multiple():.3g} x tau = {tau:.3g} s (slowest mode of the loop linearized at r = 0.1")
    # long enough for the classifier to tell: this loop converges, and is called converged
    assert resp.status == "converged"
    assert f"run of {resp.duration:.4g} s chosen by the loop" in resp.verdict()
    data = json.loads(json.dumps(resp.to_dict(), allow_nan=False))
    assert data["duration"] == pytest.approx(resp.duration)
    assert data["duration_reason"] == resp.duration_reason
    assert "adaptive" in repr(resp)


def test_the_multiple_follows_the_classifier(pendulum, pendulum_design):
    design, cls = pendulum_design(), fl.Classifier(tolerance=0.05, tail_fraction=0.5)
    tau, _ = _fd_tau(pendulum, design, 0.1)
    run = prepare_run(pendulum, design, fl.Scenario(0.1), classifier=cls)
    assert run.duration == pytest.approx(math.ceil(_multiple(0.05, 0.5) * tau / T) * T,
                                         abs=1.01 * T)


def test_slow_loop_is_clamped_and_says_so(monkeypatch):
    """The paper's TRMS design: the integrator k_I = 1e-3 gives tau ~ 2000 s."""
    plant, design = fl.plants.trms_yaw(), fl.presets.paper_design()
    tau, _ = _fd_tau(plant, design, 0.3)
    assert _multiple() * tau > 300.0
    run = prepare_run(plant, design, fl.Scenario(0.3))
    assert run.N == D.MAX_SAMPLES == 300_000
    assert run.duration_reason.startswith("clamped to 300 s (300000 samples")
    assert f"would be {_multiple() * tau:.3g} s; give duration= to run longer" in \
        run.duration_reason
    monkeypatch.setenv("FL_DESIGN_MAX_SAMPLES", "50000")  # the global limit clamps too
    run = prepare_run(plant, design, fl.Scenario(0.3))
    assert run.N == 50_000 and run.duration_reason.startswith("clamped to 50 s")


def test_fast_loop_is_raised_to_the_minimum(pendulum, pendulum_design, monkeypatch):
    monkeypatch.setattr(D, "MIN_SAMPLES", 20_000)  # above the 17.6 s the pendulum needs
    run = prepare_run(pendulum, pendulum_design(), fl.Scenario(0.1))
    assert run.N == 20_000
    assert run.duration_reason.startswith("raised to the minimum 20 s (20000 samples")


def test_unstable_linearization_falls_back_to_a_fixed_length(pendulum, pendulum_design):
    design = pendulum_design(eps=0.05)
    _, radius = _fd_tau(pendulum, design, 0.1)
    assert radius > 1.0
    run = prepare_run(pendulum, design, fl.Scenario(0.1))
    assert run.duration == pytest.approx(D.FALLBACK_DURATION) and run.N == 20_000
    assert run.duration_reason.startswith(
        "fixed 20 s: the loop linearized at r = 0.1 (eps = 0.05, gamma = 0.01) is unstable "
        "(spectral radius 1.")


def test_no_equilibrium_falls_back_to_a_fixed_length(pendulum):
    design = fl.Design(estimator=fl.EHGO(rho=2, eps=0.02, T=T),
                       controller=fl.DynamicController((2, 4), 1e-2, ki=0.5,
                                                       u_limits=(-1.0, 1.0)))
    run = prepare_run(pendulum, design, fl.Scenario(0.5))
    assert run.N == 20_000
    assert run.duration_reason.startswith("fixed 20 s: no equilibrium holding r = 0.5")


def test_explicit_duration_is_kept_exactly(pendulum, pendulum_design):
    run = prepare_run(pendulum, pendulum_design(), fl.Scenario(0.1, 5.0))
    assert (run.N, run.duration_reason) == (5000, "given")
    resp = fl.simulate(pendulum, pendulum_design(), fl.Scenario(0.1, 0.5))
    assert resp.t.size == 500 and not resp.adaptive_duration
    assert "chosen by the loop" not in resp.verdict() and "adaptive" not in repr(resp)
    assert fl.Scenario(0.1, 5.0).to_dict()["duration"] == 5.0
    assert fl.Scenario(0.1).to_dict()["duration"] is None


def test_sweep_and_estimate_resolve_once_at_the_design_point(pendulum, pendulum_design):
    """Every grid point runs the length chosen at the design's own (eps, gamma): here a stable
    eps = 0.02, although the grid's eps = 0.05 is unstable (whose own length would be 20 s)."""
    design, kernel = pendulum_design(), fl.Kernel(compiled=False)
    chosen = prepare_run(pendulum, design, fl.Scenario(0.05))
    smap = fl.sweep(pendulum, design, fl.Scenario(0.05), eps=[0.05], gamma=[0.01],
                    progress=False, kernel=kernel)
    assert (smap.duration, smap.duration_reason) == (chosen.duration, chosen.duration_reason)
    assert smap.to_dict()["duration_reason"] == chosen.duration_reason
    est = fl.estimate_eps_star(pendulum, design, fl.Scenario(0.05), eps_range=(0.02, 0.05),
                               max_simulations=2, kernel=kernel)
    assert (est.duration, est.duration_reason) == (chosen.duration, chosen.duration_reason)


@pytest.mark.parametrize("bad, match", [
    (lambda: fl.Scenario(0.1, 0.0), "duration must be > 0"),
    (lambda: fl.Scenario(0.1, -2.0), "duration must be > 0"),
    (lambda: fl.Scenario(0.1, math.nan), "duration must be finite"),
    (lambda: fl.Scenario(0.1, math.inf), "duration must be finite"),
    (lambda: fl.Scenario(0.1, "20"), "duration must be a real number"),
    (lambda: fl.Scenario(np.zeros(10)), (r"an array reference \(10 samples\) fixes the run's "
                                        r"length: give duration = len\(reference\) \* T")),
    (lambda: fl.Scenario(0.1).n_samples(T), "this Scenario has no duration"),
    (lambda: fl.Scenario(0.1, 5.0).replace(duration=-1.0), "duration must be > 0"),
])
def test_bad_durations_are_refused(bad, match):
    with pytest.raises(ParameterError, match=match):
        bad()


def test_config_duration_adaptive():
    cfg = parse_config('[scenario]\nduration = "adaptive"\n[sweep]\nduration = "adaptive"')
    assert build_scenario(cfg).duration is None
    assert build_scenario(cfg, duration=3.0).duration == 3.0
    with pytest.raises(ConfigError, match=r'\[scenario\] duration must be a number of seconds '
                                          r'or "adaptive".*got \'auto\''):
        parse_config('[scenario]\nduration = "auto"')
    with pytest.raises(ConfigError, match=r"\[sweep\] duration must be > 0 s"):
        parse_config("[sweep]\nduration = -1.0")


def test_default_config_runs_adaptive_and_compares_fixed_transients():
    """The built-in job: the design's run and the map choose their length from the loop; the
    compared runs (overshoot and noise of the transient) share one fixed length."""
    cfg = parse_config("")
    assert cfg.scenario.duration == "adaptive" and cfg.sweep.duration == "adaptive"
    assert cfg.compare.duration == 30.0
    assert parse_config("[compare]\nduration = 12.5").compare.duration == 12.5
    with pytest.raises(ConfigError, match=r"\[compare\] duration must be > 0 s"):
        parse_config("[compare]\nduration = 0")
