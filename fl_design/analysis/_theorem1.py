"""Theorem 1's constants as the paper defines them: ``lambda_x``, ``lambda_u``, ``H``, ``eps*``.

The paper's proof (state feedback, the chain ``x_rho' = a + b u`` with ``a = 0`` here, the
sample step ``h = alpha eps``) takes ``Vbar = x^T P_x x + e_u^2 / 2`` with
``(A_i + B_i K)^T P_x + P_x (A_i + B_i K) = -Q``, ``e_u = v(x) - x_(rho+1) = K x - b u`` and the
dynamic controller ``u+ = u + gamma e_u``, and shows

    Vbar(F^e) - Vbar <= -lambda_x eps |x|^2 - lambda_u e_u^2 + H eps^2 (|x|^2 + e_u^2),

where its ``eps`` multiplies ``A_i`` as the sample step (``A = I + A_i eps alpha``, the bound
written for ``alpha = 1``); here the step is ``h = alpha eps`` throughout (``H`` per ``h^2``),

``lambda_x <= lambda_min(Q)/2``, ``lambda_u`` "small enough", then
``eps* < (lambda_x - lambda)/H`` with ``lambda < min(lambda_x, lambda_u)``. Computed here:

* ``lambda_x = lambda_min(Q)/2``;
* ``lambda_u = min_b (1 - (1 - b gamma)^2) / 4``: half of the exact per-sample decrease of
  ``e_u^2/2`` under ``e_u+ = (1 - b gamma) e_u`` (the paper's completion of squares), over the
  ends of the ``b`` interval (the expression is concave in ``b``);
* ``H = max lambda_max(W(h, b) + diag(lambda_x h I, lambda_u)) / h^2`` over a log grid
  of ``h`` in ``[1e-9, alpha eps_max]`` and ``b`` at both ends, where ``W = Mbar^T Pbar Mbar - Pbar``
  is the exact one-sample change of ``Vbar`` of the sampled loop (exact ZOH of the chain with
  step ``h = alpha eps``, ``b`` constant over the sample), ``Pbar = diag(P_x, 1/2)``;
* ``eps* = min(lambda_x / H, sqrt(lambda_u / H)) / alpha`` (the supremum over
  ``lambda -> 0``: the ``x`` decrease needs ``h < lambda_x / H``, the ``e_u`` decrease
  ``h^2 < lambda_u / H``).

**What it is.** A bound on the *sampling step*: ``h* = alpha eps*`` (:attr:`step_bound`).
The theorem covers the sampled state-feedback loop for ``T < h*``; at the paper's
``gamma = 3e-3`` it is about 5e-5 s, twenty times below the paper's ``T = 1 ms``, so the
theorem says nothing about the paper's experiment (:meth:`Theorem1Constants.verdict`).

**How this differs from the LMI certificates.** The theorem is about *state feedback* and a
sample step that shrinks with eps (``T = alpha eps``); it bounds ``Vbar`` with one
``(P_x, 1/2)`` fixed in advance. The certificates of :func:`fl_design.certify_eps` keep the
design's ``T``, include the observer and search the Lyapunov matrix: they are far less
conservative, and the two eps* answer different questions. Both are computed so the claim
can be compared, not conflated.

Examples
--------
>>> import fl_design as fl
>>> from fl_design.analysis import theorem1_constants
>>> c = theorem1_constants((2, 4), 3e-4, (3.6, 6.8), alpha=0.02)
>>> c.lambda_x, c.eps_star > 0
(0.5, True)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from .. import _validate as V
from ..design._controller import _checked_gains
from ._cert_results import _Result
from ._lyapunov import _checked_Q, closed_chain
from ._surrogate import b_interval, chain_zoh


@dataclass(frozen=True, repr=False)
class Theorem1Constants(_Result):
    """Result of :func:`theorem1_constants` (see :mod:`fl_design.analysis._theorem1`).

    Parameters
    ----------
    lambda_x, lambda_u, H : float
        The paper's constants.
    eps_star : float
        ``min(lambda_x / H, sqrt(lambda_u / H)) / alpha``.
    alpha : float
        ``h = alpha eps`` (the sample step of the proof).
    eps_max : float
        Top of the eps grid of ``H``.
    argmax : tuple of float
        ``(eps, b)`` where ``H`` is attained.
    T : float or None
        The design's sampling time (whether it meets the step bound), if given.

    Examples
    --------
    >>> Theorem1Constants(0.5, 0.1, 2.0, 0.25, 1.0, 1.0, (0.5, 1.0)).eps_star
    0.25
    """

    lambda_x: float
    lambda_u: float
    H: float
    eps_star: float
    alpha: float
    eps_max: float
    argmax: tuple
    T: float | None = None

    @property
    def step_bound(self) -> float:
        """``h* = min(lambda_x / H, sqrt(lambda_u / H))``: the largest **sampling step** the
        theorem covers (its "eps*" is ``h* / alpha``: a bound on ``T = alpha eps``)."""
        return self.eps_star * self.alpha

    @property
    def meets(self) -> bool | None:
        """The design's ``T`` satisfies ``T < h*`` (None when no ``T`` was given)."""
        return None if self.T is None else bool(self.T < self.step_bound)

    def verdict(self) -> str:
        """Theorem 1 as what it is: a sampling-step bound, and whether ``T`` meets it.

        Examples
        --------
        >>> c = theorem1_constants((2, 4), 3e-3, (3.6, 6.8), alpha=0.02, T=1e-3)
        >>> c.verdict().startswith("Theorem 1 is a sampling-step bound")
        True
        """
        head = (f"Theorem 1 is a sampling-step bound: state feedback on the chain is covered "
                f"for T = alpha eps < h* = {self.step_bound:.3g} s (its 'eps*' "
                f"{self.eps_star:.3g} = h*/alpha at alpha = {self.alpha:g})")
        if self.T is None:
            return head
        if self.meets:
            return head + f"; the design's T = {self.T:g} s meets it"
        return (head + f"; the design's T = {self.T:g} s does NOT meet it "
                f"({self.T / self.step_bound:.3g}x too large): Theorem 1 says nothing about "
                "this design")

    def _repr_lines(self):
        return [(f"lambda_x = {self.lambda_x:.6g}, lambda_u = {self.lambda_u:.6g}, "
                 f"H = {self.H:.6g} (at eps, b = {self.argmax})"), self.verdict()]


def _loop(k, gamma, b, h):
    """``(x, e_u)`` one-sample matrix of the chain under exact ZOH with step ``h``."""
    rho = k.size
    Phi, Gam = chain_zoh(rho, h)
    Kr = -k[None, :]  # v = K x, K = -(k_1..k_rho)
    Ax = np.hstack([Phi + np.outer(Gam, Kr), -Gam[:, None]])  # sigma = K x - e_u
    ex = Kr @ Ax[:, :rho] - Kr  # e+ = K x+ - (sigma + b gamma e)
    ee = Kr @ Ax[:, rho:] + 1.0 - b * gamma
    return np.vstack([Ax, np.hstack([ex, ee])])


def theorem1_constants(gains, gamma: float, b_bounds, *, Q=None, alpha: float = 1.0,
                       eps_max: float = 1.0, n: int = 400,
                       T: float | None = None) -> Theorem1Constants:
    """``lambda_x``, ``lambda_u``, ``H`` and Theorem 1's ``eps*`` for the chain (state feedback).

    Parameters
    ----------
    gains : sequence of float
        ``(k_1, ..., k_rho)``.
    gamma : float
        Controller gain (``b gamma > 0``; magnitudes for ``b < 0``).
    b_bounds : (float, float)
        ``(b_min, b_max)`` of one strict sign.
    Q : array_like, optional
        Weight of ``P_x`` (default identity).
    alpha : float, optional
        Sample step ``h = alpha eps`` of the proof (the design's ``T / eps``).
    eps_max : float, optional
        Top of the eps grid of ``H`` (default 1).
    n : int, optional
        Grid points of the step ``h`` (default 400).
    T : float, optional
        The design's sampling time: the result says whether it meets the bound ``h*``.

    Returns
    -------
    Theorem1Constants

    Raises
    ------
    ParameterError
        Bad ``b_bounds``, non-positive ``alpha`` or ``eps_max``, gains not Hurwitz, or a
        ``b gamma`` outside ``(0, 2)`` (``e_u`` would not converge: ``lambda_u <= 0``).

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.analysis import theorem1_constants
    >>> c = theorem1_constants((2, 4), 1e-2, (3.6, 6.8), alpha=1.0)
    >>> round(c.lambda_u, 6) == round(min(1 - (1 - b * 1e-2) ** 2 for b in (3.6, 6.8)) / 4, 6)
    True
    """
    from ..errors import ParameterError

    k = np.asarray(_checked_gains(gains), dtype=float)
    Qa = _checked_Q(Q, k.size)
    lo, hi, _ = b_interval(b_bounds)
    g = abs(float(gamma))
    alpha, eps_max = V.positive("alpha", alpha), V.positive("eps_max", eps_max)
    n = V.integer("n", n, minimum=2)
    if not 0.0 < hi * g < 2.0:
        raise ParameterError(f"|b| gamma must lie in (0, 2) for e_u to converge; got "
                             f"{hi * g:.6g} at |b| = {hi:g} (|gamma| < {2.0 / hi:.6g})")
    Ac = closed_chain(k)
    P = scipy.linalg.solve_continuous_lyapunov(Ac.T, -Qa)
    P = (P + P.T) / 2
    lam_x = float(np.linalg.eigvalsh(Qa)[0]) / 2.0
    lam_u = min(1.0 - (1.0 - b * g) ** 2 for b in (lo, hi)) / 4.0
    Pbar = scipy.linalg.block_diag(P, 0.5)
    best, where = -np.inf, (None, None)
    for h in np.geomspace(min(1e-9, 1e-4 * alpha * eps_max), alpha * eps_max, n):
        eps = h / alpha
        D = np.diag(np.r_[np.full(k.size, lam_x * h), lam_u])
        for b in (lo, hi):
            M = _loop(k, g, b, h)
            W = M.T @ Pbar @ M - Pbar + D
            val = float(np.linalg.eigvalsh((W + W.T) / 2)[-1]) / h ** 2
            if val > best:
                best, where = val, (float(eps), float(b))
    H = max(best, 0.0)
    h_star = np.inf if H == 0.0 else min(lam_x / H, float(np.sqrt(lam_u / H)))
    star = h_star / alpha
    T = None if T is None else V.positive("T", T)
    return Theorem1Constants(lam_x, lam_u, H, float(star), alpha, eps_max, where, T)


__all__ = ["Theorem1Constants", "theorem1_constants"]
