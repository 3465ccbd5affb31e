"""The ``[uncertainty]`` table: a family of plants (the stage: :mod:`fl_design.app._stage_family`;
its report section: :mod:`fl_design.app._report_family`).

A configuration that gives parameter distributions runs the design against that family of
plants (:func:`fl_design.monte_carlo`) after the simulations, then the ``[sweep]`` grid against
``map_samples`` of them (the robust stability map), and the
report gains a *Robustness* section (verdict fractions, the worst samples, the robust eps*)::

    [uncertainty]
    samples = 200               # plants drawn (quick mode: 16)
    seed = 0                    # the same seed gives the same plants
    duration = "adaptive"       # seconds per run, or chosen from the nominal loop
    map_samples = 32            # plants per point of the robust map (quick mode: 8)
    [uncertainty.params]
    c = [0.05, 1.0]             # uniform on [lo, hi]
    b = { normal = [1.0, 0.1] } # normal: mean, standard deviation

Without ``params`` nothing runs and the report has no such section.

Examples
--------
>>> from fl_design.app import parse_config
>>> cfg = parse_config('[uncertainty.params]\\nc = [0.1, 1.0]\\nb = { normal = [1.0, 0.1] }')
>>> cfg.uncertainty.distributions()
{'c': Uniform(lo=0.1, hi=1.0), 'b': Normal(mu=1.0, sigma=0.1)}
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

from .. import _validate as V
from ..errors import ParameterError
from ._tables import duration as _duration
from ._tables import set_fields

#: Plants drawn in quick mode.
QUICK_SAMPLES = 16
#: Largest ``samples``.
MAX_SAMPLES = 1_000_000


def _spec(name: str, spec):
    """One ``params`` entry, normalized: ``(lo, hi)`` or ``{"normal"|"uniform": (a, b)}``."""
    from ..sim._family import Normal, Uniform

    kind, values = "uniform", spec
    if isinstance(spec, Mapping):
        if len(spec) != 1 or next(iter(spec)) not in ("uniform", "normal"):
            raise ParameterError(f"params.{name} must be [lo, hi], {{uniform = [lo, hi]}} or "
                                 f"{{normal = [mean, std]}}, got {V.short(dict(spec))}")
        kind, values = next(iter(spec.items()))
    if not (isinstance(values, (list, tuple)) and len(values) == 2 and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
            for v in values)):
        raise ParameterError(f"params.{name} must hold two finite numbers, got {values!r}")
    values = tuple(float(v) for v in values)
    try:
        Uniform(*values) if kind == "uniform" else Normal(*values)
    except ParameterError as err:
        raise ParameterError(f"params.{name}: {err}") from None
    return values if not isinstance(spec, Mapping) else MappingProxyType({kind: values})


@dataclass(frozen=True)
class UncertaintyTable:
    """``[uncertainty]``: a family of plants the design is run against (robustness stage).

    Parameters
    ----------
    params : mapping, optional
        Plant parameters drawn per sample: [lo, hi] (uniform) or { normal = [mean, std] }; not set: no robustness stage.
    samples : int, optional
        Plants drawn (quick mode: 16), in [1, 1000000].
    seed : int, optional
        The same seed gives the same plants (>= 0).
    duration : float or str, optional
        Seconds per run, or "adaptive" (chosen once on the nominal loop).
    map_samples : int, optional
        Plants per (eps, gamma) point of the robust map over the [sweep] grid (quick mode: 8); 0: no robust map.

    Raises
    ------
    ParameterError
        A value of ``params`` that is neither ``[lo, hi]`` nor ``{normal = [mu, sigma]}`` /
        ``{uniform = [lo, hi]}`` or numbers the distribution refuses, ``samples`` out of
        ``1 .. MAX_SAMPLES``, ``map_samples`` out of ``0 .. MAX_SAMPLES``, a negative seed, a
        bad duration.

    Examples
    --------
    >>> from fl_design.app._uncertainty import UncertaintyTable
    >>> t = UncertaintyTable(params={"c": [0.1, 1.0], "b": {"normal": [1.0, 0.1]}})
    >>> t.samples, t.distributions()
    (200, {'c': Uniform(lo=0.1, hi=1.0), 'b': Normal(mu=1.0, sigma=0.1)})
    """

    params: Mapping | None = None
    samples: int = 200
    seed: int = 0
    duration: float | str = "adaptive"
    map_samples: int = 32

    def __post_init__(self):
        params = None
        if self.params is not None:
            if not isinstance(self.params, Mapping):
                raise ParameterError(f"params must be a table {{ name = [lo, hi], ... }}, got "
                                     f"{V.short(self.params)}")
            params = MappingProxyType({V.identifier("params", k): _spec(k, v)
                                       for k, v in self.params.items()})
        samples = V.integer("samples", self.samples)
        if not 1 <= samples <= MAX_SAMPLES:
            raise ParameterError(f"samples must be in 1 .. {MAX_SAMPLES}, got {samples}")
        map_samples = V.integer("map_samples", self.map_samples)
        if not 0 <= map_samples <= MAX_SAMPLES:
            raise ParameterError(f"map_samples must be in 0 .. {MAX_SAMPLES} (0: no robust "
                                 f"map), got {map_samples}")
        seed = V.integer("seed", self.seed)
        if seed < 0:
            raise ParameterError(f"seed must be >= 0, got {seed}")
        set_fields(self, params=params or None, samples=samples, seed=seed,
                   duration=_duration("duration", self.duration), map_samples=map_samples)

    def box(self) -> dict:
        """The parameter box the certificates can cover: the uniform ranges of :attr:`params`,
        and the names with no box (normal distributions).

        Returns
        -------
        dict
            ``{"ranges": {name: (lo, hi)}, "unbounded": [names of normal parameters]}``.

        Examples
        --------
        >>> from fl_design.app._uncertainty import UncertaintyTable
        >>> UncertaintyTable(params={"c": [0.1, 1.0], "b": {"normal": [1, 0.1]}}).box()
        {'ranges': {'c': (0.1, 1.0)}, 'unbounded': ['b']}
        """
        from ..sim._family import Uniform

        ranges, unbounded = {}, []
        for name, dist in self.distributions().items():
            if isinstance(dist, Uniform):
                ranges[name] = (float(dist.lo), float(dist.hi))
            else:
                unbounded.append(name)
        return {"ranges": ranges, "unbounded": unbounded}

    def distributions(self) -> dict:
        """``{name: fl.Uniform or fl.Normal}`` of :attr:`params` (empty when not set).

        Examples
        --------
        >>> from fl_design.app._uncertainty import UncertaintyTable
        >>> UncertaintyTable(params={"b": {"uniform": [0.5, 2]}}).distributions()
        {'b': Uniform(lo=0.5, hi=2.0)}
        """
        from ..sim._family import Normal, Uniform

        out = {}
        for name, spec in (self.params or {}).items():
            kind, values = next(iter(spec.items())) if isinstance(spec, Mapping) else \
                ("uniform", spec)
            out[name] = Uniform(*values) if kind == "uniform" else Normal(*values)
        return out


__all__ = ["MAX_SAMPLES", "QUICK_SAMPLES", "UncertaintyTable"]
