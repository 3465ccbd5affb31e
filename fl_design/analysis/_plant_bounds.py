"""What a certificate may assume of the plant: ``b``, ``d sigma/d xi`` and ``b``'s rate, over a box.

:func:`plant_bounds` encloses, by interval arithmetic on the plant's symbolic expressions
(:mod:`._intervals`: sound, outward rounded, the box split into sub-boxes), over the region
(every state), the input range and a *parameter box* (``params={"c": (lo, hi)}``; the other
parameters keep their values):

* ``b = d y^(rho)/du``: the ``b_bounds`` of :func:`fl_design.certify_eps` for every plant of
  the family at once;
* ``d sigma/d xi_i`` (normal-form coordinates ``xi = (y, ..., y^(rho-1))``, ``sigma =
  y^(rho)``, any input of the range), the ``a_jacobian_bounds`` of the nonlinear certificate:
  never padded (an enclosure), so a range that does not contain 0 is never widened across it.
  Plants with internal dynamics (``rho < n``) get None and the reason;
* the rate of ``b`` per sample along trajectories inside the region, from the plant::

      |b(k+1) - b(k)| <= T max |grad_x b . f(x, u)| + max |db/du| du

  (``f`` the plant's right-hand side, ``du`` the largest change of ``u`` in one sample: given,
  or the width of the input range, the most a saturated input can jump, which the plant alone
  does not bound). ``b_rate_source`` spells the terms out. A ``b`` that depends on no state and
  no input has rate 0 (constant along trajectories, its value any of the interval).

Examples
--------
>>> import fl_design as fl
>>> pb = plant_bounds(fl.plants.pendulum(), params={"b": (0.8, 1.2), "c": (0.1, 1.0)})
>>> pb.b_bounds, pb.a_jacobian_bounds[1]
((0.8, 1.2), (-1.0, -0.1))
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .. import _validate as V
from ..errors import ParameterError
from ._cert_results import _Result
from ._intervals import interval_range


@dataclass(frozen=True, repr=False)
class PlantBounds(_Result):
    """Enclosures over a plant's region, input range and parameter box (:func:`plant_bounds`).

    Parameters
    ----------
    plant : str
        The plant's name.
    b_bounds : (float, float)
        Encloses ``b`` over the box.
    a_jacobian_bounds : tuple of (float, float) or None
        Encloses ``d sigma/d xi_i``, i = 1..rho; None with ``jacobian_note`` saying why.
    jacobian_note : str
        How the Jacobian bounds were obtained, or why there are none.
    b_rate : float or None
        Bound of ``|b(k+1) - b(k)|`` at the sampling time ``T`` (None without ``T``).
    b_rate_source : str
        Where ``b_rate`` comes from, term by term.
    params : tuple of (str, float, float)
        Every parameter with the range covered (``lo == hi``: its fixed value).
    region : tuple of (str, float, float)
        The state box.
    input_range : (float, float) or None
        The input range.
    T : float or None
        Sampling time of ``b_rate``.
    method : str
        How the enclosures were computed.
    xi_region : tuple of (float, float) or None
        The region in normal-form coordinates, when they are the states themselves
        (``xi = x``: the plant is a chain ``x_i' = x_(i+1)``); None otherwise.
    xi_op : tuple of float or None
        The operating point in those coordinates.
    u_eq : float
        The equilibrium input.

    Examples
    --------
    >>> import fl_design as fl
    >>> pb = plant_bounds(fl.plants.pendulum(), T=1e-3)
    >>> pb.b_rate, pb.covered()
    (0.0, {})
    """

    plant: str
    b_bounds: tuple
    a_jacobian_bounds: tuple | None
    jacobian_note: str
    b_rate: float | None
    b_rate_source: str
    params: tuple
    region: tuple
    input_range: tuple | None
    T: float | None
    method: str
    xi_region: tuple | None = None
    xi_op: tuple | None = None
    u_eq: float = 0.0

    def covered(self) -> dict:
        """The parameters given as ranges: ``{name: (lo, hi)}``.

        Examples
        --------
        >>> import fl_design as fl
        >>> plant_bounds(fl.plants.pendulum(), params={"c": (0.1, 1.0)}).covered()
        {'c': (0.1, 1.0)}
        """
        return {n: (lo, hi) for n, lo, hi in self.params if lo != hi}

    def _repr_lines(self):
        cov = self.covered()
        return [f"plant {self.plant}: b in [{self.b_bounds[0]:.6g}, {self.b_bounds[1]:.6g}]"
                + (f" for every {', '.join(f'{k} in [{a:g}, {b:g}]' for k, (a, b) in cov.items())}"
                   if cov else ""),
                f"d sigma/d xi: {self.a_jacobian_bounds} ({self.jacobian_note})",
                f"b rate per sample: {self.b_rate} ({self.b_rate_source})", self.method]


def _param_box(plant, params) -> dict:
    names = {str(s): s for s in plant.params}
    box = {s: (float(v), float(v)) for s, v in plant.params.items()}
    if params is None:
        return box
    if not isinstance(params, dict):
        raise ParameterError(f"params must be a dict {{name: (lo, hi)}}, got {params!r}")
    for key, rng in params.items():
        if str(key) not in names:
            raise ParameterError(f"params names {key!r}, not a parameter of {plant.name!r}: use "
                                 f"one of {sorted(names)}")
        lo, hi = V.interval(f"params[{key!r}]", rng, allow_none=False)
        box[names[str(key)]] = (lo, hi)
    return box


def _state_box(plant, region) -> dict:
    reg = dict(plant.region or {})
    by_name = {str(s): s for s in plant.states}
    for key, rng in (region or {}).items():
        if str(key) not in by_name:
            raise ParameterError(f"region names {key!r}, not a state of {plant.name!r}: use one "
                                 f"of {list(by_name)}")
        reg[by_name[str(key)]] = V.interval(f"region[{key!r}]", rng, allow_none=False)
    return reg


def _cheap_simplify(e):
    """``sp.cancel`` of ``e`` when it is a rational function of its atoms (fast), else ``e``."""
    import sympy as sp

    try:
        out = sp.cancel(sp.together(e))
    except (sp.PolynomialError, NotImplementedError, TypeError):  # pragma: no cover
        return e
    return out if sp.count_ops(out) <= sp.count_ops(e) else e


def _jacobian(plant, box, splits):
    """``d sigma/d xi`` enclosures, or ``(None, why)``."""
    import sympy as sp

    chain = plant._lie_chain()
    if chain.rho != plant.n:
        return None, (
            f"none: the plant has internal dynamics (rho = {chain.rho} < n = {plant.n}); the "
            f"LDI certificate covers rho = n only. Needed: the normal form (xi, eta) with the "
            f"{plant.n - chain.rho} internal states eta' = q(xi, eta) and interval bounds on the "
            "Jacobian of q, added to the loop (the surrogate models only the chain of rho "
            "integrators), and a region in those coordinates")
    x = sp.Matrix(list(plant.states))
    xi = sp.Matrix(list(chain.derivatives[: chain.rho]))
    Jx = xi.jacobian(x)
    row = sp.Matrix([chain.derivatives[chain.rho]]).jacobian(x) * Jx.inv()
    varies = bool(Jx.free_symbols & (set(plant.states) | {plant.input}))
    if varies:  # d xi/d x depends on the state: cancel common factors (cheap; sp.simplify
        # ran for minutes on the TRMS with motor lag). Any form encloses soundly.
        row = [_cheap_simplify(e) for e in row]
    try:
        out = tuple(interval_range(e, box, splits=splits) for e in row)
    except ParameterError as err:
        return None, f"none: {err}"
    return out, ("interval arithmetic on d sigma/d x (d xi/d x)^-1"
                 + (" (factors cancelled; d xi/d x varies with the state)" if varies else "")
                 + ", any input of the range, never padded")


def _rate(plant, b, box, T, du, splits) -> tuple[float, str]:
    import sympy as sp

    xs, u = list(plant.states), plant.input
    lie = sp.expand(sum((sp.diff(b, s) * f for s, f in zip(xs, plant.rhs)), sp.Integer(0)))
    dbu = sp.diff(b, u)
    if lie == 0 and dbu == 0:
        return 0.0, "b depends on no state and no input: constant along trajectories"
    terms, total = [], 0.0
    if lie != 0:
        lo, hi = interval_range(lie, box, splits=splits)
        g = max(abs(lo), abs(hi))
        total += T * g
        terms.append(f"T max|grad_x b . f| = {T:g} * {g:.6g}")
    if dbu != 0:
        lo, hi = interval_range(dbu, box, splits=splits)
        g = max(abs(lo), abs(hi))
        if du is None:
            if u not in box:
                raise ParameterError(
                    f"b of {plant.name!r} depends on the input and the plant has no "
                    "input_range: give du (the largest change of u per sample)")
            du_v = float(box[u][1] - box[u][0])
            why = ("the width of the input range: the plant does not bound u's change per "
                   "sample; give du for a tighter rate")
        else:
            du_v, why = du, "given"
        total += g * du_v
        terms.append(f"max|db/du| du = {g:.6g} * {du_v:g} (du: {why})")
    return float(total), " + ".join(terms) + f" = {total:.6g} per sample"


def plant_bounds(plant, *, params=None, region=None, T=None, du=None, input_range=None,
                 splits: int = 8) -> PlantBounds:
    """Enclose ``b``, ``d sigma/d xi`` and ``b``'s rate over the region and a parameter box.

    Parameters
    ----------
    plant : Plant
        The plant (its region must give every state a range; ``input_range`` is needed when
        ``b`` or ``sigma`` depend on the input).
    params : dict, optional
        ``{name: (lo, hi)}``: parameters covered over ranges (the others keep their values).
    region : dict, optional
        ``{state: (lo, hi)}`` overriding the plant's region.
    T : float, optional
        Sampling time: gives ``b_rate`` (per sample).
    du : float, optional
        Largest change of the input in one sample (default: the input range's width).
    input_range : (float, float), optional
        The inputs covered, instead of the plant's ``input_range`` (e.g. a smaller region).
    splits : int, optional
        Sub-intervals per variable of each enclosure (at most 4096 sub-boxes; default 8).

    Returns
    -------
    PlantBounds

    Raises
    ------
    ParameterError
        An unknown parameter or state, a bad range, a variable without a range, an expression
        the interval arithmetic does not support, or ``b``'s enclosure containing 0.

    Examples
    --------
    >>> import fl_design as fl
    >>> pb = plant_bounds(fl.plants.trms_yaw(), T=1e-3, du=1e-3)
    >>> [round(v, 6) for v in pb.b_bounds], round(pb.b_rate, 6)
    ([3.6, 6.8], 0.00128)
    """
    splits = V.integer("splits", splits, minimum=1)
    if T is not None:
        T = V.positive("T", T)
    if du is not None:
        du = V.nonnegative("du", du)
    box = _param_box(plant, params)
    states = _state_box(plant, region)
    box.update(states)
    if input_range is not None:
        input_range = V.interval("input_range", input_range, allow_none=False)
    else:
        input_range = None if plant.input_range is None else tuple(map(float, plant.input_range))
    if input_range is not None:
        box[plant.input] = input_range
    b = plant.normal_form().b
    lo, hi = interval_range(b, box, splits=splits)
    if lo <= 0.0 <= hi:
        raise ParameterError(
            f"b of {plant.name!r} is enclosed in [{lo:.6g}, {hi:.6g}] over the box, which "
            "contains 0: the method needs a known sign of b; narrow the region or the parameters")
    jac, note = _jacobian(plant, box, splits)
    rate, source = (None, "no T given") if T is None else _rate(plant, b, box, T, du, splits)
    chain = plant._lie_chain()
    is_chain = chain.rho == plant.n and all(
        d == s_ for d, s_ in zip(chain.derivatives[: chain.rho], plant.states))
    return PlantBounds(
        plant=str(plant.name), b_bounds=(lo, hi), a_jacobian_bounds=jac, jacobian_note=note,
        b_rate=rate, b_rate_source=source,
        params=tuple((str(s), float(r[0]), float(r[1])) for s, r in box.items()
                     if s in plant.params),
        region=tuple((str(s), float(states[s][0]), float(states[s][1])) for s in plant.states
                     if s in states),
        input_range=input_range,
        T=T, method=(f"interval arithmetic (mpmath iv, outward rounding) on the symbolic "
                     f"expressions, each variable split in up to {splits} sub-intervals"),
        xi_region=(tuple(tuple(float(v) for v in states[s_]) for s_ in plant.states)
                   if is_chain and all(s_ in states for s_ in plant.states) else None),
        xi_op=tuple(float(v) for v in plant.x_op) if is_chain else None,
        u_eq=float(plant.u_eq))


def resolve(b_bounds, b_rate, a_jacobian_bounds, T: float):
    """``(b_bounds, b_rate, a_jacobian_bounds, params, b_rate_source, plant_bounds)``.

    ``b_bounds`` may be a :class:`PlantBounds`; ``b_rate`` and ``a_jacobian_bounds`` may be
    ``"plant"`` (taken from it, its ``T`` must be the design's).
    """
    pb = b_bounds if isinstance(b_bounds, PlantBounds) else None
    plant_asked = [k for k, v in (("b_rate", b_rate), ("a_jacobian_bounds", a_jacobian_bounds))
                   if isinstance(v, str)]
    for k in plant_asked:
        if (b_rate if k == "b_rate" else a_jacobian_bounds) != "plant":
            raise ParameterError(f"{k} must be a number/ranges or 'plant', got "
                                 f"{(b_rate if k == 'b_rate' else a_jacobian_bounds)!r}")
        if pb is None:
            raise ParameterError(f"{k}='plant' needs b_bounds from plant_bounds(...), got "
                                 f"{b_bounds!r}")
    source = None if b_rate is None else "given"
    if b_rate == "plant":
        if pb.b_rate is None:
            raise ParameterError("b_rate='plant' needs plant_bounds(..., T=design.T)")
        if not math.isclose(pb.T, T, rel_tol=1e-12):
            from ..errors import DesignMismatchError

            raise DesignMismatchError(f"plant_bounds was computed at T = {pb.T:g}, the design "
                                      f"samples at T = {T:g}: recompute it with T={T:g}")
        b_rate, source = pb.b_rate, f"the plant: {pb.b_rate_source}"
    if a_jacobian_bounds == "plant":
        if pb.a_jacobian_bounds is None:
            raise ParameterError(f"a_jacobian_bounds='plant': {pb.jacobian_note}")
        a_jacobian_bounds = pb.a_jacobian_bounds
    if pb is None:
        return b_bounds, b_rate, a_jacobian_bounds, (), source, None
    return pb.b_bounds, b_rate, a_jacobian_bounds, pb.params, source, pb


__all__ = ["PlantBounds", "plant_bounds", "resolve"]
