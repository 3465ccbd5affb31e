"""Quartic SOS Lyapunov function of a switched linear loop (delta form), re-checked in NumPy.

For ``X_(k+1) = M_(s_k) X_k`` (``s_k`` any vertex, any sequence) a homogeneous quartic
``V(x) = z(x)^T Q z(x)``, ``z(x) = (x_i x_j)_(i <= j)`` the quadratic monomials and ``Q``
positive definite, is a Lyapunov function when ``V(M_v x) < V(x)`` for every vertex ``v``. The
monomials of ``M x`` are linear in those of ``x``: ``z(M x) = L(M) z(x)`` with ``L(M)`` the
second symmetric power of ``M`` (:func:`lift`), so

    V(x) - V(M_v x) = z^T (Q - L_v^T Q L_v) z.

A polynomial has many Gram matrices: ``z^T (Q - L_v^T Q L_v + T N_v) z`` is the same
polynomial for every ``N_v`` with ``z^T N_v z == 0`` (:func:`gram_slack_basis`), and the
condition is a semidefinite program in ``(Q, N_v)``: a real sum-of-squares program, strictly
stronger than a common quadratic ``P`` on the lift (``N_v = 0``), and than a common ``P`` on
``x`` (``Q = P (x) P`` restricted). With ``M = I + T Delta`` the lift is ``L = I + T E``,
``E = 2 S(I, Delta) + T S(Delta, Delta)`` (``S`` the polarized lift), and dividing by ``T``
as in :mod:`._lmi` (Schur complement, ``Q > 0``)::

    [[-(E^T Q + Q E) + N_v,  sqrt(T) E^T Q], [sqrt(T) Q E,  Q]] > 0

which is of order one at ``T = 1 ms``. Every term of ``T`` is kept: it is the exact discrete
condition, not a continuous-time approximation. ``E^T Q E`` is linear in ``Q``: the program
solved is ``R_v = -(E_v^T Q + Q E_v) - T E_v^T Q E_v + N_v > 0`` itself, assembled in NumPy
and handed to Clarabel directly (:mod:`._sdp_sos`; CVXPY as ``backend="cvxpy"``).

What a certificate proves: the NumPy re-check (:func:`recheck_sos`) finds ``Q`` and each
``R_v = -(E_v^T Q + Q E_v) - T E_v^T Q E_v + N_v`` positive definite with ``lambda_min``
above :data:`~._lmi.RECHECK_TOL` times the norm (``eigvalsh``; its rounding is ~1e-14 of the
norm), with ``N_v`` assembled from the exact slack basis (entries 0, +-1, +-1/2). Then
``V(x) - V(M_v x) = T z^T R_v z > 0`` for ``x != 0``: ``V`` decreases geometrically along
every vertex sequence, so the joint spectral radius of ``{M_v}`` is below one, and so is
that of their convex hull (the joint spectral radius of a set equals that of its convex hull;
Jungers 2009, Prop. 1.8): the loop is stable for ``b`` varying arbitrarily *inside* the
interval too, though ``V`` itself need not decrease there (a quartic need not be convex).

Examples
--------
>>> import numpy as np
>>> from fl_design.analysis._sos import sos_lyapunov
>>> from fl_design.analysis._lmi import vertex_lmi
>>> D = [np.array([[-0.4, 1.0], [-1.0, -0.4]]), np.array([[-0.4, 1.0], [-4.0, -0.4]])]
>>> vertex_lmi(D, 1e-2, common=True).certified, sos_lyapunov(D, 1e-2).certified
(False, True)
"""

from __future__ import annotations

import functools
import itertools
from dataclasses import dataclass

import numpy as np

from ._lmi import RECHECK_TOL, solve_quietly


def pairs(n: int) -> list:
    """Index pairs ``(i, j)``, ``i <= j``, of the quadratic monomials ``x_i x_j``.

    Examples
    --------
    >>> pairs(2)
    [(0, 0), (0, 1), (1, 1)]
    """
    return [(i, j) for i in range(n) for j in range(i, n)]


def lift(M: np.ndarray) -> np.ndarray:
    """``L(M)`` with ``z(M x) = L(M) z(x)``, ``z`` the monomials of :func:`pairs`.

    Examples
    --------
    >>> import numpy as np
    >>> M = np.array([[1.0, 2.0], [0.0, 3.0]])
    >>> x = np.array([0.5, -1.5])
    >>> z = lambda v: np.array([v[i] * v[j] for i, j in pairs(2)])
    >>> bool(np.allclose(lift(M) @ z(x), z(M @ x)))
    True
    """
    M = np.asarray(M, dtype=float)
    p = pairs(M.shape[0])
    ii = np.array([a for a, _ in p])
    jj = np.array([b for _, b in p])
    # (M x)_i (M x)_j = sum_kl M_ik M_jl x_k x_l; x_k x_l (k < l) appears twice
    L = M[ii][:, ii] * M[jj][:, jj] + M[ii][:, jj] * M[jj][:, ii]
    L[:, ii == jj] *= 0.5
    return L


def lift_delta(D: np.ndarray, T: float) -> np.ndarray:
    """``E`` with ``L(I + T D) = I + T E`` (no cancellation: ``E = 2 S(I, D) + T S(D, D)``).

    Examples
    --------
    >>> import numpy as np
    >>> D = np.array([[-1.0, 2.0], [0.5, -3.0]])
    >>> T = 1e-3
    >>> bool(np.allclose(np.eye(3) + T * lift_delta(D, T), lift(np.eye(2) + T * D)))
    True
    """
    n = D.shape[0]
    eye = np.eye(n)
    s_id = 0.25 * (lift(eye + D) - lift(eye - D))  # polarized S(I, D)
    return 2.0 * s_id + T * lift(D)


@functools.lru_cache(maxsize=8)
def gram_slack_basis(n: int) -> np.ndarray:
    """Basis ``(k, m, m)`` of the symmetric ``N`` with ``z^T N z == 0`` (exact: 0, +-1, +-1/2).

    For each quartic monomial with several products ``z_a z_b``, the differences of
    consecutive products (each normalized to a unit coefficient).

    Examples
    --------
    >>> gram_slack_basis(2).shape  # x1^2 x2^2 = (x1^2)(x2^2) = (x1 x2)^2
    (1, 3, 3)
    """
    p = pairs(n)
    m = len(p)
    groups: dict = {}
    for a in range(m):
        for b in range(a, m):
            key = tuple(sorted(p[a] + p[b]))
            groups.setdefault(key, []).append((a, b))
    out = []
    for prods in groups.values():
        for (a0, b0), (a1, b1) in itertools.pairwise(prods):
            N = np.zeros((m, m))
            for (a, b), s in (((a0, b0), 1.0), ((a1, b1), -1.0)):
                if a == b:
                    N[a, a] += s
                else:
                    N[a, b] += 0.5 * s
                    N[b, a] += 0.5 * s
            out.append(N)
    return np.stack(out) if out else np.zeros((0, m, m))


@dataclass(frozen=True)
class SOSSolution:
    """Outcome of :func:`sos_lyapunov`.

    Parameters
    ----------
    certified : bool
        The NumPy re-check of ``Q`` passed (the solver's status alone never certifies).
    status : str
        The solver's status (or its error).
    Q : numpy.ndarray or None
        Gram matrix of ``V`` in the monomials of :func:`pairs`.
    N : tuple of numpy.ndarray
        Gram slacks, one per vertex.
    margin : float or None
        Re-check margin (smallest ``lambda_min / ||.||``).
    note : str
        How, or why not.
    eta : float or None, optional
        The program's optimal margin (largest ``lambda_min`` of ``Q`` and the ``R_v`` with
        ``trace Q = m``; positive: strictly feasible), None when no program gave one: what
        :mod:`._sos_search` steers by (never what certifies).
    slope : float or None, optional
        ``d eta / d eps`` when the caller gave the vertices' tangents (the envelope theorem:
        the program's duals on the tangent of ``R_v``, coordinates held fixed), else None.

    Examples
    --------
    >>> SOSSolution(False, "infeasible", None, (), None, "x").certified
    False
    """

    certified: bool
    status: str
    Q: np.ndarray | None
    N: tuple
    margin: float | None
    note: str
    eta: float | None = None
    slope: float | None = None


def _rel_min(S: np.ndarray) -> float:
    lam = np.linalg.eigvalsh((S + S.T) / 2)
    return float(lam[0] / max(abs(lam[0]), abs(lam[-1]), 1e-300))


def recheck_sos(Q, N, deltas, T: float) -> float:
    """Smallest ``lambda_min / ||.||`` of ``Q`` and of each ``R_v`` (see the module), NumPy.

    Examples
    --------
    >>> import numpy as np
    >>> D = [np.array([[-1.0]])]
    >>> recheck_sos(np.eye(1), [np.zeros((1, 1))], D, 1e-3) > 0
    True
    """
    worst = _rel_min(np.asarray(Q, dtype=float))
    for Nv, D in zip(N, deltas):
        E = lift_delta(np.asarray(D, dtype=float), T)
        R = -(E.T @ Q + Q @ E) - T * (E.T @ Q @ E) + Nv
        worst = min(worst, _rel_min(R))
    return worst


@functools.lru_cache(maxsize=8)
def _problem(n: int, nv: int, T: float):
    import cvxpy as cp

    m = len(pairs(n))
    basis = gram_slack_basis(n)
    k = basis.shape[0]
    flat = basis.reshape(k, m * m).T
    E = [cp.Parameter((m, m)) for _ in range(nv)]
    Q = cp.Variable((m, m), symmetric=True)
    ys = [cp.Variable(k) for _ in range(nv)]
    eta = cp.Variable()
    cons = [Q >> eta * np.eye(m), cp.trace(Q) == m, eta <= 1.0]
    for Ev, y in zip(E, ys):
        N = cp.reshape(flat @ y, (m, m), order="C")
        QE = Q @ Ev
        R = -(QE + QE.T) - T * (Ev.T @ Q @ Ev) + N
        cons.append((R + R.T) / 2 >> eta * np.eye(m))
    return cp.Problem(cp.Maximize(eta), cons), E, Q, ys, eta


def sos_lyapunov(deltas, T: float, *, backend: str = "clarabel",
                 tangents=None) -> SOSSolution:
    """Search a quartic SOS Lyapunov function common to the vertices ``I + T Delta_v``.

    Parameters
    ----------
    deltas : sequence of numpy.ndarray
        Vertex matrices ``Delta_v = (M_v - I) / T`` (well-conditioned coordinates: the
        caller balances them).
    T : float
        Sampling time.
    backend : {"clarabel", "cvxpy"}, optional
        ``"clarabel"`` (default): the program assembled in NumPy and handed to Clarabel
        directly (:mod:`._sdp_sos`); ``"cvxpy"``: the same program through CVXPY (slower,
        kept as an independent cross-check). Either answer is re-checked in NumPy.
    tangents : sequence of numpy.ndarray, optional
        ``d Delta_v / d eps`` in the coordinates of ``deltas``: the result's ``slope`` (with
        the Clarabel backend) is then ``d eta / d eps``; nothing else depends on it.

    Returns
    -------
    SOSSolution
        Never raises on a solver failure (it is a value: not certified, with the reason).

    Raises
    ------
    ValueError
        An unknown ``backend`` (:class:`~fl_design.errors.ParameterError`).

    Examples
    --------
    >>> import numpy as np
    >>> sos_lyapunov([np.array([[1.0]])], 1e-3).certified  # unstable
    False
    """
    deltas = [np.asarray(D, dtype=float) for D in deltas]
    n = deltas[0].shape[0]
    Es = [lift_delta(D, T) for D in deltas]
    if backend == "clarabel":
        from ._sdp_sos import solve_sos

        r = solve_sos(Es, float(T), gram_slack_basis(n))
        if r.status.startswith("solver_error"):
            return SOSSolution(False, r.status, None, (), None, f"CLARABEL failed ({r.status})")
        status, eta, Qv, ys = r.status, r.eta, r.Q, r.y
        slope = _slope(r, Es, deltas, tangents, float(T))
    elif backend == "cvxpy":
        status, eta, Qv, ys = _solve_cvxpy(Es, float(T), n)
        slope = None
        if Qv is None and status.startswith("CVXPY failed"):
            return SOSSolution(False, status, None, (), None, status)
    else:
        from ..errors import ParameterError

        raise ParameterError(f"backend must be 'clarabel' or 'cvxpy', got {backend!r}")
    if eta is None or Qv is None or eta <= 0.0:
        return SOSSolution(False, status, None, (), None,
                           f"no strictly feasible quartic SOS V (status {status})", eta, slope)
    basis = gram_slack_basis(n)
    Qv = (Qv + Qv.T) / 2
    N = tuple(np.tensordot(np.asarray(y), basis, axes=1) for y in ys)
    margin = recheck_sos(Qv, N, deltas, T)
    if margin > RECHECK_TOL:
        return SOSSolution(True, status, Qv, N, margin,
                           f"quartic SOS V: CLARABEL {status}, re-checked in NumPy "
                           f"(margin {margin:.3g})", eta, slope)
    return SOSSolution(False, status, None, (), margin,
                       f"the quartic SOS solution failed the NumPy re-check (margin {margin:.3g}"
                       f" <= {RECHECK_TOL:g})", eta, slope)


def _slope(r, Es, deltas, tangents, T: float):
    """``d eta / d eps = sum_v Z_v . svec dR_v`` (None without tangents or duals).

    ``E = lift_delta(D)`` is quadratic in ``D``: its central difference with unit step is
    its exact derivative along ``dD``."""
    if tangents is None or not r.duals or r.Q is None:
        return None
    from ._sdp import svec

    out = 0.0
    for Zv, Ev, D, dD in zip(r.duals, Es, deltas, tangents):
        dD = np.asarray(dD, dtype=float)
        dE = 0.5 * (lift_delta(D + dD, T) - lift_delta(D - dD, T))
        QdE, QE = r.Q @ dE, r.Q @ Ev
        dR = -(QdE + QdE.T) - T * (dE.T @ QE + QE.T @ dE)
        out += float(Zv @ svec(dR))
    return out if np.isfinite(out) else None


def _solve_cvxpy(Es, T: float, n: int):
    """``(status, eta, Q, y)`` of the program through CVXPY + Clarabel (None where absent)."""
    prob, E, Q, ys, eta = _problem(n, len(Es), T)
    for par, Ev in zip(E, Es):
        par.value = Ev
    err = solve_quietly(prob)
    if err is not None:
        return f"CVXPY failed ({type(err).__name__})", None, None, ()
    if eta.value is None or Q.value is None:
        return str(prob.status), None, None, ()
    return (str(prob.status), float(eta.value), np.array(Q.value),
            tuple(np.array(y.value) for y in ys))


def sos_certificate(deltas, T: float, *, tangents=None) -> SOSSolution:
    """:func:`sos_lyapunov` in well-conditioned coordinates of the vertices ``Delta_v``.

    A diagonal balancing (powers of 2, exact), then the Cholesky factor ``R`` of the modal
    Lyapunov matrix of the middle vertex (:func:`~._analytic.modal_lyapunov`), in which the
    quadratic candidate is ``|x|^2``: ``Delta_v -> R Delta_v R^-1``. A similarity: the
    certificate found (and re-checked) for these matrices is ``V(R S^-1 x)`` for the
    originals (``S`` the balancing). The re-check is made on ``R Delta_v R^-1`` as formed in
    floating point (relative rounding ~1e-16, as for the modal basis of :mod:`._certify`):
    mapped back to the balanced coordinates the Gram matrices are too ill-conditioned for a
    meaningful eigenvalue margin (TRMS at eps = 0.1: ``cond L(R) = 4.8e5``, margin 7e-13).
    ``tangents`` (``d Delta_v / d eps`` in the coordinates of ``deltas``) are carried through
    the same similarities for the result's ``slope`` (:func:`sos_lyapunov`).

    Examples
    --------
    >>> import numpy as np
    >>> D = [np.array([[-0.4, 1.0], [-1.0, -0.4]]), np.array([[-0.4, 1.0], [-4.0, -0.4]])]
    >>> sos_certificate(D, 1e-2).certified  # no common quadratic P exists for this pair
    True
    """
    from ._analytic import modal_lyapunov
    from ._lmi import balance, balance_scaling

    D = [np.asarray(x, dtype=float) for x in deltas]
    sc = balance_scaling(D)
    D = balance(D)
    P = modal_lyapunov(sum(D) / len(D), T)
    if P is None:
        return SOSSolution(False, "not solved", None, (), None,
                           "the middle vertex is not Schur (or its modes are ill-conditioned)")
    try:
        R = np.linalg.cholesky((P + P.T) / 2).T
    except np.linalg.LinAlgError:  # positive definite in exact arithmetic, not in rounding
        return SOSSolution(False, "not solved", None, (), None,
                           "the middle vertex's modal Lyapunov matrix is not positive definite "
                           "in floating point (its modes are ill-conditioned): no coordinates "
                           "for the quartic certificate")
    if tangents is not None:  # the same similarities: diag(1/s) . diag(s), then R . R^-1
        tangents = [np.linalg.solve(R.T, (R @ (np.asarray(x, dtype=float) * sc[None, :]
                                              / sc[:, None])).T).T for x in tangents]
    return sos_lyapunov([np.linalg.solve(R.T, (R @ x).T).T for x in D], T, tangents=tangents)


__all__ = ["SOSSolution", "gram_slack_basis", "lift", "lift_delta", "pairs", "recheck_sos",
           "sos_certificate", "sos_lyapunov"]
