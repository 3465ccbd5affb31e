"""Closed-form Lyapunov candidates on sub-intervals of ``b``, re-checked in NumPy (no LMI).

For a frozen ``b_c`` the delta matrix ``Delta = V diag(mu) V^-1`` (eigen-decomposition) has the
*modal* Lyapunov matrix ``P = Re(V^-H W V^-1)``, ``W = diag(w_i)``, whose decrease
``Delta^T P + P Delta + T Delta^T P Delta = Re(V^-H diag(w_i d_i) V^-1)`` with
``d_i = 2 Re mu_i + T |mu_i|^2 < 0`` (``I + T Delta`` Schur) is negative definite. The weights
``w_i = |d_i|^(-1/2)`` balance the slow modes (the integrator, ``d ~ 1e-3``) against the
fast ones (observer, ``d ~ 1e2``): that ``P`` tolerates the largest perturbation of ``Delta``
coupling them, i.e. the widest interval of ``b`` around ``b_c``.

A candidate is only a guess: it is a certificate for ``[b_lo, b_hi]`` when the NumPy re-check
:func:`fl_design.analysis._lmi.recheck` of the common-``P`` vertex matrices passes at both ends
(``P > 0`` and the decrease, each with relative margin ``RECHECK_TOL``). The delta-form vertex
matrix is affine in ``Delta`` and ``Delta(b)`` is affine in ``b``, so the two ends cover every
``b`` in between, also varying from sample to sample inside the piece. Pieces that fail are
halved down to a minimum width.

Examples
--------
>>> import numpy as np
>>> from fl_design.analysis._analytic import modal_lyapunov
>>> P = modal_lyapunov(np.array([[-1.0, 1.0], [0.0, -2.0]]), 1e-3)
>>> bool(np.all(np.linalg.eigvalsh(P) > 0))
True
"""

from __future__ import annotations

import numpy as np

from ._lmi import RECHECK_TOL, recheck_stack


def modal_lyapunov(D: np.ndarray, T: float) -> np.ndarray | None:
    """Modal Lyapunov candidate of ``I + T D`` (unit spectral norm); None when not Schur.

    Parameters
    ----------
    D : numpy.ndarray
        Delta matrix ``(M - I) / T`` (balanced).
    T : float
        Sampling time.

    Returns
    -------
    numpy.ndarray or None
        Symmetric ``P`` with ``||P||_2 = 1``, or None (``M`` not Schur, or eigenvectors too
        ill-conditioned to invert).

    Examples
    --------
    >>> import numpy as np
    >>> modal_lyapunov(np.array([[1.0]]), 1e-3) is None
    True
    """
    P = modal_lyapunov_stack(np.asarray(D, dtype=float)[None], T)[0]
    return None if np.isnan(P[0, 0]) else P


def modal_lyapunov_stack(D: np.ndarray, T: float) -> np.ndarray:
    """:func:`modal_lyapunov` of a stack ``(k, n, n)`` at once; NaN matrices where None.

    Examples
    --------
    >>> import numpy as np
    >>> P = modal_lyapunov_stack(np.array([[[-1.0]], [[1.0]]]), 1e-3)
    >>> P[0].tolist(), bool(np.isnan(P[1]).all())
    ([[1.0]], True)
    """
    mu, V = np.linalg.eig(D)
    d = -(2.0 * mu.real + T * np.abs(mu) ** 2)
    bad = np.any(d <= 0.0, axis=-1)
    try:
        Vi = np.linalg.inv(V)
    except np.linalg.LinAlgError:  # one singular eigenvector matrix: one at a time
        Vi = np.stack([_inv_or_nan(v) for v in V])
    with np.errstate(invalid="ignore", over="ignore"):
        cond = np.linalg.norm(V, 1, axis=(-2, -1)) * np.linalg.norm(Vi, 1, axis=(-2, -1))
        bad |= ~(cond <= 1e12)  # 1-norm condition number (NaN: singular)
        w = np.where(d > 0.0, d, 1.0) ** -0.5
        P = (np.swapaxes(Vi.conj(), -1, -2) * w[..., None, :]) @ Vi
    P = P.real
    P = 0.5 * (P + np.swapaxes(P, -1, -2))
    P[bad] = np.nan
    good = ~bad
    if good.any():
        P[good] /= np.linalg.norm(P[good], 2, axis=(-2, -1))[:, None, None]
    return P


def _inv_or_nan(V):
    try:
        return np.linalg.inv(V)
    except np.linalg.LinAlgError:
        return np.full(V.shape, np.nan + 0j)


def real_modal_basis(D: np.ndarray) -> np.ndarray:
    """Real basis ``X`` with ``X^-1 D X`` block diagonal (1x1 and 2x2 blocks), unit columns.

    Complex pairs contribute the real and imaginary parts of one eigenvector.

    Examples
    --------
    >>> import numpy as np
    >>> D = np.array([[0.0, 1.0], [-1.0, -0.5]])
    >>> X = real_modal_basis(D)
    >>> B = np.linalg.solve(X, D @ X)
    >>> bool(np.allclose(np.sort(np.linalg.eigvals(B).imag), np.sort(np.linalg.eigvals(D).imag)))
    True
    """
    mu, V = np.linalg.eig(D)
    cols, used = [], np.zeros(mu.size, dtype=bool)
    for i in np.argsort(-mu.real):
        if used[i]:
            continue
        used[i] = True
        if abs(mu[i].imag) > 1e-12 * max(1.0, abs(mu[i])):
            j = int(np.argmin(np.where(used, np.inf, np.abs(mu - mu[i].conj()))))
            used[j] = True
            cols += [V[:, i].real, V[:, i].imag]
        else:
            cols.append(V[:, i].real)
    X = np.column_stack(cols)
    return X / np.linalg.norm(X, axis=0)


def common_p_in_modal_basis(D, T: float, failed, delta_error: float = 0.0):
    """Common-P LMI in the real modal basis ``X`` of the middle b (well conditioned when
    the balanced coordinates are not, e.g. rho = 4): ``Delta_v -> X^-1 Delta_v X``.

    The LMI and its NumPy re-check run in that basis (a congruence: the same certificate);
    ``P`` is returned in the balanced coordinates, ``X^-T P_m X^-1``. Else ``failed``.
    """
    import dataclasses

    from ._lmi import vertex_lmi

    X = real_modal_basis(0.5 * (D[0] + D[1]))
    cond = float(np.linalg.cond(X))
    if not cond < 1e10:
        return failed
    sol = vertex_lmi([np.linalg.solve(X, x @ X) for x in D], T, common=True,
                     delta_error=delta_error * cond)
    if not sol.certified:
        return failed
    Xi = np.linalg.inv(X)
    P = Xi.T @ sol.P[0] @ Xi
    return dataclasses.replace(sol, P=(P,), G=P, note=(
        f"{sol.note} in the real modal basis of the middle b (condition {cond:.3g})"))


def _cholesky_or_none(P):
    """The Cholesky factor of ``P``, or None where NumPy finds ``P`` not positive definite."""
    try:
        return np.linalg.cholesky(P)
    except np.linalg.LinAlgError:
        return None


def _whitened(P, ends, T: float, margin, delta_error: float = 0.0):
    """Margins of the pieces that failed, re-checked in ``P``'s own coordinates.

    With ``P = L L^T`` the same certificate reads ``P' = I``, ``Delta' = L^T Delta L^-T`` (a
    congruence): the relative margin no longer carries ``cond(P)`` (5e8 on b in [1, 50], where
    the plain check's margin 1e-9 is at the level of its tolerance). The similarity is computed
    in floating point: its error, ``<= 64 n cond(L) u`` relative, is added to the tolerance.
    Returns the better of the two margins, minus that error, for each piece.
    """
    fail = np.isfinite(margin) & ~(margin > RECHECK_TOL)
    if not fail.any():
        return margin
    out = margin.copy()
    k, n = P.shape[0], P.shape[-1]
    idx = np.flatnonzero(fail)
    Pi = P[idx]
    ok = np.all(np.linalg.eigvalsh(Pi) > 0.0, axis=-1)
    idx, Pi = idx[ok], Pi[ok]
    if not idx.size:
        return out
    try:
        L = np.linalg.cholesky(Pi)
    except np.linalg.LinAlgError:  # eigvalsh > 0 yet a pivot <= 0 (cond(P) ~ 1/u): one at a
        chol = [_cholesky_or_none(x) for x in Pi]  # time; those without a factor keep
        keep = np.array([c is not None for c in chol])  # their plain margin (no whitening)
        if not keep.any():
            return out
        idx, L = idx[keep], np.stack([c for c in chol if c is not None])
    Lt = np.swapaxes(L, -1, -2)
    Lti = np.linalg.inv(Lt)
    cond = np.linalg.cond(L)
    Dw = np.concatenate([Lt @ ends[idx] @ Lti, Lt @ ends[k + idx] @ Lti])
    eye = np.broadcast_to(np.eye(n), Dw.shape)
    m = (np.minimum(*np.split(recheck_stack(eye, eye, Dw, T, 0.0, delta_error * np.max(cond)),
                              2)) - 64.0 * n * cond * 2.0 ** -52)
    out[idx] = np.maximum(out[idx], m)
    return out


#: Pieces evaluated per stacked call of :func:`piecewise_modal`.
MODAL_BATCH = 32


def piecewise_modal(delta_at, lo: float, hi: float, T: float, min_width: float,
                    delta_many=None, delta_error: float = 0.0):
    """Cover ``[lo, hi]`` by pieces each certified by one modal ``P`` (adaptive halving).

    Parameters
    ----------
    delta_at : callable
        ``b -> Delta(b)`` (balanced delta matrix, affine in ``b``).
    lo, hi : float
        The interval of ``b``.
    T : float
        Sampling time.
    min_width : float
        Pieces are not halved below this width.
    delta_many : callable, optional
        ``bs -> stack of Delta(b)`` for an array of ``b`` (the same values as ``delta_at``,
        one call per batch instead of one per ``b``).
    delta_error : float, optional
        A bound on the 2-norm error of the deltas (:func:`._lmi.recheck_stack`).

    Returns
    -------
    (list, float or None, tuple or None)
        The certified pieces ``(b_lo, b_hi, P, margin)`` in increasing ``b``, the smallest
        margin, and the failing interval ``(b_lo, b_hi)`` (None when all of ``[lo, hi]`` is
        covered).

    Examples
    --------
    >>> import numpy as np
    >>> pieces, margin, bad = piecewise_modal(lambda b: np.array([[-b]]), 1.0, 2.0, 1e-3, 0.1)
    >>> len(pieces), bad
    (1, None)
    """
    pending, done = [(lo, hi)], []
    while pending:  # the narrowest pieces first, stacked in batches: a range that fails
        # somewhere reaches a failing piece of min_width after ~log2(width) batches, not
        # after every piece of every level (the same pieces are certified either way: each
        # piece's verdict and split depend on that piece alone)
        pending.sort(key=lambda p: (p[1] - p[0]) / max(abs(p[0]), abs(p[1])))
        level, pending = pending[:MODAL_BATCH], pending[MODAL_BATCH:]
        a = np.array([p[0] for p in level])
        b = np.array([p[1] for p in level])
        many = delta_many or (lambda bs: np.stack([delta_at(v) for v in bs]))
        P = modal_lyapunov_stack(many(0.5 * (a + b)), T)
        ends = many(np.concatenate([a, b]))
        k = len(level)
        margin = np.full(k, -np.inf)  # no modal P (NaN): failed, and never rechecked
        g = np.flatnonzero(~np.isnan(P[:, 0, 0]))  # (LAPACK may raise on a NaN matrix)
        if g.size:
            Pg = np.concatenate([P[g], P[g]])
            margin[g] = np.minimum(*np.split(recheck_stack(
                Pg, Pg, np.concatenate([ends[g], ends[k + g]]), T, 0.0, delta_error), 2))
        margin = _whitened(P, ends, T, margin, delta_error)
        for i in range(k):
            if margin[i] > RECHECK_TOL:
                done.append((a[i], b[i], P[i], float(margin[i])))
            elif b[i] - a[i] > min_width * (1.0 + 1e-9):
                mid = 0.5 * (a[i] + b[i])
                pending += [(a[i], mid), (mid, b[i])]
            else:
                return sorted(done, key=lambda p: p[0]), None, (float(a[i]), float(b[i]))
    done.sort(key=lambda p: p[0])
    return [(float(a), float(b), P, m) for a, b, P, m in done], min(p[3] for p in done), None


__all__ = ["common_p_in_modal_basis", "modal_lyapunov", "modal_lyapunov_stack", "piecewise_modal", "real_modal_basis"]
