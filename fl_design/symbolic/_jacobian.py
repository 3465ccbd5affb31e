"""Bounds of ``d sigma/d x_i`` over the region, in normal-form coordinates, at ``u = u_eq``.

For a plant without internal dynamics (``rho = n``) the normal-form coordinates are
``xi = (y, y', ..., y^(rho-1))`` (functions of the state ``x``) and ``sigma = y^(rho)``. The
Jacobian ``d sigma/d xi = (d sigma/d x)(d xi/d x)^-1`` at the equilibrium input ``u_eq`` is
evaluated (CasADi) on a dense tensor grid over the region's box (the same grid as
:meth:`fl_design.Plant.b_bounds`); each bound is then widened by ``margin`` times the width of
its range (a range that is a single point is not widened).
Sampling, not interval arithmetic: a steep extremum between grid points can be missed, which
is what the margin is for.

Examples
--------
>>> import fl_design as fl
>>> from fl_design.symbolic._jacobian import jacobian_bounds
>>> [tuple(round(v, 3) for v in r) for r in jacobian_bounds(fl.plants.pendulum(), margin=0.0)]
[(-9.81, 9.81), (-0.5, -0.5)]
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from .. import _validate as V
from ..errors import ParameterError, RelativeDegreeError
from ._bridge import to_casadi


def _box(plant, region) -> list[tuple[float, float]]:
    reg = plant.region or {}
    if region is not None:
        by_name = {str(s): s for s in plant.states}
        reg = dict(reg)
        for key, rng in region.items():
            sym = by_name.get(str(key), key)
            if sym not in plant.states:
                raise ParameterError(f"region names {key!r}, not a state of {plant.name!r}: "
                                     f"use one of {list(by_name)}")
            reg[sym] = V.interval(f"region[{key}]", rng, allow_none=False)
    missing = [str(s) for s in plant.states if s not in reg]
    if missing:
        raise ParameterError(f"jacobian_bounds needs a range for every state; none for "
                             f"{missing} in the region of {plant.name!r}: pass region={{...}}")
    return [reg[s] for s in plant.states]


def jacobian_bounds(plant, *, region=None, margin: float = 0.05,
                    points: int = 200_000) -> tuple[tuple[float, float], ...]:
    """``((lo, hi), ...)`` of ``d sigma/d xi_i``, i = 1..rho (see the module docstring)."""
    margin = V.nonnegative("margin", margin)
    points = V.integer("points", points, minimum=2)
    chain = plant._lie_chain()
    if chain.rho != plant.n:
        raise RelativeDegreeError(
            f"jacobian_bounds needs a plant without internal dynamics (rho = n); plant "
            f"{plant.name!r} has rho = {chain.rho} < n = {plant.n}"
        )
    args = [list(plant.states), [plant.input]]
    xi = to_casadi(list(chain.derivatives[: chain.rho]), args, "xi", subs=plant._params_map,
                   input_names=["x", "u"], output_name="xi")
    sig = to_casadi(chain.derivatives[chain.rho], args, "sigma", subs=plant._params_map,
                    input_names=["x", "u"], output_name="sigma")
    x = ca.SX.sym("x", plant.n)
    Jx = ca.jacobian(xi(x, plant.u_eq), x)
    gs = ca.jacobian(sig(x, plant.u_eq), x)
    fn = ca.Function("dsigma_dxi", [x], [ca.mtimes(gs, ca.inv(Jx))])
    box = _box(plant, region)
    m = max(2, int(np.floor(points ** (1.0 / plant.n))))
    axes = [np.linspace(lo, hi, m) for lo, hi in box]
    pts = np.stack([g.ravel() for g in np.meshgrid(*axes, indexing="ij")])
    vals = np.asarray(fn.map(pts.shape[1])(pts), dtype=float).reshape(-1, plant.n).T
    if not np.all(np.isfinite(vals)):
        raise ParameterError(f"d sigma/d xi is not finite on the region of {plant.name!r}")
    lo, hi = vals.min(axis=1), vals.max(axis=1)
    pad = margin * (hi - lo)
    return tuple((float(a - p), float(b + p)) for a, b, p in zip(lo, hi, pad))


__all__ = ["jacobian_bounds"]
