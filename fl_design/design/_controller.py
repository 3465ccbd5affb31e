"""The dynamic controller ``u(k) = sat(u(k-1) + gamma (v(xhat) - sigmahat))`` and its gains.

The controller of the paper (after Fraile, Marchi and Tabuada) does not invert the unknown
input gain ``b``: it integrates the mismatch between the desired ``rho``-th derivative
``v = -sum_i k_i (xhat_i - r^(i-1)) - k_I z`` and the estimated lumped term
``sigmahat = a + b u``, with step ``gamma``. Steps 2-5 of the normative sampled loop live here
(:meth:`DynamicController.symbolic_law`); :class:`fl_design.Design` joins them with an estimator.

Gain helpers: :func:`gains_from_poles` (closed-form pole placement, repeated poles allowed) and
:func:`lqr_gains` (continuous LQR on the chain of ``rho`` integrators).

Examples
--------
>>> import fl_design as fl
>>> ctrl = fl.DynamicController((2, 4), 3e-4, ki=1e-3, estimate_limits=(None, 0.05))
>>> ctrl.rho, ctrl.estimate_limits, ctrl.estimate_ranges
(2, (None, 0.05), (None, (-0.05, 0.05)))
>>> fl.gains_from_poles([-1, -1])
(1.0, 2.0)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import KW_ONLY, dataclass, field

import numpy as np

from .. import _validate as v
from ..errors import ComputationError, DimensionError, HurwitzError, ParameterError
from ._estimator import replace_fields
from ._poles import checked_poles, monic_coefficients

Interval = tuple[float, float]


@dataclass(frozen=True)
class DynamicController:
    """Dynamic controller of the paper, with optional integrator and saturations.

    At sample ``k``, given the estimates ``xhat = (xhat_1, ..., xhat_rho)`` and
    ``sigmahat`` and the reference ``r``::

        xhat_i <- clamp(xhat_i, estimate_limits[i-1])            i = 2..rho
        z_k     = z_(k-1) + T (xhat_1 - r)
        v_k     = -k_1 (xhat_1 - r) - sum_(i>=2) k_i xhat_i - k_I z_k
        u_k     = sat(u_(k-1) + gamma (v_k - sigmahat), u_limits)
        z_k    <- z_(k-1)  if antiwindup and u_k is on a limit and the integrator's
                           increment -gamma k_I (xhat_1 - r) pushes it further out

    The saturated ``u_k`` is the controller's state: ``u`` itself never winds up, and the
    model-free observer (driven by ``y`` alone) estimates ``sigma = a + b u`` of the input
    actually applied, so ``sigmahat`` cannot wind up while ``u`` is pinned either. The
    integrator can: conditional integration (``antiwindup=True``, the default) holds ``z``
    while ``u`` sits on a limit and ``z`` would push it further. Nothing changes while ``u``
    is inside its limits, without ``u_limits``, or with ``k_I = 0``.

    Parameters
    ----------
    gains : sequence of float
        ``(k_1, ..., k_rho)``, the paper's pole-placement gains; all > 0 and
        ``s^rho + k_rho s^(rho-1) + ... + k_2 s + k_1`` Hurwitz (checked). The length sets
        ``rho``. See :func:`gains_from_poles` and :func:`lqr_gains`.
    gamma : float
        The paper's controller gain ``gamma``, nonzero, of the sign of ``b`` (negative for a
        plant with ``b < 0``; :func:`fl_design.simulate` and :func:`fl_design.sweep` refuse a
        sign opposite to ``b``'s over the region). For ``b > 0`` the paper asks ``gamma < 1/b_max``
        (``b_max`` the upper bound of ``b(w, x)``) for a monotone decay of the error
        ``e_u = v - sigma``; ``gamma < 2/b_max`` suffices for its convergence. A too small
        ``gamma`` also destabilizes the loop: when ``b gamma / T`` is slower than the closed
        loop set by the gains, ``u`` lags behind and the loop is unstable for every ``eps``.
    ki : float, optional
        Integral gain ``K_I >= 0`` acting on ``z``, the sampled integral of ``xhat_1 - r``.
        0 (default) disables the integral action (``z`` is still accumulated).
    u_limits : (float, float) or float, optional
        Saturation ``(lo, hi)`` of the input, lo < hi; a scalar ``c`` means ``(-c, c)``.
        None (default): no saturation.
    estimate_limits : sequence, optional
        One entry per estimate ``xhat_1 .. xhat_rho``: None (no limit), a scalar ``c``
        (``(-c, c)``) or a pair ``(lo, hi)``; limits the peaking of the high-gain observer.
        Entry 0 must be None: ``xhat_1`` is the output estimate fed to the integrator and the
        normative loop clamps only ``xhat_2 .. xhat_rho``. None (default): no limits.
    antiwindup : bool, optional
        Conditional integration (default True): ``z`` is held while ``u`` is on a limit and
        the integrator pushes it further out (the C step's ``antiwindup`` parameter is the
        same law). False: ``z`` integrates whatever ``u`` does (the paper's law).
    u0 : float, optional
        Initial input ``u(-1)``, the controller state before the first sample (inside
        ``u_limits``). Default None: the plant's equilibrium input ``u_eq`` at its operating
        point when a run knows the plant (a bumpless start), else 0 (:attr:`u_start`).

    Attributes
    ----------
    rho : int
        Relative degree served, ``len(gains)``.
    u_range : (float, float) or None
        The input saturation in use (``u_limits`` stays as given: a scalar ``c`` is
        ``(-c, c)`` here).
    estimate_ranges : tuple
        ``rho`` entries, each None or ``(lo, hi)``: the estimate limits in use.
    u_start : float
        ``u0``, or 0 when ``u0`` is None (no plant context).
    time_constant : float
        The designed loop's slowest time constant (s), from the gains.

    Raises
    ------
    HurwitzError
        The gains' polynomial has a root with non-negative real part (the roots are named).
    ParameterError
        A value is non-finite, out of range, or a limit is put on ``xhat_1``.
    DimensionError
        ``estimate_limits`` does not have ``rho`` entries.

    Examples
    --------
    The paper's Twin Rotor setting (rho = 2):

    >>> import fl_design as fl
    >>> ctrl = fl.DynamicController(gains=(2, 4), gamma=3e-4, ki=1e-3,
    ...                             estimate_limits=(None, 0.05), u_limits=(-2.5, 2.5))
    >>> ctrl.gains, ctrl.gamma, ctrl.ki, ctrl.u_range
    ((2.0, 4.0), 0.0003, 0.001, (-2.5, 2.5))
    """

    gains: tuple[float, ...]
    gamma: float
    _: KW_ONLY
    ki: float = 0.0
    u_limits: Interval | None = None
    estimate_limits: tuple[Interval | None, ...] | None = None
    u0: float | None = None
    antiwindup: bool = True
    u_range: Interval | None = field(init=False, repr=False, compare=False)
    estimate_ranges: tuple[Interval | None, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        gains = _checked_gains(self.gains)
        rho = len(gains)
        u_limits = v.interval("u_limits", self.u_limits)
        u0 = None if self.u0 is None else v.real_scalar("u0", self.u0)
        if u0 is not None and u_limits is not None and not u_limits[0] <= u0 <= u_limits[1]:
            raise ParameterError(f"u0={u0!r} must lie inside u_limits={u_limits}")
        fields = {
            "gains": gains,
            "gamma": v.nonzero("gamma", self.gamma),
            "ki": v.nonnegative("ki", self.ki),
            "u_range": u_limits,
            "estimate_ranges": _checked_estimate_limits(self.estimate_limits, rho),
            "u0": u0,
            "antiwindup": _checked_switch("antiwindup", self.antiwindup),
        }
        for name, value in fields.items():
            object.__setattr__(self, name, value)

    @property
    def u_start(self) -> float:
        """The initial input without plant context: ``u0``, or 0 when ``u0`` is None."""
        return 0.0 if self.u0 is None else float(self.u0)

    @property
    def rho(self) -> int:
        """Relative degree served (number of gains)."""
        return len(self.gains)

    @property
    def time_constant(self) -> float:
        """The designed loop's slowest time constant (s).

        It is ``1 / min |Re p|`` over the roots ``p`` of ``s^rho + k_rho s^(rho-1) + ... + k_1``
        (the integrator's slow pole left out).

        Examples
        --------
        >>> import fl_design as fl
        >>> round(fl.DynamicController((2.0, 4.0), 0.01).time_constant, 4)  # -2 + sqrt(2)
        1.7071
        """
        roots = np.roots(np.concatenate([[1.0], np.asarray(self.gains, dtype=float)[::-1]]))
        return 1.0 / float(np.min(np.abs(roots.real)))

    def replace(self, **changes) -> DynamicController:
        """Return a copy with fields changed and re-validated (``dataclasses.replace``).

        Parameters
        ----------
        **changes
            New values of ``gains``, ``gamma``, ``ki``, ``u_limits``, ``estimate_limits``, ``u0``,
            ``antiwindup``.

        Examples
        --------
        >>> import fl_design as fl
        >>> fl.DynamicController((2, 4), 3e-4).replace(gamma=1e-3).gamma
        0.001
        """
        return replace_fields(self, changes)

    def symbolic_law(self, xhat_ext, r, u_prev, z_prev, ready, gamma, T: float):
        """Steps 2-5 of the normative loop as CasADi expressions.

        Parameters
        ----------
        xhat_ext : casadi.SX
            ``(rho + 1,)`` estimates ``[xhat_1 .. xhat_rho, sigmahat]`` at sample ``k``.
        r : casadi.SX
            Reference ``r_k`` (scalar).
        u_prev, z_prev : casadi.SX
            Controller state ``u_(k-1)`` (saturated) and integrator ``z_(k-1)``.
        ready : casadi.SX
            1 when the estimate is valid; 0 holds ``u`` and ``z`` at their previous values
            (least-squares window not yet full).
        gamma : casadi.SX or float
            Controller gain (symbolic, so that sweeps can change it without rebuilding).
        T : float
            Sampling time of the integrator.

        Returns
        -------
        u, z, xhat_clamped : casadi.SX
            ``u_k`` (saturated), ``z_k``, and ``(rho + 1,)`` estimates after clamping.

        Examples
        --------
        >>> import casadi as ca
        >>> import fl_design as fl
        >>> ctrl = fl.DynamicController((2, 4), 0.5, estimate_limits=(None, 1.0))
        >>> x = ca.SX.sym("x", 3)
        >>> u, z, xc = ctrl.symbolic_law(x, 0.0, 0.0, 0.0, 1, ctrl.gamma, 1e-3)
        >>> float(ca.Function("f", [x], [u])([0.0, 5.0, 0.0]))  # xhat_2 clamped to 1
        -2.0
        """
        import casadi as ca

        rho = self.rho
        xhat_ext = ca.SX(xhat_ext)
        if xhat_ext.numel() != rho + 1:
            raise DimensionError(
                f"xhat_ext must have rho + 1 = {rho + 1} entries, got {xhat_ext.numel()}"
            )
        parts = [xhat_ext[i] for i in range(rho + 1)]
        for i, lim in enumerate(self.estimate_ranges):
            if lim is not None:
                parts[i] = ca.fmin(ca.fmax(parts[i], lim[0]), lim[1])
        xhat_c = ca.vertcat(*parts)
        err = parts[0] - r
        z = z_prev + T * err
        vk = -self.gains[0] * err - self.ki * z
        for i in range(1, rho):
            vk = vk - self.gains[i] * parts[i]
        u = u_prev + gamma * (vk - parts[rho])
        if self.u_range is not None:
            lo, hi = self.u_range
            u = ca.fmin(ca.fmax(u, lo), hi)
            if self.antiwindup is not False:  # True, or a 0/1 switch symbol (the C's block)
                push = -gamma * self.ki * err  # sign of z's push on u
                out = ca.logic_or(ca.logic_and(u >= hi, push > 0), ca.logic_and(u <= lo, push < 0))
                if self.antiwindup is not True:
                    out = ca.logic_and(self.antiwindup > 0.5, out)
                z = ca.if_else(out, z_prev, z)
        hold = ready == 0
        return ca.if_else(hold, u_prev, u), ca.if_else(hold, z_prev, z), xhat_c

    def __repr__(self) -> str:
        opts = [f"ki={self.ki:g}"] if self.ki else []
        if self.u_range is not None:
            opts.append(f"u_limits=({self.u_range[0]:g}, {self.u_range[1]:g})")
        if any(lim is not None for lim in self.estimate_ranges):
            shown = ", ".join(
                "None" if lim is None else f"({lim[0]:g}, {lim[1]:g})"
                for lim in self.estimate_ranges
            )
            opts.append(f"estimate_limits=({shown})")
        if self.u0 is not None:
            opts.append(f"u0={self.u0:g}")
        if not self.antiwindup:
            opts.append("antiwindup=False")
        gains = ", ".join(f"{k:g}" for k in self.gains)
        head = [f"gains=({gains})", f"gamma={self.gamma:g}"]
        return f"DynamicController({', '.join(head + opts)})"


def _checked_switch(name: str, value) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise ParameterError(f"{name} must be True or False, got {value!r}")
    return bool(value)


def _checked_gains(gains) -> tuple[float, ...]:
    if np.ndim(gains) == 0:
        raise DimensionError(f"gains must be a sequence (k_1, ..., k_rho), got {gains!r}")
    arr = v.real_vector("gains", gains)
    if arr.size == 0:
        raise DimensionError("gains must have at least one entry (k_1, ..., k_rho), got none")
    try:
        v.hurwitz_monic("gains", arr[::-1], what="s^rho + k_rho s^(rho-1) + ... + k_1")
    except HurwitzError:
        roots = np.roots(np.concatenate([[1.0], arr[::-1]]))
        shown = ", ".join(f"{z:.6g}".strip("()") for z in roots[roots.real >= 0.0])
        raise HurwitzError(
            f"gains=(k_1, ..., k_rho)={arr.tolist()} give {_poly_text(arr)} with roots not in the "
            f"open left half-plane: {shown}; choose gains whose polynomial is Hurwitz, e.g. "
            "fl.gains_from_poles([-1] * rho) or fl.lqr_gains(rho)"
        ) from None
    if np.any(arr <= 0.0):  # implied by Hurwitz; kept for roots numerically at 0
        raise ParameterError(f"gains must all be > 0, got {arr.tolist()}")
    return tuple(float(k) for k in arr)


def _poly_text(gains: np.ndarray) -> str:
    rho = gains.size
    terms = [f"s^{rho}"]
    for i in range(rho - 1, -1, -1):  # coefficient of s^i is k_(i+1)
        power = "" if i == 0 else (" s" if i == 1 else f" s^{i}")
        sign = "-" if gains[i] < 0 else "+"
        terms.append(f"{sign} {abs(gains[i]):g}{power}")
    return " ".join(terms)


def _checked_estimate_limits(limits, rho: int) -> tuple[Interval | None, ...]:
    if limits is None:
        return (None,) * rho
    if not isinstance(limits, (Sequence, np.ndarray)) or isinstance(limits, str):
        raise DimensionError(
            f"estimate_limits must be a sequence of {rho} entries (None, c or (lo, hi)), "
            f"got {limits!r}"
        )
    if len(limits) != rho:
        raise DimensionError(
            f"estimate_limits must have rho = {rho} entries (one per xhat_1..xhat_rho), "
            f"got {len(limits)}: {limits!r}"
        )
    out = tuple(v.interval(f"estimate_limits[{i}]", lim) for i, lim in enumerate(limits))
    if out[0] is not None:
        raise ParameterError(
            f"estimate_limits[0]={out[0]} would clamp xhat_1, the output estimate used by the "
            "integrator and the tracking error; the loop clamps only xhat_2..xhat_rho: use None "
            "as the first entry"
        )
    return out


def gains_from_poles(poles: Sequence[complex]) -> tuple[float, ...]:
    """Controller gains that place the closed-loop poles (the roots of ``p(s)`` below).

    ``p(s) = s^rho + k_rho s^(rho-1) + ... + k_1``.

    Closed form: the coefficients of ``prod_i (s - p_i)``, so repeated poles are exact (no
    ``place``).

    Parameters
    ----------
    poles : sequence of complex
        The ``rho`` desired closed-loop poles; real parts < 0, complex poles in conjugate pairs.

    Returns
    -------
    tuple of float
        ``(k_1, ..., k_rho)``: ``k_1 = prod(-p_i)``, ``k_rho = -sum(p_i)``.

    Raises
    ------
    HurwitzError
        A pole has a non-negative real part.
    ParameterError
        A pole is non-finite or a complex pole lacks its conjugate.

    Examples
    --------
    >>> import fl_design as fl
    >>> fl.gains_from_poles([-1, -2])
    (2.0, 3.0)
    >>> fl.gains_from_poles([-1 + 1j, -1 - 1j])
    (2.0, 2.0)
    """
    return monic_coefficients(checked_poles(poles))[::-1]


def lqr_gains(rho: int, Q=None, R: float = 1.0) -> tuple[float, ...]:
    """Continuous-time LQR gains on the chain of ``rho`` integrators (Brunovsky form).

    Minimizes ``int x^T Q x + R v^2 dt`` for ``x' = A x + B v`` (``A`` the shift matrix,
    ``B = e_rho``), with ``v = -K x``, ``K = R^-1 B^T P`` and ``P`` the stabilizing solution of
    the continuous algebraic Riccati equation (``scipy.linalg.solve_continuous_are``).

    Parameters
    ----------
    rho : int
        Relative degree (length of the integrator chain), >= 1.
    Q : array_like, optional
        State weight: a symmetric positive semidefinite ``(rho, rho)`` matrix or a length-``rho``
        vector of its diagonal; ``(A, Q)`` must be detectable. Default: identity.
    R : float, optional
        Input weight > 0 (default 1).

    Returns
    -------
    tuple of float
        ``(k_1, ..., k_rho)`` for :class:`DynamicController`.

    Raises
    ------
    ParameterError
        ``Q`` not symmetric PSD or ``R <= 0``.
    ComputationError
        The Riccati equation has no stabilizing solution.

    Examples
    --------
    >>> import fl_design as fl
    >>> [round(k, 6) for k in fl.lqr_gains(2)]  # s^2 + sqrt(3) s + 1
    [1.0, 1.732051]
    """
    from scipy import linalg

    rho = v.integer("rho", rho, minimum=1)
    R = v.positive("R", R)
    Qm = _checked_weight(Q, rho)
    A = np.eye(rho, k=1)
    B = np.zeros((rho, 1))
    B[-1, 0] = 1.0
    try:
        P = linalg.solve_continuous_are(A, B, Qm, np.array([[R]]))
    except (np.linalg.LinAlgError, ValueError) as err:
        raise ComputationError(f"no stabilizing LQR solution for Q={Qm.tolist()}: {err}") from None
    K = (B.T @ P).ravel() / R
    if not np.all(np.isfinite(K)) or np.any(np.linalg.eigvals(A - B @ K[None, :]).real >= 0.0):
        raise ComputationError(
            f"LQR for Q={Qm.tolist()} did not give a stabilizing gain (is (A, Q) detectable?)"
        )
    return tuple(float(k) for k in K)


def _checked_weight(Q, rho: int) -> np.ndarray:
    if Q is None:
        return np.eye(rho)
    arr = np.asarray(Q, dtype=float) if not isinstance(Q, str) else None
    if arr is not None and arr.ndim == 1:
        arr = np.diag(v.real_vector("Q", arr, length=rho))
    if arr is None or arr.shape != (rho, rho):
        raise DimensionError(
            f"Q must be a ({rho}, {rho}) matrix or a length-{rho} diagonal, got {Q!r}"
        )
    if not np.all(np.isfinite(arr)):
        raise ParameterError(f"Q must be finite, got {arr.tolist()}")
    if not np.allclose(arr, arr.T, rtol=1e-12, atol=1e-12):
        raise ParameterError(f"Q must be symmetric, got {arr.tolist()}")
    eigs = np.linalg.eigvalsh(arr)
    if np.min(eigs) < -1e-12 * max(1.0, np.abs(arr).max()):
        raise ParameterError(f"Q must be positive semidefinite, got eigenvalues {eigs.tolist()}")
    return arr
