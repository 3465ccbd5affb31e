"""The quartic SOS program of :mod:`._sos` handed to Clarabel directly (no CVXPY).

Through CVXPY each SOS solve paid most of its ~2 s in canonicalization (``E^T Q E`` with ``E``
a parameter is not DPP: the problem is rebuilt at every eps) and Clarabel ran on two threads.
Here the program of :mod:`._sos`

    maximize eta  subject to  Q - eta I >= 0,  R_v(Q, y_v) - eta I >= 0 (every vertex v),
    trace Q = m,  eta <= 1,
    R_v = -(E_v^T Q + Q E_v) - T E_v^T Q E_v + sum_j y_vj N_j,

is written as Clarabel's ``A z + s = b`` with ``z = (svec Q, y_1, ..., y_V, eta)``. The map
``Q -> R_v`` is evaluated on the unit matrices of ``svec`` in closed form (rank-two outer
products of the rows of ``E_v``: ``O(m^4)`` flops, no ``m x m`` product per unit matrix); the
slack columns are ``svec N_j`` (entries 0, +-1, +-1/2, given by the caller) and the ``Q``
block is the identity (``Q`` is its own ``svec``). One thread, as :mod:`._sdp`. The answer
is a guess like any solver's: :func:`._sos.recheck_sos` re-checks it in NumPy.

Examples
--------
>>> import numpy as np
>>> from fl_design.analysis._sdp_sos import solve_sos
>>> from fl_design.analysis._sos import gram_slack_basis, lift_delta
>>> r = solve_sos([lift_delta(np.array([[-1.0]]), 1e-3)], 1e-3, gram_slack_basis(1))
>>> r.status, round(r.eta, 6)  # m = 1: Q = 1, R = 3.994: eta = min(1, Q, R)
('optimal', 1.0)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._sdp import _clarabel, _svec_index, svec


@dataclass(frozen=True)
class SOSProgramSolution:
    """Clarabel's answer to the SOS program: ``Q`` (symmetric), the slack coordinates ``y``
    per vertex, ``eta`` (each None unless the status is one of :data:`._sdp.WITH_SOLUTION`),
    the status word, the iterations and the dual vectors ``svec Z_v`` of the ``R_v`` cones
    (``d eta / d E_v`` along a direction ``dR_v`` is ``sum_v Z_v . svec dR_v``: the
    envelope theorem).

    Examples
    --------
    >>> SOSProgramSolution(None, (), None, "infeasible", 4).Q is None
    True
    """

    Q: np.ndarray | None
    y: tuple
    eta: float | None
    status: str
    iterations: int
    duals: tuple = ()


def lyapunov_columns(E: np.ndarray, T: float) -> np.ndarray:
    """``(nb, nb)``: column ``k`` is ``svec R(U_k)``, ``R(Q) = -(E^T Q + Q E) - T E^T Q E``,
    ``U_k`` the symmetric matrix with ``svec U_k = e_k`` (so ``svec R(Q) = C svec Q``).

    ``U_k`` is ``e_i e_i^T`` on the diagonal and ``(e_i e_j^T + e_j e_i^T) / sqrt 2`` off it;
    with ``g_i = E[i]`` (row ``i`` as a column), ``E^T e_i = g_i`` and the map of
    ``e_i e_j^T + e_j e_i^T`` is ``-(g_i e_j^T + e_j g_i^T + g_j e_i^T + e_i g_j^T)
    - T (g_i g_j^T + g_j g_i^T)``: outer products, never an ``m x m`` product per column.

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.analysis._sdp import svec
    >>> rng = np.random.default_rng(0)
    >>> E, Q = rng.normal(size=(3, 3)), rng.normal(size=(3, 3))
    >>> Q = Q + Q.T
    >>> R = -(E.T @ Q + Q @ E) - 0.1 * E.T @ Q @ E
    >>> bool(np.allclose(lyapunov_columns(E, 0.1) @ svec(Q), svec(R)))
    True
    """
    E = np.asarray(E, dtype=float)
    m = E.shape[0]
    rows, cols, _ = _svec_index(m)
    w = np.where(rows == cols, 0.5, 1.0 / np.sqrt(2.0))  # U_k = w (e_i e_j^T + e_j e_i^T)
    gi, gj = E[rows], E[cols]  # (nb, m)
    eye = np.eye(m)
    ei, ej = eye[rows], eye[cols]
    # the map of e_i e_j^T + e_j e_i^T, as a sum of X Y^T + Y X^T
    half = (gi[:, :, None] * ej[:, None, :] + gj[:, :, None] * ei[:, None, :]
            + T * gi[:, :, None] * gj[:, None, :])
    full = -(half + np.swapaxes(half, 1, 2)) * w[:, None, None]
    return svec(full).T


def solve_sos(Es, T: float, basis: np.ndarray, *, refine: bool = False) -> SOSProgramSolution:
    """Solve the quartic SOS program of :mod:`._sos` for the lifted vertices ``E_v``.

    Parameters
    ----------
    Es : sequence of numpy.ndarray
        ``E_v = lift_delta(Delta_v, T)``, each ``(m, m)`` with ``m = n (n + 1) / 2``.
    T : float
        Sampling time.
    basis : numpy.ndarray
        ``(k, m, m)``: the Gram slack basis ``N_j`` (:func:`._sos.gram_slack_basis`).
    refine : bool, optional
        Clarabel's iterative refinement of each KKT solve (default False: about 30 % of the
        CPU time at 7 states; a status other than solved is retried with it).

    Returns
    -------
    SOSProgramSolution
        Never raises on a solver failure: the status says it (``"solver_error: ..."``).
        Counted by :func:`._lmi.solve_count`.

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.analysis._sos import gram_slack_basis, lift_delta
    >>> r = solve_sos([lift_delta(np.array([[1.0]]), 1e-3)], 1e-3, gram_slack_basis(1))
    >>> r.eta < 0  # unstable: R < 0 whatever Q
    True
    """
    import clarabel
    import scipy.sparse as sp

    from ._lmi import counted

    m = Es[0].shape[0]
    rows, cols, scale = _svec_index(m)
    basis = np.asarray(basis, dtype=float).reshape(-1, m, m)
    slack = svec(basis).T  # (nb, k): entries 0, +-1, +-1/2 (times sqrt 2 off the diagonal)
    nb, k, nv = rows.size, basis.shape[0], len(Es)
    nz = nb + nv * k + 1
    s_eye = svec(np.eye(m))
    # rows: trace Q = m (zero cone), eta <= 1, Q - eta I, then each R_v - eta I (PSD)
    tr = sp.csr_matrix((np.ones(m), (np.zeros(m, dtype=int), np.flatnonzero(rows == cols)
                                     )), shape=(1, nz))
    top = sp.csr_matrix(([1.0], ([0], [nz - 1])), shape=(1, nz))
    q_block = sp.hstack([-sp.identity(nb), sp.csr_matrix((nb, nv * k)),
                         sp.csr_matrix(s_eye[:, None])])
    blocks = [tr, top, q_block]
    for v, E in enumerate(Es):
        parts = [sp.csr_matrix(-lyapunov_columns(E, T))]
        if v:
            parts.append(sp.csr_matrix((nb, v * k)))
        parts.append(sp.csr_matrix(-slack))
        if nv - v - 1:
            parts.append(sp.csr_matrix((nb, (nv - v - 1) * k)))
        parts.append(sp.csr_matrix(s_eye[:, None]))
        blocks.append(sp.hstack(parts))
    A = sp.vstack(blocks).tocsc()
    b = np.concatenate([[float(m), 1.0], np.zeros((1 + nv) * nb)])
    cones = [clarabel.ZeroConeT(1), clarabel.NonnegativeConeT(1)] + [
        clarabel.PSDTriangleConeT(m)] * (1 + nv)
    q = np.zeros(nz)
    q[-1] = -1.0
    status, z, iters, dual = counted(_clarabel, q, A, b, cones, refine)
    if z is None:
        return SOSProgramSolution(None, (), None, status, iters)
    Q = np.zeros((m, m))
    Q[rows, cols] = z[:nb] / scale
    Q[cols, rows] = z[:nb] / scale
    y = tuple(z[nb + v * k: nb + (v + 1) * k] for v in range(nv))
    duals = tuple(dual[2 + nb * (v + 1): 2 + nb * (v + 2)] for v in range(nv))
    return SOSProgramSolution(Q, y, float(z[-1]), status, iters, duals)


__all__ = ["SOSProgramSolution", "lyapunov_columns", "solve_sos"]
