"""The baseline a practitioner would use: linear ADRC with a ``b0`` guess (Gao's bandwidth
parameterization), discretized as it is usually coded.

Plant read as ``y^(rho) = f + b0 u`` with ``f`` the "total disturbance" (``f = a + (b - b0) u``):

* extended state observer of order ``rho + 1``, ``z' = A z + B b0 u + L (y - z_1)``, gains from
  ``(s + w_o)^(rho+1)``: ``l_i = C(rho+1, i) w_o^i``;
* control law ``u = (sum_i k_i (r^(i-1) - z_i) - z_(rho+1)) / b0`` with ``r``'s derivatives 0
  (a set-point), gains from ``(s + w_c)^rho``: ``k_i = C(rho, i-1) w_c^(rho-i+1)``;
* sampled as most embedded ADRC code does it: the observer by forward Euler, one step per
  sample, the input computed from the estimate before it sees ``y_k`` (the one-sample predictor
  form), saturated, and the saturated input fed to the observer.

:class:`LinearADRC` has the interface a run needs (``T``, ``rho``, ``step(state, y, r) ->
(state_next, u)`` as one CasADi function, ``initial_state(y0=..., u0=...)``): the virtual rig
(:mod:`fl_design.sim._rig`) runs it on the same members as the design.

Examples
--------
>>> from fl_design.design._adrc import LinearADRC
>>> c = LinearADRC(rho=2, T=1e-3, b0=5.0, wc=10.0, wo=50.0)
>>> c.observer_gains, c.controller_gains
((150.0, 7500.0, 125000.0), (100.0, 20.0))
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from .. import _validate as V
from ..errors import ParameterError


@dataclass(frozen=True)
class LinearADRC:
    """Linear ADRC (see the module).

    Parameters
    ----------
    rho : int
        Relative degree.
    T : float
        Sampling time [s].
    b0 : float
        The guess of ``b`` (nonzero; its sign is ``b``'s).
    wc, wo : float
        Controller and observer bandwidths [rad/s].
    u_limits : (float, float), optional
        Input saturation.
    """

    rho: int
    T: float
    b0: float
    wc: float
    wo: float
    u_limits: tuple | None = None

    def __post_init__(self):
        V.integer("rho", self.rho, minimum=1, maximum=8)
        V.positive("T", self.T)
        b0 = V.real_scalar("b0", self.b0)
        if b0 == 0.0:
            raise ParameterError("b0 must be nonzero (the guess of b, with its sign)")
        V.positive("wc", self.wc)
        V.positive("wo", self.wo)
        if self.u_limits is not None:
            object.__setattr__(self, "u_limits", V.interval("u_limits", self.u_limits))

    @property
    def observer_gains(self) -> tuple:
        """``l_i = C(rho+1, i) w_o^i``, i = 1..rho+1."""
        n = self.rho + 1
        return tuple(float(math.comb(n, i) * self.wo ** i) for i in range(1, n + 1))

    @property
    def controller_gains(self) -> tuple:
        """``k_i = C(rho, i-1) w_c^(rho-i+1)``, i = 1..rho (on ``z_1 .. z_rho``)."""
        return tuple(float(math.comb(self.rho, i - 1) * self.wc ** (self.rho - i + 1))
                     for i in range(1, self.rho + 1))

    def initial_state(self, *, y0: float | None = None, u0: float | None = None,
                      **_) -> np.ndarray:
        """Observer at rest at the first measurement, ``z_(rho+1) = 0``, and the held input."""
        s = np.zeros(self.rho + 2)
        s[0] = 0.0 if y0 is None else float(y0)
        s[-1] = 0.0 if u0 is None else float(u0)
        return s

    @functools.cached_property
    def step(self):
        """``adrc_step(state, y, r) -> (state_next, u)`` (casadi.Function)."""
        import casadi as ca

        n = self.rho + 1
        s = ca.SX.sym("s", n + 1)
        y, r = ca.SX.sym("y"), ca.SX.sym("r")
        z = s[:n]
        k = self.controller_gains
        v = k[0] * (r - z[0]) - sum(k[i] * z[i] for i in range(1, self.rho))
        u = (v - z[n - 1]) / float(self.b0)
        if self.u_limits is not None:
            u = ca.fmin(ca.fmax(u, self.u_limits[0]), self.u_limits[1])
        e = y - z[0]
        l_g = self.observer_gains
        dz = [z[i + 1] + l_g[i] * e for i in range(n - 1)]
        dz[-1] = dz[-1] + float(self.b0) * u
        dz.append(l_g[n - 1] * e)
        z_next = ca.vertcat(*[z[i] + self.T * dz[i] for i in range(n)])
        return ca.Function("adrc_step", [s, y, r], [ca.vertcat(z_next, u), u],
                           ["state", "y", "r"], ["state_next", "u"])

    def describe(self) -> str:
        """One line.

        Examples
        --------
        >>> LinearADRC(rho=1, T=1e-3, b0=2.0, wc=5.0, wo=20.0).describe()[:40]
        'linear ADRC (Euler ESO), b0 = 2, w_c = 5'
        """
        return (f"linear ADRC (Euler ESO), b0 = {self.b0:g}, w_c = {self.wc:g} rad/s, "
                f"w_o = {self.wo:g} rad/s, T = {self.T:g} s")


__all__ = ["LinearADRC"]
