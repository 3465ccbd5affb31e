"""The ``[class]`` configuration: what a rig owner knows, in place of a ``[plant]`` model.

A class config has the tables ``[class]`` (the fields of :class:`fl_design.PlantClass` a user
states: ``rho``, ``T``, ``b = [lo, hi]``, ``noise_std``, ``u_limits`` and the optional bounds),
``[tune]`` (``objective``, ``reference``) and ``[codegen]`` (``precision``, ``prefix``, as the
model route's). ``fl-design init --class`` writes :data:`CLASS_TOML`, every key commented.

Examples
--------
>>> from fl_design.app._class_table import parse_class_config
>>> cfg = parse_class_config('[class]\\nrho = 2\\nT = 1e-3\\nb = [1.0, 50.0]\\nnoise_std = 1e-3')
>>> cfg.plant_class.b, cfg.tune.objective
((1.0, 50.0), 'least-noise')
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from ..errors import ParameterError

#: The keys of ``[class]``: the stated fields of a PlantClass.
CLASS_KEYS = ("rho", "T", "b", "noise_std", "noise_bound", "u_limits", "b_rate", "a_slopes",
              "delay", "y_range", "operating_point", "u_eq", "name", "source")

#: What ``fl-design init --class`` writes.
CLASS_TOML = """\
# fl-design: a design for a plant class: what you know of your rig, no model.
# `fl-design run THIS.toml` tunes a design certified for every plant of the class, writes
# the report (certificate, margins at the class's extremes, member runs, the ADRC baseline)
# and the C package. `fl-design identify LOG.csv --rho R --out DIR` writes such a file from a
# log of your rig.

[class]
rho = 2                    # relative degree: how many times y is differentiated until u appears
T = 1e-3                   # sampling time [s] of your loop
b = [1.0, 50.0]            # range of b = d y^(rho) / du over the region (one sign; [-50, -1] ok)
noise_std = 1e-3           # sensor noise standard deviation (the output's units)
u_limits = [-10.0, 10.0]   # actuator limits
# Optional bounds (each one makes the class smaller and the design better):
# b_rate = 0.0             # |b(k+1) - b(k)| per sample (0: constant b; omit: b may vary freely)
# a_slopes = [[-1.0, 1.0], [-0.5, 0.5]]  # d sigma / d (y, y', ...): rho pairs [lo, hi]
# delay = 0                # input delay [samples]
# noise_bound = 3e-3       # peak bound of the noise
# y_range = [-1.0, 1.0]    # the output's range where these bounds hold
# operating_point = 0.0    # the output where it is held
# u_eq = 0.0               # the input holding it there
# name = "my rig"
# source = "stated"        # or "log" (fl-design identify writes it): where the numbers come from

[tune]
objective = "least-noise"  # or "fastest"
# reference = 1.0          # step target of the member runs (default operating point + 1)

[codegen]
precision = "double"       # or "float"
prefix = "fl"              # prefix of the C names
"""


@dataclass(frozen=True)
class TuneTable:
    """``[tune]``: the objective and the step target of the member runs."""

    objective: str = "least-noise"
    reference: float | None = None

    def __post_init__(self):
        if self.objective not in ("least-noise", "least_noise", "fastest"):
            raise ParameterError(f"objective must be 'least-noise' or 'fastest', got "
                                 f"{self.objective!r}")
        if self.reference is not None and not isinstance(self.reference, (int, float)):
            raise ParameterError(f"reference must be a number, got {self.reference!r}")


@dataclass(frozen=True)
class ClassCodegen:
    """``[codegen]`` of a class config."""

    precision: str = "double"
    prefix: str = "fl"

    def __post_init__(self):
        if self.precision not in ("double", "float"):
            raise ParameterError(f"precision must be 'double' or 'float', got "
                                 f"{self.precision!r}")
        if not (isinstance(self.prefix, str) and self.prefix.isidentifier()):
            raise ParameterError(f"prefix must be a C identifier, got {self.prefix!r}")


@dataclass(frozen=True)
class ClassConfig:
    """A validated class config: the class, ``[tune]``, ``[codegen]``, where it came from."""

    plant_class: Any
    tune: TuneTable = field(default_factory=TuneTable)
    codegen: ClassCodegen = field(default_factory=ClassCodegen)
    source: str = "<string>"


def _tuples(v):
    return tuple(_tuples(x) for x in v) if isinstance(v, list) else v


def _table(cls, name: str, body, source: str):
    from ..analysis._plant_class import PlantClass
    from ._config import ConfigError

    if not isinstance(body, dict):
        raise ConfigError(f"{source}: [{name}] must be a table")
    keys = CLASS_KEYS if cls is PlantClass else tuple(f.name for f in fields(cls))
    for k in body:
        if k not in keys:
            raise ConfigError(f"{source}: unknown key {k!r} in [{name}]; valid keys: "
                              f"{', '.join(keys)}")
    try:
        if cls is PlantClass:
            if body.get("source", "stated") not in ("stated", "log"):
                raise ConfigError(f"{source}: [class] source must be 'stated' or 'log' (where "
                                  f"the numbers come from), got {body['source']!r}")
            return PlantClass(**{"source": "stated"} | {k: _tuples(v) for k, v in body.items()})
        return cls(**{k: _tuples(v) for k, v in body.items()})
    except ParameterError as err:
        raise ConfigError(f"{source}: [{name}] {err}") from None
    except TypeError as err:  # a missing required key (rho, T, b)
        raise ConfigError(f"{source}: [{name}] needs rho, T and b ({err})") from None


def is_class_text(text: str) -> bool:
    """Whether a TOML text has a ``[class]`` table (cheap: the table header)."""
    return any(line.strip().startswith("[class]") for line in text.splitlines())


def is_class_config(path) -> bool:
    """Whether ``path`` names a readable TOML file with a ``[class]`` table (False otherwise).

    Examples
    --------
    >>> is_class_config(None), is_class_config("no-such-file.toml")
    (False, False)
    """
    if path is None or not Path(path).is_file():
        return False
    try:
        return is_class_text(Path(path).read_text(encoding="utf-8-sig"))
    except (OSError, UnicodeDecodeError):
        return False


def parse_class_config(text: str, *, source: str = "<string>") -> ClassConfig:
    """Validate a class config (see the module); ConfigError names the table and key.

    Examples
    --------
    >>> parse_class_config('[class]\\nrho = 2\\nT = 1e-3\\nb = [1.0, 0.5]')
    Traceback (most recent call last):
    ...
    fl_design.app._config.ConfigError: <string>: [class] b = (1, 0.5) is reversed: give (lo, hi) with lo <= hi
    """
    from ._config import ConfigError

    try:
        data = tomllib.loads(text.removeprefix("\ufeff"))
    except tomllib.TOMLDecodeError as err:
        raise ConfigError(f"{source}: not valid TOML: {err}") from None
    allowed = {"class", "tune", "codegen"}
    for t in data:
        if t not in allowed:
            raise ConfigError(f"{source}: a [class] config takes the tables [class], [tune], "
                              f"[codegen]; [{t}] belongs to a model config ([plant])")
    if "class" not in data:
        raise ConfigError(f"{source}: no [class] table")
    from ..analysis._plant_class import PlantClass  # imported on use: the CLI starts fast

    return ClassConfig(plant_class=_table(PlantClass, "class", data["class"], source),
                       tune=_table(TuneTable, "tune", data.get("tune", {}), source),
                       codegen=_table(ClassCodegen, "codegen", data.get("codegen", {}), source),
                       source=source)


def load_class_config(path) -> ClassConfig:
    """Read a class config file."""
    from ._config import ConfigError

    try:
        text = Path(path).read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as err:
        raise ConfigError(f"cannot read config {str(path)!r}: "
                          f"{getattr(err, 'strerror', None) or type(err).__name__}") from None
    return parse_class_config(text, source=str(path))


def class_toml(cls, *, comment: str = "") -> str:
    """A ``[class]`` config of ``cls`` (what ``fl-design identify`` writes).

    Examples
    --------
    >>> print(class_toml(fl.PlantClass(rho=1, T=1e-3, b=(1, 2))).splitlines()[1])
    rho = 1
    """
    def val(v):
        if isinstance(v, tuple):
            return "[" + ", ".join(val(x) for x in v) + "]"
        if isinstance(v, str):
            return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
        return repr(float(v)) if isinstance(v, float) else repr(v)
    lines = [f"# {c}" for c in comment.splitlines()] + ["[class]"]
    for k in CLASS_KEYS:
        v = getattr(cls, k)
        if v is None or (k == "delay" and v == 0) or (k == "name" and not v) or \
                (k == "source" and v not in ("stated", "log")):
            continue
        lines.append(f"{k} = {val(v)}")
    if cls.u_limits is None:
        lines.append("# u_limits = [lo, hi]   # your actuator's limits: a log does not know them")
    return "\n".join(lines) + "\n\n[tune]\nobjective = \"least-noise\"\n"


__all__ = ["CLASS_TOML", "ClassConfig", "class_toml", "is_class_config", "is_class_text",
           "load_class_config", "parse_class_config"]
