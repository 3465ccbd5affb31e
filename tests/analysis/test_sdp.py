"""The margin SDPs handed to Clarabel directly (:mod:`fl_design.analysis._sdp`), against the
same programs written in CVXPY (its own canonicalization, independent of ours)."""

import cvxpy as cp
import numpy as np
import pytest

from fl_design.analysis import _lmi
from fl_design.analysis._sdp import max_margin, svec, sym_basis


def test_svec_is_an_isometry_in_clarabels_order():
    rng = np.random.default_rng(0)
    M = rng.normal(size=(5, 5))
    M = M + M.T
    v = svec(M)
    assert np.isclose(np.linalg.norm(v), np.linalg.norm(M, "fro"))
    # upper triangle by columns: (0,0), (0,1), (1,1), (0,2), ...
    assert v[:4].tolist() == [M[0, 0], np.sqrt(2) * M[0, 1], M[1, 1], np.sqrt(2) * M[0, 2]]


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_max_margin_matches_cvxpy_on_random_lmis(seed):
    rng = np.random.default_rng(seed)
    nvar, d = 4, 5
    F0 = rng.normal(size=(d, d))
    F0 = F0 @ F0.T + np.eye(d)
    Fi = rng.normal(size=(nvar, d, d))
    Fi = Fi + np.swapaxes(Fi, 1, 2)
    G0 = np.eye(3)
    Gi = rng.normal(size=(nvar, 3, 3))
    Gi = 0.1 * (Gi + np.swapaxes(Gi, 1, 2))
    r = max_margin([(F0, Fi, True), (G0, Gi, False)], nvar)
    x, eta = cp.Variable(nvar), cp.Variable()
    F = F0 + sum(x[i] * Fi[i] for i in range(nvar))
    G = G0 + sum(x[i] * Gi[i] for i in range(nvar))
    prob = cp.Problem(cp.Maximize(eta), [(F + F.T) / 2 >> eta * np.eye(d),
                                         (G + G.T) / 2 >> 0, eta <= 1])
    prob.solve(solver=cp.CLARABEL)
    assert r.status == "optimal"
    assert abs(r.eta - eta.value) <= 1e-6 * max(1.0, abs(eta.value))
    # the point returned satisfies its constraints (eigenvalues, not the solver's word)
    Fx = F0 + np.tensordot(r.x, Fi, axes=1)
    Gx = G0 + np.tensordot(r.x, Gi, axes=1)
    assert np.linalg.eigvalsh(Fx)[0] >= r.eta - 1e-6
    assert np.linalg.eigvalsh(Gx)[0] >= -1e-7


@pytest.mark.parametrize(("common", "reduced"), [(True, False), (True, True), (False, False)])
def test_vertex_lmi_direct_matches_the_cvxpy_program(common, reduced):
    """The vertex LMI solved directly (2n forms; the n x n common form on request) reaches the
    margin of :func:`_lmi._problem`, the CVXPY program it replaces, and is re-checked."""
    T = 1e-3
    A = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-6.0, -11.0, -6.0]])
    B = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [-1.0, -0.5, 0.0]])
    deltas = [(np.linalg.matrix_power(np.eye(3) + T * (A + b * B) / 10, 10) - np.eye(3)) / T
              for b in (0.0, 2.0)]
    kappa = 0.1 if common else 0.0
    sol = _lmi.vertex_lmi(deltas, T, common=common, fallback=False, reduced=reduced,
                          kappa=kappa)
    assert sol.certified and sol.solver == "CLARABEL"
    assert _lmi.recheck(sol.P, sol.G, deltas, T, kappa) == pytest.approx(sol.margin)
    problem, D, kap, _, _, eta = _lmi._problem(3, 2, T, common)
    for par, Dv in zip(D, deltas):
        par.value = Dv
    kap.value = kappa
    problem.solve(solver=cp.CLARABEL)
    eta_direct = _lmi._solve_direct(deltas, T, common, kappa, reduced)[3]
    if reduced:  # the n x n form's margin is the Schur complement's: at least the 2n one's
        assert eta_direct >= eta.value - 1e-6
    else:
        assert eta_direct == pytest.approx(eta.value, rel=1e-5, abs=1e-8)


def test_max_margin_reports_a_failure_as_a_status():
    F0 = np.full((2, 2), np.nan)
    r = max_margin([(F0, np.zeros((1, 2, 2)), True)], 1)
    assert r.x is None and r.eta is None and r.status != "optimal"


def test_an_iteration_limit_returns_the_iterate_for_the_recheck(monkeypatch):
    """As through CVXPY: Clarabel stopped by its iteration limit gives its iterate
    (``user_limit``), which only the caller's NumPy re-check can accept."""
    import clarabel

    base = clarabel.DefaultSettings

    def one_iteration():
        s = base()
        s.max_iter = 1
        return s

    monkeypatch.setattr(clarabel, "DefaultSettings", one_iteration)
    F0 = np.array([[1.0, 0.5], [0.5, 1.0]])
    r = max_margin([(F0, np.array([[[1.0, 0.0], [0.0, -1.0]]]), True)], 1)
    assert r.status == "user_limit" and r.iterations == 1
    assert r.x is not None and np.isfinite(r.eta)


@pytest.mark.parametrize("seed", [4, 5])
def test_min_linear_gives_the_lyapunov_solution_and_cvxpys_optimum(seed):
    """min trace(P) s.t. A^T P + P A + Q <= 0 (A Hurwitz) is the Lyapunov equation's solution
    (SciPy); the same program in CVXPY reaches the same trace."""
    import scipy.linalg

    from fl_design.analysis._sdp import min_linear

    rng = np.random.default_rng(seed)
    n = 4
    A = rng.normal(size=(n, n))
    A -= (np.max(np.linalg.eigvals(A).real) + 0.5) * np.eye(n)  # Hurwitz
    Q = np.diag(rng.uniform(0.5, 2.0, n))
    B = sym_basis(n)
    BA = B @ A
    r = min_linear(np.trace(B, axis1=1, axis2=2), [(-Q, -(BA + np.swapaxes(BA, 1, 2)))],
                   B.shape[0])
    P = np.tensordot(r.x, B, axes=1)
    want = scipy.linalg.solve_continuous_lyapunov(A.T, -Q)
    assert r.status == "optimal" and r.eta is None
    assert np.allclose(P, want, rtol=1e-5, atol=1e-6 * np.abs(want).max())
    X = cp.Variable((n, n), symmetric=True)
    cp.Problem(cp.Minimize(cp.trace(X)), [A.T @ X + X @ A + Q << 0]).solve(solver=cp.CLARABEL)
    assert np.trace(P) == pytest.approx(np.trace(X.value), rel=1e-6)


def test_min_linear_reports_an_infeasible_program():
    from fl_design.analysis._sdp import min_linear

    # x <= -1 and x >= 1: infeasible, a status (no exception, no x)
    r = min_linear([1.0], [(np.array([[-1.0]]), -np.ones((1, 1, 1))),
                           (np.array([[-1.0]]), np.ones((1, 1, 1)))], 1)
    assert r.x is None and r.status.startswith("infeasible")
