"""The main job's configuration: a TOML file, one table per option object, validated.

Each table is one object's fields (:data:`TABLES`): ``[plant]``, ``[design]``, ``[scenario]``
(with ``[scenario.disturbance]``), ``[compare]``, ``[sweep]``, ``[certify]`` and ``[codegen]``
are the small frozen dataclasses of :mod:`fl_design.app._tables` and
:mod:`fl_design.app._design_table`; ``[classifier]`` is :class:`fl_design.Classifier`. The
objects' own validation is the schema: its message, prefixed with the table and the key, is the
:class:`ConfigError`. Every key has a default (a library plant's bench design: the paper's TRMS
by default, :data:`DEFAULT_TOML`), and ``fl-design init`` writes every field of every table
(:func:`fl_design.app._template.config_toml`). Adding a table is one dataclass and one line
of :class:`Config`.

Examples
--------
>>> from fl_design.app import load_config
>>> cfg = load_config(None)
>>> cfg.plant.library, cfg.design.eps, cfg.scenario.reference, cfg.classifier.tolerance
('trms', 0.05, 0.3, 0.02)
"""

from __future__ import annotations

import dataclasses
import math
import re
import tomllib
import warnings
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import ParameterError
from ..sim import Classifier
from ._design_table import DesignTable
from ._library_tables import fill_ranges, full_tables, library_tables, plain_toml
from ._plant_table import LIBRARY, PlantTable
from ._tables import (
    MAX_CERTIFY_POINTS,
    MAX_SWEEP_POINTS,
    CertifyTable,
    CodegenTable,
    CompareTable,
    ScenarioTable,
    SweepTable,
    table_dict,
)
from ._uncertainty import UncertaintyTable


class ConfigError(ParameterError):
    """A configuration file that cannot be used (names the table and key).

    Examples
    --------
    >>> from fl_design.app import ConfigError, parse_config
    >>> parse_config('[sweep]\\npoints = "many"')
    Traceback (most recent call last):
    ...
    fl_design.app._config.ConfigError: <string>: [sweep] points must be an integer, got 'many'
    >>> issubclass(ConfigError, ValueError)  # a ParameterError
    True
    """


@dataclass(frozen=True)
class Config:
    """A validated configuration: one immutable option object per TOML table.

    Built by :func:`parse_config` / :func:`load_config` (defaults filled in).

    Parameters
    ----------
    plant : PlantTable
        ``[plant]``.
    design : DesignTable or None
        ``[design]`` (None: a plant from expressions without a design).
    scenario : ScenarioTable
        ``[scenario]`` and ``[scenario.disturbance]``.
    classifier : fl_design.Classifier
        ``[classifier]``.
    compare, sweep, certify, codegen : CompareTable, SweepTable, CertifyTable, CodegenTable
        The stages' tables.
    uncertainty : UncertaintyTable
        ``[uncertainty]`` (no ``params``: no robustness stage).
    source : str
        Where it came from (a path or ``"<default>"``).
    notes : tuple of str
        Warnings about values that run but are likely mistakes (eps below T, ...), with the
        numbers, and deprecated keys; the command line prints them on stderr.

    Examples
    --------
    >>> from fl_design.app import load_config
    >>> cfg = load_config(None)
    >>> cfg.sweep.points
    16
    >>> cfg.design.eps = -1.0
    Traceback (most recent call last):
    ...
    dataclasses.FrozenInstanceError: cannot assign to field 'eps'
    """

    plant: PlantTable = field(default=None, metadata={"table": PlantTable})
    design: DesignTable | None = field(default=None, metadata={"table": DesignTable})
    scenario: ScenarioTable = field(default=None, metadata={"table": ScenarioTable})
    classifier: Classifier = field(default=None, metadata={"table": Classifier})
    compare: CompareTable = field(default=None, metadata={"table": CompareTable})
    sweep: SweepTable = field(default=None, metadata={"table": SweepTable})
    certify: CertifyTable = field(default=None, metadata={"table": CertifyTable})
    codegen: CodegenTable = field(default=None, metadata={"table": CodegenTable})
    uncertainty: UncertaintyTable = field(default=None, metadata={"table": UncertaintyTable})
    source: str = "<default>"
    notes: tuple = ()

    def to_dict(self) -> dict:
        """The tables as a dict (strict JSON).

        Examples
        --------
        >>> from fl_design.app import load_config
        >>> sorted(load_config(None).to_dict())[:3]
        ['certify', 'classifier', 'codegen']
        """
        return {name: None if getattr(self, name) is None else table_dict(getattr(self, name))
                for name in TABLES} | {"source": self.source, "notes": list(self.notes)}


#: TOML table name -> the class of its object (the schema), in the order ``init`` writes them.
TABLES = {f.name: f.metadata["table"] for f in dataclasses.fields(Config)
          if "table" in f.metadata}


def _keys(cls) -> tuple:
    return tuple(f.name for f in dataclasses.fields(cls) if f.init)


def _check_tables(data: dict, where: str) -> None:
    for table, body in data.items():
        if table not in TABLES:
            raise ConfigError(f"{where}: unknown table [{table}]; valid tables: "
                              f"{', '.join(f'[{t}]' for t in TABLES)}")
        if not isinstance(body, dict):
            raise ConfigError(f"{where}: {table} must be a table [{table}], got {body!r}")
        for key in body:
            if key not in _keys(TABLES[table]):
                raise ConfigError(f"{where}: unknown key {key!r} in [{table}]; valid keys: "
                                  f"{', '.join(_keys(TABLES[table]))}")


def _frozen(value):
    """TOML arrays as tuples (nested too); tables are frozen by the objects."""
    if isinstance(value, list):
        return tuple(_frozen(v) for v in value)
    if isinstance(value, dict):
        return {k: _frozen(v) for k, v in value.items()}
    return value


def _build(table: str, base: dict, given: dict):
    """``TABLES[table](**(base | given))``; its error as a ConfigError naming table and key.

    The key is the field the object's message starts with; else the one given key without
    which the table is valid; else none (a relation between keys, said by the message).
    """
    cls = TABLES[table]
    try:
        return cls(**_frozen(base | given))
    except ParameterError as err:
        msg = str(err)
    lead = re.match(r"\w+", msg)
    if lead and lead.group(0) in _keys(cls):
        raise ConfigError(f"[{table}] {msg}") from None
    for key in given:
        try:
            cls(**_frozen(base | {k: v for k, v in given.items() if k != key}))
        except ParameterError:
            continue
        raise ConfigError(f"[{table}] {key}: {msg}") from None
    raise ConfigError(f"[{table}] {msg}") from None


def _check_signs(cfg: dict) -> None:
    """The ``[sweep]`` and ``[certify]`` gamma ranges have the sign of ``[design] gamma``."""
    if cfg["design"] is None:
        return
    sign = cfg["design"].sign
    for table in ("sweep", "certify"):
        lo = cfg[table].gamma
        if lo is not None and lo[0] * sign < 0:
            raise ConfigError(f"[{table}] gamma must not contain 0 and has the sign of [design] "
                              f"gamma ({'negative' if sign < 0 else 'positive'}), got "
                              f"{list(lo)!r}")


def _warnings(cfg: dict) -> tuple:
    """Numbers that run but are likely mistakes (said on stderr and in the config's notes)."""
    d, out = cfg["design"], []
    if d is None:
        return ()
    if d.estimator == "ehgo" and d.eps < d.T:
        out.append(f"[design] eps = {d.eps:g} s is below the sampling time T = {d.T:g} s "
                   f"(alpha = T/eps = {d.T / d.eps:.3g} > 1): the observer is faster than "
                   "its sampling; eps >= T is the usual choice")
    for table, key in (("sweep", "eps"), ("certify", "eps_range")):
        lo = (getattr(cfg[table], key) or (math.inf,))[0]
        if lo < d.T:
            out.append(f"[{table}] {key} starts at {lo:g} s, below the sampling time "
                       f"T = {d.T:g} s (alpha = T/eps up to {d.T / lo:.3g})")
    return tuple(out)


def _deprecated(data: dict) -> tuple:
    """``[scenario] tolerance`` (before ``[classifier]``): moved, with a DeprecationWarning."""
    sc = data.get("scenario", {})
    if "tolerance" not in sc:
        return ()
    classifier = data.get("classifier", {})
    if isinstance(classifier, dict) and "tolerance" in classifier:
        raise ConfigError("[scenario] tolerance and [classifier] tolerance are both given: "
                          "keep [classifier] tolerance (the settling band is the classifier's)")
    msg = (f"[scenario] tolerance is deprecated: the settling band is the classifier's; write "
           f"[classifier] tolerance = {sc['tolerance']!r} instead")
    warnings.warn(msg, DeprecationWarning, stacklevel=3)
    if isinstance(classifier, dict):  # else [classifier] itself is refused, as a table
        data.setdefault("classifier", {})["tolerance"] = sc.pop("tolerance")
    return (msg,)


def _custom_defaults(tables: dict, data: dict) -> None:
    """Defaults for a plant from expressions: no TRMS design, scales from the user's numbers."""
    p, d = data.get("plant", {}), data.get("design")
    tables["plant"] = {}
    tables["design"] = {} if not d else {
        "estimator": "ehgo", "ki": 0.0, "coeffs": [], "estimate_limits": [],
        "u_limits": list(p["input_range"]) if isinstance(p.get("input_range"), list) else []}
    sc = data.get("scenario", {})
    if "reference" not in sc:
        tables["scenario"].pop("reference")
        tables["compare"]["noise_std"] = []  # derived from the step once it is known (_propose)
        return
    op = p.get("operating_point", {}) if isinstance(p.get("operating_point"), dict) else {}
    y0 = op.get("y", op.get(p.get("output"), 0.0))
    number = (int, float)
    step = abs(float(sc["reference"]) - float(y0)) if isinstance(y0, number) and \
        isinstance(sc["reference"], number) else 0.0
    if step > 0:
        tables["compare"]["noise_std"] = [float(f"{step / 300:.3g}"),
                                          float(f"{step * 0.105409:.3g}")]
    eps = (d or {}).get("eps")
    if isinstance(eps, number) and not isinstance(eps, bool) and eps > 0:
        tables["compare"]["eps_tradeoff"] = [float(f"{eps * f:.6g}")
                                             for f in (0.4, 1.0, 2.0, 4.0, 10.0)]


def _toml_line(text: str, message: str) -> str:
    """The line a TOML error points at, quoted (the key the user wrote there)."""
    import re

    m = re.search(r"at line (\d+)", message)
    lines = text.splitlines()
    if not m or not 1 <= int(m.group(1)) <= len(lines):
        return ""
    return f": {lines[int(m.group(1)) - 1].strip()[:80]!r}"


def parse_config(text: str, *, source: str = "<string>") -> Config:
    """Validate TOML text against the schema and fill in the defaults.

    A library plant (``[plant] library``) gets its bench design and bench step
    (:func:`fl_design.presets.bench_design`); a plant from expressions gets no design (give
    ``[design]`` and ``[scenario] reference``; ``derive`` needs neither, the other stages
    refuse their absence: :func:`fl_design.app._build.check_fit`). The ``[sweep]``
    and ``[certify]`` ranges default to ranges around the design point (from ``T``, eps and
    gamma: :func:`fl_design.app._template.default_ranges`).

    Parameters
    ----------
    text : str
        TOML source.
    source : str, optional
        Name used in messages.

    Returns
    -------
    Config

    Raises
    ------
    ConfigError
        Invalid TOML, an unknown table or key, a wrong type or value (the whole message of
        the API object that refused it, after the table and key).

    Examples
    --------
    >>> from fl_design.app import parse_config
    >>> parse_config('[design]\\neps = 0.1').design.eps
    0.1
    >>> parse_config('[plant]\\nlibrary = "maglev"').design.gamma
    -0.0016
    >>> parse_config('[design]\\nepsilon = 0.1')
    Traceback (most recent call last):
    ...
    fl_design.app._config.ConfigError: <string>: unknown key 'epsilon' in [design]; ...
    """

    text = text.removeprefix("\ufeff")  # a UTF-8 byte-order mark
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise ConfigError(f"{source}: not valid TOML: {err}{_toml_line(text, str(err))}") \
            from None
    except RecursionError:  # tomllib recurses per nesting level: [[[[...]]]] 5000 deep
        raise ConfigError(f"{source}: arrays or inline tables nested too deeply for a config "
                          "(a config needs two levels); write it flat") from None
    try:
        notes = _deprecated(data) if isinstance(data.get("scenario"), dict) else ()
    except ConfigError as err:
        raise ConfigError(f"{source}: {err}") from None
    if "class" in data:  # a [class] config: only `fl-design run` takes it (_class_table)
        raise ConfigError(f"{source}: a [class] config (no model): `fl-design run` designs from "
                          "it; the other commands need a [plant] model")
    _check_tables(data, source)
    try:
        plant = data.get("plant", {})
        custom = bool({"states", "rhs", "output", "input"} & set(plant))
        library = plant.get("library", "trms")
        if not custom and (not isinstance(library, str) or library not in LIBRARY):
            _build("plant", {}, plant)  # refused, naming the valid names
        tables = library_tables("trms" if custom else library)
        gamma = data.get("design", {}).get("gamma")
        if isinstance(gamma, (int, float)) and gamma * tables["design"]["gamma"] < 0:
            for table in ("sweep", "certify"):  # the bench ranges have the bench gamma's sign
                for key in ("eps", "gamma", "eps_range"):
                    tables[table].pop(key, None)
        if custom:
            _custom_defaults(tables, data)
        merged = {name: tables.get(name, {}) | data.get(name, {}) for name in TABLES}
        fill_ranges(merged, data)
        cfg = {name: None if name == "design" and not merged[name] else
               _build(name, tables.get(name, {}), merged[name]
                      if name in ("sweep", "certify") else data.get(name, {}))
               for name in TABLES}
        _check_signs(cfg)
    except ConfigError as err:
        raise ConfigError(f"{source}: {err}") from None
    return Config(**cfg, source=source, notes=notes + _warnings(cfg))


def load_config(path: str | Path | None) -> Config:
    """Read and validate a TOML configuration; None gives the embedded default.

    Parameters
    ----------
    path : str or pathlib.Path or None
        The file (None: the paper's TRMS experiment, :data:`fl_design.app.DEFAULT_TOML`).

    Returns
    -------
    Config
        As :func:`parse_config` gives it, named after the file in messages.

    Raises
    ------
    ConfigError
        The file is missing or unreadable, or its content is invalid.

    Examples
    --------
    >>> from fl_design.app import load_config
    >>> load_config(None).design.gamma
    0.0003
    """
    if path is None:
        return parse_config(plain_toml(full_tables("trms")), source="<default>")
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")  # a byte-order mark is allowed
    except (OSError, UnicodeDecodeError) as err:
        reason = getattr(err, "strerror", None) or type(err).__name__
        raise ConfigError(f"cannot read config {str(path)!r}: {reason}") from None
    return parse_config(text, source=str(path))



__all__ = ["LIBRARY", "MAX_CERTIFY_POINTS", "MAX_SWEEP_POINTS", "TABLES", "Config",
           "ConfigError", "load_config", "parse_config"]
