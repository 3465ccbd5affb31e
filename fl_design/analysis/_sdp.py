"""Small margin-maximizing SDPs handed to Clarabel directly (no CVXPY canonicalization).

The vertex LMIs of :mod:`._lmi` are tiny (matrices of order 8 to 22) and solved hundreds of
times along a curve: through CVXPY each solve paid ~12 ms of canonicalization and the first
paid ~1.8 s of ``import cvxpy``, and Clarabel ran its factorization on 2 threads, which on a
shared 2-core machine cost 40 % more CPU than one. Here the problem

    maximize eta  subject to  F_k(x) - eta c_k I  in PSD  (k = 1..m),  eta <= 1,

with each ``F_k(x) = F_k0 + sum_i x_i F_ki`` affine and symmetric (``c_k`` 1 or 0), is built
as Clarabel's ``A z + s = b`` by evaluating the ``F_k`` on the unit vectors (NumPy) and solved
with one thread. Clarabel's ``PSDTriangleConeT`` takes the upper triangle by columns, the
off-diagonal entries scaled by ``sqrt(2)`` (:func:`svec`). The answer is a guess like any
solver's: :mod:`._lmi` re-checks it in NumPy.

Examples
--------
>>> import numpy as np
>>> from fl_design.analysis._sdp import max_margin
>>> # maximize eta with [[1 + x, 0.5], [0.5, 1 - x]] >= eta I: x = 0, eta = 0.5
>>> F0 = np.array([[1.0, 0.5], [0.5, 1.0]])
>>> F1 = np.array([[[1.0, 0.0], [0.0, -1.0]]])
>>> r = max_margin([(F0, F1, True)], 1)
>>> r.status, round(r.eta, 6), round(abs(float(r.x[0])), 6)
('optimal', 0.5, 0.0)
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

#: Clarabel's status -> the CVXPY status word :mod:`._lmi` reports.
STATUS = {"Solved": "optimal", "AlmostSolved": "optimal_inaccurate",
          "PrimalInfeasible": "infeasible", "AlmostPrimalInfeasible": "infeasible_inaccurate",
          "DualInfeasible": "unbounded", "AlmostDualInfeasible": "unbounded_inaccurate",
          "MaxIterations": "user_limit", "MaxTime": "user_limit"}
#: Statuses whose iterate is returned (as CVXPY does): the caller's re-check judges it.
WITH_SOLUTION = ("optimal", "optimal_inaccurate", "user_limit")


@dataclass(frozen=True)
class MarginSolution:
    """Clarabel's answer: ``x`` and ``eta`` (None unless the status is one of
    :data:`WITH_SOLUTION`), the status word (:data:`STATUS`, else Clarabel's own in lower
    case) and its iteration count.

    Examples
    --------
    >>> MarginSolution(None, None, "infeasible", 3).x is None
    True
    """

    x: np.ndarray | None
    eta: float | None
    status: str
    iterations: int


@functools.lru_cache(maxsize=32)
def _svec_index(d: int):
    rows, cols = np.triu_indices(d)
    order = np.lexsort((rows, cols))  # by columns, then rows: the upper triangle by columns
    rows, cols = rows[order], cols[order]
    scale = np.where(rows == cols, 1.0, np.sqrt(2.0))
    return rows, cols, scale


@functools.lru_cache(maxsize=16)
def sym_basis(n: int) -> np.ndarray:
    """``(n(n+1)/2, n, n)``: the symmetric unit matrices ``E_ii``, ``E_ij + E_ji`` (``i < j``)
    (cached: do not modify the array).

    Examples
    --------
    >>> from fl_design.analysis._sdp import sym_basis
    >>> sym_basis(2).tolist()
    [[[1.0, 0.0], [0.0, 0.0]], [[0.0, 1.0], [1.0, 0.0]], [[0.0, 0.0], [0.0, 1.0]]]
    """
    rows, cols = np.triu_indices(n)
    B = np.zeros((rows.size, n, n))
    k = np.arange(rows.size)
    B[k, rows, cols] = 1.0
    B[k, cols, rows] = 1.0
    B.flags.writeable = False
    return B


def svec(M: np.ndarray) -> np.ndarray:
    """Clarabel's vector of symmetric ``M`` (``(..., d, d)``): the upper triangle by columns,
    off-diagonal entries times ``sqrt(2)`` (``||svec(M)|| = ||M||_F``).

    Examples
    --------
    >>> import numpy as np
    >>> svec(np.array([[1.0, 2.0], [2.0, 3.0]])).round(4).tolist()
    [1.0, 2.8284, 3.0]
    """
    M = np.asarray(M, dtype=float)
    rows, cols, scale = _svec_index(M.shape[-1])
    return M[..., rows, cols] * scale


def max_margin(blocks, nvar: int) -> MarginSolution:
    """Maximize ``eta`` subject to ``F_k(x) - eta c_k I >= 0`` and ``eta <= 1``.

    Parameters
    ----------
    blocks : sequence of (numpy.ndarray, numpy.ndarray, bool)
        ``(F_k0, F_ki, c_k)``: the constant ``(d, d)``, the coefficients ``(nvar, d, d)``
        (symmetric) and whether the margin ``eta`` enters the block.
    nvar : int
        Number of variables ``x``.

    Returns
    -------
    MarginSolution
        Never raises on a solver failure: the status says it (``"solver_error: ..."``).

    Examples
    --------
    >>> import numpy as np
    >>> r = max_margin([(np.eye(1), np.ones((1, 1, 1)), True)], 1)  # 1 + x >= eta, eta <= 1
    >>> r.status, round(r.eta, 6)
    ('optimal', 1.0)
    """
    import clarabel

    rows_b, rows_a, cones = [np.ones(1)], [np.eye(1, nvar + 1, nvar)], [
        clarabel.NonnegativeConeT(1)]
    for F0, Fi, with_eta in blocks:
        d = F0.shape[0]
        cols = svec(np.asarray(Fi, dtype=float)).T  # (d(d+1)/2, nvar)
        eta_col = -svec(np.eye(d))[:, None] if with_eta else np.zeros((cols.shape[0], 1))
        # s = b - A z with s = svec(F0 + sum x_i F_i - eta c I): A = -[F_i..., -c I]
        rows_a.append(-np.hstack([cols, eta_col]))
        rows_b.append(svec(np.asarray(F0, dtype=float)))
        cones.append(clarabel.PSDTriangleConeT(d))
    q = np.zeros(nvar + 1)
    q[-1] = -1.0
    status, z, iters, _ = _clarabel(q, np.vstack(rows_a), np.concatenate(rows_b), cones)
    if z is None:
        return MarginSolution(None, None, status, iters)
    return MarginSolution(z[:nvar], float(z[-1]), status, iters)


def min_linear(cost, blocks, nvar: int) -> MarginSolution:
    """Minimize ``cost @ x`` subject to ``F_k(x) = F_k0 + sum_i x_i F_ki >= 0`` (PSD).

    Parameters
    ----------
    cost : array_like
        ``(nvar,)``.
    blocks : sequence of (numpy.ndarray, numpy.ndarray)
        ``(F_k0, F_ki)``: the constant ``(d, d)`` and the coefficients ``(nvar, d, d)``.
    nvar : int
        Number of variables ``x``.

    Returns
    -------
    MarginSolution
        ``x`` (``eta`` None) and the status; never raises on a solver failure.

    Examples
    --------
    >>> import numpy as np
    >>> r = min_linear([1.0], [(np.array([[-2.0]]), np.ones((1, 1, 1)))], 1)  # x >= 2
    >>> r.status, round(float(r.x[0]), 6)
    ('optimal', 2.0)
    """
    import clarabel

    A = [-svec(np.asarray(Fi, dtype=float)).T for _, Fi in blocks]
    b = [svec(np.asarray(F0, dtype=float)) for F0, _ in blocks]
    cones = [clarabel.PSDTriangleConeT(F0.shape[0]) for F0, _ in blocks]
    status, z, iters, _ = _clarabel(np.asarray(cost, dtype=float).reshape(nvar), np.vstack(A),
                                 np.concatenate(b), cones)
    return MarginSolution(z, None, status, iters)


def _clarabel(q, A, b, cones, refine: bool = True):
    """``(status word, z or None, iterations, dual or None)`` of Clarabel's ``min q z,
    A z + s = b, s in cones`` (one thread; a solution, and its dual vector, only with a status
    of :data:`WITH_SOLUTION`). With ``refine`` False, Clarabel's iterative refinement of each
    KKT solve is off, and a status other than ``"optimal"`` is solved again with it.

    Every direct Clarabel call of :mod:`fl_design.analysis` goes through here (:mod:`._sdp`,
    :mod:`._sdp_sector`, :mod:`._sdp_sos`).
    """
    import clarabel
    import scipy.sparse as sp

    settings = clarabel.DefaultSettings()
    settings.verbose = False
    if hasattr(settings, "max_threads"):  # clarabel >= 0.10: one thread (tiny problems)
        settings.max_threads = 1
    if not refine:
        settings.iterative_refinement_enable = False
    n = q.size
    try:
        solver = clarabel.DefaultSolver(sp.csc_matrix((n, n)), q, sp.csc_matrix(A), b, cones,
                                        settings)
        sol = solver.solve()
    except Exception as err:  # noqa: BLE001 - a solver failure is a value, not an error
        return f"solver_error: {type(err).__name__}: {err}"[:120], None, 0, None
    status = STATUS.get(str(sol.status), str(sol.status).lower())
    if status != "optimal" and not refine:
        return _clarabel(q, A, b, cones, True)
    z = np.asarray(sol.x, dtype=float)
    if status not in WITH_SOLUTION or z.shape != (n,) or not np.all(np.isfinite(z)):
        return status, None, int(sol.iterations), None
    return status, z, int(sol.iterations), np.asarray(sol.z, dtype=float)


__all__ = ["STATUS", "WITH_SOLUTION", "MarginSolution", "max_margin", "min_linear", "svec", "sym_basis"]
