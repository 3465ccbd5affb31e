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

**Soundness.** ``W`` is the product ``(I + L_b)(I + H_b)`` of two unit triangular matrices
whose inverses are exact (``(I - H_b)(I - L_b)``: ``L_b`` and ``H_b`` hold ``L`` and ``H`` off
the diagonal blocks, so ``L_b^2 = H_b^2 = 0``), and the balancing scalings are powers of 2:
``E_v = K_i D_v K_i^-1`` is formed in integer arithmetic on the doubles' exact dyadic values
and rounded once, each entry to its nearest double (off by at most ``u |E_v|``, ``u`` the unit
roundoff, a subnormal by ``2^-1075``). The Frobenius norm of that bound is ``err``, about
``2 u ||E_v||`` (it was ``4 n u || |G^-1| |B| |G| ||``, ~1e5 times larger at rho = 4: the
similarity's condition number, ~1e9, rejected valid certificates near the frozen boundary).
The re-checks (:func:`fl_design.analysis._lmi.recheck_stack`, ``delta_error``) subtract that
perturbation's effect on every vertex matrix, ``||G_slack|| (2 + sqrt(T)) err``, from its
smallest eigenvalue: a certificate of ``E_v`` is then one of the exact ``K_i D_v K_i^-1``, a
congruence of the loop's own delta. The certificate is returned in the loop's coordinates
(``K^T P K``, ``K`` the double nearest ``K_i``).

Examples
--------
>>> import numpy as np
>>> import fl_design as fl
>>> from fl_design.analysis._surrogate import SurrogateLoop, delta
>>> d = fl.Design(estimator=fl.EHGO(3, 0.01, 1e-3),
...               controller=fl.DynamicController(fl.synthesize_gains(3, decay=1.0).gains, 0.1))
>>> M0, M1 = SurrogateLoop(d).parts(0.005, 0.02)
>>> from fl_design.analysis._slow_fast import slow_fast_coordinates
>>> E, K, err, S = slow_fast_coordinates([delta(M0 + b * M1, 1e-3) for b in (1.0, 5.0)], 3)
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
    (list of numpy.ndarray, numpy.ndarray, float, list of int) or None
        ``E_v``, ``K`` (a certificate ``P_E`` of the ``E_v`` is ``K^T P_E K`` in the loop's
        coordinates), ``err``, a bound on ``||E_v - exact||_2``, and the slow states ``S``
        (``x``, ``z`` when kept, ``u`` when its mode is slow too); None when the middle delta
        has no slow-fast separation (:data:`MIN_SEPARATION`) or the slow subspace is no graph
        over ``S``.

    Examples
    --------
    >>> import numpy as np
    >>> slow_fast_coordinates([-np.eye(8)] * 2, 3) is None  # one time scale only
    True
    """
    D = [np.asarray(x, dtype=float) for x in D]
    n = D[0].shape[0]
    s0 = balance_scaling(D)
    B = [x * s0[None, :] / s0[:, None] for x in D]
    Bm = 0.5 * (B[0] + B[-1])
    if not np.all(np.isfinite(Bm)):
        return None
    a = np.sort(np.abs(np.linalg.eigvals(Bm)))
    S = list(range(rho)) + ([n - 1] if n == 2 * rho + 3 else [])
    if not a[len(S)] > MIN_SEPARATION * a[len(S) - 1]:
        S = sorted(S + [2 * rho + 1])  # the controller's u slow too (a large gamma b)
        if not a[len(S)] > MIN_SEPARATION * a[len(S) - 1]:
            return None
    F = [i for i in range(n) if i not in S]
    k = len(S)
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
    Bd = np.linalg.solve(W2, B1 @ W2)
    s1 = np.ones(n)
    for idx in (S, F):
        _, (sb, _) = scipy.linalg.matrix_balance(Bd[np.ix_(idx, idx)], permute=False,
                                                 separate=True)
        s1[idx] = sb
    Lb, Hb = np.zeros((n, n)), np.zeros((n, n))
    Lb[np.ix_(F, S)], Hb[np.ix_(S, F)] = Lg, H
    return _exact_similarity(D, Lb, Hb, s0, s1, S)


def _exact_similarity(D, Lb, Hb, s0, s1, S):
    """``E_v = Ki D_v Ki^-1`` computed exactly (integers), rounded once; ``K`` and the bound.

    ``Ki = diag(1/s1) (I - Hb)(I - Lb) diag(1/s0)`` has the exact inverse
    ``diag(s0) (I + Lb)(I + Hb) diag(s1)`` (``Lb Lb = Hb Hb = 0``: the blocks are off the
    diagonal, ``s0`` and ``s1`` powers of 2): the product is formed in integer arithmetic on
    the doubles' exact dyadic values, and each entry of ``E_v`` is its correctly rounded
    double, off by at most ``u |E_v|`` (``u`` the unit roundoff), plus ``2^-1075`` where it is
    subnormal. The 2-norm of that error matrix is bounded by its Frobenius norm, computed with
    a factor 2 for its own rounding: the returned ``err``. ``K`` (the map to these
    coordinates, for the certificate's ``P`` in the loop's coordinates) is the rounded ``Ki``.
    None when a value is not finite or does not fit a double.
    """
    n = Lb.shape[0]
    k0, k1 = _log2(s0), _log2(s1)
    if k0 is None or k1 is None:
        return None
    Li, Hi = _dyadic(Lb), _dyadic(Hb)
    if Li is None or Hi is None:
        return None
    ident = np.eye(n, dtype=int).astype(object)
    one_l, one_h = ident * (1 << -Li[1]), ident * (1 << -Hi[1])
    A1 = ((one_h - Hi[0]).dot(one_l - Li[0]), Hi[1] + Li[1])  # (I - Hb)(I - Lb)
    A2 = ((one_l + Li[0]).dot(one_h + Hi[0]), Li[1] + Hi[1])  # (I + Lb)(I + Hb)
    E = []
    u = np.finfo(float).eps / 2
    err = 0.0
    for Dv in D:
        Bv = _dyadic(Dv, k0)  # diag(1/s0) D_v diag(s0), exactly
        if Bv is None:
            return None
        C = A1[0].dot(Bv[0]).dot(A2[0])
        Ev = _to_float(C, A1[1] + Bv[1] + A2[1], k1)  # diag(1/s1) C diag(s1), rounded once
        if Ev is None:
            return None
        E.append(Ev)
        err = max(err, 2.0 * u * float(np.linalg.norm(Ev)) + n * 2.0 ** -1074)
    K = _to_float(A1[0], A1[1], k1, k0)
    if K is None or not np.isfinite(err):
        return None
    return E, K, err, S


def _log2(s):
    """Exponents of a vector of powers of 2 (None when one is not)."""
    m, e = np.frexp(np.asarray(s, dtype=float))
    if not np.all(m == 0.5):
        return None
    return (e - 1).astype(int)


def _dyadic(M, k=None):
    """``(Mi, e)``: ``M = Mi 2^e`` exactly, ``Mi`` Python integers (object array), ``e <= 0``;
    with ``k`` (integer exponents) of ``diag(2^-k) M diag(2^k)``. None when not finite."""
    M = np.asarray(M, dtype=float)
    if not np.all(np.isfinite(M)):
        return None
    m, e = np.frexp(M)
    mi = (m * 2.0 ** 53).astype(np.int64)  # exact: |m| < 1
    e = e.astype(np.int64) - 53
    if k is not None:
        e = e + k[None, :] - k[:, None]
    base = min(int(e[mi != 0].min()) if np.any(mi != 0) else 0, 0)
    out = np.empty(M.shape, dtype=object)
    out.ravel()[:] = [v << x if v else 0 for v, x in zip(mi.ravel().tolist(), (e - base).ravel().tolist())]
    return out, base


def _to_float(C, e, k_row, k_col=None):
    """Correctly rounded doubles of ``C[i, j] 2^(e - k_row[i] + k_col[j])`` (``k_col``
    default ``k_row``: a similarity by ``diag(2^k_row)``; else ``diag(2^-k_row) C
    diag(2^-k_col)`` when given, see the caller). None on overflow."""
    rows, cols = C.shape
    if k_col is None:
        ex = e - k_row[:, None] + k_row[None, :]
    else:
        ex = e - k_row[:, None] - k_col[None, :]
    try:
        # Python's int true division and int -> float conversion are correctly rounded
        out = [float(c << x) if x >= 0 else c / (1 << -x)
               for c, x in zip(C.ravel().tolist(), ex.ravel().tolist())]
    except OverflowError:
        return None
    return np.array(out, dtype=float).reshape(rows, cols)





def _lyapunov_candidate(E, S, F, T: float) -> np.ndarray:
    """The delta-form Lyapunov solution of the middle of ``E`` (unit norm), weights
    ``sqrt(d)`` per time scale (as the modal ``P``'s): a guess, re-checked by the caller."""
    Em = 0.5 * (E[0] + E[-1])
    n = Em.shape[0]
    q = np.ones(n)
    for idx in (S, F):
        mu = np.linalg.eigvals(Em[np.ix_(idx, idx)])
        d = np.abs(2.0 * mu.real + T * np.abs(mu) ** 2)
        q[idx] = np.sqrt(np.exp(np.mean(np.log(np.maximum(d, 1e-300)))))
    M = np.eye(n) + T * Em
    P = scipy.linalg.solve_discrete_lyapunov(M.T, T * np.diag(q))
    P = 0.5 * (P + P.T)
    return P / np.linalg.norm(P, 2)


def piecewise_slow_fast(delta_pair, lo: float, hi: float, T: float, rho: int,
                        min_width: float):
    """Cover ``[lo, hi]`` by pieces, each certified by a closed-form ``P`` in its own
    slow-fast coordinates (adaptive halving): the modal step of two-time-scale loops.

    Each piece's deltas at its ends go through :func:`slow_fast_coordinates`, the candidate
    is the delta-form Lyapunov solution of their middle (one weight per time scale: the modal
    ``P`` fails on the near-repeated slow poles of :func:`fl_design.synthesize_gains`), and it
    counts only when :func:`fl_design.analysis._lmi.recheck_stack` passes at both ends with
    the similarity's rounding bound subtracted (affine in ``b``: the ends cover the piece).

    Parameters
    ----------
    delta_pair : callable
        ``(b_lo, b_hi) -> [Delta(b_lo), Delta(b_hi)]`` in the loop's coordinates.
    lo, hi : float
        The interval of ``b``.
    T : float
        Sampling time.
    rho : int
        Relative degree.
    min_width : float
        Pieces are not halved below this width.

    Returns
    -------
    (list, float or None, tuple or None)
        Certified pieces ``(b_lo, b_hi, P, margin)`` with ``P`` in the loop's coordinates,
        the smallest margin, and the failing interval (None when all is covered).

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.analysis._surrogate import SurrogateLoop, delta
    >>> d = fl.Design(estimator=fl.EHGO(4, 0.01, 1e-3), controller=fl.DynamicController(
    ...     fl.synthesize_gains(4, decay=1.0).gains, 0.25))
    >>> M0, M1 = SurrogateLoop(d).parts(0.004, 0.02)
    >>> done, margin, bad = piecewise_slow_fast(
    ...     lambda a, b: [delta(M0 + a * M1, 1e-3), delta(M0 + b * M1, 1e-3)],
    ...     1.0, 2.0, 1e-3, 4, 1.0 / 64)
    >>> bad is None, done[0][0], done[-1][1]
    (True, 1.0, 2.0)
    """
    from ._lmi import RECHECK_TOL, recheck_stack

    pending, done = [(lo, hi)], []
    while pending:
        a, b = pending.pop()
        margin = -np.inf
        sf = slow_fast_coordinates(delta_pair(a, b), rho)
        if sf is not None:
            E, K, err, S = sf
            F = [i for i in range(E[0].shape[0]) if i not in S]
            try:
                P = _lyapunov_candidate(E, S, F, T)
            except (np.linalg.LinAlgError, ValueError):
                P = None
            if P is not None and np.all(np.isfinite(P)):
                margin = float(np.min(recheck_stack(P[None], P[None], np.stack(E), T, 0.0,
                                                    err)))
        if margin > RECHECK_TOL:
            done.append((float(a), float(b), K.T @ P @ K, margin))
        elif b - a > min_width * (1.0 + 1e-9):
            mid = 0.5 * (a + b)
            pending += [(mid, b), (a, mid)]
        else:
            return sorted(done, key=lambda p: p[0]), None, (float(a), float(b))
    done.sort(key=lambda p: p[0])
    return done, min(p[3] for p in done), None
__all__ = ["MIN_SEPARATION", "piecewise_slow_fast", "slow_fast_coordinates"]
