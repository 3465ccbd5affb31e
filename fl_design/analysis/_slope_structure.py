"""Structure of a plant class beyond its slope box: slope-restricted static functions.

:class:`SlopeRestricted` says that ``sigma`` depends on one normal-form coordinate (or on the
input) through one time-invariant scalar function of bounded slope: a friction on ``xi_2``, a
spring on ``xi_1``, a static input map. A slope box lets the slope be any signal of time;
this structure keeps it a function of the state, which multiplier arguments (Zames-Falb,
Popov/Jury-Lee, IQCs) exploit (``fl.certify_step``). :meth:`fl_design.PlantClass.from_plant`
detects it (:func:`_detect_structure`).

Examples
--------
>>> SlopeRestricted(0, (3.6, 6.8), "input map").variable
'u'
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .. import _validate as V
from ..errors import ParameterError


def _fmt(x: float) -> str:
    return f"{x:.6g}"


@dataclass(frozen=True)
class SlopeRestricted:
    """``sigma`` depends on one variable through a static scalar function with bounded slope.

    ``sigma = phi(v) + (the rest, free of v)`` with ``v = xi_i`` (``coordinate = i``, 1..rho)
    or ``v = u`` (``coordinate = 0``), ``phi`` time-invariant and ``phi'(v)`` in ``slope``
    (a friction on ``xi_2``, a spring on ``xi_1``, a static input nonlinearity). More than a
    slope box: the slope is a *function of the state*, not an arbitrary signal of time, which is
    what multiplier arguments (Zames-Falb, Popov/Jury-Lee, IQCs) use; ``monotone`` when the
    slope keeps one sign.

    Parameters
    ----------
    coordinate : int
        ``i`` of ``xi_i`` (1..rho), or 0 for the input ``u``.
    slope : (float, float)
        Interval of ``d phi / d v``.
    name : str, optional
        What it is (``"friction"``).

    Examples
    --------
    >>> s = SlopeRestricted(2, (-505.0, -5.0), "friction")
    >>> s.variable, s.monotone, s.describe()
    ('xi_2', True, 'xi_2 enters through one static monotone function (friction), slope in [-505, -5]')
    """

    coordinate: int
    slope: tuple[float, float]
    name: str = ""

    def __post_init__(self):
        object.__setattr__(self, "coordinate", V.integer("coordinate", self.coordinate,
                                                         minimum=0, maximum=8))
        try:
            lo, hi = (float(v) for v in self.slope)
        except (TypeError, ValueError) as exc:
            raise ParameterError(f"slope must be a pair (lo, hi) of numbers, got "
                                 f"{V.short(self.slope)}") from exc
        if not (math.isfinite(lo) and math.isfinite(hi)) or lo > hi:
            raise ParameterError(f"slope = ({lo:g}, {hi:g}) of {self.variable} must be finite "
                                 f"with lo <= hi")
        object.__setattr__(self, "slope", (lo, hi))
        object.__setattr__(self, "name", str(self.name))

    @property
    def variable(self) -> str:
        """``"u"`` or ``"xi_i"``."""
        return "u" if self.coordinate == 0 else f"xi_{self.coordinate}"

    @property
    def monotone(self) -> bool:
        """The slope keeps one sign (``phi`` monotone)."""
        return self.slope[0] >= 0.0 or self.slope[1] <= 0.0

    def describe(self) -> str:
        """One phrase."""
        kind = "static monotone function" if self.monotone else "static function"
        nm = f" ({self.name})" if self.name else ""
        return (f"{self.variable} enters through one {kind}{nm}, slope in "
                f"[{_fmt(self.slope[0])}, {_fmt(self.slope[1])}]")

    def to_dict(self) -> dict:
        """Plain JSON."""
        return {"coordinate": self.coordinate, "variable": self.variable,
                "slope": list(self.slope), "monotone": self.monotone, "name": self.name}


def _structure(value, rho: int, a_slopes, b) -> tuple:
    """Validate ``structure`` (SlopeRestricted, dicts or ``(i, (lo, hi))`` pairs) against the
    class: ``coordinate <= rho``, the slope inside ``a_slopes[i-1]`` (or ``b`` for ``u``)."""
    out = []
    for item in value or ():
        if isinstance(item, SlopeRestricted):
            s = item
        elif isinstance(item, dict):
            s = SlopeRestricted(**item)
        else:
            try:
                s = SlopeRestricted(*item)
            except TypeError as exc:
                raise ParameterError(f"structure entries must be SlopeRestricted, dicts or "
                                     f"(coordinate, (lo, hi)), got {V.short(item)}") from exc
        if s.coordinate > rho:
            raise ParameterError(f"structure names xi_{s.coordinate} but rho = {rho}: use "
                                 f"coordinate 1..{rho} (xi_i) or 0 (the input u)")
        box = b if s.coordinate == 0 else (None if a_slopes is None else a_slopes[s.coordinate - 1])
        if box is None:
            raise ParameterError(f"structure on {s.variable} needs a_slopes (its slope interval "
                                 f"is the box's entry {s.coordinate})")
        tol = 1e-9 * max(1.0, abs(box[0]), abs(box[1]))
        if s.slope[0] < box[0] - tol or s.slope[1] > box[1] + tol:
            raise ParameterError(
                f"structure slope of {s.variable} [{s.slope[0]:g}, {s.slope[1]:g}] is not inside "
                f"the class's {'b' if s.coordinate == 0 else 'a_slopes'} entry "
                f"[{box[0]:g}, {box[1]:g}]")
        out.append(s)
    return tuple(out)


def _detect_structure(plant, pb) -> tuple:
    """Coordinates (and ``u``) through which ``sigma`` depends by one static scalar function.

    For a chain plant (``xi`` = the states), ``xi_i`` (or ``u``) qualifies when ``d sigma/d v``
    is free of every other state and of the input: ``sigma = phi(v) + rest(others)``. Only
    nonlinear ones (``d sigma/d v`` not constant) are listed; the slope interval is the
    enclosure already in ``pb``.
    """
    import sympy as sp

    if pb.xi_region is None or pb.a_jacobian_bounds is None:
        return ()
    chain = plant._lie_chain()
    sigma = chain.derivatives[chain.rho]
    xs, u = list(plant.states), plant.input
    out = []
    for i, v in enumerate([u] + xs[: chain.rho]):
        d = sp.diff(sigma, v)
        dep = d.free_symbols & (set(xs) | {u})
        if dep != {v}:  # constant slope, or a slope that depends on other variables
            continue
        slope = pb.b_bounds if i == 0 else pb.a_jacobian_bounds[i - 1]
        if slope[0] == slope[1]:
            continue
        name = ("input map" if i == 0 else "friction" if (i == 2 and slope[1] <= 0)
                else "")
        out.append(SlopeRestricted(i, slope, name))
    return tuple(out)


__all__ = ["SlopeRestricted"]
