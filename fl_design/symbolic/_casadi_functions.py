"""The numerical face of a plant: :class:`PlantFunctions` (CasADi SX functions f, h, sigma, b).

Examples
--------
>>> import fl_design as fl
>>> sorted(vars(fl.plants.pendulum().casadi()))
['b', 'f', 'h', 'sigma']
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca


@dataclass(frozen=True)
class PlantFunctions:
    """CasADi SX functions of a plant, numeric parameters substituted.

    Parameters
    ----------
    f : casadi.Function
        ``f(x[n], u) -> xdot[n]``.
    h : casadi.Function
        ``h(x[n]) -> y``.
    sigma : casadi.Function
        ``sigma(x[n], u) -> y^(rho)``, the true lumped term ``a + b u`` (also for a non-affine input).
    b : casadi.Function
        ``b(x[n], u) -> d y^(rho)/du``.

    Examples
    --------
    >>> import fl_design as fl
    >>> fns = fl.plants.pendulum().casadi()
    >>> float(fns.b([0.3, 0.0], 0.0))
    1.0
    """

    f: ca.Function
    h: ca.Function
    sigma: ca.Function
    b: ca.Function


__all__ = ["PlantFunctions"]
