"""Equilibria of a plant: the states and input holding given states or the output at a value.

``f(x, u) = 0`` with some states fixed and, optionally, ``h(x) = y``: the remaining states and
``u`` are solved by Newton's method, or where it does not reach the tolerance by damped least
squares (SciPy, analytic Jacobian), from several starts in the region of interest (the origin-like guess first, then a scrambled Sobol set over the region
and the input range). Distinct solutions inside the region are collected: none raises, and so
do two or more (the equilibrium is then not unique in the region: narrow it).

Examples
--------
>>> import fl_design as fl
>>> eq = fl.plants.pendulum().equilibrium(y=0.3)
>>> eq.x.round(6).tolist(), round(eq.u, 6)
([0.3, 0.0], 2.899053)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy as sp

from ..errors import PlantDefinitionError
from ._tidy import _drop_dirac, _real_maps

#: Random starts of the equilibrium search beyond the first guess (a Sobol set).
STARTS = 16
#: Newton steps tried from each start before the bounded least squares (kept only when they
#: reach the residual tolerance: a few steps on a smooth plant, e.g. 3 on the TRMS).
NEWTON_STEPS = 12


@dataclass(frozen=True)
class Equilibrium:
    """An equilibrium ``f(x, u) = 0`` of a plant, with its output ``y = h(x)``.

    Parameters
    ----------
    x : numpy.ndarray
        The states.
    u : float
        The input holding them.
    y : float
        The output there.

    Examples
    --------
    >>> import fl_design as fl
    >>> fl.plants.pendulum().equilibrium(y=0.0)
    Equilibrium(x=[0.0, 0.0], u=0.0, y=0.0)
    """

    x: np.ndarray
    u: float
    y: float

    def __repr__(self) -> str:
        return f"Equilibrium(x={self.x.tolist()}, u={self.u!r}, y={self.y!r})"


def _box(states, region, input_range) -> tuple[np.ndarray, np.ndarray]:
    lo = [region.get(s, (-np.inf, np.inf))[0] for s in states]
    hi = [region.get(s, (-np.inf, np.inf))[1] for s in states]
    u = input_range or (-np.inf, np.inf)
    return np.array([*lo, u[0]]), np.array([*hi, u[1]])


def _starts(lo: np.ndarray, hi: np.ndarray, first: np.ndarray) -> np.ndarray:
    finite_lo = np.where(np.isfinite(lo), lo, np.minimum(first, 0.0) - 1.0)
    finite_hi = np.where(np.isfinite(hi), hi, np.maximum(first, 0.0) + 1.0)
    from scipy.stats import qmc  # lazy: scipy.stats takes ~1 s to import

    sobol = qmc.Sobol(lo.size, scramble=True, seed=0).random(STARTS)
    return np.vstack([first, finite_lo + sobol * (finite_hi - finite_lo)])


def solve_equilibrium(*, states, input, rhs, output, params, region, input_range,
                      fixed: dict, y: float | None, name: str = "plant") -> Equilibrium:
    """The unique equilibrium in the region with the states ``fixed`` (and output ``y``).

    Parameters
    ----------
    states, input, rhs, output, params : SymPy objects
        The plant's definition (:class:`fl_design.Plant`).
    region : dict
        ``{state: (lo, hi)}`` (states without a range are free).
    input_range : (float, float) or None
        Admissible inputs.
    fixed : dict
        ``{state Symbol: value}`` held.
    y : float or None
        The output value held, if any.
    name : str, optional
        The plant's name, for messages.

    Returns
    -------
    Equilibrium

    Raises
    ------
    PlantDefinitionError
        No equilibrium in the region and input range, or several (both named, with what was
        tried).

    Examples
    --------
    >>> import sympy as sp
    >>> from fl_design.symbolic._equilibrium import solve_equilibrium
    >>> x1, x2, u = sp.symbols("x1 x2 u")
    >>> solve_equilibrium(states=[x1, x2], input=u, rhs=[x2, -x1 + u], output=x1, params={},
    ...                   region={}, input_range=None, fixed={}, y=0.5).u
    0.5
    """
    region = region or {}
    lo, hi = _box(states, region, input_range)
    free = [i for i, s in enumerate(states) if s not in fixed] + [len(states)]
    eqs = sp.Matrix([*rhs, *([output - y] if y is not None else [])]).subs(params)
    unknowns = [*states, input]
    first = np.array([fixed.get(s, 0.0) for s in states] + [0.0])
    first = np.clip(first, lo, hi)
    sub = {s: v for s, v in fixed.items()}
    F = eqs.subs(sub)
    syms = [unknowns[i] for i in free]
    fun = sp.lambdify([syms], list(F), modules="numpy")
    # differentiate with real stand-ins (d|x|/dx = sign(x) whatever the user's assumptions),
    # drop DiracDelta terms (the derivative almost everywhere)
    fwd, back = _real_maps([*syms, *F.free_symbols])
    J = _drop_dirac(F.xreplace(fwd).jacobian([fwd.get(s, s) for s in syms])).xreplace(back)
    jac = sp.lambdify([syms], J.tolist(), modules="numpy")
    scale = 1.0 + float(np.max(np.abs(np.asarray(fun(first[free]), dtype=float))))
    tol = 1e-9 * scale
    def res(z):
        return np.asarray(fun(z), dtype=float).ravel()

    def der(z):
        return np.atleast_2d(np.asarray(jac(z), dtype=float))

    found: list[np.ndarray] = []
    for start in _starts(lo[free], hi[free], first[free]):
        _defined_at(res, start, syms, F, name)
        z, resid = _solve_from(res, der, start, (lo[free], hi[free]), tol)
        if resid <= tol and not any(np.allclose(z, f, rtol=1e-6, atol=1e-8) for f in found):
            found.append(z)
    if not found:  # say why: an equilibrium outside the region or input range?
        z, resid = _solve_from(res, der, first[free], (-np.inf, np.inf))
        if resid <= tol:
            outside = first.copy()
            outside[free] = z
            _outside(outside, lo, hi, states, input_range, name)
    return _unique(found, first, free, fixed, y, states, output, params, name, tol)


def _defined_at(res, z, syms, F, name) -> None:
    """Refuse a region where ``f`` is undefined (e.g. ``sqrt`` of a negative number), naming
    the point and the first expression that fails there."""
    with np.errstate(all="ignore"):
        try:
            ok = bool(np.all(np.isfinite(res(z))))
        except (TypeError, ValueError, ZeroDivisionError):
            ok = False
    if ok:
        return
    point = dict(zip(syms, z.tolist()))
    where = ", ".join(f"{s}={v:.6g}" for s, v in point.items())
    bad = next((e for e in F if complex(e.subs(point).evalf()).imag != 0 or
                not np.isfinite(complex(e.subs(point).evalf()))), None)
    what = "" if bad is None else f": {bad} is not a finite real number there"
    raise PlantDefinitionError(
        f"plant {name!r} is not defined at the point ({where}) inside its region and input "
        f"range{what}; shrink the region (or input_range) to where the model is defined")


def _newton(res, der, z, bounds, steps: int) -> np.ndarray:
    """At most ``steps`` Newton steps (least-squares, clipped to ``bounds``), each kept only
    when it does not increase ``max|res|``; stops at the first step that is not kept."""
    for _ in range(steps):
        step = np.linalg.lstsq(der(z), -res(z), rcond=None)[0]
        if not np.all(np.isfinite(step)):
            break
        trial = np.clip(z + step, *bounds)
        if not np.max(np.abs(res(trial))) <= np.max(np.abs(res(z))):
            break
        z = trial
    return z


def _solve_from(res, der, start, bounds, tol=None) -> tuple[np.ndarray, float]:
    """``(z, max|residual|)`` from ``start``: Newton's method first (given ``tol``: kept when it
    reaches ``max|res| <= tol`` within :data:`NEWTON_STEPS`), else bounded least squares, then
    Newton steps to round-off."""
    with np.errstate(all="ignore"):
        if tol is not None:
            z = _newton(res, der, np.asarray(start, dtype=float), bounds, NEWTON_STEPS)
            resid = float(np.max(np.abs(res(z))))
            if resid <= tol:
                return z, resid
        import scipy.optimize  # lazy: 0.3-0.8 s to import, needed only when solving

        z = scipy.optimize.least_squares(res, start, jac=der, bounds=bounds, xtol=1e-15,
                                         ftol=1e-15, gtol=1e-15).x
        z = _newton(res, der, z, bounds, 3)
        return z, float(np.max(np.abs(res(z))))


def _outside(z, lo, hi, states, input_range, name) -> None:
    names = [f"{s}" for s in states]
    for i, v in enumerate(z):
        if not lo[i] <= v <= hi[i]:
            if i == len(states):
                raise PlantDefinitionError(
                    f"plant {name!r}: the equilibrium needs u_eq={v:.6g}, outside the input range "
                    f"{tuple(input_range)}; choose an operating point the input can hold")
            raise PlantDefinitionError(
                f"plant {name!r}: the equilibrium has {names[i]}={v:.6g}, outside the region "
                f"[{lo[i]:g}, {hi[i]:g}] of {names[i]}; choose another operating point or widen "
                "the region")


def _unique(found, first, free, fixed, y, states, output, params, name, tol) -> Equilibrium:
    held = ", ".join([f"{s}={v:g}" for s, v in fixed.items()] +
                     ([f"y={y:g}"] if y is not None else [])) or "nothing held"
    solved = ", ".join(str(s) for s in [*states, "u"] if s not in fixed)
    if not found:
        raise PlantDefinitionError(
            f"plant {name!r} has no equilibrium f(x, u) = 0 with {held} inside its region and "
            f"input range: solved for {solved} by least squares from {STARTS + 1} starts in the "
            f"region (residual tolerance {tol:.3g}); choose an operating point the plant can hold")
    if len(found) > 1:
        tidy = sorted(tuple(float(v) if abs(v) > 1e-12 else 0.0 for v in f) for f in found)
        shown = "; ".join(", ".join(f"{v:.6g}" for v in f) for f in tidy[:4])
        raise PlantDefinitionError(
            f"plant {name!r} has {len(found)} equilibria with {held} in its region ({solved} = "
            f"{shown}): not unique; narrow the region or hold more states")
    z = first.copy()
    z[free] = found[0]
    z[np.abs(z) < 1e-12] = 0.0
    x = z[:-1]
    yv = float(output.subs(params).subs(dict(zip(states, x.tolist()))))
    x.setflags(write=False)
    return Equilibrium(x=x, u=float(z[-1]), y=yv if y is None else float(y))


__all__ = ["Equilibrium", "solve_equilibrium"]
