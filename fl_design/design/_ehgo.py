"""The extended high-gain observer (EHGO) of the paper, discretized in scaled coordinates.

The model-free (``phi0 = 0``) EHGO of order ``rho + 1`` estimates ``y, y', ..., y^(rho-1)`` and
the lumped term ``sigma = y^(rho)`` with the gains ``H_i = alpha_i / eps^i``. In the scaled
coordinates ``q = D xhat``, ``D = diag(1, eps, ..., eps^rho)``, it reads::

    eps q' = F q + L y,   F = [[-alpha_1,     1, 0, ..., 0],
                               [-alpha_2,     0, 1, ..., 0],
                               ...
                               [-alpha_(rho+1), 0, ..., 0]],   L = (alpha_1, ..., alpha_(rho+1))

which contains no negative power of ``eps``. In the normalized time ``t / eps`` the sampling
step is ``alpha = T / eps``; the pair ``(F, L)`` is discretized with that step (bilinear by
default, Schur for every ``alpha > 0``) and the sampled observer is::

    xhat_k     = D^-1 (C_d xi_k + D_d y_k)
    xi_(k+1)   = A_d xi_k + B_d y_k

Examples
--------
>>> import fl_design as fl
>>> obs = fl.EHGO(rho=2, eps=0.05, T=1e-3, coeffs=(6, 11, 6))   # the paper's observer
>>> obs.alpha, obs.state_size, obs.is_schur
(0.02, 3, True)
"""

from __future__ import annotations

import warnings
from dataclasses import KW_ONLY, dataclass, field

import numpy as np

from .. import _validate as v
from ..errors import (
    ParameterError,
    UnstableDiscretizationWarning,
)
from ._ehgo_conversions import EHGOViews
from ._ehgo_discretization import (
    _EIG_MAP,
    _THETA,
    MAX_RHO,
    METHODS,
    REALIZATIONS,
    StateSpaceMatrices,
    _companion,
    _delta_matrix,
    _frozen,
    binomial_coeffs,
    delta_update,
    direct_update,
    discretize,
    start_state,
)
from ._estimator import Estimator, as_casadi, check_length, checked_estimate
from ._poles import checked_poles, monic_coefficients


@dataclass(frozen=True)
class EHGO(Estimator, EHGOViews):
    """Discrete-time extended high-gain observer (estimator protocol of :class:`fl_design.Design`).

    Parameters
    ----------
    rho : int
        Relative degree of the plant, 1..6; the observer has ``rho + 1`` states
        ``(y, y', ..., y^(rho-1), sigma)``.
    eps : float
        Observer time constant ``eps > 0`` (the paper's tunable software parameter).
    T : float
        Sampling time ``T > 0`` in seconds.
    coeffs : sequence of float, optional
        ``(alpha_1, ..., alpha_(rho+1))`` of the Hurwitz polynomial
        ``s^(rho+1) + alpha_1 s^rho + ... + alpha_(rho+1)`` (checked). Default: all roots at -1,
        the binomial coefficients ``C(rho+1, i)``. See :meth:`from_poles`.
    method : {"bilinear", "forward_euler", "backward_euler", "zoh"}, optional
        Discretization of the scaled observer with step ``alpha = T / eps`` (done by
        ``scipy.signal.cont2discrete``'s formulas). ``"bilinear"`` (default, the paper's) and the two
        others but ``"forward_euler"`` are Schur for every ``alpha > 0``; forward Euler only for
        ``alpha < alpha_max`` (see :attr:`alpha_max`).
    allow_unstable : bool, optional
        Keyword-only. Build a forward-Euler observer beyond its stability limit, with an
        :class:`~fl_design.errors.UnstableDiscretizationWarning`, instead of raising
        ParameterError. Default False.

    realization : {"direct", "delta"}, optional
        Keyword-only. How the step is computed; both have the same input-output behaviour
        to round-off and the same state ``xi``. ``"direct"`` (default):
        ``xhat = D^-1 (C_d xi + D_d y)``, ``xi+ = A_d xi + B_d y`` with the matrices as they
        come. ``"delta"``: with ``G = A_d - I`` computed directly (``(I - theta alpha F)^-1
        alpha F``, or the ZOH integral), never by subtracting ``I``, and ``e = xi - e_1 y``::

            g = G e,   xi+ = xi + g,   xhat = D^-1 (xi + theta g)

        (``theta`` = 1/2 bilinear, 1 backward Euler, 0 forward Euler and ZOH). It rests on
        ``L = -F e_1``, which makes ``B_d = -G e_1`` and ``C_d xi + D_d y = xi + theta G e``
        exactly. Why: at ``T = 1 ms`` the entries of ``A_d`` sit within ``1e-5`` of the
        identity, so the rounded ``A_d`` keeps only a few digits of ``A_d - I`` (about 11 in
        double, 2 in float) and its DC gain from ``y`` to the derivative estimates is not 0
        (``y -> sigmahat`` reaches ``-0.06`` in double at ``rho = 5, eps = T``, and ``2e7``
        in float). In the delta form a constant ``y`` with ``xi = e_1 y`` gives ``e = 0``:
        zero derivative estimates by construction, whatever the rounding of ``G``, whose
        entries keep their full relative precision. It also costs fewer operations
        (``n^2 + 2 n`` multiply-adds instead of ``2 n^2 + 2 n``). Its parameter vector is
        ``[G, diag(D^-1)]``. The C code generator uses it for single precision.

    Attributes
    ----------
    alphas : tuple of float
        The coefficients in use, ``alpha_1`` to ``alpha_(rho+1)`` (``coeffs`` stays as given:
        None means the default binomial ones).
    alpha : float
        ``T / eps``, the step in normalized time.
    matrices : StateSpaceMatrices
        ``(A_d, B_d, C_d, D_d)`` of the scaled discrete observer.
    scaling, unscaling : numpy.ndarray
        The diagonals of ``D = diag(1, eps, ..., eps^rho)`` and of ``D^-1``.
    state_size : int
        ``rho + 1``.

    Raises
    ------
    ParameterError
        ``rho`` not an integer in 1..6, ``eps`` or ``T`` not finite and > 0, unknown
        ``method``, or forward Euler beyond its limit.
    DimensionError
        ``coeffs`` not of length ``rho + 1``.
    HurwitzError
        ``coeffs`` do not give a Hurwitz polynomial.

    Notes
    -----
    :meth:`initial_state` is the observer at rest at the first measurement, ``xi = e_1 y_0``:
    the first estimate is ``(y_0, 0, ..., 0)``, not a peak of size ``eps^-rho``.

    Examples
    --------
    >>> import numpy as np, fl_design as fl
    >>> obs = fl.EHGO(rho=2, eps=0.05, T=1e-3)
    >>> obs.coeffs is None, obs.alphas                   # as given; the coefficients used
    (True, (3.0, 3.0, 1.0))
    >>> t = np.arange(2000) * obs.T
    >>> xhat = obs.filter(np.sin(t))                       # y, y', y'' = sigma
    >>> truth = [np.sin(t[-1]), np.cos(t[-1]), -np.sin(t[-1])]
    >>> np.abs(xhat[-1] - truth).round(2)                  # O(eps^3), O(eps^2), O(eps)
    array([0.  , 0.  , 0.05])
    """

    rho: int
    eps: float
    T: float
    coeffs: tuple[float, ...] | None = None
    method: str = "bilinear"
    _: KW_ONLY
    allow_unstable: bool = False
    realization: str = "direct"
    alphas: tuple[float, ...] = field(init=False, repr=False, compare=False)
    _mats: StateSpaceMatrices = field(init=False, repr=False, compare=False)
    _delta: np.ndarray = field(init=False, repr=False, compare=False)
    _roots: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        rho = v.integer("rho", self.rho, minimum=1, maximum=MAX_RHO)
        eps = v.positive("eps", self.eps)
        T = v.positive("T", self.T)
        if not isinstance(self.method, str) or self.method not in METHODS:
            raise ParameterError(
                f"method={self.method!r} is not a known discretization; valid methods: "
                f"{', '.join(repr(m) for m in METHODS)}"
            )
        if self.coeffs is None:
            coeffs = np.array(binomial_coeffs(rho))
        else:
            coeffs = v.real_vector(
                f"coeffs (alpha_1..alpha_{rho + 1} for rho={rho})", self.coeffs, length=rho + 1
            )
        roots = v.hurwitz_monic("coeffs", coeffs, what="the observer polynomial")
        if self.coeffs is None:
            roots = -np.ones(rho + 1, dtype=complex)  # exact: numpy.roots smears a repeated root
        for name, value in (("rho", rho), ("eps", eps), ("T", T)):
            object.__setattr__(self, name, value)
        object.__setattr__(self, "alphas", tuple(float(c) for c in coeffs))
        v.boolean("allow_unstable", self.allow_unstable)
        object.__setattr__(self, "_roots", roots)
        if self.method == "forward_euler":
            self._check_euler_limit()
        F, L = _companion(coeffs)
        n = rho + 1
        Ad, Bd, Cd, Dd = discretize(F, L, np.eye(n), np.zeros((n, 1)), self.alpha,
                                    METHODS[self.method])
        object.__setattr__(self, "_mats", StateSpaceMatrices(*map(_frozen, (Ad, Bd, Cd, Dd))))
        if self.realization not in REALIZATIONS:
            raise ParameterError(
                f"realization={self.realization!r} is not known; valid: {REALIZATIONS}")
        object.__setattr__(self, "_delta", _frozen(_delta_matrix(F, self.alpha, self.method)))
        if self.method != "forward_euler" and not self.is_schur:
            warnings.warn(
                f"A_d of method={self.method!r} has spectral radius {self.spectral_radius:.17g} "
                f">= 1 in floating point at alpha = T/eps = {self.alpha:.6g}; choose a less "
                "extreme ratio T/eps",
                UnstableDiscretizationWarning,
                stacklevel=3,
            )

    def _check_euler_limit(self) -> None:
        amax = self.alpha_max
        if self.alpha < amax:
            return
        msg = (
            f"method='forward_euler' is unstable at alpha = T/eps = {self.alpha:.6g} "
            f"(T={self.T!r}, eps={self.eps!r}): it needs alpha < alpha_max = {amax:.6g}, "
            f"i.e. eps > eps_min = T/alpha_max = {self.T / amax:.6g}; use method='bilinear' "
            "(stable for every alpha), a larger eps, a smaller T, or allow_unstable=True"
        )
        if not self.allow_unstable:
            raise ParameterError(msg)
        warnings.warn(msg, UnstableDiscretizationWarning, stacklevel=4)

    # --- construction helpers --------------------------------------------------------------
    @classmethod
    def from_poles(
        cls, rho: int, eps: float, T: float, poles, *, method: str = "bilinear",
        allow_unstable: bool = False,
    ) -> EHGO:
        """Observer whose normalized polynomial has the given roots (times ``1/eps`` in s).

        The coefficients are the closed-form product ``prod (s - p_i)`` (``numpy.poly``).

        Parameters
        ----------
        rho : int
            Relative degree, 1..6.
        eps : float
            Observer time constant > 0.
        T : float
            Sampling time > 0.
        poles : sequence of complex
            ``rho + 1`` roots in the open left half-plane; complex ones in conjugate pairs.
        method : str, optional
            Discretization, as in :class:`EHGO`.
        allow_unstable : bool, optional
            As in :class:`EHGO`.

        Returns
        -------
        EHGO

        Raises
        ------
        DimensionError
            Wrong number of poles.
        ParameterError
            Non-finite poles, or complex poles without their conjugate.
        HurwitzError
            A pole is not in the open left half-plane.

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.EHGO.from_poles(2, 0.05, 1e-3, [-1, -2, -3]).alphas
        (6.0, 11.0, 6.0)
        """
        rho = v.integer("rho", rho, minimum=1, maximum=MAX_RHO)
        coeffs = monic_coefficients(checked_poles(poles, count=rho + 1, what=f"rho+1 = {rho + 1}"))
        return cls(rho, eps, T, tuple(coeffs), method, allow_unstable=allow_unstable)

    has_time_constant = True

    def replace(self, **changes) -> EHGO:
        """A copy with fields changed (re-validated), e.g. ``obs.replace(eps=0.02)``.

        Fields keep the values given: default coefficients (``coeffs=None``) stay the
        default ones of the new ``rho`` when ``rho`` changes.

        Parameters
        ----------
        **changes
            Any of ``rho, eps, T, coeffs, method, allow_unstable``.

        Returns
        -------
        EHGO

        Raises
        ------
        ParameterError
            An unknown field name (the valid ones are listed).

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.EHGO(2, 0.05, 1e-3).replace(eps=0.01).alpha
        0.1
        """
        return super().replace(**changes)

    # --- derived quantities ------------------------------------------------------------------
    @property
    def alpha(self) -> float:
        """``T / eps``: the sampling step in the observer's normalized time."""
        return self.T / self.eps

    @property
    def state_size(self) -> int:
        """Length of the observer state ``xi``: ``rho + 1``."""
        return self.rho + 1

    @property
    def matrices(self) -> StateSpaceMatrices:
        """``(A_d, B_d, C_d, D_d)`` of the scaled discrete observer (read-only arrays)."""
        return self._mats

    @property
    def scaling(self) -> np.ndarray:
        """Diagonal of ``D = diag(1, eps, ..., eps^rho)`` (``q = D xhat``)."""
        return self.eps ** np.arange(self.rho + 1, dtype=float)

    @property
    def unscaling(self) -> np.ndarray:
        """Diagonal of the unscaling ``D^-1`` (entries ``1/eps^i``, i = 0..rho; ``xhat = D^-1 q``)."""
        return 1.0 / self.scaling

    @property
    def gains(self) -> np.ndarray:
        """Unscaled observer gains ``H_i = alpha_i / eps^i``, i = 1..rho+1."""
        return np.asarray(self.alphas) / self.eps ** np.arange(1, self.rho + 2, dtype=float)

    @property
    def poles(self) -> np.ndarray:
        """Roots of ``s^(rho+1) + alpha_1 s^rho + ... + alpha_(rho+1)`` (eigenvalues of F)."""
        return self._roots.copy()

    @property
    def alpha_max(self) -> float:
        """Forward-Euler stability limit ``min_lam -2 Re(lam) / |lam|^2`` over the roots.

        ``I + alpha F`` is Schur iff ``alpha < alpha_max``. The roots come from
        ``numpy.roots`` (exact -1 for the default coefficients): for a user-given root of
        multiplicity m they are accurate to about ``1e-16^(1/m)``, so the limit of repeated roots
        is then slightly underestimated (the safe side).
        """
        lam = self._roots
        return float(np.min(-2.0 * lam.real / np.abs(lam) ** 2))

    @property
    def spectral_radius(self) -> float:
        """Largest modulus of the eigenvalues of ``A_d``.

        Computed from the roots ``lam`` of the observer polynomial through the method's exact
        eigenvalue map (bilinear ``(1 + alpha lam/2) / (1 - alpha lam/2)``, forward Euler
        ``1 + alpha lam``, backward Euler ``1 / (1 - alpha lam)``, ZOH ``exp(alpha lam)``):
        ``numpy.linalg.eigvals(A_d)`` would smear the repeated eigenvalue of the default
        coefficients by ``~1e-16^(1/(rho+1))``.
        """
        z = _EIG_MAP[self.method](self.alpha * self._roots)
        return float(np.max(np.abs(z)))

    @property
    def is_schur(self) -> bool:
        """True when every eigenvalue of ``A_d`` lies strictly inside the unit circle."""
        return self.spectral_radius < 1.0

    @property
    def flops_per_step(self) -> int:
        """Multiply-adds per sample: ``2 n^2 + 2 n`` (direct) or ``n^2 + 2 n`` (delta), n = rho + 1.

        Direct, with ``D^-1 C_d`` and ``D^-1 D_d`` folded into constants: ``n^2 + n`` for the
        output and ``n^2 + n`` for the state update. Delta: ``n^2`` for ``G e``, ``n`` for
        ``xi + theta g`` and ``n`` for the unscaling (``xi + g`` is ``n`` additions more).
        """
        n = self.state_size
        return n * n + 2 * n if self.realization == "delta" else 2 * n * n + 2 * n

    @property
    def delta_matrix(self) -> np.ndarray:
        """``G = A_d - I`` computed without subtracting ``I`` (read-only; see ``realization``)."""
        return self._delta

    # --- estimator protocol ------------------------------------------------------------------
    def initial_state(self, *, y0: float | None = None, estimate=None,
                      params=None) -> np.ndarray:
        """The observer at rest at the first measurement ``y0``, or at a given estimate.

        Parameters
        ----------
        y0 : float, optional
            First measurement (default 0): ``xi_0 = e_1 y0``, the rest state of every method
            and realization, whose first estimate is ``(y0, 0, ..., 0)`` (no peaking).
        estimate : array_like, optional
            ``(rho + 1,)`` first estimates ``(xhat_1, ..., sigmahat)`` to start from instead.
        params : array_like, optional
            A :meth:`parameter_vector` of this family (another ``eps``; default this one's).

        Returns
        -------
        numpy.ndarray
            ``(rho + 1,)`` observer state ``xi`` (of the realization in use).

        Examples
        --------
        >>> import fl_design as fl
        >>> obs = fl.EHGO(1, 0.1, 1e-3)
        >>> obs.initial_state(), obs.initial_state(y0=-0.05)
        (array([0., 0.]), array([-0.05,  0.  ]))
        """
        y0 = 0.0 if y0 is None else v.real_scalar("y0", y0)
        if estimate is not None:
            estimate = checked_estimate(estimate, self.rho)
        p = self.parameter_vector() if params is None else params
        theta = _THETA[self.method] if self.realization == "delta" else None
        return start_state(p, self.state_size, theta=theta, y0=y0, estimate=estimate)

    def parameter_vector(self) -> np.ndarray:
        """``[A_d, B_d, C_d, D_d, diag(D^-1)]`` flattened row-major, length ``2 n^2 + 3 n``.

        For ``realization="delta"``: ``[G, diag(D^-1)]``, length ``n^2 + n``.

        All that depends on ``eps`` and ``T``: an observer of the same ``rho``, ``coeffs`` and
        ``method`` but another ``eps`` is obtained by passing its vector to
        :meth:`symbolic_update`.

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.EHGO(2, 0.05, 1e-3).parameter_vector().shape
        (27,)
        >>> fl.EHGO(2, 0.05, 1e-3, realization="delta").parameter_vector().shape
        (12,)
        """
        if self.realization == "delta":
            return np.concatenate([self._delta.ravel(), self.unscaling])
        A, B, C, D = self._mats
        return np.concatenate([A.ravel(), B.ravel(), C.ravel(), D.ravel(), self.unscaling])

    def symbolic_update(self, xi, y, p):
        """One observer step as CasADi expressions (steps 1 and 7 of the normative loop).

        Parameters
        ----------
        xi : casadi.SX or MX or DM, shape (rho+1,)
            Observer state ``xi_k``.
        y : casadi scalar
            Measurement ``y_k``.
        p : casadi vector
            Parameters laid out as :meth:`parameter_vector`.

        Returns
        -------
        xhat_ext : (rho+1, 1)
            ``D^-1 (C_d xi_k + D_d y_k)`` = ``[xhat_1..xhat_rho, sigmahat]``.
        xi_next : (rho+1, 1)
            ``A_d xi_k + B_d y_k``.
        ready : scalar
            Constant 1 (the EHGO estimate is always available).

        Examples
        --------
        >>> import casadi, fl_design as fl
        >>> obs = fl.EHGO(1, 0.1, 1e-3)
        >>> xhat, xi1, ready = obs.symbolic_update(casadi.DM.zeros(2), 1.0, obs.parameter_vector())
        >>> xhat.shape, float(ready)
        ((2, 1), 1.0)
        """
        xi, y, p = as_casadi(xi), as_casadi(y), as_casadi(p)
        check_length("xi", xi, self.state_size)
        if self.realization == "delta":
            return delta_update(xi, y, p, theta=_THETA[self.method])
        return direct_update(xi, y, p)



__all__ = ["EHGO", "METHODS", "StateSpaceMatrices", "binomial_coeffs"]
