"""Numerics of the EHGO: companion form, discretization maps, closed-form coefficients.

Kept apart from :class:`fl_design.EHGO` (the validated object) so each stays one concept:
the observer polynomial's companion pair ``(F, L)``, the delta matrix ``A_d - I`` computed
without cancellation, the exact eigenvalue maps of the discretizations, and a blocked linear
simulation used by :meth:`fl_design.EHGO.filter`.

Examples
--------
>>> from fl_design.design import binomial_coeffs
>>> binomial_coeffs(3)
(4.0, 6.0, 4.0, 1.0)
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

#: user-facing method name -> scipy.signal.cont2discrete method
METHODS = {
    "bilinear": "bilinear",
    "forward_euler": "euler",
    "backward_euler": "backward_diff",
    "zoh": "zoh",
}
MAX_RHO = 6
#: realizations of the discrete observer (see :class:`EHGO`)
REALIZATIONS = ("direct", "delta")
#: weight of ``G e`` in the output map ``C_d xi + D_d y = xi + theta G (xi - e_1 y)``
_THETA = {"bilinear": 0.5, "forward_euler": 0.0, "backward_euler": 1.0, "zoh": 0.0}
#: eigenvalue of A_d as a function of alpha * lam, lam an eigenvalue of F
_EIG_MAP = {
    "bilinear": lambda al: (1 + al / 2) / (1 - al / 2),
    "forward_euler": lambda al: 1 + al,
    "backward_euler": lambda al: 1 / (1 - al),
    "zoh": np.exp,
}


class StateSpaceMatrices(NamedTuple):
    """Matrices ``(A, B, C, D)`` of a state-space model (a tuple: unpack or pass to scipy).

    Examples
    --------
    >>> import fl_design as fl
    >>> A, B, C, D = fl.EHGO(rho=1, eps=0.1, T=1e-3).matrices
    >>> A.shape, D.shape
    ((2, 2), (2, 1))
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray


def binomial_coeffs(rho: int) -> tuple[float, ...]:
    """Coefficients ``alpha_i = C(rho+1, i)`` of ``(s + 1)^(rho+1)``: all observer poles at -1.

    Closed form (the pole is repeated: never computed by a pole-placement routine).

    Parameters
    ----------
    rho : int
        Relative degree; the polynomial has degree ``rho + 1``.

    Returns
    -------
    tuple of float
        ``(alpha_1, ..., alpha_(rho+1))``.

    Examples
    --------
    >>> from fl_design.design import binomial_coeffs
    >>> binomial_coeffs(2)
    (3.0, 3.0, 1.0)
    """
    return tuple(float(math.comb(rho + 1, i)) for i in range(1, rho + 2))


def _companion(coeffs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``F`` (observer companion form) and ``L`` of ``eps q' = F q + L y``."""
    n = coeffs.size
    F = np.eye(n, k=1)
    F[:, 0] = -coeffs
    return F, coeffs.reshape(n, 1).copy()


def _delta_matrix(F: np.ndarray, alpha: float, method: str) -> np.ndarray:
    """``G = A_d - I`` without subtracting ``I``: ``(I - theta alpha F)^-1 alpha F`` or ZOH."""
    n = F.shape[0]
    if method == "zoh":  # G = int_0^1 exp(alpha F s) ds alpha F, from one block exponential
        import scipy.linalg  # lazy: 0.2-0.4 s to import, only for ZOH

        block = np.zeros((2 * n, 2 * n))
        block[:n, :n], block[:n, n:] = alpha * F, np.eye(n)
        return scipy.linalg.expm(block)[:n, n:] @ (alpha * F)
    theta = 1.0 if method == "backward_euler" else _THETA[method]
    return np.linalg.solve(np.eye(n) - theta * alpha * F, alpha * F)


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.flags.writeable = False
    return a


def _conjugate_closed(poles: np.ndarray, *, tol: float) -> list[complex]:
    """Return the poles whose complex conjugate is missing from ``poles`` (empty if closed)."""
    remaining = list(poles)
    unpaired = []
    while remaining:
        p = remaining.pop(0)
        if abs(p.imag) <= tol:
            continue
        dist = [abs(q - np.conj(p)) for q in remaining]
        if dist and min(dist) <= tol:
            remaining.pop(int(np.argmin(dist)))
        else:
            unpaired.append(p)
    return unpaired


def _lsim_blocked(A, B, C, D, u, x0, block: int = 128) -> np.ndarray:
    """Outputs of ``x+ = A x + B u, out = C x + D u`` for scalar input u, vectorized per block.

    Within a block of length L the outputs are a Toeplitz product with the Markov parameters
    plus the free response of the block's initial state; only the L-step state propagation
    between blocks is a Python loop (N / L iterations).
    """
    N, n, m = u.size, A.shape[0], C.shape[0]
    if N == 0:
        return np.zeros((0, m))
    L = min(block, N)
    pw = np.empty((L + 1, n, n))
    pw[0] = np.eye(n)
    for i in range(1, L + 1):
        pw[i] = pw[i - 1] @ A
    h = np.empty((L, m))
    h[0] = D[:, 0]
    h[1:] = (C @ pw[: L - 1] @ B)[..., 0]
    lag = np.arange(L)[:, None] - np.arange(L)[None, :]
    toeplitz = np.where((lag >= 0)[..., None], h[np.clip(lag, 0, None)], 0.0)  # (L, L, m)
    free = C @ pw[:L]  # (L, m, n)
    reach = (pw[L - 1 :: -1] @ B)[..., 0]  # (L, n): A^(L-1-j) B
    nb = -(-N // L)
    U = np.zeros(nb * L)
    U[:N] = u
    U = U.reshape(nb, L)
    drive = U @ reach  # (nb, n)
    X0 = np.empty((nb, n))
    x = np.asarray(x0, dtype=float)
    for b in range(nb):
        X0[b] = x
        x = pw[L] @ x + drive[b]
    out = np.einsum("ijm,bj->bim", toeplitz, U) + np.einsum("imn,bn->bim", free, X0)
    return out.reshape(nb * L, m)[:N]


def direct_update(xi, y, p):
    """``(xhat, xi_next, 1)`` of ``xi+ = A_d xi + B_d y``, ``xhat = D^-1 (C_d xi + D_d y)``.

    ``p = [A_d, B_d, C_d, D_d (row-major), diag(D^-1)]``; CasADi expressions.

    Parameters
    ----------
    xi, y, p : casadi.SX or DM
        State ``(n,)``, measurement, parameters ``(2 n^2 + 3 n,)``.

    Returns
    -------
    tuple

    Examples
    --------
    >>> import casadi, fl_design as fl
    >>> from fl_design.design._ehgo_discretization import direct_update
    >>> obs = fl.EHGO(1, 0.1, 1e-3)
    >>> float(direct_update(casadi.DM.zeros(2), 1.0, casadi.DM(obs.parameter_vector()))[2])
    1.0
    """
    import casadi

    from ._estimator import check_length, rows

    n = xi.numel()
    check_length("p", p, 2 * n * n + 3 * n)
    A, B = rows(p, 0, n, n), p[n * n : n * n + n]
    C, D = rows(p, n * n + n, n, n), p[2 * n * n + n : 2 * n * n + 2 * n]
    xhat = p[2 * n * n + 2 * n :] * (casadi.mtimes(C, xi) + D * y)
    return xhat, casadi.mtimes(A, xi) + B * y, type(xi)(1.0)


def delta_update(xi, y, p, *, theta: float):
    """``(xhat, xi_next, 1)`` of the delta realization ``xi+ = xi + G e``, ``e = xi - e_1 y``.

    ``xhat = D^-1 (xi + theta G e)``, ``p = [G (row-major), diag(D^-1)]``: a constant ``y``
    gives exactly zero derivative estimates at rest.

    Parameters
    ----------
    xi, y, p : casadi.SX or DM
        State ``(n,)``, measurement, parameters ``(n^2 + n,)``.
    theta : float
        Output weight of the method (bilinear 1/2, backward Euler 1, others 0).

    Returns
    -------
    tuple

    Examples
    --------
    >>> import casadi, numpy as np, fl_design as fl
    >>> from fl_design.design._ehgo_discretization import delta_update
    >>> obs = fl.EHGO(1, 0.1, 1e-3, realization="delta")
    >>> xhat, _, _ = delta_update(casadi.DM([1.0, 0.0]), 1.0, casadi.DM(obs.parameter_vector()),
    ...                           theta=0.5)
    >>> np.asarray(xhat).ravel().tolist()
    [1.0, 0.0]
    """
    import casadi

    from ._estimator import check_length, rows

    n = xi.numel()
    check_length("p", p, n * n + n)
    g = casadi.mtimes(rows(p, 0, n, n), casadi.vertcat(xi[0] - y, xi[1:]))
    xhat = p[n * n :] * (xi + theta * g if theta else xi)
    return xhat, xi + g, type(xi)(1.0)


def start_state(p, n: int, *, theta: float | None, y0: float, estimate=None) -> np.ndarray:
    """Observer state whose estimate is ``estimate`` at the measurement ``y0`` (from ``p``).

    Without ``estimate`` the observer at rest at ``y0``: ``xi = e_1 y0`` solves
    ``xi = A_d xi + B_d y0`` for every method and both realizations (``(I - A_d)^-1 B_d =
    -F^-1 L = e_1``: ``F e_1 = -L``), whatever ``eps``; its estimate is ``(y0, 0, ..., 0)``.
    With ``estimate`` the state solving ``D^-1 (C_d xi + D_d y0) = estimate`` (direct,
    ``theta=None``) or ``D^-1 (xi + theta G (xi - e_1 y0)) = estimate`` (delta).

    Parameters
    ----------
    p : array_like
        A parameter vector of the realization (see :meth:`fl_design.EHGO.parameter_vector`).
    n : int
        ``rho + 1``.
    theta : float or None
        The delta realization's output weight; None for the direct realization.
    y0 : float
        First measurement.
    estimate : array_like, optional
        ``(rho + 1,)`` estimates ``xhat_1, ..., sigmahat`` at the first sample.

    Returns
    -------
    numpy.ndarray
        ``(n,)`` observer state ``xi`` of the realization ``p`` belongs to.

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.design._ehgo_discretization import start_state
    >>> obs = fl.EHGO(1, 0.1, 1e-3)
    >>> start_state(obs.parameter_vector(), 2, theta=None, y0=0.5).tolist()
    [0.5, 0.0]
    """
    p = np.asarray(p, dtype=float).ravel()
    e1 = np.zeros(n)
    e1[0] = 1.0
    if estimate is None:
        return e1 * float(y0) + 0.0  # + 0.0: no negative zeros
    scaled = np.asarray(estimate, dtype=float) / p[-n:]  # D xhat
    if theta is None:
        C, D = p[n * n + n : 2 * n * n + n].reshape(n, n), p[2 * n * n + n : 2 * n * n + 2 * n]
        return np.linalg.solve(C, scaled - D * y0)
    G = p[: n * n].reshape(n, n)
    return np.linalg.solve(np.eye(n) + theta * G, scaled + theta * G @ e1 * y0)


#: gbt weight of each method (scipy.signal.cont2discrete's generalized bilinear transform).
_GBT = {"bilinear": 0.5, "euler": 0.0, "backward_diff": 1.0}


def discretize(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, dt: float,
               method: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``scipy.signal.cont2discrete`` (gbt and zoh), the same formulas without ``scipy.signal``.

    Importing ``scipy.signal`` costs about 1 s (it pulls in ``scipy.stats``) and ``scipy.linalg``
    0.2-0.4 s; every process building an observer would pay it. The operations are those of
    SciPy 1.17's ``cont2discrete`` (the tests compare with it): the gbt solves use NumPy's LAPACK
    ``gesv`` (LU with partial pivoting, like ``scipy.linalg.solve``; bit-identical results on
    the EHGO matrices of rho 1-6, 300 eps values, all three methods), ZOH ``scipy.linalg.expm``
    (imported only then).

    Parameters
    ----------
    A, B, C, D : numpy.ndarray
        Continuous state-space matrices.
    dt : float
        Step.
    method : {"bilinear", "euler", "backward_diff", "zoh"}
        SciPy's method name.

    Returns
    -------
    tuple of numpy.ndarray
        ``(A_d, B_d, C_d, D_d)``.

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.design._ehgo_discretization import discretize
    >>> discretize(np.array([[-1.0]]), np.ones((1, 1)), np.ones((1, 1)), np.zeros((1, 1)),
    ...            0.1, "zoh")[0].round(6)
    array([[0.904837]])
    """
    if method == "zoh":
        n, m = A.shape[0], B.shape[1]
        em = np.vstack((np.hstack((A, B)), np.zeros((m, n + m))))
        import scipy.linalg

        ms = scipy.linalg.expm(dt * em)[:n, :]
        return ms[:, :n], ms[:, n:], C, D
    alpha = _GBT[method]
    ima = np.eye(A.shape[0]) - alpha * dt * A
    ad = np.linalg.solve(ima, np.eye(A.shape[0]) + (1.0 - alpha) * dt * A)
    bd = np.linalg.solve(ima, dt * B)
    cd = np.linalg.solve(ima.transpose(), C.transpose()).transpose()
    return ad, bd, cd, D + alpha * np.dot(C, bd)


__all__ = ["MAX_RHO", "METHODS", "REALIZATIONS", "StateSpaceMatrices", "binomial_coeffs"]
