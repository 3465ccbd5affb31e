"""The float step's observer about the last sample, as a recursion (``_float_realize``): the
same observer as the EHGO in double, and where the float error of the rho = 4 step came from."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

import fl_design as fl
from fl_design import presets
from fl_design.codegen import step_design
from fl_design.codegen._float_check import emulate
from fl_design.codegen._float_realize import LevelFreeEHGO, design_states, level_free
from fl_design.codegen._graph import parameter_fields, parametric_core
from fl_design.codegen._guard import guard_settings
from fl_design.codegen._vectors import vector_record

F = np.float32


def _random_record(seed, n=600, level=0.3):
    rng = np.random.default_rng(seed)
    y = level + np.cumsum(rng.normal(0.0, 2e-3, n))
    r = np.where(np.arange(n) < n // 2, level, level + 0.05)
    return y, r


@pytest.mark.parametrize("rho", [1, 2, 4, 5])
@pytest.mark.parametrize("method", ["bilinear", "backward_euler", "forward_euler", "zoh"])
def test_same_observer_as_the_ehgo_in_double(rho, method):
    """Against the user's EHGO in its direct realization (A_d, B_d, C_d, D_d): the same inputs,
    estimates and, mapped back, states on a random record (the recursion where it applies,
    the matrix form for ZOH)."""
    eps, T = 0.02, 1e-3
    obs = fl.EHGO(rho, eps, T, method=method)
    ctrl = fl.DynamicController(tuple(fl.gains_from_poles([-3.0] * rho)), 1e-3,
                                u_limits=(-50.0, 50.0))
    user = fl.Design(estimator=obs, controller=ctrl)
    lf = level_free(user)
    assert isinstance(lf.estimator, LevelFreeEHGO)
    assert (lf.estimator.recursion() is None) == (method == "zoh")
    y, r = _random_record(rho)
    ref = user.run(y, r, state0=user.initial_state(y0=y[0]))
    got = lf.run(y, r, state0=lf.initial_state(y0=y[0]))
    scale = np.max(np.abs(ref.u))
    assert np.max(np.abs(got.u - ref.u)) <= 1e-9 * scale
    for i in range(rho):
        peak = np.max(np.abs(ref.xhat[:, i])) + 1e-12
        assert np.max(np.abs(got.xhat[:, i] - ref.xhat[:, i])) <= 1e-8 * peak
    back = design_states(lf, got.state)
    assert back.shape == ref.state.shape
    peak = np.max(np.abs(ref.state), axis=0) + 1e-12
    assert np.all(np.max(np.abs(back - ref.state), axis=0) <= 1e-8 * peak)


def test_start_from_an_estimate_is_the_ehgo_start():
    obs = fl.EHGO(3, 0.05, 1e-3, realization="delta")
    lf = LevelFreeEHGO(3, 0.05, 1e-3, realization="delta")
    est = [0.2, -1.0, 3.0, 40.0]
    for y0 in (None, 0.25):
        xi, s = obs.initial_state(y0=y0, estimate=est), lf.initial_state(y0=y0, estimate=est)
        assert s.size == lf.state_size == 5
        np.testing.assert_allclose(s[0] + s[-1], xi[0], rtol=0, atol=1e-15)
        np.testing.assert_array_equal(s[1:-1], xi[1:])
        f = lambda e, x: ca.Function("f", [], [e.symbolic_update(x, 0.25,
                                                                 e.parameter_vector())[0]])()
        np.testing.assert_allclose(np.asarray(f(lf, ca.DM(s))["o0"]).ravel(),
                                   np.asarray(f(obs, ca.DM(xi))["o0"]).ravel(), rtol=1e-12,
                                   atol=1e-9)


def test_no_stored_value_carries_the_level():
    """The state's entries read back by the next innovation are the innovation and the scaled
    derivatives, not the level: at rest at y0 every entry but y_last is exactly 0."""
    d = step_design(presets.flexible_joint_design(), "float")
    s = d.initial_state(y0=0.6, u0=0.0)
    n = d.rho + 1
    assert s[n] == 0.6 and not np.any(s[:n])
    p = [f.value for f in parameter_fields(d)]
    x_next = np.asarray(parametric_core(d)(s, 0.6, 0.6, p)[0]).ravel()
    assert not np.any(x_next[:n]) and x_next[n] == 0.6


def _vector_dev(design, plain, guard):
    """Emulated float deviation from Design.step (double) on the vector record, of the level-free
    step ``design`` and of the plain delta step ``plain`` (same record, same float inputs)."""
    y, r = vector_record(guard.y_min, guard.y_max, 1500)
    y, r = y.astype(F).astype(float), r.astype(F).astype(float)
    out = []
    for d in (design, plain):
        ref = d.run(y, r, state0=d.initial_state(y0=y[0], u0=guard.u_op)).u
        u32 = emulate(d, y, r, np.asarray(d.initial_state(y0=0.0, u0=guard.u_op), F),
                      y_c=float(y[0])).astype(float)
        out.append(float(np.max(np.abs(u32 - ref)) / np.max(np.abs(ref))))
    return out


def _cases():
    from .test_faults_unseen import CASES

    yield "flexible_joint", presets.flexible_joint_design(), fl.plants.flexible_joint()
    yield "trms", presets.paper_design(), fl.plants.trms_yaw()
    yield "maglev", presets.maglev_design(), fl.plants.maglev()
    for name in ("pendulum", "heater", "chain3"):
        design, plant, _, _ = CASES[name]()
        yield name, design, plant


@pytest.mark.parametrize("name,user,plant", list(_cases()), ids=lambda v: v if isinstance(
    v, str) else "")
def test_float_error_on_the_vectors_is_within_the_bound_and_no_worse(name, user, plant):
    """The float step's own deviation on its test-vector record: within the float bound and no
    larger than the plain delta realization's (the flexible joint: 4.5e-4 before, the level's
    rounding read back by the innovation and amplified by ~1/eps^4)."""
    from fl_design.codegen._compare import FLOAT_BOUND

    used = step_design(user, "float")
    est = user.estimator
    plain = fl.Design(estimator=est.replace(realization="delta"), controller=user.controller)
    lf, pl = _vector_dev(used, plain, guard_settings(used, plant))
    assert lf < FLOAT_BOUND, (name, lf, pl)
    assert lf <= pl, (name, lf, pl)


def test_the_flexible_joint_meets_the_bound_it_missed():
    """The plain delta step of the flexible joint misses the float bound on its vectors (the
    rounding of its level state, 5.1e-4 by per-operation attribution: _float_realize's
    docstring); the level-free recursion is more than ten times within it."""
    from fl_design.codegen._compare import FLOAT_BOUND

    user, plant = presets.flexible_joint_design(), fl.plants.flexible_joint()
    plain = fl.Design(estimator=user.estimator.replace(realization="delta"),
                      controller=user.controller)
    guard = guard_settings(plain, plant)
    lf, pl = _vector_dev(step_design(user, "float"), plain, guard)
    assert pl > FLOAT_BOUND > 10 * lf


@pytest.mark.slow
def test_compiled_flexible_joint_is_the_emulation_bit_for_bit(tmp_path):
    """The generated float C of the flexible joint (the level-free recursion) against the
    emulation behind the prediction, started away from 0 and crossing it."""
    from fl_design._toolchain import find_compiler
    from fl_design.codegen import generate_c

    if find_compiler() is None:
        pytest.skip("no C compiler installed")
    pkg = generate_c(presets.flexible_joint_design(), tmp_path, precision="float",
                     plant=fl.plants.flexible_joint())
    k = np.arange(2000)
    y = 0.4 - 0.6 * (1 - np.exp(-k / 300.0)) + 1e-3 * np.sin(k / 37.0)
    r = np.full(k.size, -0.2)
    u_c = pkg.run(y, r, start=True)
    used = pkg.step_design
    u_e = emulate(used, y, r, used.initial_state(y0=0.0, u0=pkg.guard.u_op), y_c=float(y[0]))
    np.testing.assert_array_equal(u_c, u_e.astype(float))


def test_the_error_budget_of_the_flexible_joints_closed_loop():
    """On a closed-loop record of the flexible joint the float step's own arithmetic is within
    the bound; what is left of the predicted error is the measurement's rounding to float
    (Design.step fed float y against fed double y), which no realization of the step changes."""
    from fl_design.codegen._compare import FLOAT_BOUND, recorded_run, reference_inputs
    from fl_design.codegen._float_check import float_error_budget, predict_float_error

    user, plant, sc = presets.flexible_joint_design(), fl.plants.flexible_joint(), \
        fl.Scenario(0.05, 1.5)
    b = float_error_budget(user, plant, sc)
    assert b["total"] == predict_float_error(user, plant, sc)
    assert b["total"] <= b["arithmetic"] + b["measurement"] * (1 + 1e-9)
    assert b["arithmetic"] < FLOAT_BOUND
    # the measurement's part, computed independently with the user's own design (direct)
    ym, r, u0 = recorded_run(plant, user, sc)
    ref = reference_inputs(user, ym, r, u0)
    ref32 = reference_inputs(user, ym.astype(F).astype(float), r.astype(F).astype(float), u0)
    meas = float(np.max(np.abs(ref32 - ref)) / np.max(np.abs(ref)))
    assert b["measurement"] == pytest.approx(meas, rel=1e-3)
