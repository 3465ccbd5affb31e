"""Rate-bounded certificate: ``P(b)`` piecewise affine in ``b`` for ``|b_(k+1) - b_k| <= db``.

With ``V_k = X_k^T P(b_k) X_k`` the loop ``X_(k+1) = M(b_k) X_k`` decreases when
``M(b)^T P(b') M(b) < P(b)`` for every admissible pair ``(b, b')`` (``b' = b_(k+1)``). With a
slack ``G`` (de Oliveira, Bernussou and Geromel, 1999) this follows from

    [[P(b), M(b)^T G^T], [G M(b), G + G^T - P(b')]] > 0,

and after the congruence ``x_2 -> y_2 - x_1`` and a ``1/sqrt(T)`` scaling of the first block
(``M = I + T Delta``), the delta form::

    [[(P(b) - P(b'))/T - (G Delta(b) + Delta(b)^T G^T), N^T], [N, G + G^T - P(b')]] > 0,
    N = (P(b') - G^T)/sqrt(T) + sqrt(T) G Delta(b).

``P`` is continuous and affine on the pieces ``[k_i, k_(i+1)]`` of the interval (values
``P_i`` at the knots), ``G = G_i`` constant on the piece of ``b``, ``Delta(b)`` affine: on each *cell* (``b`` in piece
``i``, ``b'`` in piece ``j``, ``|b - b'| <= db``, a convex polygon) the matrix is affine in
``(b, b')`` jointly, so its vertices cover the cell. The pieces are at least ``db`` wide, so
only ``j = i`` and neighbouring pieces meet. ``db = 0`` is the frozen case.

Coordinates: the modal Lyapunov basis of the middle ``b`` (:mod:`._analytic`), where the
candidate ``P`` is the identity; solved by CVXPY + Clarabel, then re-checked in NumPy at every
cell vertex (``lambda_min > RECHECK_TOL ||S||``) and at every knot (``P_i > 0``).

Examples
--------
>>> from fl_design.analysis._rate import cell_vertices
>>> cell_vertices(0.0, 1.0, 0.0, 1.0, 0.25)
[(0.0, 0.0), (0.0, 0.25), (0.25, 0.0), (0.75, 1.0), (1.0, 0.75), (1.0, 1.0)]
"""

from __future__ import annotations

import functools
import math

import numpy as np

from ._analytic import modal_lyapunov
from ._lmi import RECHECK_TOL, solve_quietly


def cell_vertices(a0: float, a1: float, c0: float, c1: float, db: float) -> list:
    """Vertices of ``{(b, b'): b in [a0, a1], b' in [c0, c1], |b - b'| <= db}`` (may be empty).

    Examples
    --------
    >>> cell_vertices(0.0, 1.0, 1.0, 2.0, 0.1)
    [(0.9, 1.0), (1.0, 1.0), (1.0, 1.1)]
    """
    # clip the rectangle by the two half-planes b' - b <= db and b - b' <= db
    poly = [(a0, c0), (a1, c0), (a1, c1), (a0, c1)]
    for sgn in (1.0, -1.0):
        out = []
        for k, p in enumerate(poly):
            q = poly[(k + 1) % len(poly)]
            fp, fq = sgn * (p[1] - p[0]) - db, sgn * (q[1] - q[0]) - db
            if fp <= 0.0:
                out.append(p)
            if fp * fq < 0.0:
                t = fp / (fp - fq)
                out.append((p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])))
        poly = out
        if not poly:
            return []
    uniq = []
    for p in poly:
        p = (round(p[0], 15), round(p[1], 15))
        if p not in uniq:
            uniq.append(p)
    return sorted(uniq)


def _pairs(knots, db: float) -> list:
    """``(i, j, b, b')`` for every vertex of every non-empty cell."""
    out = []
    m = len(knots) - 1
    for i in range(m):
        for j in range(max(0, i - 1), min(m, i + 2)):
            for b, b2 in cell_vertices(knots[i], knots[i + 1], knots[j], knots[j + 1], db):
                out.append((i, j, b, b2))
    return out


def _interp(values, knots, i, b):
    span = knots[i + 1] - knots[i]
    t = 0.0 if span == 0.0 else (b - knots[i]) / span
    return (1.0 - t) * values[i] + t * values[i + 1]


def _block(Pb, Pb2, G, D, T, xp):
    sT = math.sqrt(T)
    GD = G @ D
    A11 = (Pb - Pb2) / T - (GD + GD.T)
    A21 = (Pb2 - G.T) / sT + sT * GD
    return xp([[A11, A21.T], [A21, G + G.T - Pb2]])


def recheck_rate(Ps, G, deltas, knots, T: float, db: float) -> float:
    """Smallest ``lambda_min / ||S||`` over the cell vertices and knot ``P_i`` (NumPy).

    Examples
    --------
    >>> import numpy as np
    >>> D = [np.array([[-1.0]])] * 2
    >>> recheck_rate([np.eye(1)] * 2, [np.eye(1)], D, [0.0, 1.0], 1e-3, 0.1) > 0
    True
    """
    worst = math.inf
    for P in Ps:
        lam = np.linalg.eigvalsh((P + P.T) / 2)
        worst = min(worst, lam[0] / max(abs(lam[0]), abs(lam[-1])))
    for i, j, b, b2 in _pairs(knots, db):
        S = _block(_interp(Ps, knots, i, b), _interp(Ps, knots, j, b2), G[i],
                   _interp(deltas, knots, i, b), T, np.block)
        lam = np.linalg.eigvalsh((S + S.T) / 2)
        worst = min(worst, lam[0] / max(abs(lam[0]), abs(lam[-1])))
    return float(worst)


@functools.lru_cache(maxsize=16)
def _problem(n: int, knots: tuple, T: float, db: float):
    """The LMI for one shape, knots and rate (CVXPY parameters: ``Delta`` at the knots)."""
    import cvxpy as cp

    E = [cp.Parameter((n, n)) for _ in knots]
    Ps = [cp.Variable((n, n), symmetric=True) for _ in knots]
    G = [cp.Variable((n, n)) for _ in knots[:-1]]  # one slack per piece of b
    eta = cp.Variable()
    cons = [eta <= 1.0]
    for i, j, b, b2 in _pairs(knots, db):
        S = _block(_interp(Ps, knots, i, b), _interp(Ps, knots, j, b2), G[i],
                   _interp(E, knots, i, b), T, cp.bmat)
        cons.append((S + S.T) / 2 >> eta * np.eye(2 * n))
    for P in Ps:
        cons += [P >> eta * np.eye(n), P << 10.0 * np.eye(n)]
    return cp.Problem(cp.Maximize(eta), cons), E, Ps, G, eta


def rate_lmi(delta_at, b_lo: float, b_hi: float, T: float, db: float, pieces: int = 4):
    """Certify ``X+ = M(b_k) X`` for ``|b_(k+1) - b_k| <= db`` with a piecewise-affine ``P(b)``.

    Parameters
    ----------
    delta_at : callable
        ``b -> Delta(b) = (M(b) - I)/T`` (affine in ``b``).
    b_lo, b_hi : float
        The interval.
    T : float
        Sampling time.
    db : float
        Rate bound per sample (>= 0).
    pieces : int, optional
        Pieces of ``P(b)`` (fewer when a piece would be narrower than ``db``).

    Returns
    -------
    (bool, float or None, str)
        Certified (after the NumPy re-check), the re-check margin, and a note.

    Examples
    --------
    >>> import numpy as np
    >>> ok, margin, note = rate_lmi(lambda b: np.array([[-b]]), 1.0, 2.0, 1e-3, 0.01)
    >>> ok
    True
    """
    width = b_hi - b_lo
    m = max(1, min(int(pieces), int(width / db) if db > 0 else int(pieces)))
    knots = tuple(float(k) for k in np.linspace(b_lo, b_hi, m + 1))
    P0 = modal_lyapunov(delta_at(0.5 * (b_lo + b_hi)), T)
    if P0 is None:
        return False, None, "the middle frozen loop is not Schur"
    R = np.linalg.cholesky((P0 + P0.T) / 2).T
    Ri = np.linalg.inv(R)
    E = [R @ delta_at(k) @ Ri for k in knots]  # P0 -> identity
    prob, E_par, Ps, G, eta = _problem(E[0].shape[0], knots, float(T), float(db))
    for par, Ek in zip(E_par, E):
        par.value = Ek
    err = solve_quietly(prob)
    if err is not None:
        return False, None, f"CLARABEL failed ({type(err).__name__})"
    if eta.value is None or Ps[0].value is None or eta.value <= 0.0:
        return False, None, f"no strictly feasible P(b) (status {prob.status})"
    Pv = [np.array(P.value) for P in Ps]
    margin = recheck_rate(Pv, [np.array(g.value) for g in G], E, knots, T, db)
    if margin > RECHECK_TOL:
        return True, margin, (f"P(b) affine on {m} piece(s), rate |db| <= {db:.4g}: CLARABEL "
                              f"{prob.status}, re-checked in NumPy (margin {margin:.3g})")
    return False, margin, f"the solution failed the NumPy re-check (margin {margin:.3g})"


__all__ = ["cell_vertices", "rate_lmi", "recheck_rate"]
