"""The paper's Lyapunov conditions for the linear part: ``P_x``, ``K``, ``lambda_x``, ``H``.

With the chain of integrators ``(A_i, B_i)`` and ``v = K x``, ``K = -(k_1, ..., k_rho)``, the
paper takes ``P_x`` from ``(A_i + B_i K)^T P_x + P_x (A_i + B_i K) = -Q`` and shows, along the
approximate model ``F^a`` (the chain under zero-order hold, ``x+ = M_T x``,
``M_T = exp(T A_i) + Gamma(T) K``)::

    V(F^a x) - V(x) <= -lambda_min(Q) T |x|^2 + H T^2 |x|^2,   lambda_x <= lambda_min(Q)/2

:func:`certify_lyapunov` computes ``P_x`` twice (SciPy's Lyapunov solver and a CVXPY LMI), the
constant ``H`` over ``(0, T]`` and the sampling time below which the decrease
``<= -lambda_x T |x|^2`` holds; :func:`synthesize_gains` gives the smallest gains achieving a
decay rate (all poles at ``-decay``, closed form, proved by a Lyapunov equation).

Examples
--------
>>> import fl_design as fl
>>> c = fl.certify_lyapunov((2, 4), T=1e-3)
>>> c.lambda_x, c.decrease_holds
(0.5, True)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from .. import _validate as V
from ..design._controller import _checked_gains
from ..errors import CertificationError, DimensionError, ParameterError
from ._cert_results import _Result, json_number
from ._surrogate import chain_zoh


@dataclass(frozen=True, repr=False)
class LyapunovCertificate(_Result):
    """Result of :func:`certify_lyapunov`.

    Parameters
    ----------
    gains : tuple of float
        ``(k_1, ..., k_rho)``.
    Q : numpy.ndarray
        The weight.
    P_x : numpy.ndarray
        Solution of the continuous Lyapunov equation (SciPy).
    P_lmi : numpy.ndarray or None
        Smallest-trace ``P`` of the LMI ``A_c^T P + P A_c + Q <= 0`` (Clarabel), None on
        failure.
    lmi_status : str
        Status of the LMI (CVXPY's words: ``"optimal"``, ``"infeasible"``, ...).
    lambda_x : float
        ``lambda_min(Q) / 2``.
    T : float or None
        Sampling time checked.
    H : float or None
        ``max_t lambda_max(M_t^T P M_t - P + lambda_min(Q) t I) / t^2`` on a 200-point grid of
        ``(0, T]``.
    T_bound : float or None
        ``min(T, (lambda_min(Q) - lambda_x) / H)``: on the grid of ``(0, T_bound]`` the
        decrease ``V(F^a x) - V(x) <= -lambda_x t |x|^2`` holds.
    decrease_holds : bool or None
        The decrease ``<= -lambda_x T |x|^2`` at ``T`` itself (NumPy eigenvalues).
    certified : bool
        ``P_x > 0`` and the Lyapunov residual small (and the decrease at ``T`` if given).

    Examples
    --------
    >>> import fl_design as fl
    >>> sorted(fl.certify_lyapunov((1, 2)).to_dict())[:3]
    ['H', 'P_lmi', 'P_x']
    """

    gains: tuple
    Q: np.ndarray
    P_x: np.ndarray
    P_lmi: np.ndarray | None
    lmi_status: str
    lambda_x: float
    T: float | None
    H: float | None
    T_bound: float | None
    decrease_holds: bool | None
    certified: bool

    def _repr_lines(self):
        return [f"gains {self.gains}: certified {self.certified}, lambda_x = {self.lambda_x:g}",
                f"P_x = {np.array2string(self.P_x, precision=4)}",
                f"T = {self.T}, H = {self.H}, decrease below T_bound = {self.T_bound}"]


def _checked_Q(Q, rho: int) -> np.ndarray:
    if Q is None:
        return np.eye(rho)
    try:
        Qa = np.asarray(Q, dtype=float)
    except (TypeError, ValueError):
        raise ParameterError(f"Q must be a real {rho}x{rho} matrix, got {Q!r}") from None
    if Qa.shape != (rho, rho):
        raise DimensionError(f"Q must be {rho}x{rho} (rho = {rho}), got shape {Qa.shape}")
    if not np.all(np.isfinite(Qa)):
        raise ParameterError(f"Q must be finite, got {Qa.tolist()}")
    if np.max(np.abs(Qa - Qa.T)) > 1e-12 * max(1.0, np.max(np.abs(Qa))):
        raise ParameterError(f"Q must be symmetric, got {Qa.tolist()}")
    lam = np.linalg.eigvalsh(Qa)
    if lam[0] <= 0.0:
        raise ParameterError(f"Q must be positive definite; its smallest eigenvalue is "
                             f"{lam[0]:.6g} (Q = {Qa.tolist()})")
    return Qa


def closed_chain(gains) -> np.ndarray:
    """``A_i + B_i K`` (companion matrix of ``s^rho + k_rho s^(rho-1) + ... + k_1``)."""
    k = np.asarray(gains, dtype=float)
    A = np.eye(k.size, k=1)
    A[-1] -= k
    return A


def _lmi_P(Ac, Q):
    """Smallest-trace ``P`` with ``A_c^T P + P A_c + Q <= 0``: Clarabel directly
    (:func:`._sdp.min_linear`, no CVXPY import), counted by :func:`._lmi.solve_count`."""
    from ._lmi import counted
    from ._sdp import min_linear, sym_basis

    B = sym_basis(Q.shape[0])  # P = sum_i x_i B_i
    BA = B @ Ac
    F = -(np.swapaxes(BA, -1, -2) + BA)  # -(A_c^T P + P A_c) - Q >= 0
    r = counted(min_linear, np.trace(B, axis1=1, axis2=2), [(-Q, F)], B.shape[0])
    return (None if r.x is None else np.tensordot(r.x, B, axes=1)), r.status


def certify_lyapunov(gains, Q=None, *, T: float | None = None,
                     raise_on_failure: bool = False) -> LyapunovCertificate:
    """``P_x``, ``lambda_x``, and for a given ``T`` the constant ``H`` along ``F^a``.

    Parameters
    ----------
    gains : sequence of float
        ``(k_1, ..., k_rho)`` (Hurwitz, as for :class:`~fl_design.DynamicController`).
    Q : array_like, optional
        Symmetric positive definite ``rho x rho`` weight (default identity).
    T : float, optional
        Sampling time: compute ``H``, ``T_bound`` and the decrease at ``T``.
    raise_on_failure : bool, optional
        Raise :class:`~fl_design.errors.CertificationError` when not certified.

    Returns
    -------
    LyapunovCertificate

    Raises
    ------
    ParameterError
        ``Q`` not symmetric positive definite, gains not Hurwitz.

    Examples
    --------
    >>> import numpy as np, fl_design as fl
    >>> c = fl.certify_lyapunov((2, 4), np.diag([2.0, 1.0]), T=0.01)
    >>> bool(np.allclose(c.P_x, c.P_lmi, atol=1e-6)), c.lambda_x
    (True, 0.5)
    """
    k = _checked_gains(gains)
    Qa = _checked_Q(Q, len(k))
    Ac = closed_chain(k)
    P = scipy.linalg.solve_continuous_lyapunov(Ac.T, -Qa)
    P = (P + P.T) / 2
    P_lmi, status = _lmi_P(Ac, Qa)
    lam_q = float(np.linalg.eigvalsh(Qa)[0])
    resid = np.max(np.abs(Ac.T @ P + P @ Ac + Qa)) / max(1.0, np.max(np.abs(Qa)))
    ok = bool(np.linalg.eigvalsh(P)[0] > 0 and resid < 1e-9)
    H = T_bound = holds = None
    if T is not None:
        T = V.positive("T", T)
        S, eye = [], np.eye(len(k))
        for t in np.geomspace(1e-3 * T, T, 200):  # delta form: no cancellation in M^T P M - P
            Phi, Gam = chain_zoh(len(k), t)
            D = (Phi - eye) / t - np.outer(Gam / t, k)
            W = (D.T @ P + P @ D + lam_q * eye) / t + D.T @ P @ D
            S.append(np.linalg.eigvalsh((W + W.T) / 2)[-1])
        H = max(float(max(S)), 0.0)
        T_bound = T if H == 0.0 else min(T, (lam_q - lam_q / 2) / H)
        Phi, Gam = chain_zoh(len(k), T)
        M = Phi - np.outer(Gam, k)
        holds = bool(np.linalg.eigvalsh(M.T @ P @ M - P)[-1] <= -lam_q / 2 * T)
        ok = ok and holds
    if raise_on_failure and not ok:
        raise CertificationError(f"gains {k} not certified (decrease at T={T}: {holds})")
    return LyapunovCertificate(gains=k, Q=Qa, P_x=P, P_lmi=P_lmi, lmi_status=status,
                               lambda_x=lam_q / 2, T=T, H=json_number(H), T_bound=T_bound,
                               decrease_holds=holds, certified=ok)


@dataclass(frozen=True, repr=False)
class GainSynthesis(_Result):
    """Result of :func:`synthesize_gains`.

    Parameters
    ----------
    gains : tuple of float or None
        ``(k_1, ..., k_rho)``, None when the LMI failed.
    P : numpy.ndarray or None
        Lyapunov matrix of the decay: ``(A_c + decay I)^T P + P (A_c + decay I) < 0``.
    decay : float
        Asked decay rate.
    eigenvalues : numpy.ndarray or None
        Eigenvalues of ``A_i + B_i K`` (NumPy).
    solver_status : str
        How the gains were obtained (and why not certified).
    certified : bool
        Every eigenvalue has real part ``<= -decay`` (NumPy) and ``P > 0``.

    Examples
    --------
    >>> import fl_design as fl
    >>> fl.synthesize_gains(2, decay=1.0).certified
    True
    """

    gains: tuple | None
    P: np.ndarray | None
    decay: float
    eigenvalues: np.ndarray | None
    solver_status: str
    certified: bool

    def to_dict(self) -> dict:
        out = super().to_dict()
        if self.eigenvalues is not None:
            out["eigenvalues"] = [[float(z.real), float(z.imag)] for z in self.eigenvalues]
        return out

    def _repr_lines(self):
        return [f"gains {self.gains} for decay {self.decay:g}: certified {self.certified}"]


#: The poles are placed at ``-(1 + DECAY_SPARE) * decay``: a repeated root's computed
#: eigenvalues scatter by ``~ (machine eps)^(1/rho)`` relative, 2e-3 at rho = 6.
DECAY_SPARE = 0.02


def synthesize_gains(rho: int, *, decay: float, max_gain: float = 1e4) -> GainSynthesis:
    """The smallest gains ``K`` with every mode of ``A_i + B_i K`` decaying at least at ``decay``.

    Every monic polynomial whose roots have real parts ``<= -d`` is
    ``sum_j c_j (s + d)^j`` with ``c_j >= 0`` (its roots shifted by ``d`` are Hurwitz, and a
    Hurwitz polynomial has nonnegative coefficients), so its coefficients are, entry by
    entry, at least those of ``(s + d)^rho``: all poles at ``-d`` are the smallest gains that
    achieve the decay, and exist for every ``rho`` and ``d > 0``. The poles are placed at
    ``-(1 + DECAY_SPARE) d`` (closed form, :func:`fl_design.design._poles.monic_coefficients`),
    and the decay is proved by ``P = T^-T T^-1`` with ``T`` the scaled Jordan basis of the
    repeated root (``T^-1 A_c T = lam I + e N``, ``e = DECAY_SPARE d / 2``): NumPy checks that
    the symmetric part of ``T^-1 (A_c + d I) T`` is negative definite (then
    ``V = x^T P x`` decays at ``2 d``), and the eigenvalues.

    Parameters
    ----------
    rho : int
        Relative degree (1..6).
    decay : float
        Decay rate > 0 asked of every closed-loop mode.
    max_gain : float, optional
        Largest gain accepted: a result above it is returned not certified, saying so.

    Returns
    -------
    GainSynthesis

    Examples
    --------
    >>> import fl_design as fl
    >>> s = fl.synthesize_gains(2, decay=0.5)
    >>> s.gains, bool(max(s.eigenvalues.real) <= -0.5)
    ((0.2601, 1.02), True)
    """
    from ..design._poles import monic_coefficients

    rho = V.integer("rho", rho, minimum=1, maximum=6)
    decay = V.positive("decay", decay)
    max_gain = V.positive("max_gain", max_gain)
    coeffs = monic_coefficients(np.full(rho, -(1.0 + DECAY_SPARE) * decay, dtype=complex))
    gains = tuple(float(c) for c in coeffs[::-1])  # s^rho + k_rho s^(rho-1) + ... + k_1
    Ac = closed_chain(gains)
    lam = -(1.0 + DECAY_SPARE) * decay
    # Jordan basis of the companion matrix at its repeated root: v_j = (1/j!) d^j/dlam^j of
    # (1, lam, ..., lam^(rho-1)), scaled by eps^j so that T^-1 A_c T = lam I + eps N
    idx = np.arange(rho)
    Vj = np.array([[math.comb(i, j) * lam ** (i - j) if i >= j else 0.0 for j in idx]
                  for i in idx])
    Tm = Vj * (0.5 * DECAY_SPARE * decay) ** idx[None, :]
    K = np.linalg.solve(Tm, (Ac + decay * np.eye(rho)) @ Tm)  # re-checked, not assumed
    positive = bool(np.linalg.eigvalsh((K + K.T) / 2)[-1] < 0)
    Ti = np.linalg.inv(Tm)
    P = Ti.T @ Ti  # V(x) = |T^-1 x|^2 decays at rate 2 decay
    eig = np.linalg.eigvals(Ac)
    ok = bool(np.max(eig.real) <= -decay and positive)
    status = "closed form: all poles at -(1 + DECAY_SPARE) decay"
    if max(gains) > max_gain:
        ok, status = False, f"{status}; a gain {max(gains):.6g} exceeds max_gain = {max_gain:g}"
    return GainSynthesis(gains, P, decay, eig, status, ok)


__all__ = ["GainSynthesis", "LyapunovCertificate", "certify_lyapunov", "closed_chain",
           "synthesize_gains"]
