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
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import ParameterError
from ._template import config_toml


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
    "certify": {"enabled": (bool,), "eps_range": (list,), "gamma": (list,), "points": (int,)},
    "codegen": {"enabled": (bool,), "precision": (str,), "prefix": (str,),
                "sil_duration": _NUM},
    "uncertainty": {"params": (dict,), "samples": (int,), "seed": (int,),
                    "duration": _DURATION},
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
    uncertainty : dict, optional
        The ``[uncertainty]`` table (:mod:`fl_design.app._uncertainty`; no ``params``: no
        robustness stage).
    source : str
        Where it came from (a path or ``"<default>"``).
    notes : tuple of str
        Warnings about values that run but are likely mistakes (eps below T, ...), with the
        numbers; the command line prints them on stderr.

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
    notes: tuple = ()
    uncertainty: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """The tables as a dict (strict JSON).

        Examples
        --------
        >>> from fl_design.app import load_config
        >>> sorted(load_config(None).to_dict())[:3]
        ['certify', 'codegen', 'compare']
        """
        return {name: dict(getattr(self, name)) for name in _SCHEMA} | {
            "source": self.source, "notes": list(self.notes)}


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


def _check_design(d: dict, custom: bool) -> None:
    """``[design]`` through the API's own objects: the config accepts what the API accepts."""
    from ..design import EHGO, DynamicController

    if not d:  # a plant from expressions without [design]: refused by check_fit when used
        return
    if d.get("estimator") not in ("ehgo", "least_squares"):
        raise ConfigError(f"[design] estimator must be 'ehgo' or 'least_squares', got "
                          f"{d.get('estimator')!r}")
    need = ("gains", "gamma", "T") + (("eps",) if d["estimator"] == "ehgo" else ())
    missing = [k for k in need if k not in d]
    if missing:
        raise ConfigError(f"[design] needs {', '.join(missing)} for this plant (a plant from "
                          "expressions has no bench design): give gains (rho numbers), gamma "
                          "(the sign of b), eps and T (s); `fl-design init --from-ode` shows them")
    gains = _numbers("design", "gains", d["gains"])
    u_lim = _numbers("design", "u_limits", d["u_limits"], 2) if d.get("u_limits") else None
    limits = estimate_limits(d.get("estimate_limits"))
    if limits is not None and len(limits) != len(gains):
        limits = None  # the relative degree is checked against the plant's (prepare)
    _api("design", "gains/gamma/ki/u_limits/estimate_limits", lambda: DynamicController(
        gains, d["gamma"], ki=d.get("ki", 0.0), u_limits=u_lim, estimate_limits=limits))
    coeffs = _numbers("design", "coeffs", d["coeffs"]) if d.get("coeffs") else None
    if coeffs is not None and len(coeffs) != len(gains) + 1:
        coeffs = None  # the relative degree is checked against the plant's (prepare)
    if d["estimator"] == "ehgo":
        _api("design", "eps/T/coeffs",
             lambda: EHGO(rho=len(gains), eps=d["eps"], T=d["T"], coeffs=coeffs))
    elif d["T"] <= 0:
        raise ConfigError(f"[design] T must be > 0, got {d['T']!r}")


def estimate_limits(value) -> tuple | None:
    """``[design] estimate_limits``: numbers, or ``"none"`` for an estimate without a limit.

    Examples
    --------
    >>> from fl_design.app._config import estimate_limits
    >>> estimate_limits([2.5, "none"])
    (2.5, None)
    """
    if not value:
        return None
    out = []
    for v in value:
        if isinstance(v, str) and v.lower() == "none":
            out.append(None)
        elif isinstance(v, (int, float)) and not isinstance(v, bool):
            out.append(float(v))
        else:
            raise ConfigError(f'[design] estimate_limits entries are numbers or "none", '
                              f"got {v!r}")
    return tuple(out)


def _check_range(table: str, key: str, value, gamma_sign: float | None = None) -> None:
    """A [lo, hi] range: two finite numbers, lo < hi, of one sign (eps > 0; gamma as b)."""
    lo, hi = _numbers(table, key, value, 2)
    if not lo < hi:
        raise ConfigError(f"[{table}] {key} must be [lo, hi] with lo < hi, got {value!r}")
    if gamma_sign is None and lo <= 0:
        raise ConfigError(f"[{table}] {key} must hold positive numbers (s), got {value!r}")
    if gamma_sign is not None and (lo * hi <= 0 or (gamma_sign and lo * gamma_sign < 0)):
        sign = "negative" if gamma_sign < 0 else "positive"
        raise ConfigError(f"[{table}] {key} must not contain 0 and has the sign of [design] "
                          f"gamma ({sign}), got {value!r}")


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
    _check_design(d, bool(custom))
    sign = math.copysign(1.0, d["gamma"]) if d else 0.0
    for table, key, g in (("sweep", "eps", None), ("sweep", "gamma", sign),
                          ("certify", "gamma", sign), ("certify", "eps_range", None)):
        if key in t[table]:
            _check_range(table, key, t[table][key], g)
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


def _warnings(t: dict) -> tuple:
    """Numbers that run but are likely mistakes (said on stderr and in the config's notes)."""
    d, out = t["design"], []
    if not d:
        return ()
    T = float(d["T"])
    if d.get("estimator") == "ehgo" and d["eps"] < T:
        out.append(f"[design] eps = {d['eps']:g} s is below the sampling time T = {T:g} s "
                   f"(alpha = T/eps = {T / d['eps']:.3g} > 1): the observer is faster than "
                   "its sampling; eps >= T is the usual choice")
    for table, key in (("sweep", "eps"), ("certify", "eps_range")):
        lo = t[table].get(key, [math.inf])[0]
        if lo < T:
            out.append(f"[{table}] {key} starts at {lo:g} s, below the sampling time "
                       f"T = {T:g} s (alpha = T/eps up to {T / lo:.3g})")
    return tuple(out)


def _custom_defaults(tables: dict, data: dict) -> None:
    """Defaults for a plant from expressions: no TRMS design, scales from the user's numbers."""
    p, d = data.get("plant", {}), data.get("design")
    tables["plant"] = {"output_unit": "output units", "input_unit": "input units"}
    tables["design"] = {} if not d else {
        "estimator": "ehgo", "ki": 0.0, "coeffs": [], "estimate_limits": [],
        "u_limits": list(p["input_range"]) if isinstance(p.get("input_range"), list) else []}
    sc = data.get("scenario", {})
    if "reference" not in sc:
        tables["scenario"].pop("reference")
        return
    op = p.get("operating_point", {}) if isinstance(p.get("operating_point"), dict) else {}
    y0 = op.get("y", op.get(p.get("output"), 0.0))
    step = abs(float(sc["reference"]) - float(y0)) if isinstance(y0, _NUM) and \
        isinstance(sc["reference"], _NUM) else 0.0
    if step > 0:
        tables["compare"]["noise_std"] = [float(f"{step / 300:.3g}"),
                                          float(f"{step * 0.105409:.3g}")]
    eps = (d or {}).get("eps")
    if isinstance(eps, _NUM) and not isinstance(eps, bool) and eps > 0:
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
    >>> parse_config('[design]\\neps = 0.1').design["eps"]
    0.1
    >>> parse_config('[plant]\\nlibrary = "maglev"').design["gamma"]
    -0.0016
    >>> parse_config('[design]\\nepsilon = 0.1')
    Traceback (most recent call last):
    ...
    fl_design.app._config.ConfigError: <string>: unknown key 'epsilon' in [design]; ...
    """
    from ._template import fill_ranges, library_tables
    from ._uncertainty import check_table as check_uncertainty

    text = text.removeprefix("\ufeff")  # a UTF-8 byte-order mark
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise ConfigError(f"{source}: not valid TOML: {err}{_toml_line(text, str(err))}") \
            from None
    _check_tables(data, source)
    plant = data.get("plant", {})
    custom = bool({"states", "rhs", "output", "input"} & set(plant))
    library = plant.get("library", "trms")
    if not custom and library not in LIBRARY:
        raise ConfigError(f"{source}: [plant] library must be one of {', '.join(LIBRARY)}, got "
                          f"{library!r} (or give states, input, rhs and output)")
    tables = library_tables("trms" if custom else library)
    gamma = data.get("design", {}).get("gamma")
    if isinstance(gamma, _NUM) and gamma * tables["design"]["gamma"] < 0:
        for table in ("sweep", "certify"):  # the bench ranges have the bench gamma's sign
            for key in ("eps", "gamma", "eps_range"):
                tables[table].pop(key, None)
    if custom:
        _custom_defaults(tables, data)
    tables.setdefault("uncertainty", {})
    for name, body in data.items():
        tables[name].update(body)
    try:
        fill_ranges(tables, data)
        _check_semantics(tables)
        check_uncertainty(tables["uncertainty"])
    except ConfigError as err:
        raise ConfigError(f"{source}: {err}") from None
    return Config(**tables, source=source, notes=_warnings(tables))


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


#: The embedded default: the paper's TRMS experiment, as ``fl-design init`` writes it.
DEFAULT_TOML = config_toml("trms")


__all__ = ["DEFAULT_TOML", "Config", "ConfigError", "load_config", "parse_config"]
