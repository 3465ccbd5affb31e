"""Lur'e certificate of the sampled loop: the friction as a static monotone slope-restricted map.

**Why this argument.** A common quadratic ``P`` fails on the TRMS because the friction's slope
``d sigma/d x_rho`` spans ``[-505, -5]`` and the LDI lets it switch arbitrarily in time. The
friction is not arbitrary: it is a *static, monotone, slope-restricted* function of ``x_rho``.
This module keeps that structure (a Lur'e system) and asks for a Lyapunov function that depends
on the nonlinearity (Popov / Jury-Lee type, both signs of the integral term)::

    x_rho' = -a0 x_rho - phi(x_rho) + b u,   phi(0) = 0,  0 <= phi' <= k  (rho = 2)
    V(X) = X^T P X + 2 (q+ - q-) int_0^{x_rho} phi(s)/k ds

It is the cheapest tool that uses the structure and reuses the loop's exact sample maps
(:func:`._sector.loop_channels` with the linear part ``-a0``); Zames-Falb multipliers
(non-causal) and piecewise-quadratic functions are stronger and not implemented.

**The sampled model, exact.** Over one sample ``u`` is held and ``w = x_rho`` solves a scalar
autonomous ODE, so ``w(t)`` is monotone between ``w_k`` and ``w_(k+1)`` and so is ``phi(w(t))``.
Variation of constants gives, exactly, ``X+ = M(b) X + B(b) psi - k beta e_w Phi - k g e_1
Phi'`` where ``beta = (1 - e^(-a0 T))/a0``, ``g = (T - beta)/a0`` and ``Phi``, ``Phi'`` are
weighted means (positive kernels) of ``phi(w(t))/k``: both lie between ``p0 = phi(w_k)/k`` and
``p1 = phi(w_(k+1))/k``. ``b = g(u_k)/u_k`` is constant over the sample; ``psi`` are the
dead-zones of the input limits and the estimate clamp (:mod:`._sector`), here with their global
sector condition (``G = K``: valid for every state, so a certificate is global).

**Conditions (S-procedure).** With ``dp = (p1 - p0)/T``, ``dF = (Phi - p0)/T``, ``dF' = (Phi' -
p0)/T`` (scaled so that the LMI stays well conditioned): ``p0 (w0 - p0) >= 0``, ``p1 (w1 - p1)
>= 0`` (sector), ``dp (dw - dp) >= 0`` (slope, ``dw = (w1 - w0)/T``), ``dF (dp - dF) >= 0``,
``dF' (dp - dF') >= 0`` (the means lie between), the dead-zones' sector. The integral term's
increment is bounded by monotonicity: ``int_{w0}^{w1} phi <= phi(w1)(w1 - w0)`` and
``>= phi(w0)(w1 - w0)``. Asked at both ends of ``b`` (the form is affine in ``b``), in the delta
form of :mod:`._sector`::

    (V(X+) - V(X)) / T + kappa X^T P X + sum(multipliers x constraints) <= 0

The LMI is solved with ``2 kappa``; :func:`recheck_lure` rebuilds every form in NumPy and asks
``lambda_max <= -margin ||.||_F`` at ``kappa``, ``P - q- e_w e_w^T > 0`` (``V`` positive
definite) and non-negative multipliers. Then ``V`` decreases by ``kappa T X^T P X`` every sample
for every plant of the class, from every start: global exponential convergence.

**Measured on the TRMS** (``verify/claim_12_step_certified.py``): with ``b in [3.6, 6.8]`` no
certificate even for the linear part alone at ``a0 >= 450`` (the sticky regime's slow mode
with ``b`` switching); with ``b`` frozen the friction slope range certified stays narrow (the
paper's ``k = 500`` is not). So the TRMS's 0.3 rad step stays NOT certified by this argument.

Examples
--------
>>> import fl_design as fl
>>> paper = fl.presets.paper_design()
>>> free = fl.Design(estimator=paper.estimator,
...                  controller=fl.DynamicController((2.0, 4.0), 3e-4, ki=1e-3))
>>> lure_certificate(free, (3.6, 3.6), 5.0, 2.0).certified
True
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError
from ._cert_results import _Result
from ._sector import RECHECK_MARGIN


@dataclass(frozen=True, repr=False)
class LureCertificate(_Result):
    """The answer of :func:`lure_certificate`.

    Parameters
    ----------
    certified : bool
        The LMI was solved and passed :func:`recheck_lure`.
    argument : str
        The class and the Lyapunov function, in words.
    worst : float
        The re-check's worst relative value (< 0: every inequality holds with margin).
    seconds : float
        Wall time.
    P : numpy.ndarray or None
        ``V``'s quadratic part over the loop coordinates ``names``.
    q_plus, q_minus : float
        The integral term's coefficients (``V = X^T P X + 2 (q+ - q-) int phi/k``).
    names : tuple of str
        Loop coordinates.
    tau : numpy.ndarray or None
        The five S-procedure multipliers (sector at ``k``, at ``k+1``, slope, the two means).
    s : numpy.ndarray or None
        The dead-zones' multipliers.
    kappa : float
        The decay certified.
    W : numpy.ndarray or None
        The coordinates of the re-check (``X = W Xt``; :func:`recheck_lure` takes ``W`` and
        ``W^T P W``).
    """

    certified: bool
    argument: str
    worst: float
    seconds: float
    P: object = None
    q_plus: float = math.nan
    q_minus: float = math.nan
    names: tuple = ()
    tau: object = None
    s: object = None
    kappa: float = math.nan
    W: object = None

    def _repr_lines(self):
        return [("certified" if self.certified else "NOT certified") + ": " + self.argument,
                f"re-check worst {self.worst:.3g} ({self.seconds:.2f} s)"]


@dataclass(frozen=True)
class _Model:
    """The exact sampled Lur'e model at each end of ``b`` (module docstring)."""

    Rs: tuple       # (n, N) per b end: (X+ - X)/T = R zeta
    N: int
    n: int
    m: int
    K: np.ndarray
    H: np.ndarray
    T: float
    names: tuple
    i_w: int        # index of x_rho in X


def lure_model(design, b_bounds, damping: float, slope: float) -> _Model:
    """The sampled loop ``X+ = X + T R zeta``, ``zeta = (X, psi, p0, dp, dF, dF')``.

    Parameters
    ----------
    design : Design
        An EHGO design with ``rho = 2``.
    b_bounds : (float, float)
        Range of ``b = g(u)/u`` (positive).
    damping : float
        The linear part's damping ``a0 >= 0`` (``x_2' = -a0 x_2 - phi(x_2) + b u``).
    slope : float
        Upper slope bound ``k > 0`` of ``phi``.

    Returns
    -------
    _Model

    Examples
    --------
    >>> import fl_design as fl
    >>> lure_model(fl.presets.paper_design(), (3.6, 6.8), 5.0, 500.0).N
    13
    """
    from ._sector import loop_channels

    if design.rho != 2:
        raise ParameterError(f"the Lur'e certificate handles rho = 2 (the friction acts on x_2), "
                             f"got rho = {design.rho}")
    a0, k = float(damping), float(slope)
    if not (math.isfinite(a0) and a0 >= 0):
        raise ParameterError(f"damping must be a finite number >= 0, got {damping!r}")
    if not (math.isfinite(k) and k > 0):
        raise ParameterError(f"slope must be a finite number > 0, got {slope!r}")
    try:
        blo, bhi = (float(x) for x in b_bounds)
    except (TypeError, ValueError):
        raise ParameterError(f"b_bounds must be (b_min, b_max), got {b_bounds!r}") from None
    if not (0 < blo <= bhi and math.isfinite(bhi)):
        raise ParameterError(f"b_bounds must satisfy 0 < b_min <= b_max < inf, got {b_bounds!r}")
    T = float(design.T)
    beta = T * math.exp(-a0 * T / 2) * _sinhc(a0 * T / 2)  # (1 - e^(-a0 T))/a0, also a0 = 0
    g = T * T / 2 if a0 * T < 1e-8 else (T - beta) / a0
    Rs, chs = [], []
    for b in sorted({blo, bhi}):
        ch = loop_channels(design, (b, b), [(0.0, 0.0), (-a0, -a0)])
        chs.append(ch)
    ch = chs[0]
    n, m = ch.Ms.shape[1], ch.K.shape[0]
    N = n + m + 4
    i_w = 1
    fw, fe = np.zeros(n), np.zeros(n)
    fw[i_w] = -k * beta / T
    fe[0] = -k * g / T
    for c in chs:
        R = np.zeros((n, N))
        R[:, :n] = (c.Ms[0] - np.eye(n)) / T
        R[:, n:n + m] = c.Bs[0] / T
        R[:, n + m] = fw + fe          # Phi = p0 + T dF, Phi' = p0 + T dF'
        R[:, n + m + 2] = T * fw
        R[:, n + m + 3] = T * fe
        Rs.append(R)
    return _Model(tuple(Rs), N, n, m, ch.K, ch.H, T, ch.names, i_w)


def _sinhc(x: float) -> float:
    return 1.0 if x == 0 else math.sinh(x) / x


def _forms(mod: _Model, R: np.ndarray, W: np.ndarray):
    """The constant quadratic forms in ``zeta`` (coordinates ``X = W Xt``)."""
    N, n, m, T = mod.N, mod.n, mod.m, mod.T

    def e(i):
        v = np.zeros(N)
        v[i] = 1.0
        return v

    def sym(a, b):
        A = np.outer(a, b)
        return (A + A.T) / 2

    wrow = np.zeros(N)
    wrow[:n] = W[mod.i_w]
    wR = W[mod.i_w] @ R
    p0, dp, dF, dFp = (e(n + m + i) for i in range(4))
    p1 = p0 + T * dp
    w1 = wrow + T * wR
    cons = [sym(p0, wrow - p0), sym(p1, w1 - p1), sym(dp, wR - dp), sym(dF, dp - dF),
            sym(dFp, dp - dFp)]
    return wR, p0, p1, dp, cons


def _assemble(mod, R, W, P, qp, qm, tau, s, kappa, lib=np):
    """``Omega`` (the delta form without ``T R^T P R``) of one ``b`` end."""
    n, m, N = mod.n, mod.m, mod.N
    wR, p0, p1, dp, cons = _forms(mod, R, W)
    Ex = np.zeros((n, N))
    Ex[:, :n] = np.eye(n)
    PR = Ex.T @ P @ R
    Om = PR + PR.T + kappa * (Ex.T @ P @ Ex)
    qa, qb = np.outer(p1, wR), np.outer(p0, wR)
    dd = mod.T * np.outer(dp, dp)  # the slope bound's triangle: exact for a linear phi
    Om = Om + qp * (qa + qa.T - dd) - qm * (qb + qb.T + dd)
    for i, C in enumerate(cons):
        Om = Om + tau[i] * C
    if m:
        Ep = np.zeros((m, N))
        Ep[:, n:n + m] = np.eye(m)
        Gx = np.zeros((m, N))
        Gx[:, :n] = mod.K @ W
        S = lib.diag(s) if lib is not np else np.diag(s)
        A = Ep.T @ S @ ((np.eye(m) - mod.H) @ Ep - Gx)
        Om = Om - (A + A.T)
    return Om


def recheck_lure(mod: _Model, W, P, qp, qm, tau, s, kappa) -> float:
    """Worst relative value of every inequality (< 0: all hold with :data:`RECHECK_MARGIN`).

    Plain NumPy: each ``b`` end's ``Omega + T R^T P R`` (``lambda_max / ||.||_F``), ``V``'s
    positive definiteness ``P - q- w w^T`` (``-lambda_min / ||P||``) and the signs.
    """
    if min(qp, qm, float(np.min(tau)), float(np.min(s)) if mod.m else 0.0) < 0:
        return math.inf
    worst = -math.inf
    for R0 in mod.Rs:
        R = np.linalg.solve(W, R0[:, :mod.n] @ W)
        R = np.hstack([R, np.linalg.solve(W, R0[:, mod.n:])])
        A = _assemble(mod, R, W, P, qp, qm, tau, s, kappa) + mod.T * (R.T @ P @ R)
        A = (A + A.T) / 2
        worst = max(worst, float(np.linalg.eigvalsh(A)[-1]) / np.linalg.norm(A))
    ww = np.outer(W[mod.i_w], W[mod.i_w])
    worst = max(worst, -float(np.linalg.eigvalsh(P - qm * ww)[0]) / np.linalg.norm(P))
    return worst + RECHECK_MARGIN


def lure_certificate(design, b_bounds, damping: float, slope: float, *,
                     kappa: float = 1e-5) -> LureCertificate:
    """Global Lur'e certificate of the sampled loop for the class of the module docstring.

    Parameters
    ----------
    design : Design
        An EHGO design with ``rho = 2``; its input limits and estimate clamps are inside.
    b_bounds : (float, float)
        Range of ``b = g(u)/u`` over the input range (positive), varying in time.
    damping : float
        Linear damping ``a0 >= 0``.
    slope : float
        ``phi`` is monotone with slope in ``[0, slope]``.
    kappa : float, optional
        Decay asked (``V(X+) - V(X) <= -kappa T X^T P X``), > 0.

    Returns
    -------
    LureCertificate

    Raises
    ------
    ParameterError
        ``rho != 2``, a negative damping, a non-positive slope, bad ``b`` bounds or kappa.

    Examples
    --------
    >>> import fl_design as fl
    >>> lure_certificate(fl.presets.paper_design(), (3.6, 6.8), 450.0, 55.0).certified
    False
    """
    import cvxpy as cp

    from ._analytic import real_modal_basis
    from ._lmi import solve_quietly

    t0 = time.perf_counter()
    kap = float(kappa)
    if not (math.isfinite(kap) and kap > 0):
        raise ParameterError(f"kappa must be a finite number > 0, got {kappa!r}")
    mod = lure_model(design, b_bounds, damping, slope)
    n, m, T = mod.n, mod.m, mod.T
    blo, bhi = (float(x) for x in b_bounds)
    words = (f"every plant x_2' = -{float(damping):g} x_2 - phi(x_2) + b u with phi monotone, "
             f"phi(0) = 0, slope in [0, {float(slope):g}], b in [{blo:g}, {bhi:g}] varying in "
             f"time; the design's input limits and estimate clamps (global sector); V = X^T P X "
             f"+ 2 q int_0^x2 phi/k (Popov/Jury-Lee type), decay kappa = {kap:g} 1/s")
    W = real_modal_basis(sum(R[:, :n] for R in mod.Rs) / len(mod.Rs))
    if np.linalg.cond(W) > 1e8:
        W = np.eye(n)
    Wi = np.linalg.inv(W)
    P = cp.Variable((n, n), symmetric=True)
    qp, qm = cp.Variable(nonneg=True), cp.Variable(nonneg=True)
    tau = cp.Variable(5, nonneg=True)
    s = cp.Variable(m, nonneg=True) if m else np.zeros(0)
    ww = np.outer(W[mod.i_w], W[mod.i_w])
    cons = [P >> np.eye(n), P - qm * ww >> 1e-3 * np.eye(n)]
    sT = math.sqrt(T)
    for R0 in mod.Rs:
        R = np.hstack([Wi @ R0[:, :n] @ W, Wi @ R0[:, n:]])
        Om = _assemble(mod, R, W, P, qp, qm, tau, s, 2.0 * kap, lib=cp)
        big = cp.bmat([[Om, sT * R.T @ P], [sT * P @ R, -P]])
        cons.append((big + big.T) / 2 << -1e-9 * np.eye(mod.N + n))
    prob = cp.Problem(cp.Minimize(cp.trace(P)), cons)
    err = solve_quietly(prob)
    if err is not None or prob.status != "optimal" or P.value is None:
        why = f"solver: {err}" if err is not None else f"status {prob.status}"
        return LureCertificate(False, f"no Lur'e certificate ({why}) for {words}", math.inf,
                               time.perf_counter() - t0, names=mod.names)
    Pv = (P.value + P.value.T) / 2
    vals = (max(float(qp.value), 0.0), max(float(qm.value), 0.0),
            np.maximum(np.asarray(tau.value, float), 0.0),
            np.maximum(np.asarray(s.value, float), 0.0) if m else np.zeros(0))
    worst = recheck_lure(mod, W, Pv, *vals, kap)
    ok = worst < 0
    Px = Wi.T @ Pv @ Wi  # back to the loop coordinates X
    head = "Lur'e certificate (re-checked)" if ok else "the Lur'e LMI's solution FAILED the re-check"
    return LureCertificate(bool(ok), f"{head}: {words}", float(worst),
                           time.perf_counter() - t0, Px if ok else None,
                           vals[0] if ok else math.nan, vals[1] if ok else math.nan, mod.names,
                           vals[2] if ok else None, vals[3] if ok else None, kap,
                           W if ok else None)


__all__ = ["LureCertificate", "lure_certificate", "lure_model", "recheck_lure"]
