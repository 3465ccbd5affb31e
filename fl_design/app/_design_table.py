"""``[design]``: the keys of an estimator and its dynamic controller, checked by building them.

A :class:`fl_design.Design` holds two objects (an estimator, a controller); its TOML table is
their fields side by side. :class:`DesignTable` is that table: every value is checked by the
API objects themselves (:class:`fl_design.DynamicController`, :class:`fl_design.EHGO` or
:class:`fl_design.LeastSquaresEstimator`), and :meth:`DesignTable.build` makes the design.

Examples
--------
>>> from fl_design.app._design_table import DesignTable
>>> DesignTable(eps=0.05, T=1e-3, gains=[1.0, 2.0], gamma=3e-4).build().estimator.eps
0.05
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .. import _validate as V
from ..errors import ParameterError

ESTIMATORS = ("ehgo", "least_squares")


def estimate_limits(value) -> tuple | None:
    """``[design] estimate_limits``: numbers, or ``"none"`` for an estimate without a limit.

    Parameters
    ----------
    value : sequence or None
        Numbers and ``"none"`` strings; empty or None: no limits.

    Returns
    -------
    tuple or None
        A positive bound per estimate (None: that one unbounded); None: no limits at all.

    Raises
    ------
    ParameterError
        Not an array, or an entry neither a positive number nor ``"none"``.

    Examples
    --------
    >>> from fl_design.app._design_table import estimate_limits
    >>> estimate_limits([2.5, "none"])
    (2.5, None)
    """
    if not value:
        return None
    if isinstance(value, str) or not isinstance(value, (list, tuple)):
        raise ParameterError(f'estimate_limits must be an array of numbers or "none", got '
                             f"{V.short(value)}")
    out = []
    for v in value:
        if isinstance(v, str) and v.lower() == "none":
            out.append(None)
        elif V.is_real_number(v):
            out.append(V.positive("estimate_limits entry", v))
        else:
            raise ParameterError(f'estimate_limits entries are numbers or "none", got {v!r}')
    return tuple(out)


@dataclass(frozen=True)
class DesignTable:
    """``[design]``: an estimator (EHGO or least squares) under the dynamic controller.

    Parameters
    ----------
    estimator : str, optional
        ehgo | least_squares.
    eps : float, optional
        Observer time constant (s); keep it >= T.
    T : float, optional
        Sampling time (s).
    coeffs : tuple of float, optional
        Observer polynomial s^(rho+1) + c1 s^rho + ... (rho + 1 numbers); [] for binomial.
    window : int, optional
        least_squares only: samples in the fit.
    gains : tuple of float, optional
        K: closed loop s^rho + K_rho s^(rho-1) + ... + K_1 (rho numbers).
    gamma : float, optional
        Controller gain, with the sign of b; |gamma| < 1/max|b|.
    ki : float, optional
        Integral gain.
    u_limits : tuple of float, optional
        Input saturation [lo, hi]; [] for none.
    estimate_limits : tuple, optional
        Bounds on |xhat_i|, a number or "none" each; [] for none.

    Raises
    ------
    ParameterError
        A missing gains, gamma, T (or eps for an EHGO); whatever the controller or the
        estimator refuses (their own messages).

    Examples
    --------
    >>> from fl_design.app._design_table import DesignTable
    >>> DesignTable(estimator="least_squares", T=1e-3, gains=[1.0, 2.0], gamma=3e-4).window
    9
    """

    estimator: str = "ehgo"
    eps: float | None = None
    T: float | None = None
    coeffs: tuple = ()
    window: int = 9
    gains: tuple | None = None
    gamma: float | None = None
    ki: float = 0.0
    u_limits: tuple = ()
    estimate_limits: tuple = ()

    def __post_init__(self) -> None:
        V.choice("estimator", self.estimator, ESTIMATORS)
        need = ("gains", "gamma", "T") + (("eps",) if self.estimator == "ehgo" else ())
        missing = [k for k in need if getattr(self, k) is None]
        if missing:
            raise ParameterError(
                f"needs {', '.join(missing)} for this plant (a plant from expressions has no "
                "bench design): give gains (rho numbers), gamma (the sign of b), eps and T (s); "
                "`fl-design init --from-ode` shows them")
        set_ = object.__setattr__
        set_(self, "gains", V.real_tuple("gains", self.gains, nonempty=True))
        set_(self, "coeffs", V.real_tuple("coeffs", self.coeffs))
        set_(self, "u_limits", V.real_tuple("u_limits", self.u_limits,
                                         length=2 if len(self.u_limits) else None))
        limits = estimate_limits(self.estimate_limits)
        set_(self, "estimate_limits", () if limits is None else
             tuple("none" if v is None else v for v in limits))
        set_(self, "T", V.positive("T", self.T))
        if self.eps is not None:
            set_(self, "eps", V.positive("eps", self.eps))
        set_(self, "window", V.integer("window", self.window, minimum=1))
        # the API's objects check the rest (gamma, ki, the polynomials, ...); a length that
        # does not match the gains is refused when the plant is known (prepare, build)
        self._make(len(self.gains), None, None, lenient=True)

    def build(self, *, rho: int | None = None, eps: float | None = None,
              window: int | None = None):
        """The :class:`fl_design.Design` of this table.

        Parameters
        ----------
        rho : int, optional
            Relative degree (default: the number of gains). Limits and coefficients whose
            length does not match are left out here and refused when the plant is known.
        eps : float, optional
            Override the observer's eps.
        window : int, optional
            A least-squares baseline with this window instead.

        Examples
        --------
        >>> from fl_design.app._design_table import DesignTable
        >>> DesignTable(eps=0.05, T=1e-3, gains=[1.0, 2.0], gamma=3e-4).build(window=5).rho
        2
        """
        return self._make(rho or len(self.gains), eps, window, lenient=False)

    def _make(self, rho: int, eps, window, *, lenient: bool):
        from ..design import EHGO, Design, DynamicController, LeastSquaresEstimator

        limits = estimate_limits(self.estimate_limits)
        if lenient and limits is not None and len(limits) != len(self.gains):
            limits = None
        ctrl = DynamicController(self.gains, self.gamma, ki=self.ki,
                                 u_limits=self.u_limits or None, estimate_limits=limits)
        if window is None and self.estimator == "least_squares":
            window = self.window
        if window is not None:
            est = LeastSquaresEstimator(rho=rho, T=self.T, window=int(window))
        else:
            coeffs = self.coeffs or None
            if lenient and coeffs is not None and len(coeffs) != rho + 1:
                coeffs = None
            est = EHGO(rho=rho, eps=self.eps if eps is None else eps, T=self.T, coeffs=coeffs)
        return Design(estimator=est, controller=ctrl)

    @property
    def sign(self) -> float:
        """The sign of gamma (that of b), +1.0 or -1.0."""
        return math.copysign(1.0, self.gamma)


__all__ = ["DesignTable", "estimate_limits"]
