"""The sampled EHGO loop built from the paper's equations, apart from fl_design (for the attacks).

Plant: the chain ``x_i' = x_(i+1)``, ``x_rho' = a^T x + b u`` with ``u`` held over each sample
(exact zero-order hold, the matrix exponential of the augmented chain). Observer: the scaled
EHGO ``eps q' = F q + L y`` (companion ``F``, ``L = alpha``) discretized by Tustin with step
``T / eps`` (``A_d = (I - h F/2)^-1 (I + h F/2)``, ``B_d = (I - h F/2)^-1 h L``, output
``q = C_d xi + D_d y`` with ``C_d = (I - h F/2)^-1``, ``D_d = C_d h L / 2``), estimates
``xhat = diag(1, 1/eps, ..., 1/eps^rho) q``. Controller, in the normative order: ``z_k =
z_(k-1) + T xhat_1``, ``v = -sum k_i xhat_i - k_I z_k``, ``u_k = u_(k-1) + gamma (v -
xhat_(rho+1))``; the observer then takes ``y_k``. State ``(x, u, [z,] xi)``; ``z`` is left out
when ``k_I = 0`` (it feeds nothing: an eigenvalue 1 that is no mode of the loop).

Everything is computed in :mod:`mpmath` at ``dps`` digits from the design's numbers (the
``float`` matrices are the rounded exact ones), so a growth found in double precision can be
confirmed without the rounding of a near-unit-circle, ill-conditioned loop.

Examples
--------
>>> M = loop_matrix(rho=2, T=1e-3, eps=0.01, alphas=(3, 3, 1), gains=(1, 2), gamma=0.01, b=2.0)
>>> M.shape
(6, 6)
"""

from __future__ import annotations

import mpmath
import numpy as np


def _mp_loop(rho, T, eps, alphas, gains, ki, gamma, b, a_row, dps):
    mp = mpmath.mp
    old = mp.dps
    mp.dps = dps
    try:
        T, eps, gamma, b, ki = (mpmath.mpf(v) for v in (T, eps, gamma, b, ki))
        n_o = rho + 1
        # plant ZOH: exp(T [[A_c, e_rho], [0, 0]]) with A_c the chain (+ a in its last row)
        Z = mpmath.zeros(rho + 1, rho + 1)
        for i in range(rho):
            Z[i, i + 1] = 1
        if a_row is not None:
            for j in range(rho):
                Z[rho - 1, j] += mpmath.mpf(a_row[j])
        E = mpmath.expm(Z * T)
        # scaled EHGO, Tustin with h = T / eps
        F = mpmath.zeros(n_o, n_o)
        L = mpmath.zeros(n_o, 1)
        for i in range(n_o):
            L[i, 0] = mpmath.mpf(alphas[i])
            F[i, 0] = -L[i, 0]
            if i + 1 < n_o:
                F[i, i + 1] = 1
        h = T / eps
        Im = mpmath.eye(n_o) - F * (h / 2)
        Cd = mpmath.inverse(Im)
        Ad = Cd * (mpmath.eye(n_o) + F * (h / 2))
        Bd = Cd * L * h
        Dd = Cd * L * (h / 2)
        use_z = ki != 0
        n = rho + 1 + (1 if use_z else 0) + n_o
        iu, iz, i0 = rho, rho + 1, rho + 1 + (1 if use_z else 0)
        # rows: xhat_j (as a row over the state) = eps^-j (Cd[j] xi + Dd[j] x_1)
        Xh = mpmath.zeros(n_o, n)
        for j in range(n_o):
            s = eps ** (-j)
            for c in range(n_o):
                Xh[j, i0 + c] = s * Cd[j, c]
            Xh[j, 0] += s * Dd[j, 0]
        zrow = mpmath.zeros(1, n)
        if use_z:
            zrow[0, iz] = 1
            for c in range(n):
                zrow[0, c] += T * Xh[0, c]
        urow = mpmath.zeros(1, n)
        urow[0, iu] = 1
        for c in range(n):
            v = -sum(mpmath.mpf(gains[i]) * Xh[i, c] for i in range(rho)) - ki * zrow[0, c]
            urow[0, c] += gamma * (v - Xh[rho, c])
        M = mpmath.zeros(n, n)
        for i in range(rho):
            for c in range(rho):
                M[i, c] += E[i, c]
            for c in range(n):  # held input: x+ = Phi x + Gamma b u_k
                M[i, c] += E[i, rho] * b * urow[0, c]
        for c in range(n):
            M[iu, c] = urow[0, c]
            if use_z:
                M[iz, c] = zrow[0, c]
        for j in range(n_o):
            for c in range(n_o):
                M[i0 + j, i0 + c] = Ad[j, c]
            M[i0 + j, 0] += Bd[j, 0]
        return M
    finally:
        mp.dps = old


def loop_matrix(*, rho, T, eps, alphas, gains, gamma, b, ki=0.0, a_row=None, dps=40,
                exact=False):
    """The loop matrix ``X_(k+1) = M X_k`` (``float`` array, or the mpmath matrix when
    ``exact``).

    Parameters
    ----------
    rho, T, eps : int, float, float
        Relative degree, sampling time, observer time constant.
    alphas, gains : sequence of float
        Observer coefficients ``alpha_1..alpha_(rho+1)``, controller gains ``k_1..k_rho``.
    gamma, b, ki : float
        Controller gain (the sign of ``b``), the high-frequency gain, integral gain.
    a_row : sequence of float, optional
        Slopes ``d sigma / d x_i`` (None: ``a = 0``).
    dps : int
        mpmath digits.
    exact : bool
        Return the mpmath matrix.

    Returns
    -------
    numpy.ndarray or mpmath.matrix

    Examples
    --------
    >>> M = loop_matrix(rho=1, T=1e-3, eps=0.01, alphas=(2, 1), gains=(1,), gamma=0.1, b=1.0)
    >>> bool(np.max(np.abs(np.linalg.eigvals(M))) < 1)
    True
    """
    M = _mp_loop(int(rho), T, eps, tuple(alphas), tuple(gains), ki, gamma, b,
                 None if a_row is None else tuple(a_row), dps)
    if exact:
        return M
    return np.array(M.tolist(), dtype=float)


__all__ = ["loop_matrix"]
