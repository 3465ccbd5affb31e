"""A Lyapunov matrix chosen for the largest covered set of plant starts (one LMI, CVXPY).

The nonlinear certificate (:mod:`._ldi`) needs *some* common ``P`` for the sample maps; any
feasible one proves stability, but the covered initial states ``V(X) <= c`` inside the region
depend on which. :func:`widest_covered_p` asks, over the same vertex matrices ``Delta_v`` (in
coordinates ``X = W X_b``), for the ``P`` whose unit sublevel set lies inside the room
(``|X_i| <= r_i``: ``[[P, W^T e_i], [e_i^T W, r_i^2]] >= 0``, the Schur complement of
``e_i^T W P^-1 W^T e_i <= r_i^2``) and holds the largest scaled ellipsoid of plant starts
``sum (x0_j / w_j)^2 <= 1 / t`` (``G^T P G <= t diag(w)^-2``, minimize ``t``; ``G`` maps a plant
start, the observer at rest, to the loop state), with the delta-form decrease
``M_v^T P M_v <= (1 - 2 kappa T) P`` at every vertex. The caller re-checks the result in
NumPy (the contraction of :func:`._ldi._contraction` and the sublevel set of
:func:`._ldi.covered_set`): the solver's answer is a candidate, not a certificate.

Examples
--------
>>> import numpy as np
>>> P = widest_covered_p([np.array([[-1.0]])], np.eye(1), 1e-3, 0.0, {0: 2.0},
...                      np.eye(1), np.ones(1))
>>> round(float(P[0, 0]), 4)   # the unit sublevel set touches the room: P = 1 / 2^2
0.25
"""

from __future__ import annotations

import math

import numpy as np

from ._lmi import solve_quietly


def widest_covered_p(Db, W, T: float, kappa: float, room: dict, G, w):
    """``P`` (the loop's coordinates) maximizing the covered starts, or None (module docstring).

    Parameters
    ----------
    Db : sequence of numpy.ndarray
        Vertex delta matrices in the coordinates ``X_b = W^-1 X``.
    W : numpy.ndarray
        The coordinate change.
    T : float
        Sampling time.
    kappa : float
        Decay rate asked (>= 0).
    room : dict
        ``{index: r}`` of the constrained loop coordinates.
    G : numpy.ndarray
        ``(n, m)``: loop state of a plant start (observer at rest).
    w : array_like
        ``(m,)`` the shape of the starts' ellipsoid (e.g. the region's half-widths).

    Returns
    -------
    numpy.ndarray or None
        ``P`` in the loop's coordinates (unit sublevel set), None when the solver finds none.

    Examples
    --------
    >>> import numpy as np
    >>> widest_covered_p([np.array([[1.0]])], np.eye(1), 1e-3, 0.0, {0: 1.0}, np.eye(1),
    ...                  np.ones(1)) is None   # unstable: no P
    True
    """
    import cvxpy as cp

    Db = [np.asarray(D, dtype=float) for D in Db]
    W = np.asarray(W, dtype=float)
    n = W.shape[0]
    Wi = np.linalg.inv(W)
    Gb = Wi @ np.asarray(G, dtype=float)
    w = np.asarray(w, dtype=float)
    # scale X_b so that the roomiest coordinate is O(1) (the room constraints fix P's size)
    P = cp.Variable((n, n), symmetric=True)
    t = cp.Variable()
    sT = math.sqrt(T)
    cons = []
    for D in Db:
        A11 = -(P @ D + D.T @ P) - 2.0 * kappa * P
        A21 = sT * P @ D
        S = cp.bmat([[A11, A21.T], [A21, P]])
        cons.append((S + S.T) / 2 >> 0)
    for i, r in room.items():
        c = W[i].reshape(n, 1)
        B = cp.bmat([[P, c], [c.T, np.array([[r * r]])]])
        cons.append((B + B.T) / 2 >> 0)
    Q = Gb.T @ P @ Gb
    cons.append(t * np.diag(1.0 / w ** 2) - (Q + Q.T) / 2 >> 0)
    prob = cp.Problem(cp.Minimize(t), cons)
    if solve_quietly(prob) is not None:  # a solver failure is "no candidate"
        return None
    if prob.status not in ("optimal", "optimal_inaccurate") or P.value is None:
        return None
    Pb = (P.value + P.value.T) / 2
    if np.linalg.eigvalsh(Pb)[0] <= 0.0:
        return None
    return Wi.T @ Pb @ Wi


__all__ = ["widest_covered_p"]
