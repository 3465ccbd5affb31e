"""simulate / Response: the sampled loop against independent integrations and definitions."""

from __future__ import annotations

import json
import math
import warnings

import matplotlib

matplotlib.use("Agg")

import itertools

import numpy as np
import pytest
import scipy.integrate
import sympy as sp

import fl_design as fl
from fl_design.errors import (
    CompilationWarning,
    DesignMismatchError,
    DimensionError,
    ParameterError,
    ResourceLimitError,
)
from fl_design.sim import ClosedLoop
from fl_design.sim._run import prepare_run
from fl_design.sim.kernel._loop import default_substeps

T = 1e-3


def trms_design(eps: float = 0.05, gamma: float = 3e-4) -> fl.Design:
    """The paper's TRMS yaw design (``fl.presets.paper_design``)."""
    return fl.presets.paper_design(eps, gamma)


def escape_plant():
    """x' = x^2 + u: finite escape time 1/x0 without control."""
    x, u = sp.symbols("x u")
    return fl.Plant.from_ode([x], u, [x**2 + u], x, name="escape")


def escape_design():
    return fl.Design(estimator=fl.EHGO(rho=1, eps=0.05, T=1e-2),
                     controller=fl.DynamicController((1,), 1e-3))


# Plants of the library with a design each (rho 2, 2, 3, 4).
CASES = {
    "pendulum": (fl.plants.pendulum,
                 lambda: fl.Design(estimator=fl.EHGO(rho=2, eps=0.02, T=T),
                                   controller=fl.DynamicController((2, 4), 1e-2)),
                 0.05),
    "trms_yaw": (fl.plants.trms_yaw, lambda: trms_design(), 0.3),
    "trms_yaw_motor_lag": (lambda: fl.plants.trms_yaw(motor_lag=True),
                           lambda: fl.Design(estimator=fl.EHGO(rho=3, eps=0.05, T=T),
                                             controller=fl.DynamicController((1, 3, 3), 1e-4)),
                           0.2),
    "flexible_joint": (fl.plants.flexible_joint,
                       lambda: fl.Design(estimator=fl.EHGO(rho=4, eps=0.01, T=T),
                                         controller=fl.DynamicController((1, 4, 6, 4), 1e-5)),
                       0.1),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_rk4_loop_agrees_with_cvodes_reference(name):
    make_plant, make_design, r = CASES[name]
    plant, design = make_plant(), make_design()
    fast = fl.simulate(plant, design, fl.Scenario(r, 1.0))
    ref = fl.simulate(plant, design, fl.Scenario(r, 1.0), integrator=fl.Cvodes())
    assert not fast.diverged and not ref.diverged
    scale = max(abs(r), np.max(np.abs(ref.y)))
    assert np.max(np.abs(fast.y - ref.y)) <= 1e-6 * scale
    assert np.max(np.abs(fast.u - ref.u)) <= 1e-6 * max(1.0, np.max(np.abs(ref.u)))
    assert np.max(np.abs(fast.x - ref.x)) <= 1e-6 * max(1.0, np.max(np.abs(ref.x)))


def test_plant_is_integrated_under_zero_order_hold(pendulum_design, pendulum):
    """The states equal an independent solve_ivp of the plant with the logged u held."""
    resp = fl.simulate(pendulum, pendulum_design(), fl.Scenario(0.1, 0.5, x0=[0.2, -0.1]))
    g, c = 9.81, 0.5
    x = np.array([0.2, -0.1])
    for k in range(resp.t.size - 1):
        u = resp.u[k]
        sol = scipy.integrate.solve_ivp(lambda t, z, u=u: [z[1], -g * np.sin(z[0]) - c * z[1] + u],
                                        (0.0, T), x, rtol=1e-12, atol=1e-14, method="DOP853")
        x = sol.y[:, -1]
        np.testing.assert_allclose(resp.x[k + 1], x, rtol=0, atol=1e-9)


def test_design_sees_the_measurements_it_is_given(pendulum_design, pendulum):
    """u from the loop equals Design.run (the design's own mapaccum) fed with the logged ym.

    The loop starts the estimator at rest at the first measurement (bumpless start).
    """
    resp = fl.simulate(pendulum, pendulum_design(), fl.Scenario(0.1, 0.5, noise=fl.Noise(std=1e-3, seed=3)))
    d = pendulum_design()
    ol = d.run(resp.ym, resp.r, state0=d.initial_state(y0=resp.ym[0], u0=pendulum.u_eq))
    np.testing.assert_allclose(resp.u, ol.u, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(resp.xhat, ol.xhat[:, :2], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(resp.sigmahat, ol.xhat[:, 2], rtol=1e-12, atol=1e-12)


def test_true_sigma_and_coordinates(pendulum_design, pendulum):
    resp = fl.simulate(pendulum, pendulum_design(), fl.Scenario(0.1, 0.3))
    th, om = resp.x[:, 0], resp.x[:, 1]
    np.testing.assert_allclose(resp.coords[:, 0], th, atol=1e-15)
    np.testing.assert_allclose(resp.coords[:, 1], om, atol=1e-15)
    np.testing.assert_allclose(resp.sigma, -9.81 * np.sin(th) - 0.5 * om + resp.u, atol=1e-12)


def test_noise_and_quantization_are_injected_deterministically(pendulum_design, pendulum):
    d, q, std = pendulum_design(), 1e-3, 2e-3
    resp = fl.simulate(pendulum, d, fl.Scenario(0.1, 0.4, noise=fl.Noise(std=std, seed=7)))
    w = std * np.random.default_rng(7).standard_normal(resp.t.size)
    np.testing.assert_allclose(resp.ym - resp.y, w, atol=1e-15)
    quant = fl.simulate(pendulum, d, fl.Scenario(0.1, 0.4, quantization=q, noise=fl.Noise(std=std, seed=7)))
    np.testing.assert_allclose(quant.ym / q, np.round(quant.ym / q), atol=1e-9)
    assert np.max(np.abs(quant.ym - (quant.y + w))) <= q / 2 + 1e-15
    again = fl.simulate(pendulum, d, fl.Scenario(0.1, 0.4, quantization=q, noise=fl.Noise(std=std, seed=7)))
    np.testing.assert_array_equal(again.u, quant.u)
    other = fl.simulate(pendulum, d, fl.Scenario(0.1, 0.4, quantization=q, noise=fl.Noise(std=std, seed=8)))
    assert not np.array_equal(other.u, quant.u)


def test_compiled_kernel_equals_interpreted(pendulum_design, pendulum, tmp_path):
    d = pendulum_design()
    a = fl.simulate(pendulum, d, fl.Scenario(0.1, 0.5, quantization=1e-4, noise=fl.Noise(std=1e-3)))
    b = fl.simulate(pendulum, d, fl.Scenario(0.1, 0.5, quantization=1e-4, noise=fl.Noise(std=1e-3)), kernel=fl.Kernel(compiled=True, cache_dir=tmp_path))
    for name in ("y", "ym", "u", "xhat", "sigmahat", "sigma", "x"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert list(tmp_path.glob("fl_loop_*.so"))


def test_metrics_follow_their_definitions(pendulum_design, pendulum):
    resp = fl.simulate(pendulum, pendulum_design(gamma=3e-3), fl.Scenario(0.1, 15.0))
    y, u, r, t = resp.y, resp.u, 0.1, resp.t
    step = r - y[0]
    assert resp.overshoot == pytest.approx(max(0.0, 100 * (y.max() - r) / step), abs=1e-12)
    t10 = t[np.argmax(y >= 0.1 * step)]
    t90 = t[np.argmax(y >= 0.9 * step)]
    assert resp.rise_time == pytest.approx(t90 - t10, abs=1e-12)
    outside = np.flatnonzero(np.abs(y - r) > resp.tol)
    assert resp.settling_time == pytest.approx(t[outside[-1]] + T, abs=1e-12)
    assert resp.tol == pytest.approx(0.02 * step)
    # IAE is the rectangle rule of the integral of |e|: compare with the trapezoid rule.
    assert resp.iae == pytest.approx(scipy.integrate.trapezoid(np.abs(y - r), t), rel=1e-3)
    assert resp.input_rms == pytest.approx(np.sqrt(np.mean(u**2)), rel=1e-12)
    assert resp.input_tv == pytest.approx(np.sum(np.abs(np.diff(u))), rel=1e-12)
    tail = slice(int(0.8 * t.size), None)
    assert resp.steady_state_error == pytest.approx(np.mean(y[tail] - r), rel=1e-9, abs=1e-15)
    assert resp.tail_amplitude == pytest.approx(np.ptp(y[tail]), rel=1e-12)
    est = np.sqrt(np.mean((resp.xhat - resp.coords) ** 2, axis=0))
    np.testing.assert_allclose(resp.estimation_rms[:2], est, rtol=1e-12)
    assert resp.converged == (resp.tail_error <= resp.tol and resp.tail_amplitude <= resp.tol)
    json.dumps(resp.to_dict())


def test_ehgo_input_noise_falls_when_eps_rises():
    """Input noise at rest: falls from eps = 0.05 to 0.5, as the observer's own filter predicts.

    Near rest ``u_k - u_(k-1) = gamma (v_k - sigmahat_k)`` with the estimates driven by the noise:
    filtering the same noise with ``EHGO.filter`` (open loop) predicts its size.
    """
    plant, gamma, std = fl.plants.trms_yaw(), 3e-4, 1e-3
    sizes = []
    for eps in (0.05, 0.1, 0.2, 0.5):
        d = trms_design(eps=eps, gamma=gamma)
        resp = fl.simulate(plant, d, fl.Scenario(0.0, 2.0, noise=fl.Noise(std=std, seed=0)))
        assert resp.stable
        xh = d.estimator.filter(std * np.random.default_rng(0).standard_normal(resp.t.size))
        predicted = gamma * (-2 * xh[:, 0] - 4 * xh[:, 1] - xh[:, 2])
        measured = np.diff(resp.u)
        assert np.std(measured[500:]) == pytest.approx(np.std(predicted[500:]), rel=0.02)
        sizes.append(np.std(measured[500:]))
    assert all(a > b for a, b in itertools.pairwise(sizes))
    assert sizes[0] > 20 * sizes[-1]


@pytest.mark.parametrize("kind", ["interpreted", "compiled", "cvodes"])
def test_finite_escape_is_classified_not_raised(kind, tmp_path):
    kw = {"compiled": {"kernel": fl.Kernel(compiled=True, cache_dir=tmp_path)},
          "cvodes": {"integrator": fl.Cvodes()}}.get(kind, {})
    resp = fl.simulate(escape_plant(), escape_design(), fl.Scenario(0.0, 3.0, x0=[2.0]),
                       classifier=fl.Classifier(divergence_bound=1e300), **kw)
    assert resp.status == "diverged" and resp.diverged and not resp.stable
    assert 0.45 <= resp.divergence_time <= 0.6  # escape of x' = x^2 from 2 at t = 0.5
    k = resp.divergence_index
    assert np.all(np.isnan(resp.y[k:])) and np.all(np.isfinite(resp.y[:k]))
    assert math.isnan(resp.overshoot) and math.isnan(resp.iae)
    fig = resp.plot()
    assert len(fig.axes) == 3


def test_divergence_bound_default_and_custom(pendulum_design, pendulum):
    np.testing.assert_allclose(fl.Classifier().bound_for(pendulum), [20 * math.pi, 200.0])
    resp = fl.simulate(pendulum, pendulum_design(eps=0.2), fl.Scenario(0.05, 10.0), classifier=fl.Classifier(divergence_bound=0.2))
    assert resp.diverged
    k = resp.divergence_index
    assert np.all(np.abs(resp.x[: k - 1]) <= 0.2)


def test_reference_forms(pendulum_design, pendulum):
    d = pendulum_design()
    const = fl.simulate(pendulum, d, fl.Scenario(0.1, 0.2))
    arr = fl.simulate(pendulum, d, fl.Scenario(np.full(200, 0.1), 0.2))
    fun = fl.simulate(pendulum, d, fl.Scenario(lambda t: 0.1 + 0 * t, 0.2))
    scalar_fun = fl.simulate(pendulum, d, fl.Scenario(lambda t: 0.1 if t >= 0 else 0.0, 0.2))
    for other in (arr, fun, scalar_fun):
        np.testing.assert_array_equal(other.u, const.u)
    np.testing.assert_allclose(fun.t, np.arange(200) * T)


def test_default_substeps_bound_h_lambda(pendulum):
    assert default_substeps(pendulum, 1e-3) == 1
    lam = np.max(np.abs(np.linalg.eigvals(pendulum.linearization()[0])))
    assert default_substeps(pendulum, 1.0) == math.ceil(lam)


def test_no_compiler_falls_back_with_a_warning(pendulum_design, pendulum, tmp_path, monkeypatch):
    monkeypatch.setenv("CC", str(tmp_path / "no-such-compiler"))
    with pytest.warns(CompilationWarning, match="no C compiler"):
        resp = fl.simulate(pendulum, pendulum_design(), fl.Scenario(0.1, 0.2), kernel=fl.Kernel(compiled=True, cache_dir=tmp_path))
    ref = fl.simulate(pendulum, pendulum_design(), fl.Scenario(0.1, 0.2),
                      kernel=fl.Kernel(compiled=False))
    np.testing.assert_array_equal(resp.u, ref.u)


def test_failing_compiler_falls_back_with_a_warning(pendulum_design, pendulum, tmp_path, monkeypatch):
    monkeypatch.setenv("CC", "false")
    with pytest.warns(CompilationWarning, match="failed"):
        fl.simulate(pendulum, pendulum_design(), fl.Scenario(0.1, 0.2), kernel=fl.Kernel(compiled=True, cache_dir=tmp_path))


def test_compiled_kernel_is_cached(pendulum_design, pendulum, tmp_path):
    d = pendulum_design()
    fl.simulate(pendulum, d, fl.Scenario(0.1, 0.1), kernel=fl.Kernel(compiled=True, cache_dir=tmp_path))
    libs = list(tmp_path.glob("fl_loop_*.so"))
    stamp = libs[0].stat().st_mtime_ns
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fl.simulate(pendulum, d.replace(eps=0.05, gamma=3e-3), fl.Scenario(0.2, 0.1), kernel=fl.Kernel(compiled=True, cache_dir=tmp_path))
    assert list(tmp_path.glob("fl_loop_*.so")) == libs
    assert libs[0].stat().st_mtime_ns == stamp


# --- bad input ---------------------------------------------------------------------------------
@pytest.mark.parametrize("make, error, match", [
    (lambda: fl.Scenario(0.1, -1.0), ParameterError, "duration must be > 0"),
    (lambda: fl.Scenario(0.1, 0.0), ParameterError, "duration must be > 0"),
    (lambda: fl.Scenario(0.1, 1e-4), ParameterError, "shorter than one sample"),
    (lambda: fl.Scenario(0.1, 6e-4), ParameterError, "shorter than one sample"),
    (lambda: fl.Scenario(0.1, 1e9), ResourceLimitError, "FL_DESIGN_MAX_SAMPLES"),
    (lambda: fl.Scenario(np.zeros(7), 0.1), DimensionError,
     "N = round\\(duration/T\\) = 100 samples"),
    (lambda: fl.Scenario(np.zeros((100, 2)), 0.1), DimensionError, "one-dimensional"),
    (lambda: fl.Scenario(lambda t: np.nan * t, 0.1), ParameterError, "non-finite"),
    (lambda: fl.Scenario(0.1, 0.1, x0=[0.0]), DimensionError, "x0 must have length 2"),
    (lambda: fl.Noise(std=-1.0), ParameterError, "noise std must be >= 0"),
    (lambda: fl.Scenario(0.1, 0.1, quantization=0.0), ParameterError,
     "quantization must be > 0"),
    (lambda: fl.Noise(std=0.1, seed=-1), ParameterError, "noise seed must be >= 0"),
    (lambda: fl.Scenario(0.1, 0.1, noise=0.1), ParameterError, "noise must be a fl.Noise"),
    (lambda: fl.Classifier(tail_fraction=0.0), ParameterError,
     "tail_fraction must be in \\(0, 1\\]"),
    (lambda: fl.Classifier(tolerance=-0.1), ParameterError, "tolerance must be > 0"),
    (lambda: fl.Classifier(divergence_bound=[1.0, -1.0]), ParameterError,
     "divergence_bound must be > 0"),
    (lambda: fl.Classifier(divergence_bound=[1.0]), DimensionError,
     "divergence_bound must have length 2"),
    (lambda: fl.RK4(substeps=0), ParameterError, "substeps must be >= 1"),
    (lambda: "euler", ParameterError, "integrator must be fl.RK4"),
    (lambda: fl.Kernel(compiled="no"), ParameterError, "compiled must be True or False"),
])
def test_bad_input_is_refused(pendulum_design, pendulum, make, error, match):
    def run():
        value = make()
        if isinstance(value, fl.Scenario):
            return fl.simulate(pendulum, pendulum_design(), value)
        key = {fl.Noise: "noise", fl.Classifier: "classifier", fl.Kernel: "kernel"}.get(
            type(value), "integrator")
        if key == "noise":
            return fl.simulate(pendulum, pendulum_design(), fl.Scenario(0.1, 0.1, noise=value))
        return fl.simulate(pendulum, pendulum_design(), fl.Scenario(0.1, 0.1), **{key: value})

    with pytest.raises(error, match=match):
        run()


def test_relative_degree_mismatch_is_refused(pendulum):
    d1 = fl.Design(estimator=fl.EHGO(rho=1, eps=0.05, T=T),
                   controller=fl.DynamicController((1,), 1e-2))
    with pytest.raises(DesignMismatchError, match="relative degree 2 but the design serves rho=1"):
        fl.simulate(pendulum, d1, fl.Scenario(0.1, 0.1))
    with pytest.raises(DesignMismatchError, match="relative degree"):
        ClosedLoop(pendulum, d1, substeps=1)


def test_prepare_run_constants(pendulum_design, pendulum):
    run = prepare_run(pendulum, pendulum_design(), fl.Scenario(lambda t: 0.2 * (t >= 0.5), 1.0, x0=[0.05, 0.0]), classifier=fl.Classifier(tail_fraction=0.25))
    assert run.N == 1000 and run.k_tail == 750
    assert run.y0 == 0.05 and run.step == pytest.approx(0.15)
    assert run.tol == pytest.approx(0.02 * 0.2)  # scale = peak-to-peak of r (0.2) > |step|


@pytest.mark.parametrize("compiled", [False, True], ids=["interpreted", "generated C"])
def test_if_else_drops_nan_and_inf_of_the_rejected_branch(compiled, tmp_path):
    """The divergence freeze relies on it: if_else selects, it does not multiply by 0/1."""
    import casadi as ca

    from fl_design._toolchain import build, generate_source

    c, a, b = ca.SX.sym("c"), ca.SX.sym("a"), ca.SX.sym("b")
    fn = ca.Function("fl_select", [c, a, b], [ca.if_else(c, a, b), a <= 1.0])
    if compiled:
        fn = ca.external("fl_select", str(build(generate_source(fn), "fl_select",
                                                cache_dir=tmp_path)))
    for cond, x, y in [(0, np.nan, 2.0), (0, np.inf, 2.0), (0, -np.inf, 2.0), (1, 2.0, np.nan),
                       (1, 2.0, np.inf)]:
        assert float(fn(cond, x, y)[0]) == 2.0
    assert float(fn(1, np.nan, 0.0)[1]) == 0.0  # NaN fails every comparison: out of bounds


def test_runners_agree_on_diverging_runs_including_skipped_samples(tmp_path):
    """The compiled driver skips a frozen run's samples; the accumulators are unchanged."""
    run = prepare_run(escape_plant(), escape_design(), fl.Scenario(0.0, 20.0, x0=[2.0]), classifier=fl.Classifier(divergence_bound=1e300))
    P = np.column_stack([escape_design().replace(gamma=g).parameter_vector()
                         for g in (1e-3, 1e-2)])
    acc0 = run.initial_accumulator(P)
    native = run.loop.runner(cache_dir=tmp_path).run(acc0, run.D, threads=2)
    interp = run.loop.runner(compiled=False).run(acc0, run.D)
    np.testing.assert_array_equal(native, interp)
    info = run.loop.layout.unpack(native)
    np.testing.assert_array_equal(info["k"], [run.N, run.N])
    np.testing.assert_array_equal(info["diverged"], [1.0, 1.0])
    assert np.all(np.isfinite(info["x"]))


# --- one home for metrics: the kernel's accumulators == NumPy over the trajectories -----------
@pytest.mark.parametrize("kind", ["interpreted", "compiled", "cvodes"])
@pytest.mark.parametrize("case", ["stable", "noisy", "diverging"])
def test_response_metrics_equal_numpy_oracle(pendulum, pendulum_design, tmp_path, kind, case):
    from tests.oracles import metrics_from_trajectories, region_exit_time, status_from_trajectories

    kw = {"compiled": {"kernel": fl.Kernel(compiled=True, cache_dir=tmp_path)},
          "cvodes": {"integrator": fl.Cvodes()}}.get(kind, {})
    design, sc = {
        "stable": (pendulum_design(), fl.Scenario(0.1, 4.0)),
        "noisy": (pendulum_design(gamma=3e-2), fl.Scenario(0.1, 4.0, noise=fl.Noise(1e-3, 4))),
        "diverging": (pendulum_design(eps=0.2), fl.Scenario(0.05, 6.0)),
    }[case]
    resp = fl.simulate(pendulum, design, sc, **kw)
    assert resp.diverged == (case == "diverging")
    assert resp.status == status_from_trajectories(resp)
    np.testing.assert_equal(resp.region_exit_time,
                            region_exit_time(resp, pendulum.region, pendulum.states))
    oracle = metrics_from_trajectories(resp)
    for name, value in oracle.items():
        np.testing.assert_allclose(resp.metrics[name], value, rtol=1e-9, atol=1e-12,
                                   err_msg=f"{name} ({kind}, {case})")


def test_adding_a_metric_is_one_table_entry(monkeypatch):
    """A metric added to the table appears in Response.metrics and StabilityMap.metrics."""
    from fl_design.sim import _metrics

    extra = _metrics.Metric("peak_error", "output",
                            lambda g, T: np.maximum(g["e_max"], -g["e_min"]))
    monkeypatch.setattr(_metrics, "METRICS", (*_metrics.METRICS, extra))
    d = fl.Design(estimator=fl.EHGO(rho=2, eps=0.02, T=T),
                  controller=fl.DynamicController((2, 4), 1e-2))
    resp = fl.simulate(fl.plants.pendulum(), d, fl.Scenario(0.1, 1.0))
    assert resp.metrics["peak_error"] == pytest.approx(np.max(np.abs(resp.y - resp.r)), rel=1e-12)
    smap = fl.sweep(fl.plants.pendulum(), d, fl.Scenario(0.1, 1.0), eps=[0.02], gamma=[1e-2],
                    progress=False, kernel=fl.Kernel(compiled=False))
    assert smap.metrics["peak_error"][0, 0] == pytest.approx(resp.metrics["peak_error"], rel=1e-12)


def test_cvodes_failure_on_a_bounded_state_is_a_solver_failure(pendulum, pendulum_design):
    """A solver that gives up is not a verdict on the loop: status 'solver_failed'."""
    resp = fl.simulate(pendulum, pendulum_design(), fl.Scenario(0.1, 0.05),
                       integrator=fl.Cvodes(max_num_steps=1))
    assert resp.status == "solver_failed" and not resp.diverged and not resp.stable


def test_verdicts_say_what_they_mean(pendulum):
    """Converging (shrinking, not yet in tolerance), oscillating (limit cycle), region exit."""
    from tests.oracles import status_from_trajectories

    slow = fl.presets.pendulum_design(gamma=3e-3)         # slow but convergent
    resp = fl.simulate(pendulum, slow, fl.Scenario(0.1, 6.0))
    assert resp.status == "converging" == status_from_trajectories(resp)
    longer = fl.simulate(pendulum, slow, fl.Scenario(0.1, 2 * resp.time_to_tolerance))
    assert longer.status == "converged"
    # the envelope's exponential extrapolation predicts the settling time
    assert longer.settling_time == pytest.approx(resp.time_to_tolerance, rel=0.15)
    assert resp.verdict().startswith("converging: |e| = 0.0262 > 0.002 at the end, envelope "
                                     "-53 % over the last 3 s (time constant 3.47 s")
    assert resp.metrics["decay_rate"] == pytest.approx(1 / 3.47, rel=0.01)
    # saturated input + an unstable eps: a bounded limit cycle, not 'diverged'
    cyc = fl.simulate(pendulum, fl.presets.pendulum_design(eps=0.2, u_limits=(-1.2, 1.2)),
                      fl.Scenario(0.05, 30.0))
    assert cyc.status == "oscillating" == status_from_trajectories(cyc) and cyc.bounded
    assert cyc.tail_amplitude > cyc.tol
    assert cyc.verdict().startswith("oscillating: 24 reversals, swings of 0.178 peak-to-peak "
                                    "(band 0.001), period 1.23 s")
    assert "u at its limits 70 % of the time" in cyc.verdict()
    u = cyc.u[cyc.t.size // 2:]
    assert cyc.metrics["saturated_fraction"] == pytest.approx(np.mean(np.abs(u) >= 1.2), abs=1e-3)


def test_wrong_typed_plant_or_design_is_a_clear_error(pendulum, pendulum_design):
    with pytest.raises(ParameterError, match="plant must be a fl.Plant.*got str 'x'"):
        fl.simulate("x", pendulum_design(), fl.Scenario(0.1, 0.1))
    with pytest.raises(ParameterError, match="design must be a fl.Design"):
        fl.sweep(pendulum, fl.EHGO(2, 0.05, 1e-3), fl.Scenario(0.1, 0.1), eps=[0.1],
                 gamma=[1e-2], progress=False)


def test_a_mode_slower_than_the_run_is_undecided_a_limit_cycle_oscillates():
    """TRMS, the paper's design, 30 s: the error drifts away (+28 % over the last 15 s, its
    slowest linearized mode, ~2000 s, is far slower than the run) without a swing: 'undecided',
    and the verdict says what decides. A real limit cycle (eps = 0.5, gamma = 0.03) swings:
    'oscillating'. The tail numbers are recomputed from the recorded output and the status from
    the whole record (:func:`tests.oracles.status_from_trajectories`)."""
    from tests.oracles import status_from_trajectories

    plant, design = fl.plants.trms_yaw(), fl.presets.paper_design()
    slow = fl.simulate(plant, design, fl.Scenario(0.3, 30.0))
    cycle = fl.simulate(plant, design.replace(eps=0.5, gamma=0.03), fl.Scenario(0.3, 30.0))
    for resp in (slow, cycle):
        e = resp.r[resp.k_tail:] - resp.y[resp.k_tail:]
        assert resp.tail_error == pytest.approx(np.max(np.abs(e)), rel=1e-12)
        assert resp.tail_amplitude == pytest.approx(np.ptp(e), rel=1e-12)
        assert resp.status == status_from_trajectories(resp)
        assert resp.bounded and not resp.stable
    assert slow.status == "undecided"
    assert slow.verdict().startswith("undecided: |e| = 0.0208 > 0.006, envelope +28 % over the "
                                     "last 15 s without a full swing (0 reversals;")
    assert "a run of 90 s or more decides" in slow.verdict()
    e = cycle.r[cycle.k_tail:] - cycle.y[cycle.k_tail:]
    assert np.min(e) < 0 < np.max(e)  # swings through the reference
    assert cycle.status == "oscillating" and cycle.metrics["reversals"] >= 2


def test_converging_inside_the_band_says_so_and_forecasts_the_swings():
    """A loop inside the band whose swings still exceed the tolerance is ``converging``; its
    reason says it is inside the band (not "|e| > band") and when the swings will be small
    enough, and a run twice that long is ``converged``."""
    import re

    plant, design = fl.plants.trms_yaw(), fl.presets.paper_design()
    short = fl.simulate(plant, design, fl.Scenario(0.3, 400.0))
    text = short.verdict()
    assert short.status == "converging"
    assert short.metrics["tail_error"] <= short.tol  # inside the band: the swings decide
    assert text.startswith("converging: inside the band at the end (|e| <= 0.00427 <= 0.006) "
                           "but still swinging 0.00765 peak-to-peak (more than 0.006)")
    when = float(re.search(r"swings within 0.006 peak-to-peak at about t = ([0-9.]+) s", text)[1])
    assert when > 400.0 and "(beyond this run)" in text
    long = fl.simulate(plant, design, fl.Scenario(0.3, 2 * when))
    assert long.status == "converged"
