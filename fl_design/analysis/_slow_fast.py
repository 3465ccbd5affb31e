"""Slow-fast coordinates of the EHGO loop: the LMI and modal steps of ``rho >= 3`` run there.

The loop state ``X = (x_1..x_rho, xi_0..xi_rho, u[, z])`` spans powers of ``1/eps``: the
observer's ``xi_j`` follow ``eps^j x_(j+1)`` on the slow modes, so the slow and fast
eigenvectors are nearly parallel (condition ~1e9 at rho = 3 and 4, even after
:func:`scipy.linalg.matrix_balance`), the modal ``P`` fails its re-check and the interior-point
LMI fails numerically: nothing was certified at rho 3 and 4. The standard remedy is the
singular-perturbation decoupling (Kokotovic's two-time-scale transformation): with ``S`` the
slow states (``x``, and ``z`` when kept) and ``F`` the fast ones (``xi``, ``u``; the dynamic
controller's ``u`` is fast), a unit block-triangular ``W = [[I, H], [0, I]] [[I, 0], [L, I]]``
(``S``/``F`` blocks) makes the middle delta block diagonal: ``L`` is the slow invariant
subspace as a graph over ``x`` (an ordered real Schur form), ``H`` solves a Sylvester equation.
Each block is then balanced on its own (powers of 2). At the interval's ends the deltas keep an
``O(width)`` coupling, which the certificates cover as usual (affine in ``b``).

**Soundness.** Computed in floating point, ``E = G^-1 B G`` (``G = W diag(s)``, ``B`` the
power-of-2 balanced delta, itself exact) is off by ``Delta`` with, componentwise,
``|Delta| <= 4 n u |G^-1| |B| |G|`` (products and a backward-stable solve; ``u`` the unit
roundoff); its 2-norm is bounded by the Frobenius norm of that matrix, returned as ``err``.
The re-checks (:func:`fl_design.analysis._lmi.recheck_stack`, ``delta_error``) subtract that
perturbation's effect on every vertex matrix, ``||G_slack|| (2 + sqrt(T)) err``, from its
smallest eigenvalue: a certificate of ``E`` is then one of the exact ``G^-1 B G``, a
congruence of the loop's own delta. The certificate is returned in the loop's coordinates
(``K^T P K``, ``K = G^-1 diag(1/s0)``).

Examples
--------
>>> import numpy as np
>>> import fl_design as fl
>>> from fl_design.analysis._surrogate import SurrogateLoop, delta
>>> d = fl.Design(estimator=fl.EHGO(3, 0.01, 1e-3),
...               controller=fl.DynamicController(fl.synthesize_gains(3, decay=1.0).gains, 0.1))
>>> M0, M1 = SurrogateLoop(d).parts(0.005, 0.02)
>>> from fl_design.analysis._slow_fast import slow_fast_coordinates
>>> E, K, err = slow_fast_coordinates([delta(M0 + b * M1, 1e-3) for b in (1.0, 5.0)], 3)
>>> bool(err < 1e-9 * np.linalg.norm(E[0], 2)), bool(np.allclose(np.linalg.eigvals(E[0]).real.min(),
...     np.linalg.eigvals(delta(M0 + M1, 1e-3)).real.min()))
(True, True)
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from ._lmi import balance_scaling

#: Smallest ratio of the fast modes' smallest ``|mu|`` to the slow modes' largest: below it the
#: loop has no two time scales and the plain balanced coordinates are kept.
MIN_SEPARATION = 3.0


def slow_fast_coordinates(D, rho: int):
    """Deltas in slow-fast coordinates, the map back and the similarity's error bound.

    Parameters
    ----------
    D : sequence of numpy.ndarray
        Vertex deltas ``(M_v - I) / T`` in the loop's coordinates (``SurrogateLoop`` order).
    rho : int
        Relative degree (``x_1..x_rho`` lead the state; ``z`` is last when kept).

    Returns
    -------
    (list of numpy.ndarray, numpy.ndarray, float) or None
        ``E_v``, ``K`` (a certificate ``P_E`` of the ``E_v`` is ``K^T P_E K`` in the loop's
        coordinates) and ``err``, a bound on ``||E_v - exact||_2``; None when the middle
        delta has no slow-fast separation (:data:`MIN_SEPARATION`) or the slow subspace is
        no graph over ``x``.
    """
    D = [np.asarray(x, dtype=float) for x in D]
    n = D[0].shape[0]
    S = list(range(rho)) + ([n - 1] if n == 2 * rho + 3 else [])
    F = [i for i in range(n) if i not in S]
    k = len(S)
    s0 = balance_scaling(D)
    B = [x * s0[None, :] / s0[:, None] for x in D]
    Bm = 0.5 * (B[0] + B[-1])
    if not np.all(np.isfinite(Bm)):
        return None
    a = np.sort(np.abs(np.linalg.eigvals(Bm)))
    if not a[k] > MIN_SEPARATION * a[k - 1]:
        return None
    thr2 = a[k - 1] * a[k]
    _, U, sdim = scipy.linalg.schur(Bm, output="real", sort=lambda x, y: x * x + y * y <= thr2)
    if sdim != k:
        return None
    Vs = U[:, :k]
    try:
        Lg = np.linalg.solve(Vs[S].T, Vs[F].T).T  # the slow subspace: xi = L x
        W = np.eye(n)
        W[np.ix_(F, S)] = Lg
        B1 = np.linalg.solve(W, Bm @ W)
        H = scipy.linalg.solve_sylvester(B1[np.ix_(S, S)], -B1[np.ix_(F, F)], -B1[np.ix_(S, F)])
    except (np.linalg.LinAlgError, ValueError):
        return None
    W2 = np.eye(n)
    W2[np.ix_(S, F)] = H
    W = W @ W2
    Bd = np.linalg.solve(W, Bm @ W)
    s1 = np.ones(n)
    for idx in (S, F):
        _, (sb, _) = scipy.linalg.matrix_balance(Bd[np.ix_(idx, idx)], permute=False,
                                                 separate=True)
        s1[idx] = sb
    G = W * s1[None, :]
    try:
        Gi = np.linalg.inv(G)
    except np.linalg.LinAlgError:
        return None
    E = [np.linalg.solve(G, x @ G) for x in B]
    u = np.finfo(float).eps / 2
    err = max(float(np.linalg.norm(np.abs(Gi) @ np.abs(x) @ np.abs(G))) for x in B) * 4 * n * u
    if not (np.isfinite(err) and all(np.all(np.isfinite(x)) for x in E)):
        return None
    return E, Gi / s0[None, :], err


__all__ = ["MIN_SEPARATION", "slow_fast_coordinates"]
