"""The main job's configuration: a TOML file, one table per option object, validated.

Tables: ``[plant]`` (a library name, or SymPy expressions as strings), ``[design]``,
``[scenario]``, ``[compare]`` (the paper's estimator comparison), ``[sweep]``, ``[certify]``
and ``[codegen]``. Every key has a default (the paper's TRMS design: :data:`DEFAULT_TOML`); an
unknown table or key, a wrong type or a missing value raises :class:`ConfigError` naming the
table and the key.

Examples
--------
>>> from fl_design.app import load_config
>>> cfg = load_config(None)
>>> cfg.plant["library"], cfg.design["eps"], cfg.scenario["reference"]
('trms', 0.05, 0.3)
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

from ..errors import ParameterError


class ConfigError(ParameterError):
    """A configuration file that cannot be used (names the table and key).

    Examples
    --------
    >>> from fl_design.app import ConfigError, parse_config
    >>> try:
    ...     parse_config('[sweep]\\npoints = "many"')
    ... except ConfigError as err:
    ...     print(err)
    <string>: [sweep] points must be an integer, got 'many'
    """


#: The embedded default: the paper's TRMS yaw experiment (Shenoy et al.).
DEFAULT_TOML = """\
# The paper's TRMS yaw experiment (Shenoy, Saradagi, Pasumarthy, Chellaboina).
[plant]
library = "trms"          # trms | trms-lag | pendulum | flexible-joint
output_unit = "rad"       # axis labels of the report
input_unit = "V"

[design]
estimator = "ehgo"        # ehgo | least_squares
eps = 0.05                # observer time constant (s)
T = 0.001                 # sampling time (s)
coeffs = [6.0, 11.0, 6.0] # s^3 + 6 s^2 + 11 s + 6
gains = [2.0, 4.0]
gamma = 0.0003
ki = 0.001
u_limits = [-2.5, 2.5]
estimate_limits = ["none", 0.05]   # |xhat_2| <= 0.05 rad/s

[scenario]
reference = 0.3           # rad
duration = "adaptive"     # from the loop's slowest time constant, or seconds
tolerance = 0.02          # relative to the step (settling band 2 %)
noise_std = 0.0           # sensor noise of the main run (rad)
seed = 1

[compare]
windows = [9, 26]                      # least-squares baselines
noise_std = [0.001, 0.0316227766]      # std 1e-3 and the paper's variance 1e-3
eps_tradeoff = [0.02, 0.05, 0.1, 0.2, 0.5]
seed = 1
duration = 30.0           # s: the transient (overshoot, noise) of every compared run

[sweep]
eps = [0.005, 1.0]        # log-spaced range (s)
gamma = [3e-5, 0.03]
points = 16               # per axis
duration = "adaptive"     # one length for the map, from the design point's slowest mode

[certify]
enabled = true
gamma = [1.5e-4, 3e-3]
points = 8

[codegen]
enabled = true
precision = "double"
prefix = "fl"
sil_duration = 10.0       # s of software in the loop
"""

_NUM = (int, float)
_DURATION = (int, float, str)  # seconds, or "adaptive" (fl.Scenario without a duration)
# table -> key -> (types, description)
_SCHEMA: dict[str, dict[str, tuple]] = {
    "plant": {"library": (str,), "motor_lag": (bool,), "name": (str,), "states": (list,),
              "input": (str,), "rhs": (list,), "output": (str,), "params": (dict,),
              "region": (dict,), "input_range": (list,), "operating_point": (dict,),
              "output_unit": (str,), "input_unit": (str,)},
    "design": {"estimator": (str,), "eps": _NUM, "T": _NUM, "coeffs": (list,),
               "window": (int,), "gains": (list,), "gamma": _NUM, "ki": _NUM,
               "u_limits": (list,), "estimate_limits": (list,)},
    "scenario": {"reference": _NUM, "duration": _DURATION, "tolerance": _NUM, "noise_std": _NUM,
                 "seed": (int,)},
    "compare": {"windows": (list,), "noise_std": (list,), "eps_tradeoff": (list,),
                "seed": (int,), "duration": _DURATION},
    "sweep": {"eps": (list,), "gamma": (list,), "points": (int,), "duration": _DURATION},
    "certify": {"enabled": (bool,), "gamma": (list,), "points": (int,)},
    "codegen": {"enabled": (bool,), "precision": (str,), "prefix": (str,),
                "sil_duration": _NUM},
}
#: Library plants by config name (``[plant] library``, ``--plant``).
LIBRARY = ("trms", "trms-lag", "pendulum", "flexible-joint", "cart-pendulum", "maglev")


@dataclass(frozen=True)
class Config:
    """A validated configuration: one dict per table (defaults filled in).

    Parameters
    ----------
    plant, design, scenario, compare, sweep, certify, codegen : dict
        The tables.
    source : str
        Where it came from (a path or ``"<default>"``).

    Examples
    --------
    >>> from fl_design.app import load_config
    >>> load_config(None).sweep["points"]
    16
    """

    plant: dict
    design: dict
    scenario: dict
    compare: dict
    sweep: dict
    certify: dict
    codegen: dict
    source: str = "<default>"

    def to_dict(self) -> dict:
        """The tables as a dict (strict JSON).

        Examples
        --------
        >>> from fl_design.app import load_config
        >>> sorted(load_config(None).to_dict())[:3]
        ['certify', 'codegen', 'compare']
        """
        return {name: dict(getattr(self, name)) for name in _SCHEMA} | {"source": self.source}


def _type_name(types: tuple) -> str:
    if types == _DURATION:
        return 'a number of seconds or "adaptive"'
    return {str: "a string", bool: "true or false", int: "an integer", list: "an array",
            dict: "a table"}.get(types[0], "a number") if len(types) == 1 else "a number"


def _check_value(table: str, key: str, value, types: tuple) -> None:
    ok = isinstance(value, types) and not (isinstance(value, bool) and bool not in types)
    if not ok:
        raise ConfigError(f"[{table}] {key} must be {_type_name(types)}, got {value!r}")
    if isinstance(value, float) and not math.isfinite(value):
        raise ConfigError(f"[{table}] {key} must be finite, got {value!r}")


def _check_tables(data: dict, where: str) -> None:
    for table, body in data.items():
        if table not in _SCHEMA:
            raise ConfigError(f"{where}: unknown table [{table}]; valid tables: "
                              f"{', '.join(f'[{t}]' for t in _SCHEMA)}")
        if not isinstance(body, dict):
            raise ConfigError(f"{where}: {table} must be a table [{table}], got {body!r}")
        for key, value in body.items():
            if key not in _SCHEMA[table]:
                raise ConfigError(f"{where}: unknown key {key!r} in [{table}]; valid keys: "
                                  f"{', '.join(_SCHEMA[table])}")
            try:
                _check_value(table, key, value, _SCHEMA[table][key])
            except ConfigError as err:
                raise ConfigError(f"{where}: {err}") from None


def _numbers(table: str, key: str, value, n: int | None = None, *, positive=False) -> list:
    if not isinstance(value, list) or (n is not None and len(value) != n) or not value:
        size = f"{n} numbers" if n else "a non-empty array of numbers"
        raise ConfigError(f"[{table}] {key} must be {size}, got {value!r}")
    for v in value:
        if isinstance(v, bool) or not isinstance(v, _NUM) or not math.isfinite(v) or \
                (positive and v <= 0):
            kind = "positive numbers" if positive else "finite numbers"
            raise ConfigError(f"[{table}] {key} must hold {kind}, got {v!r} in {value!r}")
    return [float(v) for v in value]


#: Largest ``[sweep] points`` per axis (a grid of points**2 runs; 2048**2 = 4.2e6 runs).
MAX_SWEEP_POINTS = 2048
#: Largest ``[certify] points`` (one semidefinite program each).
MAX_CERTIFY_POINTS = 1000


def _api(table: str, key: str, check) -> None:
    """Run the API's own validator so that the config accepts exactly what the API accepts."""
    try:
        check()
    except ParameterError as err:
        raise ConfigError(f"[{table}] {key}: {err}") from None


def _check_api_values(t: dict) -> None:
    from ..design._least_squares import max_window
    from ..sim import Noise

    sc, cmp = t["scenario"], t["compare"]
    _api("scenario", "seed/noise_std", lambda: Noise(std=sc["noise_std"], seed=sc["seed"]))
    _numbers("compare", "noise_std", cmp["noise_std"]) if cmp["noise_std"] else None
    for std in cmp["noise_std"]:
        _api("compare", "seed/noise_std", lambda std=std: Noise(std=std, seed=cmp["seed"]))
    for w in cmp["windows"]:
        if isinstance(w, bool) or not isinstance(w, int) or not 1 <= w <= max_window():
            raise ConfigError(f"[compare] windows must hold integers in [1, {max_window()}] "
                              f"($FL_DESIGN_MAX_WINDOW), got {w!r} in {cmp['windows']!r}")
    limits = {"sweep": MAX_SWEEP_POINTS, "certify": MAX_CERTIFY_POINTS}
    for table, top in limits.items():
        n = t[table]["points"]
        if not 2 <= n <= top:
            raise ConfigError(f"[{table}] points must be >= 2 and <= {top}, got {n!r}"
                              + (" (a grid of points**2 runs)" if table == "sweep" else ""))


def _check_plant_values(p: dict) -> None:
    """A plant from expressions: names are identifiers, ranges and values are finite numbers."""
    import keyword

    def name(key, v):
        if not (isinstance(v, str) and v.isidentifier() and not keyword.iskeyword(v)):
            raise ConfigError(f"[plant] {key} must be a name (letters, digits, _; not starting "
                              f"with a digit), got {v!r}")
    for s in p.get("states", []):
        name("states", s)
    if "input" in p:
        name("input", p["input"])
    for k, v in p.get("params", {}).items():
        name("params", k)
        _numbers("plant", f"params.{k}", [v])
    for key in ("region", "operating_point"):
        for k, v in p.get(key, {}).items():
            name(key, k)
            _numbers("plant", f"{key}.{k}", v if key == "region" else [v],
                     2 if key == "region" else 1)
    if "input_range" in p:
        _numbers("plant", "input_range", p["input_range"], 2)


def _check_semantics(t: dict) -> None:
    p, d = t["plant"], t["design"]
    _check_plant_values(p)
    _check_api_values(t)
    custom = {"states", "rhs", "output", "input"} & set(p)
    if custom:
        missing = [k for k in ("states", "input", "rhs", "output") if k not in p]
        if missing:
            raise ConfigError(f"[plant] a plant from expressions needs {missing[0]!r} (states, "
                              "input, rhs and output as strings)")
        p.pop("library", None)
    elif p.get("library") not in LIBRARY:
        raise ConfigError(f"[plant] library must be one of {', '.join(LIBRARY)}, got "
                          f"{p.get('library')!r} (or give states, input, rhs and output)")
    if d["estimator"] not in ("ehgo", "least_squares"):
        raise ConfigError(f"[design] estimator must be 'ehgo' or 'least_squares', got "
                          f"{d['estimator']!r}")
    for key in ("eps", "T", "gamma"):
        if d[key] <= 0:
            raise ConfigError(f"[design] {key} must be > 0, got {d[key]!r}")
    _numbers("design", "gains", d["gains"], positive=True)
    for table, key, n in (("sweep", "eps", 2), ("sweep", "gamma", 2), ("certify", "gamma", 2)):
        _numbers(table, key, t[table][key], n, positive=True)
    _numbers("compare", "eps_tradeoff", t["compare"]["eps_tradeoff"], positive=True)
    for table, key in (("scenario", "duration"), ("compare", "duration"), ("sweep", "duration"),
                       ("codegen", "sil_duration")):
        if isinstance(t[table][key], str):
            if t[table][key] != "adaptive":
                raise ConfigError(f'[{table}] {key} must be a number of seconds or "adaptive" '
                                  f"(chosen from the loop's slowest time constant), got "
                                  f"{t[table][key]!r}")
            continue
        if t[table][key] <= 0:
            raise ConfigError(f"[{table}] {key} must be > 0 s, got {t[table][key]!r}")
    if t["codegen"]["precision"] not in ("double", "float"):
        raise ConfigError(f"[codegen] precision must be 'double' or 'float', got "
                          f"{t['codegen']['precision']!r}")


def _defaults() -> dict:
    return tomllib.loads(DEFAULT_TOML)


def parse_config(text: str, *, source: str = "<string>") -> Config:
    """Validate TOML text against the schema and fill in the defaults.

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
        Invalid TOML, an unknown table or key, a wrong type or value.

    Examples
    --------
    >>> from fl_design.app import parse_config
    >>> parse_config('[design]\\neps = 0.1').design["eps"]
    0.1
    >>> parse_config('[design]\\nepsilon = 0.1')
    Traceback (most recent call last):
    ...
    fl_design.app._config.ConfigError: <string>: unknown key 'epsilon' in [design]; ...
    """
    text = text.removeprefix("\ufeff")  # a UTF-8 byte-order mark
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise ConfigError(f"{source}: not valid TOML: {err}") from None
    _check_tables(data, source)
    tables = _defaults()
    if "plant" in data and "library" not in data["plant"]:
        tables["plant"] = {"output_unit": "output units", "input_unit": "input units"}
    for name, body in data.items():
        tables[name].update(body)
    try:
        _check_semantics(tables)
    except ConfigError as err:
        raise ConfigError(f"{source}: {err}") from None
    return Config(**tables, source=source)


def load_config(path: str | Path | None) -> Config:
    """Read and validate a TOML configuration; None gives the embedded default.

    Parameters
    ----------
    path : str or pathlib.Path or None
        The file (None: :data:`DEFAULT_TOML`, the paper's TRMS experiment).

    Returns
    -------
    Config

    Raises
    ------
    ConfigError
        The file is missing or unreadable, or its content is invalid.

    Examples
    --------
    >>> from fl_design.app import load_config
    >>> load_config(None).design["gamma"]
    0.0003
    """
    if path is None:
        return parse_config(DEFAULT_TOML, source="<default>")
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")  # a byte-order mark is allowed
    except (OSError, UnicodeDecodeError) as err:
        reason = getattr(err, "strerror", None) or type(err).__name__
        raise ConfigError(f"cannot read config {str(path)!r}: {reason}") from None
    return parse_config(text, source=str(path))


__all__ = ["DEFAULT_TOML", "Config", "ConfigError", "load_config", "parse_config"]
