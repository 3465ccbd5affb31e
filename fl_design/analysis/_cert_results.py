"""Frozen result objects of the certificates (strict-JSON ``to_dict``, readable ``repr``).

Examples
--------
>>> from fl_design.analysis._cert_results import json_number
>>> json_number(float("nan")), json_number(0.5)
(None, 0.5)
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field, fields

import numpy as np


def json_number(value):
    """A float for finite numbers, None for NaN/inf/None (strict JSON has neither)."""
    if value is None:
        return None
    value = float(value)
    return value if math.isfinite(value) else None


def _plain(value):
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return json_number(value)
    if isinstance(value, np.ndarray):
        return [_plain(v) for v in value.tolist()]
    if isinstance(value, (tuple, list)):
        return [_plain(v) for v in value]
    return value


class _Result:
    def to_dict(self) -> dict:
        """Plain numbers, lists and strings; NaN and inf become None (strict JSON).

        Examples
        --------
        >>> import json
        >>> r = PointCertificate(0.05, False, None, 0, False, None, "x", None, "why")
        >>> json.loads(json.dumps(r.to_dict(), allow_nan=False))["certified"]
        False
        """
        return {f.name: _plain(getattr(self, f.name)) for f in fields(self)}

    def _repr_lines(self) -> list[str]:  # pragma: no cover - overridden
        return []

    def __repr__(self) -> str:
        head = type(self).__name__
        return "\n".join([head] + [f"  {line}" for line in self._repr_lines()])


@dataclass(frozen=True, repr=False)
class _OfClass(_Result):
    """The class a certificate covers (keyword-only fields shared by every certificate).

    ``plant_class`` is the :class:`fl_design.PlantClass` certified (a Plant given to a
    certificate is read as its class, ``PlantClass.from_plant``; a bare ``b`` range as the
    named chain class ``PlantClass.chain``); ``class_description`` its one line;
    ``uncovered`` what the certificate does not cover, in words. A subclass's docstring gets
    these three documented at the end of its Parameters (:data:`CLASS_FIELDS_DOC`, added by
    ``__init_subclass__``): written once, rendered and checked with each certificate.
    """

    plant_class: object = field(default=None, kw_only=True)
    class_description: str = field(default="", kw_only=True)
    uncovered: tuple = field(default=(), kw_only=True)

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        cls.__doc__ = _with_class_fields(cls.__doc__ or "")

    def to_dict(self) -> dict:
        out = super().to_dict()
        out["plant_class"] = None if self.plant_class is None else self.plant_class.to_dict()
        return out

    def _class_lines(self) -> list[str]:
        if not self.class_description:
            return []
        out = [f"certifies the {self.class_description}"]
        if self.uncovered:
            out.append("not covered: " + "; ".join(self.uncovered))
        return out


#: The numpydoc entry of :class:`_OfClass`'s fields, written once: every certificate's docstring
#: gets it at the end of its Parameters section (:func:`_with_class_fields`).
CLASS_FIELDS_DOC = (
    "plant_class, class_description, uncovered",
    "    Keyword-only: the :class:`fl_design.PlantClass` certified (or None), its one line,",
    "    and what the certificate does not cover (tuple of str).",
)


def _with_class_fields(doc: str) -> str:
    r"""``doc`` with :data:`CLASS_FIELDS_DOC` inserted before its Examples section (at the end
    when it has none), indented as that section's header.

    Examples
    --------
    >>> print(_with_class_fields("A result.\n\nParameters\n----------\nx : float\n    A value."
    ...                          "\n\nExamples\n--------\nx = 1.0\n"))
    A result.
    <BLANKLINE>
    Parameters
    ----------
    x : float
        A value.
    plant_class, class_description, uncovered
        Keyword-only: the :class:`fl_design.PlantClass` certified (or None), its one line,
        and what the certificate does not cover (tuple of str).
    <BLANKLINE>
    Examples
    --------
    x = 1.0
    <BLANKLINE>
    """
    lines = doc.split("\n")
    at = next((i for i in range(len(lines) - 1) if lines[i].strip() == "Examples"
               and set(lines[i + 1].strip()) == {"-"}), len(lines))
    indent = lines[at][: len(lines[at]) - len(lines[at].lstrip())] if at < len(lines) else ""
    end = at - 1 if 0 < at < len(lines) and not lines[at - 1].strip() else at  # after the last entry
    return "\n".join(lines[:end] + [indent + x for x in CLASS_FIELDS_DOC] + [""] + lines[at:])


def class_fields(cls) -> dict:
    """The keyword fields of :class:`_OfClass` for a :class:`fl_design.PlantClass`.

    The certificates' loop has no input delay: a class with one is certified without it (the
    class named is the same class with ``delay = 0``) and its delay is listed as not covered.
    """
    covered = dataclasses.replace(cls, delay=0) if getattr(cls, "delay", 0) else cls
    return {"plant_class": covered, "class_description": covered.describe(),
            "uncovered": tuple(cls.uncovered())}


def _fmt(x) -> str:
    return "None" if x is None or (isinstance(x, float) and not math.isfinite(x)) else f"{x:.6g}"


@dataclass(frozen=True, repr=False)
class PointCertificate(_Result):
    """The LMI certificate of the surrogate loop at one ``eps`` (and ``gamma``).

    Parameters
    ----------
    eps : float
        Observer time constant checked.
    certified : bool
        True when a certificate passed the NumPy re-check.
    kind : str or None
        ``"common"`` (one ``P``: covers ``b`` varying from sample to sample in the interval),
        ``"parameter-dependent"`` (``P(b)`` affine on each piece of the interval: covers every
        constant ``b``) or ``"ldi"`` (common ``P`` with Jacobian bounds).
    pieces : int
        Sub-intervals of the ``b`` interval with their own vertex certificate.
    covers_time_varying_b : bool
        True for a common ``P`` on the whole interval.
    solver : str or None
        Solver of the certificate(s).
    solver_status : str
        CVXPY status of the last solve.
    margin : float or None
        Smallest relative eigenvalue margin of the NumPy re-check.
    reason : str
        How it was certified, or why not.
    covers : str or None
        What the certificate covers: ``"frozen"`` (every constant ``b``), ``"varying"``
        (``b`` arbitrary in time), ``"rate-bounded"`` (``|b_(k+1) - b_k| <= db``) or
        ``"nonlinear"`` (the linear differential inclusion of the plant in its region); None
        when not certified.
    b_pieces : tuple of (float, float)
        The sub-intervals of ``|b|`` certified, in increasing order (empty when not certified;
        for ``b < 0`` the loop is evaluated with ``|b|`` and ``gamma`` of the sign of ``b``).
    lyapunov : tuple of (numpy.ndarray, numpy.ndarray)
        Per piece, ``(P_lo, P_hi)`` in the loop's coordinates (``SurrogateLoop.names``, the
        kept states): on the piece ``P(b)`` is the linear interpolation, and
        ``M(b)^T P(b) M(b) < P(b)`` at every ``b`` of it (``P_lo = P_hi``: a common ``P``).
        Not in :meth:`to_dict`.

    Examples
    --------
    >>> PointCertificate(0.05, True, "common", 1, True, "CLARABEL", "optimal", 1e-6, "ok").kind
    'common'
    """

    eps: float
    certified: bool
    kind: str | None
    pieces: int
    covers_time_varying_b: bool
    solver: str | None
    solver_status: str
    margin: float | None
    reason: str
    b_pieces: tuple = ()
    lyapunov: tuple = ()
    covers: str | None = None

    def to_dict(self) -> dict:
        out = super().to_dict()
        del out["lyapunov"]
        return out

    def _repr_lines(self):
        what = f"{self.covers} b" if self.covers else "-"
        return [(f"eps = {self.eps:.6g}: {'certified' if self.certified else 'not certified'}"
                f" for {what} ({self.kind or '-'}, {self.pieces} piece(s)), {self.reason}")]


@dataclass(frozen=True, repr=False)
class EpsBracket(_Result):
    """eps* of one coverage as a bracket: certified below, refuted at or above.

    Parameters
    ----------
    covers : str
        ``"frozen"``, ``"varying"``, ``"rate-bounded"`` or ``"nonlinear"`` (see
        :mod:`fl_design.analysis._coverage`).
    certified : float or None
        Largest eps found with a certificate of this coverage (None: none).
    refuted : float or None
        Smallest eps found with a counterexample of this coverage (None: none found).
    how_certified : str
        The certificate used.
    how_refuted : str
        The counterexample (a constant ``b``, or a switching sequence of ``b``).
    b_rate : float or None
        The rate bound ``db`` per sample (rate-bounded only).
    counterexample : tuple of (float, int)
        The refuting switching sequence, one period as runs ``(b, samples)`` (empty for a
        constant-``b`` counterexample or none).

    Examples
    --------
    >>> b = EpsBracket("varying", 0.08, 0.122, "common P", "periodic switching")
    >>> round(b.gap, 3), str(b)
    (0.525, 'varying b: eps* in [0.08, 0.122]')
    """

    covers: str
    certified: float | None
    refuted: float | None
    how_certified: str
    how_refuted: str
    b_rate: float | None = None
    counterexample: tuple = ()

    @property
    def gap(self) -> float:
        """``refuted / certified - 1`` (NaN when either end is missing)."""
        if self.certified is None or self.refuted is None:
            return math.nan
        return self.refuted / self.certified - 1.0

    def __str__(self) -> str:
        what = (f"rate-bounded b (|db| <= {self.b_rate:.4g} per sample)"
                if self.covers == "rate-bounded" else
                "class (slopes and b varying in time)" if self.covers == "nonlinear" else
                f"{self.covers} b")
        return f"{what}: eps* in [{_fmt(self.certified)}, {_fmt(self.refuted)}]"

    def _repr_lines(self):
        return [str(self), f"certified by {self.how_certified}", f"refuted by {self.how_refuted}"]


@dataclass(frozen=True, repr=False)
class EpsCertificate(_OfClass):
    """Result of :func:`fl_design.certify_eps` (see there for what is covered).

    Parameters
    ----------
    eps, gamma, T : float
        The design's numbers (``gamma`` with the sign of ``b``).
    b_bounds : tuple of float
        The interval of ``b`` covered.
    eps_range : tuple of float
        The eps search interval.
    eps_star_frozen : float or None
        Largest eps below which every frozen-b surrogate loop on the ``b`` grid is Schur (an
        eigenvalue scan, not a certificate: the upper end of the frozen bracket).
    eps_star_common : float or None
        Largest eps found with a common quadratic Lyapunov function (covers varying ``b``).
    eps_star_certified : float or None
        The certified end of the bracket of ``covers``: the strongest coverage the data
        supports (varying ``b`` unless ``b_rate`` says otherwise, nonlinear with Jacobian
        bounds).
    certified : bool
        The design's own eps is certified for ``covers``.
    point : PointCertificate
        The certificate at the design's eps (of coverage ``covers``).
    n_b_grid : int
        Points of the ``b`` grid of the frozen check.
    a_jacobian_bounds : tuple or None
        Bounds on ``da/dx_i`` (linear differential inclusion), or None (``a = 0``).
    reason : str
        Summary.
    covers : str
        The coverage of ``certified`` and ``eps_star_certified``.
    brackets : tuple of EpsBracket
        ``[certified, refuted]`` per coverage searched (empty without a search).
    b_rate : float or None
        The rate bound per sample given (None: ``b`` arbitrary in time; 0: constant ``b``).
    eps_intervals_frozen : tuple of (float, float)
        The eps of the range at which every frozen loop of the ``b`` grid is Schur, as
        intervals (a scan of ``4 n_scan`` points, ends refined): not always ``(0, eps*]``
        (for gamma just above its lower bound the stable eps form a band away from 0).
    params : tuple of (str, float, float)
        The plant parameters covered, with their ranges (``lo == hi``: a fixed value), when
        ``b_bounds`` came from :func:`fl_design.analysis.plant_bounds`; empty otherwise.
    b_rate_source : str or None
        Where ``b_rate`` came from (``"given"``, or the plant's derivation term by term).
    covered_set : CoveredSet or None
        For a nonlinear certificate from a ``PlantBounds`` of a chain plant: the initial loop
        states covered, the largest sublevel set of ``V`` in the region
        (:class:`fl_design.analysis._ldi.CoveredSet`).

    Examples
    --------
    >>> import fl_design as fl
    >>> c = fl.certify_eps(fl.presets.paper_design(), (3.6, 6.8), search=False)
    >>> c.certified, c.covers
    (True, 'varying')
    """

    eps: float
    gamma: float
    T: float
    b_bounds: tuple
    eps_range: tuple
    eps_star_frozen: float | None
    eps_star_common: float | None
    eps_star_certified: float | None
    certified: bool
    point: PointCertificate
    n_b_grid: int
    a_jacobian_bounds: tuple | None
    reason: str
    covers: str = "varying"
    brackets: tuple = ()
    b_rate: float | None = None
    eps_intervals_frozen: tuple = ()
    params: tuple = ()
    b_rate_source: str | None = None
    covered_set: object = None

    def bracket(self, covers: str):
        """The :class:`EpsBracket` of one coverage, or None when not searched.

        Examples
        --------
        >>> import fl_design as fl
        >>> c = fl.certify_eps(fl.presets.paper_design(), (3.6, 6.8), search=False)
        >>> c.bracket("varying") is None
        True
        """
        return next((b for b in self.brackets if b.covers == covers), None)

    def to_dict(self) -> dict:
        out = super().to_dict()
        out["point"] = self.point.to_dict()
        out["brackets"] = [b.to_dict() for b in self.brackets]
        out["covered_set"] = None if self.covered_set is None else self.covered_set.to_dict()
        return out

    def _repr_lines(self):
        lines = [(f"design eps = {self.eps:.6g}, gamma = {self.gamma:.6g}, b in "
                  f"[{self.b_bounds[0]:g}, {self.b_bounds[1]:g}], T = {self.T:g}"),
                 (f"certified for its class ({self.covers}): {self.certified} "
                  f"({self.point.kind or '-'}); eps* certified "
                  f"{_fmt(self.eps_star_certified)} ({self.covers} b)")]
        lines += [str(b) + (f"  <- headline (certified by {b.how_certified.split(':')[0]})"
                            if b.covers == self.covers else "")
                  for b in self.brackets]
        lines = self._class_lines() + lines
        ranges = [f"{n} in [{a:g}, {b:g}]" for n, a, b in self.params if a != b]
        if ranges and "every plant with" not in self.class_description:
            lines.append("covers every plant with " + ", ".join(ranges))
        if self.b_rate is not None:
            lines.append(f"b rate {self.b_rate:.6g} per sample ({self.b_rate_source})")
        if self.covered_set is not None:
            lines += ["covered initial states: " + x for x in self.covered_set._repr_lines()]
        if self.eps_intervals_frozen:
            lines.append("frozen-stable eps: " + ", ".join(
                f"[{a:.6g}, {b:.6g}]" for a, b in self.eps_intervals_frozen))
        return lines + [self.reason]


@dataclass(frozen=True, repr=False)
class GammaCertificate(_OfClass):
    """Whether the design's gamma is certified, and the gamma interval that is
    (:func:`fl_design.certify_gamma`).

    Parameters
    ----------
    gamma, eps, T : float
        The design's numbers.
    b_bounds : tuple of float
        The interval of ``b``.
    paper_bound : float
        ``1/b_max`` (the paper's condition ``gamma < 1/b_max``).
    convergence_bound : float
        ``2/b_max`` (convergence of ``e_u`` alone).
    gamma_min, gamma_max : float or None
        Admissible interval at the design's eps: every frozen-b surrogate loop on the grid is
        Schur for ``gamma`` inside.
    gamma_lower_bound : float or None
        Smallest ``gamma_min`` over the eps grid ``eps_grid``: below it no eps of the grid works.
    eps_grid : tuple of float
        The eps values of ``gamma_lower_bound``.
    certified : bool
        The design's gamma lies inside ``(gamma_min, gamma_max)`` and the LMI certificate at
        ``(eps, gamma)`` holds.
    point : PointCertificate
        The LMI certificate at the design's numbers.
    reason : str
        Why (not).
    params : tuple of (str, float, float)
        The plant parameters covered with their ranges (from a ``PlantBounds``), else empty.

    Examples
    --------
    >>> import fl_design as fl
    >>> g = fl.certify_gamma(fl.presets.paper_design(), (3.6, 6.8))
    >>> g.certified, g.paper_bound == 1 / 6.8
    (True, True)
    """

    gamma: float
    eps: float
    T: float
    b_bounds: tuple
    paper_bound: float
    convergence_bound: float
    gamma_min: float | None
    gamma_max: float | None
    gamma_lower_bound: float | None
    eps_grid: tuple
    certified: bool
    point: PointCertificate
    reason: str
    params: tuple = ()

    def to_dict(self) -> dict:
        out = super().to_dict()
        out["point"] = self.point.to_dict()
        return out

    def _repr_lines(self):
        what = f" for {self.point.covers} b" if self.point.covers else ""
        ranges = [f"{n} in [{a:g}, {b:g}]" for n, a, b in self.params if a != b]
        if ranges:
            what += " and every plant with " + ", ".join(ranges)
        return self._class_lines() + [
                (f"gamma = {self.gamma:.6g} at eps = {self.eps:.6g}: certified{what} "
                 f"{self.certified}"),
                (f"admissible (frozen b grid): [{_fmt(self.gamma_min)}, {_fmt(self.gamma_max)}];"
                f" lower bound over eps {_fmt(self.gamma_lower_bound)}"),
                f"paper 1/b_max = {self.paper_bound:.6g}, 2/b_max = {self.convergence_bound:.6g}",
                self.reason]


__all__ = ["EpsBracket", "EpsCertificate", "GammaCertificate", "PointCertificate", "json_number"]
