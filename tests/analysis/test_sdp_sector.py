"""The step certificate's conic programs handed to Clarabel directly
(:mod:`fl_design.analysis._sdp_sector`), against the same programs written in CVXPY (its own
canonicalization, independent of ours), and the shortcuts of :func:`fl_design.certify_step`
against its slow path (issue 33)."""

from __future__ import annotations

import math

import cvxpy as cp
import numpy as np
import pytest
import scipy.linalg

import fl_design as fl
from fl_design.analysis import _sector, _step_cert
from fl_design.analysis._sdp_sector import ellipsoid_program, solve_conic, start_program


def _sym(rng, k, d):
    F = rng.normal(size=(k, d, d))
    return F + np.swapaxes(F, -1, -2)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_solve_conic_matches_cvxpy_on_random_programs(seed):
    rng = np.random.default_rng(seed)
    nv, d = 4, 4
    F0, Fi = np.eye(d) * 3.0, 0.3 * _sym(rng, nv, d)
    A, b = rng.normal(size=(3, nv)), rng.normal(size=3)
    c = rng.normal(size=nv)
    # PSD block, ||A x + b|| <= 5, -1 <= x <= 1, x_0 + x_1 = 0.1
    soc = np.hstack([np.zeros((nv, 1)), A.T])
    blocks = [("psd", F0, Fi), ("soc", np.concatenate([[5.0], b]), soc),
              ("nonneg", np.ones(nv), np.eye(nv)), ("nonneg", np.ones(nv), -np.eye(nv)),
              ("zero", np.array([-0.1]), np.array([[1.0], [1.0], [0.0], [0.0]]))]
    r = solve_conic(c, blocks)
    x = cp.Variable(nv)
    F = F0 + sum(x[i] * Fi[i] for i in range(nv))
    prob = cp.Problem(cp.Minimize(c @ x), [(F + F.T) / 2 >> 0, cp.norm(A @ x + b) <= 5.0,
                                          cp.abs(x) <= 1, x[0] + x[1] == 0.1])
    prob.solve(solver=cp.CLARABEL)
    assert r.status == "optimal" and prob.status == "optimal"
    assert math.isclose(r.eta, prob.value, rel_tol=1e-6, abs_tol=1e-7)
    np.testing.assert_allclose(r.x, x.value, atol=1e-5)


def test_solve_conic_says_infeasible_and_refuses_a_bad_block():
    # x >= 1 and x <= 0
    r = solve_conic(np.zeros(1), [("nonneg", np.array([-1.0]), np.ones((1, 1))),
                                  ("nonneg", np.array([0.0]), -np.ones((1, 1)))])
    assert r.status == "infeasible" and r.x is None
    with pytest.raises(ValueError, match="one of"):
        solve_conic(np.zeros(1), [("cone", np.zeros(1), np.ones((1, 1)))])


def _cvxpy_ellipsoid(ch, Pt, Kt, kappa, nbar):
    """The multipliers' SDP of the _sector docstring written in CVXPY (the program the step
    certificate solved before it went to Clarabel directly)."""
    T, n, m = ch.T, Pt["n"], ch.K.shape[0]
    s, Z, mu = cp.Variable(m), cp.Variable((m, n)), cp.Variable(nonneg=True)
    beta = cp.Parameter(nonneg=True)
    cons = [s >= 1e-6]
    for v in range(ch.Ms.shape[0]):
        D, B, E = Pt["D"][v], Pt["B"][v], Pt["E"][v]
        Rn = np.hstack([D, B] + ([E] if nbar > 0 else []))
        blocks = [[D + D.T + 2 * kappa * np.eye(n), B + Z.T],
                  [B.T + Z, cp.diag(s) @ ch.H + ch.H.T @ cp.diag(s) - 1.9 * cp.diag(s)]]
        if nbar > 0:
            blocks[0].append(E)
            blocks[1].append(np.zeros((m, 1)))
            blocks.append([E.T, np.zeros((1, m)), -cp.reshape(mu, (1, 1), order="C") / 1.1])
        A = cp.bmat(blocks) + T * (Rn.T @ Rn)
        cons.append((A + A.T) / 2 << -1e-7 * np.eye(Rn.shape[1]))
    for j in range(m):
        lim = ch.room[j] - abs(ch.kn[j]) * nbar
        cons.append(cp.norm(s[j] * Kt[j] - Z[j]) <= lim * (1 - 1e-6) * (beta * s[j]))
    cons.append(mu * nbar ** 2 * beta ** 2 <= kappa * (1 - 1e-6) if nbar > 0 else mu == 0)
    prob = cp.Problem(cp.Minimize(0), cons)

    def feasible(b):
        beta.value = b
        prob.solve(solver=cp.CLARABEL)
        return prob.status == "optimal"
    return feasible


@pytest.mark.parametrize("nbar", [0.0, 1e-4])
def test_ellipsoid_program_agrees_with_cvxpy_about_the_certified_level(nbar):
    design = fl.presets.paper_design()
    cls = fl.PlantClass.chain(2, b=(3.6, 6.8), T=1e-3)
    c = fl.certify_step(cls, design, fl.Scenario(0.3))
    ch = _sector.loop_channels(design, (3.6, 6.8), None)
    n, T = c.P.shape[0], ch.T
    Lc = np.linalg.cholesky(c.P)
    Li = scipy.linalg.solve_triangular(Lc, np.eye(n), lower=True)
    Pt = {"n": n, "D": [Lc.T @ ((M - np.eye(n)) / T) @ Li.T for M in ch.Ms],
          "B": [Lc.T @ B / T for B in ch.Bs], "E": [Lc.T @ E[:, None] / T for E in ch.Es]}
    Kt = ch.K @ Li.T
    q = _step_cert._contraction(ch, c.P)
    kappa = 0.25 * (1.0 - q * q) / T  # the decay certify_step asks of this P
    ours, theirs = ellipsoid_program(ch, Pt, Kt, kappa, nbar), _cvxpy_ellipsoid(
        ch, Pt, Kt, kappa, nbar)
    seen = []
    for factor in (1e-3, 0.25, 64.0):  # inside, and far beyond, the certified level
        b = (factor * c.level) ** -0.5
        got = ours(b)
        assert (got is not None) == theirs(b)
        seen.append(got is not None)
        if got is not None:  # the multipliers pass the NumPy re-check of _sector
            s, Zt, mu = got
            E = _sector.Ellipsoid(c.P, factor * c.level, kappa, mu, nbar, 0.0)
            worst, _ = _sector.recheck(ch, E, np.diag(s), Zt @ Lc.T, {}, np.zeros(n))
            assert worst < 0.0
    # without noise every level below the certified one holds; with it, the small ones do
    # not (mu nbar^2 <= kappa level): the certified levels are a band
    assert seen == ([True, True, False] if nbar == 0 else [False, seen[1], False])


@pytest.mark.filterwarnings("ignore:Solution may be inaccurate")
def test_start_program_matches_cvxpy_on_a_small_lmi():
    rng = np.random.default_rng(4)
    n, T, k = 3, 1e-3, 0.05
    W = [rng.normal(size=(n, n)) for _ in range(3)]
    Db = [-np.eye(n) + 0.5 * (w - w.T) + 0.1 * w for w in W]  # a common P exists (near I)
    rows = [(rng.normal(size=n), 1.0 + rng.random()) for _ in range(3)]
    x0 = rng.normal(size=n)
    P_ours = start_program(Db, T, k, rows, x0)
    P = cp.Variable((n, n), symmetric=True)
    cons = []
    for D in Db:
        S = cp.bmat([[-(P @ D + D.T @ P) - 2 * k * P, math.sqrt(T) * D.T @ P],
                     [math.sqrt(T) * P @ D, P]])
        cons.append((S + S.T) / 2 >> 0)
    for c, r in rows:
        cw = c.reshape(n, 1)
        B = cp.bmat([[P, cw], [cw.T, np.array([[r * r]])]])
        cons.append((B + B.T) / 2 >> 0)
    prob = cp.Problem(cp.Minimize(cp.quad_form(x0, P)), cons)
    prob.solve(solver=cp.CLARABEL)
    # the minimizers are not unique (P may grow where x0 does not look): the optimal values
    # agree, both solvers stop near them
    assert prob.status in ("optimal", "optimal_inaccurate")
    assert math.isclose(float(x0 @ P_ours @ x0), prob.value, rel_tol=1e-5)
    assert np.linalg.eigvalsh(P_ours)[0] > 0


def test_level_cap_bounds_every_level_solve_ellipsoid_returns():
    design = fl.presets.pendulum_design()
    plant = fl.plants.pendulum()
    c = fl.certify_step(plant, design, fl.Scenario(0.1))
    eq = plant.equilibrium(y=0.1)
    (_, b, box, ueq, rooms, _), = _step_cert._plant_tries(
        plant, design, np.asarray(eq.x, float), float(eq.u), [(1.0, 1.0)])
    ch = _sector.loop_channels(design, b, box, u_eq=ueq)
    X0 = np.zeros(c.P.shape[0])
    X0[0] = -0.1
    q = _step_cert._contraction(ch, c.P)
    kappa = 0.25 * (1.0 - q * q) / design.T
    cap = _sector.level_cap(ch, c.P, rooms=rooms)
    E, ratio, _ = _sector.solve_ellipsoid(ch, c.P, X0, kappa=kappa, rooms=rooms)
    assert E is not None and E.level <= cap
    assert ratio >= float(X0 @ c.P @ X0) / cap  # the lower bound certify_step uses


def test_passing_over_the_ldi_p_gives_the_slow_paths_certificate(monkeypatch):
    """The pendulum's start: the LDI certificate's P cannot beat the start-covering one (its
    level cap shows it): the certificate is the one both P solved give, with fewer SDPs."""
    from fl_design.analysis._lmi import solve_count

    plant, design, sc = fl.plants.pendulum(), fl.presets.pendulum_design(), fl.Scenario(0.1)
    n0 = solve_count()
    fast = fl.certify_step(plant, design, sc)
    n_fast = solve_count() - n0
    monkeypatch.setattr(_sector, "level_cap", lambda *a, **k: math.inf)  # never passed over
    n0 = solve_count()
    slow = fl.certify_step(plant, design, sc)
    n_slow = solve_count() - n0
    assert n_fast < n_slow
    assert (fast.certified, fast.region_scale) == (slow.certified, slow.region_scale)
    assert fast.largest_step == slow.largest_step and fast.level == slow.level
    np.testing.assert_array_equal(fast.P, slow.P)


def test_direct_solves_are_counted_and_reported_after_the_solve():
    from fl_design.analysis._lmi import solve_count, solve_progress

    seen, n0 = [], solve_count()
    with solve_progress(lambda: seen.append(solve_count()), every=0.0):
        r = solve_conic(np.array([1.0]), [("nonneg", np.array([-2.0]), np.ones((1, 1)))])
    assert r.status == "optimal" and math.isclose(float(r.x[0]), 2.0, rel_tol=1e-7)
    assert solve_count() - n0 == 1 and seen == [n0 + 1]
