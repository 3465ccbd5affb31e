"""Two estimators of ``b`` over windows of a log, and the input delay.

Both read the log's model as the paper does: ``y^(rho) = a + b u`` with ``a`` and ``b`` slowly
varying along the visited states, ``u`` held over each sample (ZOH) and reaching the plant
``delay`` samples late. ``U`` is the exact ZOH response of a chain of ``rho`` integrators to the
delayed input (:func:`chain_response`): over a short window, ``y = poly_(rho+1)(t) + b U`` (the
polynomial carries the initial conditions and ``a`` with its drift), so ``b`` is a regression
coefficient and no derivative of the noisy output is ever taken for it. When ``a`` moves within
a window (a motor's back-EMF under a fast loop), its slopes in ``y, y', ...`` are regressors too:
the chain responses of those signals, integrals of ``y`` (:func:`slope_regressors`; the
identification fits them when they cut the residual, ``_identify.SLOPE_GAIN``).

* **local least squares** (``"local-ls"``): per window, ``y`` regressed on a polynomial of
  degree ``rho + 1`` in time and ``U`` (the polynomial projected out once: the windows share
  it); ``b`` with its standard error from the residual;
* **EHGO sigmahat** (``"ehgo-sigmahat"``): the model-free EHGO (the design's own estimator,
  bilinear, all poles at ``-1/eps``) run over ``y`` gives ``sigmahat``; run over ``U`` it gives
  the same filter's image of ``u``; per window ``sigmahat(y)`` regressed on a line in time and
  ``sigmahat(U)``; the standard error is inflated by ``sqrt(eps/T)`` for the filtered,
  correlated residual.

The delay is the lag (0 .. ``max_delay`` samples) whose chain response explains ``y`` best: the
least-squares cross-correlation of ``y`` with the delayed input's chain response (the sum of
squared window residuals of the local fit, smallest wins; lags within :data:`DELAY_TIE` of it
tie and the longest is taken; the next worse lag's ratio is the confidence).

Examples
--------
>>> import numpy as np
>>> from fl_design.identification._estimators import chain_response
>>> chain_response(np.ones(4), 1.0, 2, 0).round(3)   # (k T)^2 / 2 of a unit input
array([0. , 0.5, 2. , 4.5])
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import scipy.signal

#: Lags whose fit is within this fraction of the best are ties (the longest is taken).
DELAY_TIE = 1e-3
#: Names of the estimators.
NAMES = ("local-ls", "ehgo-sigmahat")


def chain_response(u: np.ndarray, T: float, rho: int, delay: int) -> np.ndarray:
    """Exact ZOH response (zero initial state) of ``y^(rho) = u(k - delay)``, sampled."""
    num, den = _chain_tf(float(T), int(rho))
    ud = np.concatenate([np.zeros(delay), u[:u.size - delay]]) if delay else u
    return scipy.signal.lfilter(num, den, ud)


@functools.lru_cache(maxsize=32)
def _chain_tf(T: float, rho: int):
    num, den, _ = scipy.signal.cont2discrete(([1.0], [1.0] + [0.0] * rho), T, method="zoh")
    return np.ravel(num), np.asarray(den, dtype=float)


def _windows(segments, n_win: int, skip: int = 0) -> np.ndarray:
    """Start indices of half-overlapping windows inside each segment (after ``skip``)."""
    starts = []
    for a, b in segments:
        a2 = a + skip
        if b - a2 >= n_win:
            starts.extend(range(a2, b - n_win + 1, max(1, n_win // 2)))
    return np.asarray(starts, dtype=int)


def _poly_basis(n: int, degree: int) -> np.ndarray:
    tau = np.linspace(-1.0, 1.0, n)
    Q, _ = np.linalg.qr(np.vander(tau, degree + 1, increasing=True))
    return Q


def _regress(Y: np.ndarray, U: np.ndarray, Q: np.ndarray, Z: np.ndarray | None = None):
    """Per row: ``Y = Q c + Z_row s + b U``; returns b, its standard error, residual rms,
    ``|U_perp|`` (``Z``: ``(rows, n, m)`` nuisance regressors per row, the slopes of ``a``)."""
    Yp = Y - (Y @ Q) @ Q.T
    Up = U - (U @ Q) @ Q.T
    m = 0
    if Z is not None and Z.shape[-1]:
        m = Z.shape[-1]
        Zp = Z - np.einsum("nk,rkm->rnm", Q @ Q.T, Z)
        for i in range(Y.shape[0]):  # project the slopes' regressors out, window by window
            Qz, _ = np.linalg.qr(Zp[i])
            Yp[i] -= Qz @ (Qz.T @ Yp[i])
            Up[i] -= Qz @ (Qz.T @ Up[i])
    uu = np.einsum("ij,ij->i", Up, Up)
    with np.errstate(divide="ignore", invalid="ignore"):
        b = np.einsum("ij,ij->i", Up, Yp) / uu
        res = Yp - b[:, None] * Up
        dof = max(Y.shape[1] - Q.shape[1] - m - 1, 1)
        s = np.sqrt(np.einsum("ij,ij->i", res, res) / dof)
        se = s / np.sqrt(uu)
    return b, se, s, np.sqrt(uu)


@dataclass(frozen=True)
class WindowEstimates:
    """``b`` per window of one estimator.

    Parameters
    ----------
    name : str
        ``"local-ls"`` or ``"ehgo-sigmahat"``.
    start : numpy.ndarray
        Window start indices (length ``n_win``).
    b, se : numpy.ndarray
        Estimate and standard error per window.
    residual : numpy.ndarray
        Residual rms per window.
    excitation : numpy.ndarray
        Norm of the input's chain response left after the polynomial (local-ls) per window.
    y_mid : numpy.ndarray
        Mean output per window (where in the state space).
    n_win : int
        Samples per window.
    """

    name: str
    start: np.ndarray
    b: np.ndarray
    se: np.ndarray
    residual: np.ndarray
    excitation: np.ndarray
    y_mid: np.ndarray
    n_win: int

    def informative(self, rel: float) -> np.ndarray:
        """Windows whose ``b`` is known within ``rel`` (relative standard error)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.isfinite(self.b) & (self.se <= rel * np.abs(self.b))


def _stack(x: np.ndarray, starts: np.ndarray, n: int) -> np.ndarray:
    view = np.lib.stride_tricks.sliding_window_view(x, n)
    return view[starts]


def _stack_rows(Z: np.ndarray, starts: np.ndarray, n: int) -> np.ndarray:
    """``(windows, n, m)`` slices of the ``(N, m)`` regressors."""
    return np.stack([Z[a:a + n] for a in starts])


def slope_regressors(y, T: float, rho: int) -> np.ndarray:
    """``(N, rho)``: the chain responses of ``y, y', ..., y^(rho-1)`` (``rho - i`` integrals of
    ``y`` for ``y^(i)``, the rest is a polynomial the window's fit carries): with them ``a``'s
    slopes in the output and its derivatives are fitted per window, derivative-free.

    Examples
    --------
    >>> import numpy as np
    >>> slope_regressors(np.ones(3), 1.0, 2).round(3)
    array([[0. , 0. ],
           [0.5, 1. ],
           [2. , 2. ]])
    """
    return np.column_stack([chain_response(y, T, rho - i, 0) for i in range(rho)])


def local_ls(y, U, segments, n_win: int, rho: int, Z=None) -> WindowEstimates:
    """Estimator ``"local-ls"`` (module); ``Z``: :func:`slope_regressors` (None: ``a`` a
    polynomial in time over each window)."""
    starts = _windows(segments, n_win)
    if not starts.size:
        return WindowEstimates("local-ls", starts, *(np.zeros(0),) * 5, n_win)
    Q = _poly_basis(n_win, rho + 1)
    Y, UU = _stack(y, starts, n_win), _stack(U, starts, n_win)
    b, se, s, ex = _regress(Y, UU, Q, None if Z is None else _stack_rows(Z, starts, n_win))
    return WindowEstimates("local-ls", starts, b, se, s, ex, Y.mean(axis=1), n_win)


def ehgo_filter(x: np.ndarray, rho: int, T: float, eps: float, segments) -> np.ndarray:
    """The model-free EHGO's ``sigmahat`` of the signal ``x``, restarted at rest per segment."""
    from ..design import EHGO

    est = EHGO(rho=rho, eps=eps, T=T)
    A, B, C, D = (np.asarray(m, dtype=float) for m in est.matrices)
    k = float(est.unscaling[-1])
    num, den = scipy.signal.ss2tf(A, B.reshape(-1, 1), C[-1:].reshape(1, -1),
                                  np.atleast_2d(D.ravel()[-1]))
    out = np.full(x.size, np.nan)
    for a, b in segments:
        seg = x[a:b] - x[a]
        out[a:b] = k * scipy.signal.lfilter(num[0], den, seg)
    return out


def ehgo_sigmahat(y, U, segments, n_win: int, rho: int, T: float, eps: float,
                  Z=None) -> WindowEstimates:
    """Estimator ``"ehgo-sigmahat"`` (module); ``Z``: :func:`slope_regressors`, filtered
    alike."""
    skip = math.ceil(15.0 * eps / T)
    starts = _windows(segments, n_win, skip=skip)
    if not starts.size:
        return WindowEstimates("ehgo-sigmahat", starts, *(np.zeros(0),) * 5, n_win)
    sy = ehgo_filter(y, rho, T, eps, segments)
    su = ehgo_filter(U, rho, T, eps, segments)
    Q = _poly_basis(n_win, 1)
    Y, UU = _stack(sy, starts, n_win), _stack(su, starts, n_win)
    Zf = None if Z is None else np.column_stack(
        [ehgo_filter(Z[:, j], rho, T, eps, segments) for j in range(Z.shape[1])])
    b, se, s, ex = _regress(Y, UU, Q, None if Zf is None else _stack_rows(Zf, starts, n_win))
    se = se * math.sqrt(max(eps / T, 1.0))
    return WindowEstimates("ehgo-sigmahat", starts, b, se, s, ex,
                           _stack(y, starts, n_win).mean(axis=1), n_win)


def find_delay(y, u, segments, n_win: int, rho: int, T: float, max_delay: int, Z=None):
    """The input delay (samples) and its confidence (module); ``Z`` as in :func:`local_ls`."""
    costs = []
    for d in range(int(max_delay) + 1):
        U = chain_response(u, T, rho, d)
        est = local_ls(y, U, segments, n_win, rho, Z)
        ok = np.isfinite(est.residual)
        costs.append(float(np.sum(est.residual[ok] ** 2)) if ok.any() else math.inf)
    costs = np.asarray(costs)
    best = int(np.argmin(costs))
    near = np.flatnonzero(costs <= costs[best] * (1.0 + DELAY_TIE))
    best = int(near.max())  # lags that fit as well: the longest (the class is conservative)
    others = costs[costs > costs[best] * (1.0 + DELAY_TIE)]
    ratio = float(np.min(others) / costs[best]) if others.size and costs[best] > 0 else math.inf
    return best, ratio, costs


__all__ = ["NAMES", "WindowEstimates", "chain_response", "ehgo_filter", "ehgo_sigmahat",
           "find_delay", "local_ls", "slope_regressors"]
