"""The least-squares data-driven estimator of Fraile, Marchi and Tabuada (the paper's baseline).

A polynomial of degree ``d >= rho`` is fitted by least squares to the last ``N = window``
samples at the relative times ``t_j = -(N-1-j) T`` (j = 0 oldest, j = N-1 the current sample);
its derivatives at ``t = 0`` are the estimates ``y, y', ..., y^(rho)``, the last being
``sigmahat``. With a constant ``T`` the fit is one precomputed linear map::

    xhat_ext_k = M @ (y_(k-N+1), ..., y_k),    M in R^((rho+1) x N)

Examples
--------
>>> import numpy as np, fl_design as fl
>>> est = fl.LeastSquaresEstimator(rho=2, T=1e-3, window=9)
>>> t = np.arange(20) * est.T
>>> est.filter(1 + 2 * t + 3 * t**2)[-1].round(8)         # y, y', y'' at t[-1]
array([1.039083, 2.114   , 6.      ])
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .. import _validate as v
from .._limits import env_limit
from ..errors import DimensionError, ParameterError, ResourceLimitError
from ._estimator import Estimator, as_casadi, check_length, checked_estimate, rows

#: Environment variable lifting the default cap :data:`MAX_WINDOW` on ``window``.
MAX_WINDOW_ENV = "FL_DESIGN_MAX_WINDOW"
#: Default largest window (the fit's ``window x window`` solve then needs about 0.4 GB).
MAX_WINDOW = 5000


def max_window() -> int:
    """Largest accepted ``window``: ``$FL_DESIGN_MAX_WINDOW`` if set, else :data:`MAX_WINDOW`.

    Examples
    --------
    >>> from fl_design.design._least_squares import max_window
    >>> max_window() >= 26
    True
    """
    return env_limit(MAX_WINDOW_ENV, MAX_WINDOW, unit="samples")


def derivative_matrix(window: int, degree: int, rho: int, T: float) -> np.ndarray:
    """``M`` mapping the last ``window`` samples (oldest first) to ``y, ..., y^(rho)`` at t = 0.

    Time is scaled by ``tau = T * window`` (``s = t / tau`` in ``(-1, 0]``) so that the
    Vandermonde matrix ``V_ji = s_j^i`` stays well conditioned whatever ``T``; its
    pseudo-inverse comes from ``scipy.linalg.lstsq`` (SVD-based) and the coefficients of
    ``s^i`` are turned into derivatives by ``i! / tau^i``.

    Parameters
    ----------
    window : int
        Number of samples ``N`` in the fit (oldest first).
    degree : int
        Degree of the fitted polynomial (``>= rho``, ``< window``).
    rho : int
        Highest derivative estimated.
    T : float
        Sampling time.

    Returns
    -------
    numpy.ndarray
        ``(rho + 1, window)``.

    Examples
    --------
    >>> from fl_design.design import derivative_matrix
    >>> derivative_matrix(2, 1, 1, 0.5).round(12) + 0.0           # two-point difference
    array([[ 0.,  1.],
           [-2.,  2.]])
    """
    import scipy.linalg  # lazy: 0.2-0.4 s to import, only for this estimator

    tau = T * window
    s = -(window - 1 - np.arange(window)) / window
    V = np.vander(s, degree + 1, increasing=True)
    pinv = scipy.linalg.lstsq(V, np.eye(window), lapack_driver="gelsd")[0]
    fact = np.array([math.factorial(i) / tau**i for i in range(rho + 1)])
    return fact[:, None] * pinv[: rho + 1]


@dataclass(frozen=True)
class LeastSquaresEstimator(Estimator):
    """Causal sliding-window least-squares differentiator (estimator protocol of ``Design``).

    Parameters
    ----------
    rho : int
        Relative degree, 1..6: estimates ``y, y', ..., y^(rho-1)`` and ``sigma = y^(rho)``.
    T : float
        Sampling time > 0.
    window : int
        Number ``N`` of samples in the fit, ``N >= degree + 1``.
    degree : int, optional
        Degree of the fitted polynomial, ``>= rho``; default ``rho``.

    Attributes
    ----------
    fit_degree : int
        The degree in use (``degree`` stays as given: None means ``rho``).
    matrix : numpy.ndarray
        ``M``, shape ``(rho+1, window)``; row ``i`` gives ``y^(i)`` at the current sample.
    state_size : int
        ``window + 1``: the buffer of the last samples and a sample counter.

    Raises
    ------
    ParameterError
        ``rho`` not in 1..6, ``T`` not finite and > 0, ``degree < rho``, bad ``window``.
    ResourceLimitError
        ``window`` above :func:`max_window` (5000 samples unless ``$FL_DESIGN_MAX_WINDOW``).
    DimensionError
        ``window < degree + 1`` (the fit would be underdetermined).

    Notes
    -----
    State layout: ``[y_(k-N+1), ..., y_k, count]`` with the oldest sample first. Until
    ``window`` samples have been shifted in, ``ready`` is 0 and the design's controller holds
    its state. Multiply-adds per sample: ``(rho+1) * window`` (:attr:`flops_per_step`).

    Examples
    --------
    >>> import fl_design as fl
    >>> est = fl.LeastSquaresEstimator(2, 1e-3, window=9)
    >>> est.fit_degree, est.state_size, est.flops_per_step
    (2, 10, 27)
    """

    rho: int
    T: float
    window: int
    degree: int | None = None
    fit_degree: int = field(init=False, repr=False, compare=False)
    _M: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        rho = v.integer("rho", self.rho, minimum=1, maximum=6)
        T = v.positive("T", self.T)
        degree = rho if self.degree is None else v.integer("degree", self.degree)
        if degree < rho:
            raise ParameterError(
                f"degree={degree} must be >= rho={rho}: a polynomial of lower degree has no "
                f"{rho}-th derivative to estimate sigma"
            )
        window = v.integer("window", self.window, minimum=1)
        limit = max_window()
        if window > limit:
            raise ResourceLimitError(
                f"window={window} exceeds the limit of {limit} samples: the fit needs about "
                f"{16 * window**2 / 2**30:.3g} GiB (a window x window least-squares solve) and "
                f"the step keeps window + 1 states; set the environment variable "
                f"{MAX_WINDOW_ENV}={window} to lift the limit"
            )
        if window < degree + 1:
            raise DimensionError(
                f"window={window} samples cannot determine a polynomial of degree {degree}: "
                f"need window >= degree + 1 = {degree + 1}"
            )
        for name, value in (("rho", rho), ("T", T), ("window", window)):
            object.__setattr__(self, name, value)
        object.__setattr__(self, "fit_degree", degree)
        M = derivative_matrix(window, degree, rho, T)
        M.flags.writeable = False
        object.__setattr__(self, "_M", M)

    def replace(self, **changes) -> LeastSquaresEstimator:
        """A copy with fields changed (re-validated), e.g. ``est.replace(window=26)``.

        When ``rho`` changes and ``degree`` was the default (``== rho``), the degree follows.

        Parameters
        ----------
        **changes
            Any of ``rho, T, window, degree``.

        Returns
        -------
        LeastSquaresEstimator

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.LeastSquaresEstimator(2, 1e-3, 9).replace(window=26).window
        26
        """
        return super().replace(**changes)

    @property
    def matrix(self) -> np.ndarray:
        """``M`` (read-only), shape ``(rho+1, window)``: ``xhat_ext = M @ buffer``."""
        return self._M

    @property
    def state_size(self) -> int:
        """``window + 1``: sample buffer and counter."""
        return self.window + 1

    @property
    def flops_per_step(self) -> int:
        """Multiply-adds per sample of ``M @ buffer``: ``(rho + 1) * window``."""
        return (self.rho + 1) * self.window

    def initial_state(self, *, y0: float | None = None, estimate=None,
                      params=None) -> np.ndarray:
        """A full window: as if the output had been ``y0`` (or followed ``estimate``) before.

        Without ``y0`` and ``estimate``: the empty buffer (``zeros(window + 1)``), not ready
        until ``window`` samples have been shifted in.

        The buffer holds the past samples ``y(-(window-1) T), ..., y(-T)`` of the constant
        ``y0`` (default 0), or of the polynomial ``sum_i estimate[i] t^i / i!`` (the given
        ``y, y', ..., sigma``), and the count says full: the first sample is already a fit
        (``ready = 1``) and a constant output gives zero derivative estimates.

        Parameters
        ----------
        y0 : float, optional
            First measurement (default: none, the empty buffer).
        estimate : array_like, optional
            ``(rho + 1,)`` derivatives of the output before the start (with ``y0``: the
            polynomial wins).
        params : array_like, optional
            Unused (the window has no time constant to sweep); accepted for the interface.

        Returns
        -------
        numpy.ndarray
            ``(window + 1,)``: the ``window`` buffered samples, oldest first, then the count
            of samples seen.

        Examples
        --------
        >>> import fl_design as fl
        >>> est = fl.LeastSquaresEstimator(1, 1e-3, 3)
        >>> est.initial_state(), est.initial_state(y0=0.5)
        (array([0., 0., 0., 0.]), array([0.5, 0.5, 0.5, 3. ]))
        """
        N = self.window
        t = (np.arange(N) - N) * self.T
        if y0 is None and estimate is None:
            return np.zeros(N + 1)
        if estimate is None:
            buffer = np.full(N, v.real_scalar("y0", y0))
        else:
            c = checked_estimate(estimate, self.rho)
            buffer = sum(c[i] * t**i / math.factorial(i) for i in range(self.rho + 1))
        return np.concatenate([buffer, [float(N)]])

    def parameter_vector(self) -> np.ndarray:
        """``M`` flattened row-major (length ``(rho+1) * window``).

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.LeastSquaresEstimator(1, 1e-3, 3).parameter_vector().shape
        (6,)
        """
        return self._M.ravel()

    def symbolic_update(self, xi, y, p):
        """Shift ``y_k`` into the buffer and fit (steps 1 and 7 of the normative loop).

        Parameters
        ----------
        xi : casadi.SX or MX or DM, shape (window+1,)
            ``[buffer (oldest first), count]``.
        y : casadi scalar
            Measurement ``y_k``.
        p : casadi vector
            ``M`` flattened row-major, as :meth:`parameter_vector`.

        Returns
        -------
        xhat_ext : (rho+1, 1)
            ``M @ buffer_new``, ``buffer_new = (buffer[1:], y_k)``.
        xi_next : (window+1, 1)
            ``[buffer_new, min(count + 1, window)]``.
        ready : scalar
            1 when ``count + 1 >= window`` (the window is full), else 0.

        Examples
        --------
        >>> import casadi, fl_design as fl
        >>> est = fl.LeastSquaresEstimator(1, 1e-3, 3)
        >>> xhat, xi, ready = est.symbolic_update(casadi.DM.zeros(4), 1.0, est.parameter_vector())
        >>> xi.T, float(ready)
        (DM([[0, 0, 1, 1]]), 0.0)
        """
        import casadi

        N, m = self.window, self.rho + 1
        xi, y, p = as_casadi(xi), as_casadi(y), as_casadi(p)
        check_length("xi", xi, N + 1)
        check_length("p", p, m * N)
        buffer = casadi.vertcat(xi[1:N], y)
        count = casadi.fmin(xi[N] + 1, N)
        xhat = casadi.mtimes(rows(p, 0, m, N), buffer)
        return xhat, casadi.vertcat(buffer, count), count >= N

    def filter(self, y_samples) -> np.ndarray:
        """Estimates for every sample; NaN rows while the window is not yet full.

        Parameters
        ----------
        y_samples : array_like, shape (K,)
            Measurements taken every ``T``.

        Returns
        -------
        numpy.ndarray, shape (K, rho+1)
            Row ``k`` is ``M @ (y_(k-N+1), ..., y_k)`` for ``k >= N-1``, NaN before.

        Examples
        --------
        >>> import numpy as np, fl_design as fl
        >>> fl.LeastSquaresEstimator(1, 0.1, 2).filter([0.0, 1.0, 3.0])
        array([[nan, nan],
               [ 1., 10.],
               [ 3., 20.]])
        """
        y = v.real_vector("y_samples", np.ravel(y_samples))
        out = np.full((y.size, self.rho + 1), np.nan)
        if y.size >= self.window:
            windows = np.lib.stride_tricks.sliding_window_view(y, self.window)
            out[self.window - 1 :] = windows @ self._M.T
        return out


__all__ = ["LeastSquaresEstimator", "derivative_matrix"]
