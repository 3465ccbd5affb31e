"""The config tables without an API object of their own: one small frozen dataclass each.

Each class's fields are its TOML table's keys and its numpydoc ``Parameters`` are their
documentation (the comments ``fl-design init`` writes: :func:`field_docs`). Every value is
checked in ``__post_init__`` with the shared validators of :mod:`fl_design._validate` or by the
API object it configures (:class:`fl_design.Noise`, :class:`fl_design.Disturbance`,
:class:`fl_design.DynamicController`, :class:`fl_design.EHGO`, ...), so the config accepts
exactly what the API accepts; arrays are kept as tuples and tables as read-only mappings.
``[plant]`` is in :mod:`fl_design.app._plant_table`, ``[design]`` in
:mod:`fl_design.app._design_table`; ``[classifier]`` is :class:`fl_design.Classifier` itself.

Examples
--------
>>> from fl_design.app._tables import SweepTable
>>> SweepTable(eps=[0.01, 1.0], gamma=[1e-4, 1e-2]).eps
(0.01, 1.0)
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

from .. import _validate as V
from .._json import jsonable
from ..errors import ParameterError

#: Largest ``[sweep] points`` per axis (a grid of points**2 runs; 2048**2 = 4.2e6 runs).
MAX_SWEEP_POINTS = 2048
#: Largest ``[certify] points`` (one semidefinite program each).
MAX_CERTIFY_POINTS = 1000


def field_docs(cls) -> dict:
    """Each field's first line of documentation, from the class's numpydoc ``Parameters``.

    Parameters
    ----------
    cls : type
        A dataclass documented in numpydoc style (``a, b : type`` entries allowed).

    Returns
    -------
    dict
        Field name -> the first paragraph of its description, on one line (markup
        ````x```` removed).

    Examples
    --------
    >>> from fl_design.app._tables import SweepTable, field_docs
    >>> field_docs(SweepTable)["points"]
    'Per axis (points**2 closed-loop runs), in [2, 2048].'
    """
    text = (cls.__doc__ or "").expandtabs()
    m = re.search(r"\n( *)Parameters\n *-+\n(.*?)(?:\n\s*\n *\w[\w ]*\n *-+\n|\Z)", text, re.DOTALL)
    out = {}
    if not m:
        return out
    indent, names, para = len(m.group(1)), [], True
    for line in m.group(2).splitlines():
        stripped = line.strip()
        if len(line) - len(line.lstrip()) == indent and stripped:
            names, para = [n.strip() for n in stripped.split(" : ")[0].split(",")], True
        elif not stripped:
            para = False  # the first paragraph of a description only
        elif para:
            for n in names:
                text = re.sub(r":\w+:`~?([^`]+)`", r"\1", stripped.replace("``", ""))
                out[n] = f"{out.get(n, '')} {text}".strip()
    return out


def table_dict(obj) -> dict:
    """A table object's fields as strict JSON (tuples as lists, mappings as dicts).

    Examples
    --------
    >>> from fl_design.app._tables import CodegenTable, table_dict
    >>> table_dict(CodegenTable())["precision"]
    'double'
    """
    if not type(obj).__module__.startswith("fl_design.app"):  # an API object: its own form
        return obj.to_dict()
    return {f.name: jsonable(_plain(getattr(obj, f.name))) for f in dataclasses.fields(obj)}


def _plain(value):
    if isinstance(value, Mapping):
        return {k: _plain(v) for k, v in value.items()}
    return value


def set_fields(obj, **values) -> None:
    """Set fields of a frozen dataclass in its ``__post_init__`` (normalized values)."""
    for k, v in values.items():
        object.__setattr__(obj, k, v)


def mapping(name: str, value, check) -> MappingProxyType:
    """A read-only ``{key: check(name.key, value)}`` of a TOML table whose keys are names.

    Examples
    --------
    >>> from fl_design._validate import real_scalar
    >>> from fl_design.app._tables import mapping
    >>> dict(mapping("params", {"g": 9.81}, real_scalar))
    {'g': 9.81}
    """
    if not isinstance(value, Mapping):
        raise ParameterError(f"{name} must be a table {{ key = value, ... }}, got "
                             f"{V.short(value)}")
    return MappingProxyType({V.identifier(name, k): check(f"{name}.{k}", v)
                             for k, v in value.items()})


def duration(name: str, value):
    """``"adaptive"`` or a number of seconds > 0 (a length of run in the config).

    Examples
    --------
    >>> from fl_design.app._tables import duration
    >>> duration("duration", 2), duration("duration", "adaptive")
    (2.0, 'adaptive')
    """
    if isinstance(value, str):
        if value != "adaptive":
            raise ParameterError(f'{name} must be a number of seconds or "adaptive" (chosen '
                                 f"from the loop's slowest time constant), got {value!r}")
        return value
    out = V.real_scalar(name, value)
    if out <= 0:
        raise ParameterError(f"{name} must be > 0 s, got {out!r}")
    return out


def _points(name: str, value, top: int, why: str = "") -> int:
    n = V.integer(name, value)
    if not 2 <= n <= top:
        raise ParameterError(f"{name} must be >= 2 and <= {top}, got {n!r}{why}")
    return n


def _disturbance(value):
    """``[scenario.disturbance]``: ``input``/``output`` each ``{step = {...}}`` or
    ``{sine = {...}}`` -> :class:`fl_design.Disturbance` (its own checks)."""
    from ..sim import Disturbance, Sine, Step

    if value is None or isinstance(value, Disturbance):
        return value
    if not isinstance(value, Mapping) or not set(value) <= {"input", "output"}:
        raise ParameterError(f"disturbance must be a table with input and/or output, got "
                             f"{V.short(dict(value) if isinstance(value, Mapping) else value)}")
    kinds = {"step": Step, "sine": Sine}
    signals = {}
    for where, spec in value.items():
        name = f"disturbance.{where}"
        if not (isinstance(spec, Mapping) and len(spec) == 1 and set(spec) <= set(kinds)
                and isinstance(next(iter(spec.values())), Mapping)):
            raise ParameterError(f"{name} must be {{ step = {{ at = 10.0, size = 0.5 }} }} or "
                                 "{ sine = { amplitude = 0.1, frequency = 2.0 } } (phase, at "
                                 f"optional), got {V.short(spec)}")
        kind, body = next(iter(spec.items()))
        try:
            signals[where] = kinds[kind](**body)
        except TypeError:
            fields = [f.name for f in dataclasses.fields(kinds[kind])]
            raise ParameterError(f"{name}.{kind} takes {', '.join(fields)}, got "
                                 f"{', '.join(body)}") from None
        except ParameterError as err:
            raise ParameterError(f"{name}.{kind}: {err}") from None
    return Disturbance(**signals)


@dataclass(frozen=True)
class ScenarioTable:
    """``[scenario]``: the main run's step, length, noise and disturbances.

    Parameters
    ----------
    reference : float, optional
        The output's step target (absolute, in the plant's units).
    duration : float or str, optional
        "adaptive" (from the loop's slowest mode) or seconds.
    noise_std : float, optional
        Sensor noise (standard deviation) of the main run.
    seed : int, optional
        Noise seed.
    disturbance : Disturbance, optional
        [scenario.disturbance] input/output = { step = { at, size } } or { sine = { amplitude, frequency } }.

    Raises
    ------
    ParameterError
        A non-finite reference, a bad duration, what :class:`fl_design.Noise` or
        :class:`fl_design.Disturbance` refuses.

    Examples
    --------
    >>> from fl_design.app._tables import ScenarioTable
    >>> t = ScenarioTable(0.3, disturbance={"input": {"step": {"at": 1.0, "size": 0.5}}})
    >>> t.build().disturbance.input
    Step(at=1.0, size=0.5)
    """

    reference: float | None = None
    duration: float | str = "adaptive"
    noise_std: float = 0.0
    seed: int = 1
    disturbance: object = None

    def __post_init__(self) -> None:
        from ..sim import Noise

        if self.reference is not None:
            set_fields(self, reference=V.real_scalar("reference", self.reference))
        set_fields(self, duration=duration("duration", self.duration),
             disturbance=_disturbance(self.disturbance))
        Noise(std=self.noise_std, seed=self.seed)
        if self.reference is not None:
            self.build()  # and fl.Scenario accepts the whole

    def build(self, *, duration=None, noise_std=None, seed=None):
        """The :class:`fl_design.Scenario` of this table, optionally changed.

        Parameters
        ----------
        duration : float or str, optional
            Override (``"adaptive"``: the run chooses its length).
        noise_std : float, optional
            Override.
        seed : int, optional
            Override.

        Examples
        --------
        >>> from fl_design.app._tables import ScenarioTable
        >>> ScenarioTable(0.3, 2.0).build(noise_std=0.1).noise.std
        0.1
        """
        from ..sim import Noise, Scenario

        length = self.duration if duration is None else duration
        return Scenario(self.reference, None if length == "adaptive" else float(length),
                        noise=Noise(self.noise_std if noise_std is None else noise_std,
                                    seed=self.seed if seed is None else seed),
                        disturbance=self.disturbance)


@dataclass(frozen=True)
class CompareTable:
    """``[compare]``: the paper's estimator comparison (least squares, noise trade-off).

    Parameters
    ----------
    windows : tuple of int, optional
        Least-squares baselines (samples in the fit).
    noise_std : tuple of float, optional
        Sensor noise levels of the comparison.
    eps_tradeoff : tuple of float, optional
        eps values of the noise trade-off (s).
    seed : int, optional
        Noise seed of every compared run.
    duration : float or str, optional
        Seconds (or "adaptive"), every compared run.

    Raises
    ------
    ParameterError
        A window outside [1, $FL_DESIGN_MAX_WINDOW], what :class:`fl_design.Noise` refuses,
        a non-positive eps, a bad duration.

    Examples
    --------
    >>> from fl_design.app._tables import CompareTable
    >>> CompareTable(windows=[9]).windows
    (9,)
    """

    windows: tuple = (9, 26)
    noise_std: tuple = (1e-3, 0.0316)
    eps_tradeoff: tuple = (0.02, 0.05, 0.1)
    seed: int = 1
    duration: float | str = 30.0

    def __post_init__(self) -> None:
        from ..design._least_squares import max_window
        from ..sim import Noise

        if isinstance(self.windows, str) or not isinstance(self.windows, (list, tuple)):
            raise ParameterError(f"windows must be an array of integers, got "
                                 f"{V.short(self.windows)}")
        for w in self.windows:
            if isinstance(w, bool) or not isinstance(w, int) or not 1 <= w <= max_window():
                raise ParameterError(f"windows must hold integers in [1, {max_window()}] "
                                     f"($FL_DESIGN_MAX_WINDOW), got {w!r} in {self.windows!r}")
        stds = V.real_tuple("noise_std", self.noise_std)
        for std in stds:
            Noise(std=std, seed=self.seed)
        Noise(seed=self.seed)
        set_fields(self, windows=tuple(self.windows), noise_std=stds,
             eps_tradeoff=V.real_tuple("eps_tradeoff", self.eps_tradeoff, positive_only=True,
                                    nonempty=True),
             duration=duration("duration", self.duration))


@dataclass(frozen=True)
class SweepTable:
    """``[sweep]``: the stability map over (eps, gamma).

    Parameters
    ----------
    eps : (float, float), optional
        Log-spaced range (s); default [max(2 T, eps/10), 20 eps].
    gamma : (float, float), optional
        Log-spaced range with the sign of gamma; default [gamma/10, 100 gamma].
    points : int, optional
        Per axis (points**2 closed-loop runs), in [2, 2048].
    duration : float or str, optional
        "adaptive" or seconds, one length for the whole map.

    Raises
    ------
    ParameterError
        A range that is not [lo, hi] of one sign (eps > 0), points outside [2, 2048].

    Examples
    --------
    >>> from fl_design.app._tables import SweepTable
    >>> SweepTable(points=4).points
    4
    """

    eps: tuple | None = None
    gamma: tuple | None = None
    points: int = 16
    duration: float | str = "adaptive"

    def __post_init__(self) -> None:
        if self.eps is not None:
            set_fields(self, eps=V.log_range("eps", self.eps))
        if self.gamma is not None:
            set_fields(self, gamma=V.log_range("gamma", self.gamma, sign=0))
        set_fields(self, points=_points("points", self.points, MAX_SWEEP_POINTS,
                                  " (a grid of points**2 runs)"),
             duration=duration("duration", self.duration))


@dataclass(frozen=True)
class CertifyTable:
    """``[certify]``: the LMI certificates and the eps*(gamma) curve.

    Parameters
    ----------
    enabled : bool, optional
        The LMI certificates (needs [plant] region and input_range).
    eps_range : (float, float), optional
        Where eps* is searched (s); default that of [sweep] eps.
    gamma : (float, float), optional
        The eps*(gamma) curve; default [gamma/2, 10 gamma].
    points : int, optional
        Gammas on the curve, in [2, 1000].

    Raises
    ------
    ParameterError
        A range that is not [lo, hi] of one sign, points outside [2, 1000].

    Examples
    --------
    >>> from fl_design.app._tables import CertifyTable
    >>> CertifyTable(enabled=False).points
    8
    """

    enabled: bool = True
    eps_range: tuple | None = None
    gamma: tuple | None = None
    points: int = 8

    def __post_init__(self) -> None:
        V.boolean("enabled", self.enabled)
        if self.eps_range is not None:
            set_fields(self, eps_range=V.log_range("eps_range", self.eps_range))
        if self.gamma is not None:
            set_fields(self, gamma=V.log_range("gamma", self.gamma, sign=0))
        set_fields(self, points=_points("points", self.points, MAX_CERTIFY_POINTS))


@dataclass(frozen=True)
class CodegenTable:
    """``[codegen]``: the C99 step and its software-in-the-loop check.

    Parameters
    ----------
    enabled : bool, optional
        Generate the C99 step and check it in the loop.
    precision : str, optional
        double | float.
    prefix : str, optional
        Prefix of the C names.
    sil_duration : float, optional
        Seconds of software in the loop.

    Raises
    ------
    ParameterError
        An unknown precision, a prefix that is no C identifier, a non-positive duration.

    Examples
    --------
    >>> from fl_design.app._tables import CodegenTable
    >>> CodegenTable(precision="float").prefix
    'fl'
    """

    enabled: bool = True
    precision: str = "double"
    prefix: str = "fl"
    sil_duration: float = 10.0

    def __post_init__(self) -> None:
        from ..codegen._generate import check_prefix

        V.boolean("enabled", self.enabled)
        V.choice("precision", self.precision, ("double", "float"))
        check_prefix(self.prefix)
        set_fields(self, sil_duration=V.positive("sil_duration", self.sil_duration))


__all__ = ["CertifyTable", "CodegenTable", "CompareTable", "ScenarioTable", "SweepTable",
           "duration", "field_docs", "mapping", "set_fields", "table_dict"]
