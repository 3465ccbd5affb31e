"""The linear surrogate of the sampled loop: a chain of integrators + the design's step.

The plant is replaced by its feedback-linearization skeleton, a chain of ``rho`` integrators
``x_i' = x_(i+1)``, ``x_rho' = sigma`` with ``sigma = a^T x + b u`` (``a = 0`` unless Jacobian
bounds are given), ``u`` held over each sample (exact zero-order hold, :func:`chain_zoh`). The
design's part of the loop matrix is the Jacobian of :attr:`fl_design.Design.parametric_step`
with respect to its state and ``y`` at the equilibrium ``y = r = 0`` (clamps and saturation
inactive): nothing of the loop is re-implemented. Loop state ``X = (x, design state)``::

    X_(k+1) = M(b) X_k,   M(b) = M0 + b M1   (only the plant's input column depends on b)

so ``M`` is affine in ``b`` and conditions at the two ends of ``b_bounds`` cover the interval.
The surrogate depends on ``b`` and ``gamma`` through ``b gamma`` only (``b u`` is a state up to
scaling): a negative ``b`` interval is handled as ``|b|`` with ``gamma`` taking its sign.

Examples
--------
>>> import fl_design as fl
>>> from fl_design.analysis._surrogate import SurrogateLoop
>>> loop = SurrogateLoop(fl.presets.paper_design())
>>> M0, M1 = loop.parts()
>>> M0.shape, loop.names
((7, 7), ('x_1', 'x_2', 'xi_0', 'xi_1', 'xi_2', 'u', 'z'))
"""

from __future__ import annotations

import functools
import math

import numpy as np
import scipy.linalg

from .._blas import serial_blas
from ..errors import DesignMismatchError, ParameterError


def b_interval(b_bounds) -> tuple[float, float, float]:
    """Validate ``b_bounds``; return ``(|b|_min, |b|_max, sign)``.

    Raises ParameterError naming the value when it is not a finite ``(lo, hi)`` with
    ``lo <= hi`` of one strict sign.
    """
    try:
        lo, hi = (float(v) for v in b_bounds)
    except (TypeError, ValueError):
        raise ParameterError(
            f"b_bounds must be a pair (b_min, b_max) of real numbers, got {b_bounds!r}"
        ) from None
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise ParameterError(f"b_bounds must be finite, got ({lo!r}, {hi!r})")
    if lo > hi:
        raise ParameterError(
            f"b_bounds must satisfy b_min <= b_max, got ({lo!r}, {hi!r}) (reversed?)"
        )
    if lo <= 0.0 <= hi:
        raise ParameterError(
            f"b_bounds=({lo!r}, {hi!r}) contains 0 or changes sign: the method needs a known "
            "sign of b, i.e. 0 < b_min <= b_max or b_min <= b_max < 0"
        )
    return (lo, hi, 1.0) if lo > 0 else (-hi, -lo, -1.0)


def jacobian_box(a_jacobian_bounds, rho: int) -> np.ndarray | None:
    """Validate ``a_jacobian_bounds`` (``rho`` pairs ``(lo, hi)``); return a ``(rho, 2)`` array."""
    if a_jacobian_bounds is None:
        return None
    try:
        box = np.asarray(a_jacobian_bounds, dtype=float)
    except (TypeError, ValueError):
        raise ParameterError(
            f"a_jacobian_bounds must be {rho} pairs (lo, hi) of da/dx_i, got {a_jacobian_bounds!r}"
        ) from None
    if box.ndim != 2 or box.shape[1] != 2:
        raise ParameterError(
            f"a_jacobian_bounds must be a sequence of (lo, hi) pairs, got shape {box.shape}"
        )
    if box.shape[0] != rho:
        raise DesignMismatchError(
            f"a_jacobian_bounds has {box.shape[0]} pairs (a plant of relative degree "
            f"{box.shape[0]}) but the design serves rho = {rho}: give one (lo, hi) per x_1..x_rho"
        )
    if not np.all(np.isfinite(box)) or np.any(box[:, 0] > box[:, 1]):
        raise ParameterError(
            f"a_jacobian_bounds must be finite pairs with lo <= hi, got {box.tolist()}"
        )
    return box


def chain_matrices(rho: int, a_row=None) -> np.ndarray:
    """Continuous ``(rho + 1)``-square matrix of ``(x, u)``: chain, ``sigma = a^T x + u``."""
    X = np.eye(rho + 1, k=1)
    if a_row is not None:
        X[rho - 1, :rho] += np.asarray(a_row, dtype=float)
    return X


def chain_zoh(rho: int, T: float, a_row=None) -> tuple[np.ndarray, np.ndarray]:
    """Exact zero-order hold ``x+ = Phi x + Gamma sigma_u`` of the chain (``u`` held over T).

    Examples
    --------
    >>> Phi, Gamma = chain_zoh(2, 0.1)
    >>> Phi.tolist(), Gamma.round(6).tolist()
    ([[1.0, 0.1], [0.0, 1.0]], [0.005, 0.1])
    """
    key = None if a_row is None else tuple(float(v) for v in np.ravel(a_row))
    E = _expm_chain(int(rho), float(T), key)
    return E[:rho, :rho].copy(), E[:rho, rho].copy()


@functools.lru_cache(maxsize=256)
def _expm_chain(rho: int, T: float, a_row) -> np.ndarray:
    # one BLAS thread: a 3 x 3 expm took 5-10 ms with the default threads on a loaded 2-core
    # machine (each pool wake-up waits for a time slice), 40 us with one (certify_lyapunov
    # asks for 200 of them)
    with serial_blas():
        return scipy.linalg.expm(T * chain_matrices(rho, a_row))


class SurrogateLoop:
    """Loop matrices ``M0, M1`` of the surrogate for designs of one structure.

    Parameters
    ----------
    design : Design
        Gives the structure (estimator type, ``rho``, gains, ``ki``, limits) and the default
        numbers; :meth:`parts` evaluates the loop at other ``eps`` and ``gamma``.

    Examples
    --------
    >>> import fl_design as fl
    >>> loop = SurrogateLoop(fl.presets.paper_design())
    >>> loop.rho, loop.T
    (2, 0.001)
    """

    def __init__(self, design):
        import casadi as ca

        self.design, self.rho, self.T = design, design.rho, design.T
        self._p_est = design.parameter_vector()[:-1]
        self._cache: dict[float, np.ndarray] = {}
        self._last: tuple = (None, None)
        lay = design.state_layout
        s = ca.SX.sym("s", design.state_size)
        y = ca.SX.sym("y")
        p = ca.SX.sym("p", design.parameter_vector().size)
        s_next, u = design.parametric_step(s, y, 0.0, p)[:2]
        self._jac = ca.Function("fl_surrogate_jac", [s, y, p], [
            ca.jacobian(s_next, s), ca.jacobian(s_next, y), ca.jacobian(u, s), ca.jacobian(u, y)])
        self._s0 = self._point(design)
        self.names = (tuple(f"x_{i + 1}" for i in range(self.rho))
                      + tuple(f"xi_{i}" for i in range(lay["estimator"].stop)) + ("u", "z"))
        self.keep = list(range(len(self.names)))
        if design.controller.ki == 0.0:  # z feeds nothing: its unit column is no mode
            self.keep.pop()

    @staticmethod
    def _point(design) -> np.ndarray:
        ctrl = design.controller
        for i, lim in enumerate(ctrl.estimate_ranges):
            if lim is not None and not lim[0] < 0.0 < lim[1]:
                raise ParameterError(
                    f"estimate_limits[{i}]={lim} does not contain 0 in its interior: the linear "
                    "surrogate needs the clamps inactive at the equilibrium (xhat = 0)"
                )
        s0 = np.zeros(design.state_size)
        if ctrl.u_range is not None:
            lo, hi = ctrl.u_range
            s0[design.state_layout["u"]] = 0.0 if lo < 0.0 < hi else 0.5 * (lo + hi)
        return s0

    @property
    def size(self) -> int:
        """Number of loop states kept (the decoupled ``z`` removed when ``ki = 0``)."""
        return len(self.keep)

    def estimator_vector(self, eps: float | None) -> np.ndarray:
        """The estimator's parameter vector at ``eps`` (cached; None: the design's own)."""
        if eps is None:
            return self._p_est
        key = float(eps)
        if key not in self._cache:
            if len(self._cache) > 4096:
                self._cache.clear()
            est = self.design.estimator.replace(eps=key)
            self._cache[key] = np.asarray(est.parameter_vector(), dtype=float).ravel()
        return self._cache[key]

    def parts(self, eps: float | None = None, gamma: float | None = None,
              a_row=None) -> tuple[np.ndarray, np.ndarray]:
        """``(M0, M1)`` with ``M(b) = M0 + b M1``, at ``eps`` and ``gamma`` (default the design's).

        Parameters
        ----------
        eps : float, optional
            Observer time constant (the estimator's ``replace(eps=...)``).
        gamma : float, optional
            Controller gain; may be negative (the sign of ``b gamma`` is what matters).
        a_row : array_like, optional
            ``da/dx`` (``rho`` numbers) of the plant's ``sigma = a^T x + b u``.

        Returns
        -------
        (numpy.ndarray, numpy.ndarray)

        Examples
        --------
        >>> import fl_design as fl
        >>> M0, M1 = SurrogateLoop(fl.presets.paper_design()).parts(eps=0.02)
        >>> float(M0[0, 1]), bool(M1[2:].any())
        (0.001, False)
        """
        Phi, Gam = chain_zoh(self.rho, self.T, a_row)
        return self.assemble(Phi, Gam, self.input_row(eps, gamma), eps, gamma)

    def _jacobians(self, eps, gamma):
        """The design's Jacobians at ``(eps, gamma)`` (the last point is remembered)."""
        g = self.design.controller.gamma if gamma is None else float(gamma)
        key = (None if eps is None else float(eps), g)
        if self._last[0] != key:
            p = np.concatenate([self.estimator_vector(eps), [g]])
            self._last = (key, [np.array(m.full(), dtype=float)
                                for m in self._jac(self._s0, 0.0, p)])
        return self._last[1]

    def input_row(self, eps: float | None = None, gamma: float | None = None) -> np.ndarray:
        """The row ``u_k = row @ X_k`` of the design's input (all states, none removed)."""
        _, _, us, uy = self._jacobians(eps, gamma)
        row = np.zeros(self.rho + us.size)
        row[0], row[self.rho:] = uy.item(), us.ravel()
        return row

    def assemble(self, Phi, Gam, u_row, eps=None, gamma=None) -> tuple[np.ndarray, np.ndarray]:
        """``(M0, M1)`` from a plant ``x+ = Phi x + b Gam u`` and the design's Jacobians."""
        Js, Jy = self._jacobians(eps, gamma)[:2]
        M0, M1 = self._stack(Phi, Gam, Js[None], Jy[None], u_row[None])
        return M0[0], M1[0]

    def _stack(self, Phi, Gam, Js, Jy, u_rows):
        """Stacked ``(M0, M1)`` (plain slicing, no ``np.block``), the kept states only."""
        rho, m, k = self.rho, Js.shape[-1], Js.shape[0]
        M0 = np.zeros((k, rho + m, rho + m))
        M0[:, :rho, :rho] = Phi
        M0[:, rho:, :1] = Jy.reshape(k, m, 1)
        M0[:, rho:, rho:] = Js
        M1 = np.zeros_like(M0)
        M1[:, :rho] = np.asarray(Gam)[None, :, None] * u_rows[:, None, :]
        if len(self.keep) < rho + m:
            M0, M1 = (M[:, self.keep][:, :, self.keep] for M in (M0, M1))
        return M0, M1

    def parts_many(self, eps_values, gamma) -> tuple[np.ndarray, np.ndarray]:
        """Stacked ``(M0, M1)`` at many eps (one mapped CasADi call), ``(k, n, n)`` each.

        ``gamma`` is one gain or one per eps (a gain scan at one eps repeats that eps).

        Examples
        --------
        >>> import fl_design as fl
        >>> loop = SurrogateLoop(fl.presets.paper_design())
        >>> M0, M1 = loop.parts_many([0.02, 0.05], 3e-4)
        >>> bool(np.array_equal(M0[1], loop.parts(0.05, 3e-4)[0]))
        True
        """
        eps_values = [float(e) for e in eps_values]
        k = len(eps_values)
        gammas = np.broadcast_to(np.asarray(gamma, dtype=float), (k,))
        p = np.stack([np.concatenate([self.estimator_vector(e), [float(g)]])
                      for e, g in zip(eps_values, gammas)], axis=1)
        Js, Jy, us, uy = (np.asarray(m, dtype=float) for m in
                          self._jac.map(k)(np.tile(self._s0[:, None], (1, k)), 0.0, p))
        n_s = self._s0.size
        Js = Js.reshape(n_s, k, n_s).transpose(1, 0, 2)
        rows = np.zeros((k, self.rho + n_s))
        rows[:, 0], rows[:, self.rho:] = uy.ravel(), us.reshape(k, n_s)
        Phi, Gam = chain_zoh(self.rho, self.T)
        return self._stack(Phi, Gam, Js, Jy.T, rows)


def delta(M: np.ndarray, T: float) -> np.ndarray:
    """Delta-form matrix ``(M - I) / T``."""
    return (M - np.eye(M.shape[-1])) / T


def schur_margins(deltas: np.ndarray, T: float) -> np.ndarray:
    """``max_i (2 Re mu_i + T |mu_i|^2)`` per delta matrix: < 0 iff ``I + T Delta`` is Schur.

    ``|1 + T mu|^2 < 1`` is ``2 Re mu + T |mu|^2 < 0``; computing it from the eigenvalues
    ``mu`` of ``Delta`` keeps the digits that ``|lambda| - 1`` of ``M``'s eigenvalues
    (within 1e-6 of the unit circle at T = 1 ms) would lose.
    """
    mu = np.linalg.eigvals(deltas)
    return np.max(2.0 * mu.real + T * np.abs(mu) ** 2, axis=-1)


__all__ = ["SurrogateLoop", "b_interval", "chain_matrices", "chain_zoh", "delta",
           "jacobian_box", "schur_margins"]
