"""The plant class: what the method's theory assumes of a plant, as data (no SymPy).

A certificate of fl_design is a claim about **every plant of a class**, never about one model.
:class:`PlantClass` is that class: the relative degree ``rho`` and the sampling time ``T``; the
sign and range of the high-frequency gain ``b``; what is known of ``b`` along trajectories (its
change per sample, or nothing: arbitrary variation, the paper's ``b(k) = b(w(k), x(k))``); a box
for the slopes ``d sigma / d xi_i`` of the lumped term with respect to the normal-form coordinates
``xi = (y, y', ..., y^(rho-1))`` (``a(x) = 0`` only where the class says so); the input delay in
samples; the sensor noise; the input limits; and the internal dynamics' assumption (minimum phase,
with a stated decay rate where known).

Three ways to get one:

* stated by a user who knows only these facts: ``PlantClass(rho=2, T=1e-3, b=(1, 50),
  noise_std=1e-3)``;
* from a model: :meth:`PlantClass.from_plant` encloses ``b``, the slopes of ``sigma`` and ``b``'s
  rate by interval arithmetic over the plant's region, input range and a parameter box
  (:func:`fl_design.analysis.plant_bounds`: sound, outward rounded);
* from a rig's log: :func:`fl_design.identify`.

The chain of integrators with ``a = 0`` is a *named* class, :meth:`PlantClass.chain`, never "the
plant": a certificate of the chain says so in its one-line class description (:meth:`describe`).

Examples
--------
>>> import fl_design as fl
>>> cls = fl.PlantClass(rho=2, T=1e-3, b=(1.0, 50.0), noise_std=1e-3)
>>> cls.describe()
'stated class: rho = 2, T = 0.001 s, b in [1, 50] varying arbitrarily, sigma = b u + a with a = 0 (no slope box), no input delay, noise std 0.001'
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace

from .. import _validate as V
from ..errors import ParameterError
from ._slope_structure import SlopeRestricted, _detect_structure, _structure

#: Where a class came from (``source``).
SOURCES = ("stated", "chain", "plant", "log")


def _signed_interval(name: str, value) -> tuple[float, float]:
    """A closed interval of one strict sign (the range of ``b``)."""
    if value is None:
        raise ParameterError(f"{name} is required: the range (lo, hi) of b, of one strict sign, "
                             f"e.g. {name}=(1.0, 50.0)")
    if V.is_real_number(value):
        v = float(value)
        value = (v, v)
    try:
        lo, hi = (V.real_scalar(name, v) for v in value)
    except (TypeError, ValueError) as exc:  # not a pair of real numbers
        raise ParameterError(f"{name} must be a pair (lo, hi) of finite numbers, got "
                             f"{V.short(value)}") from exc
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise ParameterError(f"{name} must be finite, got ({lo}, {hi})")
    if lo > hi:
        raise ParameterError(f"{name} = ({lo:g}, {hi:g}) is reversed: give (lo, hi) with lo <= hi")
    if lo <= 0.0 <= hi:
        raise ParameterError(
            f"{name} = ({lo:g}, {hi:g}) contains 0: the method needs b of one known sign "
            f"(b > 0 or b < 0 on the whole class); a plant whose b crosses 0 is outside it")
    return float(lo), float(hi)


def _slope_box(value, rho: int):
    if value is None:
        return None
    try:
        box = tuple(tuple(float(c) for c in pair) for pair in value)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"a_slopes must be {rho} pairs (lo, hi) of d sigma/d xi_i, "
                             f"got {V.short(value)}") from exc
    if len(box) != rho or any(len(p) != 2 for p in box):
        raise ParameterError(f"a_slopes must be {rho} pairs (lo, hi) (one per xi_1..xi_{rho}), "
                             f"got {V.short(value)}")
    for i, (lo, hi) in enumerate(box, 1):
        if not (math.isfinite(lo) and math.isfinite(hi)) or lo > hi:
            raise ParameterError(f"a_slopes[{i - 1}] (d sigma/d xi_{i}) = ({lo:g}, {hi:g}) "
                                 f"must be finite with lo <= hi")
    return box


def _fmt(x: float) -> str:
    return f"{x:.6g}"


@dataclass(frozen=True)
class PlantClass:
    """The plants a certificate covers: what the method's theory assumes, as data.

    Parameters
    ----------
    rho : int
        Relative degree (1..8).
    T : float or None
        Sampling time [s]; None: the design's (a class derived from a model before a design).
    b : (float, float)
        Range of ``b = d y^(rho) / du`` over the class, of one strict sign (``b_min == b_max``
        for a known constant).
    b_rate : float or None, optional
        Bound of ``|b(k+1) - b(k)|`` per sample along trajectories; None (default): ``b`` may vary
        arbitrarily in its range from sample to sample; 0: each member has a constant ``b``.
    a_slopes : sequence of (float, float) or None, optional
        Box of ``d sigma / d xi_i``, i = 1..rho (at any input of the range): the class holds every
        plant whose lumped term's slopes stay in the box along its trajectories. None: ``a = 0``
        (the chain of integrators, the paper's surrogate).
    delay : int, optional
        Input delay in samples (default 0).
    noise_std : float, optional
        Standard deviation of the sensor noise (default 0).
    noise_bound : float or None, optional
        A peak bound of the sensor noise (None: not bounded, e.g. Gaussian).
    u_limits : (float, float) or None, optional
        The actuator's limits.
    y_range : (float, float) or None, optional
        The output's range where the class's bounds hold (the region of interest).
    zero_dynamics : str, optional
        The internal dynamics' assumption: ``"none"`` (n = rho), ``"minimum phase"`` (assumed),
        or a description with the decay rate (from a model).
    zero_dynamics_decay : float or None, optional
        Slowest decay rate of the zero dynamics [1/s] where known.
    source : str, optional
        ``"stated"``, ``"chain"``, ``"plant"`` or ``"log"``.
    name : str, optional
        A short name (the plant's, the log's file name).
    notes : tuple of str, optional
        How the bounds were obtained and what was left out.
    operating_point : float or None, optional
        The output value the class's bounds were taken around (the reference), if any.
    u_eq : float or None, optional
        The equilibrium input at the operating point, if known.
    structure : sequence of SlopeRestricted, optional
        Where ``sigma`` depends on a coordinate (or on ``u``) through one static scalar
        function of bounded slope (:class:`SlopeRestricted`): friction, springs, a static input
        map. More than the slope box says (the slope follows the state, it is not an arbitrary
        signal): multiplier arguments use it (``fl.certify_step``).
    params : tuple of (str, float, float), optional
        The model's parameters with the ranges covered (``lo == hi``: fixed), from a model.
    region : tuple of (str, float, float), optional
        The model's state box over which the bounds were enclosed (from a model).

    Examples
    --------
    >>> import fl_design as fl
    >>> fl.PlantClass.chain(2, b=(3.6, 6.8), T=1e-3).describe()
    'chain class: rho = 2, T = 0.001 s, b in [3.6, 6.8] varying arbitrarily, sigma = b u + a with a = 0 (no slope box), no input delay, no sensor noise'
    """

    rho: int
    T: float | None
    b: tuple[float, float]
    b_rate: float | None = None
    a_slopes: tuple[tuple[float, float], ...] | None = None
    delay: int = 0
    noise_std: float = 0.0
    noise_bound: float | None = None
    u_limits: tuple[float, float] | None = None
    y_range: tuple[float, float] | None = None
    zero_dynamics: str = "none"
    zero_dynamics_decay: float | None = None
    source: str = "stated"
    name: str = ""
    notes: tuple[str, ...] = field(default_factory=tuple)
    operating_point: float | None = None
    u_eq: float | None = None
    structure: tuple = ()
    params: tuple = ()
    region: tuple = ()

    def __post_init__(self):
        s = object.__setattr__
        if self.rho is None:
            raise ParameterError("a plant class needs rho, the relative degree (1..8)")
        s(self, "rho", V.integer("rho", self.rho, minimum=1, maximum=8))
        if self.T is not None:
            T = V.positive("T", self.T)
            if T > 10.0:
                raise ParameterError(f"T = {T:g} s: a sampling time above 10 s is not plausible "
                                     f"(is it in ms? give seconds)")
            s(self, "T", T)
        s(self, "b", _signed_interval("b", self.b))
        if self.b_rate is not None:
            s(self, "b_rate", V.nonnegative("b_rate", self.b_rate))
        s(self, "a_slopes", _slope_box(self.a_slopes, self.rho))
        s(self, "delay", V.integer("delay", self.delay, minimum=0, maximum=1000))
        s(self, "noise_std", V.nonnegative("noise_std", self.noise_std))
        if self.noise_bound is not None:
            s(self, "noise_bound", V.nonnegative("noise_bound", self.noise_bound))
        for nm in ("u_limits", "y_range"):
            v = getattr(self, nm)
            if v is not None:
                lo, hi = V.interval(nm, v, allow_none=False)
                if not lo < hi:
                    raise ParameterError(f"{nm} = ({lo:g}, {hi:g}) must satisfy lo < hi")
                s(self, nm, (lo, hi))
        if self.source not in SOURCES:
            raise ParameterError(f"source must be one of {SOURCES}, got {self.source!r}")
        if self.zero_dynamics_decay is not None:
            s(self, "zero_dynamics_decay", V.positive("zero_dynamics_decay",
                                                      self.zero_dynamics_decay))
        s(self, "notes", tuple(str(n) for n in self.notes))
        for nm in ("operating_point", "u_eq"):
            v = getattr(self, nm)
            if v is not None:
                s(self, nm, V.real_scalar(nm, v))
        s(self, "structure", _structure(self.structure, self.rho, self.a_slopes, self.b))
        s(self, "params", tuple((str(n), float(lo), float(hi)) for n, lo, hi in self.params))
        s(self, "region", tuple((str(n), float(lo), float(hi)) for n, lo, hi in self.region))

    # -- constructors ---------------------------------------------------------------------
    @classmethod
    def chain(cls, rho: int, *, b, T: float | None = None, **kw) -> PlantClass:
        """The chain of ``rho`` integrators, ``y^(rho) = b u`` (``a = 0``), as a named class.

        Examples
        --------
        >>> PlantClass.chain(1, b=2.0).b
        (2.0, 2.0)
        """
        kw.setdefault("name", f"chain of {int(rho)} integrators")
        return cls(rho=rho, T=T, b=b, source="chain", **kw)

    @classmethod
    def from_plant(cls, plant, *, T: float | None = None, region=None, params=None,
                   input_range=None, du=None, splits: int = 8, noise_std: float = 0.0,
                   delay: int = 0) -> PlantClass:
        """The class of a model: interval enclosures over its region and a parameter box.

        ``b``, the slopes ``d sigma / d xi_i`` and (with ``T``) ``b``'s rate per sample are
        enclosed by :func:`fl_design.analysis.plant_bounds` (sound interval arithmetic over the
        region, the input range and ``params``). Plants with internal dynamics (``rho < n``) get
        no slope box from the enclosure (their coordinates are not the states); the class then
        says so in ``notes`` and a certificate of it does not cover ``a``.

        Parameters
        ----------
        plant : Plant
        T : float, optional
            Sampling time (gives ``b_rate``); None: the design's, and ``b`` may vary arbitrarily.
        region, params, input_range, du, splits
            As :func:`fl_design.analysis.plant_bounds`.
        noise_std : float, optional
            Sensor noise of the rig (a model does not know it).
        delay : int, optional
            Input delay in samples.

        Examples
        --------
        >>> import fl_design as fl
        >>> c = PlantClass.from_plant(fl.plants.pendulum(c=0.05))
        >>> c.b, c.a_slopes[1]
        ((1.0, 1.0), (-0.05, -0.05))
        """
        from ._plant_bounds import plant_bounds

        pb = plant_bounds(plant, params=params, region=region, T=T, du=du,
                          input_range=input_range, splits=splits)
        return cls._from_bounds(plant, pb, T=T, noise_std=noise_std, delay=delay)

    @classmethod
    def _from_bounds(cls, plant, pb, *, T=None, noise_std: float = 0.0,
                     delay: int = 0) -> PlantClass:
        """:meth:`from_plant` from enclosures ``pb`` already computed for ``plant``."""
        notes = [f"enclosures: {pb.method}"]
        if pb.a_jacobian_bounds is None:
            notes.append(f"no slope box for a: {pb.jacobian_note}")
        if pb.b_rate_source:
            notes.append(f"b rate: {pb.b_rate_source}")
        try:
            minimum_phase, eig = plant._zero_dynamics()
        except Exception as exc:  # noqa: BLE001 - a plant whose zero dynamics cannot be formed
            minimum_phase, eig = None, ()
            notes.append(f"zero dynamics not analysed: {exc}")
        n_internal = len(getattr(plant, "states", ())) - plant.relative_degree()
        if n_internal <= 0:
            zd, decay = "none", None
        elif minimum_phase is None:
            zd, decay = "not analysed", None
        else:
            re = [float(complex(e).real) for e in eig]
            decay = -max(re) if re and max(re) < 0 else None
            zd = ("minimum phase" if minimum_phase else "NOT minimum phase") + (
                f" (zero-dynamics eigenvalues {', '.join(f'{complex(e):.4g}' for e in eig)})")
        ranges = plant._state_ranges() if hasattr(plant, "_state_ranges") else None
        y_range = None
        if ranges is not None:
            states, out = ranges if isinstance(ranges, tuple) else (ranges, None)
            if out is not None and isinstance(states, dict) and states.get(out):
                y_range = tuple(states[out])
        structure = _detect_structure(plant, pb)
        if structure:
            notes.append("structure: " + "; ".join(x.describe() for x in structure)
                         + " (d sigma/d v depends on v alone)")
        cov = pb.covered()
        if cov:
            notes.append("every plant with " + ", ".join(f"{k} in [{a:g}, {b:g}]"
                                                         for k, (a, b) in cov.items()))
        return cls(rho=plant.relative_degree(), T=T, b=pb.b_bounds,
                   b_rate=pb.b_rate if T is not None else None,
                   a_slopes=pb.a_jacobian_bounds, delay=delay, noise_std=noise_std,
                   u_limits=pb.input_range, y_range=y_range, zero_dynamics=zd,
                   zero_dynamics_decay=decay, source="plant", name=str(plant.name),
                   notes=tuple(notes), u_eq=pb.u_eq, structure=structure,
                   params=pb.params, region=pb.region)

    # -- reading ----------------------------------------------------------------------------
    @property
    def b_min(self) -> float:
        """The smaller end of ``b``'s range."""
        return self.b[0]

    @property
    def b_max(self) -> float:
        """The larger end of ``b``'s range."""
        return self.b[1]

    @property
    def sign(self) -> float:
        """The sign of ``b`` (+1 or -1)."""
        return 1.0 if self.b[0] > 0 else -1.0

    def with_T(self, T: float) -> PlantClass:
        """The same class sampled at ``T`` (a class without ``T`` takes the design's).

        Examples
        --------
        >>> PlantClass(rho=1, T=None, b=(1, 2)).with_T(1e-3).T
        0.001
        """
        if self.T is not None and not math.isclose(self.T, T, rel_tol=1e-12):
            from ..errors import DesignMismatchError

            raise DesignMismatchError(
                f"the class is sampled at T = {self.T:g} s, the design at T = {T:g} s: "
                f"design at the class's T or restate the class")
        return replace(self, T=float(T))

    def certificate_args(self) -> dict:
        """The keyword arguments of :func:`fl_design.certify_eps` that encode this class.

        Examples
        --------
        >>> PlantClass(rho=2, T=1e-3, b=(1, 5), b_rate=0.0).certificate_args()
        {'b_bounds': (1.0, 5.0), 'a_jacobian_bounds': None, 'b_rate': 0.0}
        """
        return {"b_bounds": self.b, "a_jacobian_bounds": self.a_slopes, "b_rate": self.b_rate}

    def uncovered(self) -> tuple[str, ...]:
        """What a certificate of this class's linear(ized) loop does not cover, in words."""
        out = []
        if self.u_limits is not None:
            out.append(f"input saturation at u in [{_fmt(self.u_limits[0])}, "
                       f"{_fmt(self.u_limits[1])}]")
        else:
            out.append("input saturation (the design's limits, if any)")
        out += ["the estimate clamp", "integrator windup"]
        if self.noise_std or self.noise_bound:
            out.append("sensor noise (bounded effect, not stability)")
        if self.delay:
            out.append(f"the {self.delay}-sample input delay")
        if self.zero_dynamics not in ("none",):
            out.append(f"the internal dynamics ({self.zero_dynamics})")
        return tuple(out)

    def describe(self) -> str:
        """The class in one line: what every certificate of it covers.

        Examples
        --------
        >>> PlantClass(rho=2, T=1e-3, b=(-2, -1), b_rate=0.0).describe()[:60]
        'stated class: rho = 2, T = 0.001 s, b in [-2, -1] constant p'
        """
        who = {"stated": "stated class", "chain": "chain class", "log": "identified class",
               "plant": "class of plant"}[self.source]
        if self.name and self.source in ("plant", "log"):
            who += f" '{self.name}'"
        T = "T from the design" if self.T is None else f"T = {self.T:g} s"
        lo, hi = self.b
        bb = f"b = {_fmt(lo)}" if lo == hi else f"b in [{_fmt(lo)}, {_fmt(hi)}]"
        if lo != hi:
            if self.b_rate is None:
                bb += " varying arbitrarily"
            elif self.b_rate == 0:
                bb += " constant per plant"
            else:
                bb += f" changing <= {self.b_rate:.3g} per sample"
        if self.a_slopes is None:
            a = "sigma = b u + a with a = 0 (no slope box)"
        else:
            a = "d sigma/d xi in " + " x ".join(f"[{_fmt(p[0])}, {_fmt(p[1])}]"
                                                for p in self.a_slopes)
        d = "no input delay" if not self.delay else f"input delay {self.delay} samples"
        if self.noise_bound is not None:
            nz = f"noise |n| <= {self.noise_bound:g}"
        elif self.noise_std:
            nz = f"noise std {self.noise_std:g}"
        else:
            nz = "no sensor noise"
        parts = [f"rho = {self.rho}", T, bb, a]
        parts += [x.describe() for x in self.structure]
        parts += [d, nz]
        ranges = [f"{n} in [{lo:g}, {hi:g}]" for n, lo, hi in self.params if lo != hi]
        if ranges:
            parts.append("every plant with " + ", ".join(ranges))
        if self.region:
            parts.append("over the region " + ", ".join(f"{n} in [{lo:.4g}, {hi:.4g}]"
                                                         for n, lo, hi in self.region))
        if self.zero_dynamics != "none":
            parts.append(f"internal dynamics: {self.zero_dynamics}")
        return f"{who}: " + ", ".join(parts)

    def to_dict(self) -> dict:
        """Plain numbers, lists and strings (strict JSON).

        Examples
        --------
        >>> PlantClass(rho=1, T=1e-3, b=(1, 2)).to_dict()["b"]
        [1.0, 2.0]
        """
        def plain(v):
            if isinstance(v, SlopeRestricted):
                return v.to_dict()
            if isinstance(v, tuple):
                return [plain(x) for x in v]
            if isinstance(v, float) and not math.isfinite(v):
                return None
            return v
        d = {f.name: plain(getattr(self, f.name)) for f in fields(self)}
        d["description"] = self.describe()
        return d


__all__ = ["PlantClass", "SlopeRestricted"]
