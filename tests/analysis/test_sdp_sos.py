"""The quartic SOS program handed to Clarabel directly against CVXPY's and closed forms."""

from __future__ import annotations

import numpy as np
import pytest

from fl_design.analysis._sdp import svec
from fl_design.analysis._sdp_sos import lyapunov_columns, solve_sos
from fl_design.analysis._sos import gram_slack_basis, lift_delta, sos_lyapunov
from fl_design.errors import ParameterError


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_lyapunov_columns_are_the_map_on_svec(seed):
    """``C svec Q == svec(-(E^T Q + Q E) - T E^T Q E)`` for random symmetric ``Q``."""
    rng = np.random.default_rng(seed)
    m = 6
    E = rng.normal(size=(m, m))
    T = float(rng.uniform(1e-4, 1e-1))
    C = lyapunov_columns(E, T)
    for _ in range(3):
        Q = rng.normal(size=(m, m))
        Q = Q + Q.T
        R = -(E.T @ Q + Q @ E) - T * (E.T @ Q @ E)
        np.testing.assert_allclose(C @ svec(Q), svec(R), rtol=1e-12, atol=1e-12)


def _pair(rng, n, spread):
    """Two Hurwitz matrices ``A - (spread + max Re) I`` around one random ``A``."""
    A = rng.normal(size=(n, n))
    out = []
    for _ in range(2):
        X = A + 0.6 * rng.normal(size=(n, n))
        shift = max(np.linalg.eigvals(X).real) + spread
        out.append(X - shift * np.eye(n))
    return out


@pytest.mark.parametrize("seed", range(4))
def test_direct_optimum_matches_cvxpy_on_random_instances(seed):
    """The largest margin ``eta`` of the same program: Clarabel directly vs through CVXPY."""
    rng = np.random.default_rng(100 + seed)
    n = 2 + seed % 2
    T = 1e-2
    deltas = _pair(rng, n, float(rng.uniform(-0.05, 0.3)))
    Es = [lift_delta(D, T) for D in deltas]
    direct = solve_sos(Es, T, gram_slack_basis(n))
    from fl_design.analysis._sos import _solve_cvxpy

    status, eta, Q, _ = _solve_cvxpy(Es, T, n)
    assert direct.status == "optimal" and status == "optimal"
    assert abs(direct.eta - eta) <= 1e-6 * max(1.0, abs(eta)), (direct.eta, eta)
    # the direct solution satisfies its own constraints (trace, PSD within the solver's tol)
    assert abs(np.trace(direct.Q) - Q.shape[0]) < 1e-6
    assert np.linalg.eigvalsh(direct.Q)[0] >= direct.eta - 1e-6


@pytest.mark.parametrize("seed", range(3))
def test_both_backends_give_the_same_verdict(seed):
    rng = np.random.default_rng(200 + seed)
    deltas = _pair(rng, 2, float(rng.uniform(-0.1, 0.3)))
    a = sos_lyapunov(deltas, 1e-2)
    b = sos_lyapunov(deltas, 1e-2, backend="cvxpy")
    if a.margin is not None and b.margin is not None and min(a.margin, b.margin) > 1e-8:
        assert a.certified and b.certified
    if a.certified:  # a certificate is its own re-check, whichever backend found it
        assert a.margin > 1e-11 and "re-checked in NumPy" in a.note


def test_unknown_backend_is_refused():
    with pytest.raises(ParameterError, match="backend must be 'clarabel' or 'cvxpy'"):
        sos_lyapunov([np.array([[-1.0]])], 1e-3, backend="scs")


def test_slope_is_the_derivative_of_the_margin():
    """``slope`` (duals, envelope theorem) against a central difference of ``eta``."""
    rng = np.random.default_rng(5)
    T = 1e-2
    A = [np.array([[-0.4, 1.0], [-1.0, -0.4]]), np.array([[-0.4, 1.0], [-4.0, -0.4]])]
    dA = [0.1 * rng.normal(size=(2, 2)) for _ in A]
    s0 = sos_lyapunov(A, T, tangents=dA)
    h = 1e-5
    up = sos_lyapunov([a + h * d for a, d in zip(A, dA)], T)
    down = sos_lyapunov([a - h * d for a, d in zip(A, dA)], T)
    fd = (up.eta - down.eta) / (2 * h)
    assert s0.certified and abs(s0.slope - fd) <= 1e-3 * abs(fd) + 1e-6, (s0.slope, fd)
    assert sos_lyapunov(A, T).slope is None  # no tangents: no slope
