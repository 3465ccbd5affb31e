"""The envelope fits behind the classifier (:mod:`fl_design.sim._status`), batched over runs.

``log`` of the error's envelope against time: a least-squares line (slope, standard error,
fitted level), the ``t`` of a quadratic term (a hump or a trough), and where a strictly
decreasing envelope is heading (its successive drops fitted as a geometric sequence).

Examples
--------
>>> import numpy as np
>>> from fl_design.sim._envelope import fit_line
>>> slope, se, level, n = fit_line(np.exp(-np.arange(5.0) / 2), np.arange(5.0))
>>> round(float(slope), 12), int(n)
(-0.5, 5)
"""

from __future__ import annotations

import numpy as np


def fit_line(env: np.ndarray, centres: np.ndarray):
    """Least-squares line through ``log env`` against ``centres`` (last axis): slope, its
    standard error and the points used (finite, positive entries only)."""
    ok = np.isfinite(env) & (env > 0)
    n = ok.sum(axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        y = np.where(ok, np.log(np.where(ok, env, 1.0)), 0.0)
        x = np.where(ok, centres, 0.0)
        xm, ym = x.sum(-1) / n, y.sum(-1) / n
        dx = np.where(ok, x - xm[..., None], 0.0)
        dy = np.where(ok, y - ym[..., None], 0.0)
        sxx = (dx * dx).sum(-1)
        slope = (dx * dy).sum(-1) / sxx
        resid = np.where(ok, dy - slope[..., None] * dx, 0.0)
        se = np.sqrt((resid * resid).sum(-1) / np.maximum(n - 2, 1) / sxx)
        level = ym + slope * (np.where(ok, centres, -np.inf).max(-1) - xm)
    enough = n >= 3
    return (np.where(enough, slope, np.nan), np.where(enough, se, np.nan),
            np.where(enough, np.exp(level), np.nan), n)


def _inverse3(m: np.ndarray) -> np.ndarray:
    """Inverses of a stack of symmetric 3 x 3 normal matrices: batched LU where they are well
    conditioned (thousands of runs: 10x faster than ``pinv``'s SVDs), ``pinv`` for the rest."""
    out = np.empty_like(m)
    flat, res = m.reshape(-1, 3, 3), out.reshape(-1, 3, 3)
    scale = np.abs(np.trace(flat, axis1=1, axis2=2)) / 3.0
    with np.errstate(all="ignore"):
        ok = np.abs(np.linalg.det(flat)) > 1e-12 * scale ** 3 if flat.shape[0] else \
            np.zeros(0, bool)
    ok &= np.all(np.isfinite(flat), axis=(1, 2))
    if np.any(ok):
        res[ok] = np.linalg.inv(flat[ok])
    if np.any(~ok):
        res[~ok] = np.linalg.pinv(flat[~ok])
    return out


def curvature_t(env: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """``t`` statistic of the quadratic term of ``log env`` against ``centres`` (last axis; all
    points finite, at least 5; NaN otherwise): a hump or a trough, half a swing slower than
    the window, is not a flat envelope."""
    ok = np.all(np.isfinite(env) & (env > 0), axis=-1) & (env.shape[-1] >= 5)
    with np.errstate(divide="ignore", invalid="ignore"):
        y = np.log(np.where(np.isfinite(env) & (env > 0), env, 1.0))
        x = centres - centres.mean(-1, keepdims=True)
        x = x / np.max(np.abs(x), axis=-1, keepdims=True)
        X = np.stack([np.ones_like(x), x, x * x], -1)
        X = np.broadcast_to(X, (*y.shape, 3))
        xtx = np.einsum("...ki,...kj->...ij", X, X)
        inv = _inverse3(xtx)
        coef = np.einsum("...ij,...kj,...k->...i", inv, X, y)
        resid = y - np.einsum("...ki,...i->...k", X, coef)
        # residuals below 1e-9 (relative) are rounding: a perfect exponential has no curvature
        var = np.maximum((resid * resid).sum(-1) / max(env.shape[-1] - 3, 1), 1e-18)
        t = coef[..., 2] / np.sqrt(var * inv[..., 2, 2])
    return np.where(ok, t, np.nan)


def asymptote(env: np.ndarray) -> np.ndarray:
    """Where a monotone decaying envelope (last axis) is heading: ``env_last - d_last q / (1 -
    q)``, the differences ``d`` of successive values fitted as a geometric sequence of ratio
    ``q < 1`` (``E = c + A q^i`` gives ``c``; an exponential to zero gives 0). NaN when the
    envelope is not strictly decreasing, has fewer than 4 points, or ``q >= 1``."""
    d = env[..., :-1] - env[..., 1:]
    ok = np.all(np.isfinite(d) & (d > 0), axis=-1) & (env.shape[-1] >= 4)
    with np.errstate(divide="ignore", invalid="ignore"):
        y = np.log(np.where(d > 0, d, 1.0))
        x = np.arange(d.shape[-1], dtype=float)
        xc = x - x.mean()
        q = np.exp((y * xc).sum(-1) / (xc * xc).sum())
        c = env[..., -1] - d[..., -1] * q / (1 - q)
    return np.where(ok & (q < 1), c, np.nan)


__all__ = ["asymptote", "curvature_t", "fit_line"]
