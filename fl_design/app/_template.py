"""The configuration of each library plant, and ``fl-design init``: commented TOML text.

:func:`library_tables` turns a library plant's bench design
(:func:`fl_design.presets.bench_design`) and bench step into the config's values;
:func:`default_ranges` gives the ``[sweep]`` and ``[certify]`` ranges from the design's ``T``,
``eps`` and ``gamma``. :func:`config_toml` parses them into a :class:`~fl_design.app.Config`
and :func:`render` writes that config back: every field of every table object
(:data:`fl_design.app._config.TABLES`), each with its value (or commented out when unset) and
the first sentence of its documentation. The keys, defaults and comments ``init`` writes are
thus the option objects' own; ``fl-design run`` accepts the file as is.

Examples
--------
>>> import tomllib
>>> from fl_design.app._template import config_toml
>>> tomllib.loads(config_toml("maglev"))["design"]["gamma"]
-0.0016
"""

from __future__ import annotations

import math

#: Units of each library plant's output and input (axis labels of the report).
UNITS = {"trms": ("rad", "V"), "trms-lag": ("rad", "V"), "pendulum": ("rad", "N m"),
         "flexible-joint": ("rad", "N m"), "cart-pendulum": ("m", "N"), "maglev": ("m", "V")}
#: Length of the compared runs and of software in the loop per library plant (s): a few times
#: the bench step's settling time (measured: trms-lag 19.3 s, flexible-joint 2.7 s,
#: cart-pendulum 2.9 s, maglev 0.51 s, pendulum 17.5 s).
_RUN_LENGTH = {"trms": 30.0, "trms-lag": 40.0, "pendulum": 30.0, "flexible-joint": 6.0,
               "cart-pendulum": 6.0, "maglev": 2.0}

#: Library plants whose stable window is narrower than the default ranges: the maglev's loop
#: converges only for |gamma| in about [6e-4, 2.4e-3] and eps below about 3 ms (fl.sweep,
#: 3 s runs); the map is drawn around that window.
_RANGES = {"maglev": {"sweep": {"eps": [1.2e-3, 6e-3], "gamma": [-1e-2, -2e-4]},
                      "certify": {"gamma": [-3e-3, -6e-4]}}}

#: The paper's noise std sqrt(1e-3) relative to its 0.3 rad step.
_PAPER_NOISE = math.sqrt(1e-3) / 0.3

_PLANT_DOC = {
    "trms": "the paper's TRMS yaw (rho = 2, b in [3.6, 6.8], input [-2.5, 2.5] V)",
    "trms-lag": "the TRMS yaw with its motor lag (rho = 3, input [-2.5, 2.5] V)",
    "pendulum": "a damped pendulum (rho = 2, b = 1, torque [-20, 20] N m)",
    "flexible-joint": "a flexible-joint robot (rho = 4, b = 418.5, input [-10, 10])",
    "cart-pendulum": "a gantry crane, output the cart (rho = 2, force [-10, 10] N)",
    "maglev": "a magnetic levitation at a 6 mm gap (rho = 3, b < 0: gamma < 0, coil [0, 24] V)",
}


def default_ranges(eps: float, T: float, gamma: float) -> dict:
    """The ``[sweep]`` and ``[certify]`` ranges around a design point, from ``T``, eps, gamma.

    eps from ``max(2 T, eps/10)`` (the observer no faster than half the sampling rate) to
    ``20 eps``; gamma over ``[gamma/10, 100 gamma]`` for the map and ``[gamma/2, 10 gamma]``
    for the certificates, with the sign of gamma (the sign of ``b``). For the paper's TRMS
    (eps 0.05, T 1 ms, gamma 3e-4) these are the paper's ranges.

    Parameters
    ----------
    eps, T, gamma : float
        The design point (gamma nonzero, either sign).

    Returns
    -------
    dict
        ``sweep_eps``, ``sweep_gamma``, ``certify_gamma``, ``certify_eps`` (lists [lo, hi]).

    Examples
    --------
    >>> from fl_design.app._template import default_ranges
    >>> r = default_ranges(0.05, 1e-3, 3e-4)
    >>> r["sweep_eps"], [round(g, 9) for g in r["sweep_gamma"]]
    ([0.005, 1.0], [3e-05, 0.03])
    >>> default_ranges(2e-3, 1e-3, -1e-3)["certify_gamma"]
    [-0.01, -0.0005]
    """
    lo = max(2.0 * T, eps / 10.0)
    eps_r = [_round(lo), _round(max(20.0 * eps, 4.0 * lo))]

    def span(a, b):
        v = [_round(gamma * a), _round(gamma * b)]
        return sorted(v)
    return {"sweep_eps": eps_r, "certify_eps": list(eps_r), "sweep_gamma": span(0.1, 100.0),
            "certify_gamma": span(0.5, 10.0)}


def _round(x: float) -> float:
    return float(f"{x:.6g}")


def library_tables(name: str) -> dict:
    """A library plant's tables (without the ranges: see :func:`default_ranges`).

    Parameters
    ----------
    name : str
        A library plant (``fl-design --plant`` name).

    Returns
    -------
    dict
        ``plant``, ``design``, ``scenario``, ``compare``, ``sweep``, ``certify``, ``codegen``.

    Examples
    --------
    >>> from fl_design.app._template import library_tables
    >>> library_tables("flexible-joint")["design"]["gains"]
    [625.0, 500.0, 150.0, 20.0]
    """
    from ..presets import BENCH_REFERENCES, bench_design

    d = bench_design(name)
    est, ctrl = d.estimator, d.controller
    ref = BENCH_REFERENCES[name]
    step = abs(ref - (6e-3 if name == "maglev" else 0.0))
    length = _RUN_LENGTH[name]
    y_unit, u_unit = UNITS[name]
    limits = [] if ctrl.estimate_limits is None else \
        ["none" if v is None else float(v) for v in ctrl.estimate_limits]
    return {
        "plant": {"library": name, "output_unit": y_unit, "input_unit": u_unit},
        "design": {"estimator": "ehgo", "eps": float(est.eps), "T": float(est.T),
                   "coeffs": [float(c) for c in est.coeffs] if est.coeffs is not None else
                   [float(math.comb(d.rho + 1, k)) for k in range(1, d.rho + 2)],
                   "gains": [float(k) for k in ctrl.gains], "gamma": float(ctrl.gamma),
                   "ki": float(ctrl.ki),
                   "u_limits": [] if ctrl.u_limits is None else [float(v) for v in ctrl.u_limits],
                   "estimate_limits": limits},
        "scenario": {"reference": float(ref), "duration": "adaptive", "noise_std": 0.0,
                     "seed": 1},
        "compare": {"windows": [9, 26], "noise_std": [_round(step / 300), float(f"{step * _PAPER_NOISE:.10g}")],
                    "eps_tradeoff": [_round(est.eps * f) for f in (0.4, 1.0, 2.0, 4.0, 10.0)
                                     if est.eps * f >= est.T],
                    "seed": 1, "duration": length},
        "sweep": {"points": 16, "duration": "adaptive"} | _RANGES.get(name, {}).get("sweep", {}),
        "certify": {"enabled": True, "points": 8} | _RANGES.get(name, {}).get("certify", {}),
        "codegen": {"enabled": True, "precision": "double", "prefix": "fl",
                    "sil_duration": min(length, 10.0)},
    }


def _value(v) -> str:
    """A TOML value (strings, numbers, booleans, arrays, inline tables, disturbances)."""
    from collections.abc import Mapping

    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else "nan"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, Mapping):
        return "{ " + ", ".join(f"{k} = {_value(x)}" for k, x in v.items()) + " }"
    if hasattr(v, "sampled"):  # a fl.Disturbance of steps and sines
        spec = {where: {d["kind"]: {k: x for k, x in d.items() if k != "kind"}}
                for where, d in v.to_dict().items() if d is not None}
        return _value(spec)
    return str(v)


#: Commented-out examples of keys without a default value (shown as ``# key = example``).
_EXAMPLES = {"disturbance": "{ input = { step = { at = 10.0, size = 0.5 } } }",
             "divergence_bound": "1e6",
             "uncertainty.params": "{ c = [0.05, 1.0], b = { normal = [1.0, 0.1] } }"}


def _sentence(text: str) -> str:
    import re

    return re.split(r"(?<=\.)\s+(?=[A-Z])", " ".join(text.split()), maxsplit=1)[0]


def render(cfg, header: str) -> str:
    """TOML text of every field of every table of ``cfg``, with its documentation.

    Parameters
    ----------
    cfg : Config
        A validated configuration.
    header : str
        Comment lines put first (without the ``#``).

    Returns
    -------
    str

    Examples
    --------
    >>> from fl_design.app import load_config
    >>> from fl_design.app._template import render
    >>> print(render(load_config(None), "x").split("[design]")[1].splitlines()[2])
    eps = 0.05  # Observer time constant (s); keep it >= T.
    """
    import dataclasses

    from ._config import TABLES
    from ._tables import field_docs

    lines = [f"# {h}".rstrip() for h in header.splitlines()]
    for table, cls in TABLES.items():
        obj = getattr(cfg, table)
        if obj is None:
            continue
        docs = field_docs(cls)
        lines += ["", f"[{table}]"]
        for f in dataclasses.fields(cls):
            if not f.init:
                continue
            value, doc = getattr(obj, f.name), _sentence(docs.get(f.name, ""))
            if value is None:
                example = _EXAMPLES.get(f"{table}.{f.name}", _EXAMPLES.get(f.name, "..."))
                line = f"# {f.name} = {example}  # (not set) {doc}"
            else:
                line = f"{f.name} = {_value(value)}  # {doc}"
            lines.append(line.rstrip(" #"))
    return "\n".join(lines) + "\n"


def _toml(tables: dict) -> str:
    """Plain TOML of ``{table: {key: value}}`` (no comments; parsed by :func:`config_toml`)."""
    return "\n".join(f"[{t}]\n" + "".join(f"{k} = {_value(v)}\n" for k, v in body.items())
                     for t, body in tables.items())


def full_tables(name: str) -> dict:
    """A library plant's tables with the default ranges filled in (what ``init`` writes).

    Parameters
    ----------
    name : str
        A library plant.

    Returns
    -------
    dict

    Examples
    --------
    >>> from fl_design.app._template import full_tables
    >>> full_tables("trms")["certify"]["gamma"]
    [0.00015, 0.003]
    """
    t = library_tables(name)
    fill_ranges(t, {})
    return t


def fill_ranges(tables: dict, given: dict) -> None:
    """Fill the ``[sweep]`` and ``[certify]`` ranges the user did not give, from ``[design]``.

    Parameters
    ----------
    tables : dict
        The merged tables (``design`` holds eps, T, gamma).
    given : dict
        The user's tables (what they gave is kept).

    Examples
    --------
    >>> from fl_design.app._template import fill_ranges
    >>> given = {"sweep": {"eps": [0.01, 0.1]}}
    >>> t = {"design": {"eps": 0.05, "T": 1e-3, "gamma": 3e-4}, "sweep": {"eps": [0.01, 0.1]},
    ...      "certify": {}}
    >>> fill_ranges(t, given)
    >>> t["sweep"], t["certify"]
    ({'eps': [0.01, 0.1], 'gamma': [3e-05, 0.03]}, {'gamma': [0.00015, 0.003], 'eps_range': [0.01, 0.1]})
    """
    d = tables["design"]
    if not all(isinstance(d.get(k), (int, float)) and not isinstance(d.get(k), bool) and d[k]
               for k in ("eps", "T", "gamma")):
        return
    r = default_ranges(float(d["eps"]), float(d["T"]), float(d["gamma"]))
    # a value already in ``tables`` (the user's, or a library plant's window) is kept
    tables["sweep"].setdefault("eps", r["sweep_eps"])
    tables["sweep"].setdefault("gamma", r["sweep_gamma"])
    tables["certify"].setdefault("gamma", r["certify_gamma"])
    if "eps_range" not in given.get("certify", {}):
        tables["certify"]["eps_range"] = list(tables["sweep"]["eps"])


#: The ``init --from-ode`` example: a mass on a hardening spring with viscous friction,
#: written only to be replaced (no other table holds a number derived from it).
_EXAMPLE_PLANT = {"name": "my_plant", "states": ["x", "v"], "input": "u",
                  "rhs": ["v", "(-k*x - k3*x**3 - c*v + u)/m"], "output": "x",
                  "params": {"m": 1.0, "k": 4.0, "k3": 1.0, "c": 0.4},
                  "region": {"x": [-2.0, 2.0], "v": [-5.0, 5.0]}, "input_range": [-10.0, 10.0],
                  "operating_point": {"x": 0.0}, "output_unit": "m", "input_unit": "N"}

#: Keys ``init --from-ode`` leaves to the run: derived from the plant and the (proposed)
#: design, never another plant's numbers.
DERIVED = {"scenario": ("reference",), "sweep": ("eps", "gamma"),
           "certify": ("eps_range", "gamma"),
           "compare": ("noise_std", "eps_tradeoff", "duration"),
           "codegen": ("sil_duration",)}

_DERIVED_WHY = {
    "reference": "the operating output plus 5 % of the output's range in the region",
    "eps": "around the design's eps, from T to the loop's time scale",
    "gamma": "around the design's gamma, from its certified interval",
    "eps_range": "as [sweep] eps",
    "noise_std": "1/300 and 0.105 of the step (the paper's noise relative to its step)",
    "eps_tradeoff": "0.5, 1, 2, 4 times the design's eps",
    "duration": "not set here: the tool's default for every plant",
    "sil_duration": "not set here: the tool's default for every plant",
}


def _from_ode_text() -> str:
    """The ``init --from-ode`` text: ``[plant]`` given, every derived key commented out."""
    from ._config import parse_config

    cfg = parse_config(_toml({"plant": _EXAMPLE_PLANT}), source="init")
    head = ("fl-design configuration for your own plant, written as expressions.\n"
            "Edit [plant] only (the example is a mass on a hardening spring): every other number "
            "is\nderived from YOUR plant when you run it: the step (5 % of the output's range "
            "in the\nregion), a design proposed by fl.tune (time scale, T, gains, gamma, a "
            "certified eps; each\nchoice said with its reason), the map and certificate "
            "ranges around that design, the\ncompared noise from the step. Uncomment a key "
            "to set it yourself. To give your own design\nadd a [design] table: gains (rho "
            "numbers), gamma (with the sign of b), eps and T (s),\nu_limits.\n"
            "Run: fl-design run THIS.toml --out out")
    lines = render(cfg, head).splitlines()
    at = lines.index("[scenario]") - 1  # [design] comes after [plant]: every key left to tune
    lines[at:at] = ["", "[design]", *_design_lines()]
    table, out = None, []
    for line in lines:
        if line.startswith("[") and line.endswith("]"):
            table = line[1:-1]
        key = line.lstrip("# ").split(" = ", 1)[0] if " = " in line else None
        if key in DERIVED.get(table, ()):
            doc = line.split("  # ", 1)[1] if "  # " in line else ""
            doc = doc.replace("(not set) ", "")
            line = f"# {key} = ...  # (derived: {_DERIVED_WHY[key]}) {doc}".rstrip()
        out.append(line)
    return "\n".join(out) + "\n"


def _design_lines() -> list[str]:
    """``[design]``'s keys, each commented out: proposed by :func:`fl_design.tune`."""
    import dataclasses

    from ._config import TABLES
    from ._tables import field_docs

    cls = TABLES["design"]
    docs = field_docs(cls)
    return [f"# {f.name} = ...  # (not set: proposed by fl.tune from your plant) "
            f"{_sentence(docs.get(f.name, ''))}".rstrip()
            for f in dataclasses.fields(cls) if f.init]


def config_toml(plant: str | None = "trms", *, from_ode: bool = False) -> str:
    """The commented configuration ``fl-design init`` writes (``fl-design run`` accepts it).

    Parameters
    ----------
    plant : str, optional
        A library plant (default the paper's TRMS).
    from_ode : bool, optional
        A plant written as expressions instead (an example with every ``[plant]`` key:
        states, input, rhs, output, params, region, input_range, operating_point) and no
        other plant-specific number: the reference, the design (:func:`fl_design.tune`), the
        ranges and the compared noise are derived from the plant at run time
        (:data:`DERIVED`); edit ``[plant]`` only.

    Returns
    -------
    str

    Examples
    --------
    >>> from fl_design.app import parse_config
    >>> from fl_design.app._template import config_toml
    >>> cfg = parse_config(config_toml(from_ode=True))
    >>> cfg.plant.states, cfg.design, cfg.scenario.reference
    (('x', 'v'), None, None)
    """
    from ._config import parse_config

    if from_ode:
        return _from_ode_text()
    head = (f"fl-design configuration: {_PLANT_DOC[plant]},\nwith its bench design "
            f"(fl_design.presets.bench_design({plant!r})). Every table and key is\nshown "
            "with its value. The operating point is the plant's own ("
            + ("gap y = 6 mm, current and voltage solved" if plant == "maglev" else "the origin")
            + ").\nRun: fl-design run THIS.toml --out out")
    return render(parse_config(_toml(full_tables(plant)), source="init"), head)


def fit_ranges(cfg) -> tuple:
    """``(cfg, notes)``: every ``[sweep]`` and ``[certify]`` range holds the design's point.

    A range given (or derived) that misses the design's eps or gamma is widened to hold it,
    a factor 2 beyond it, and one note says which range, from what to what; a gamma range of
    the other sign than the design's gamma cannot be widened: :class:`ConfigError`, one line.

    Parameters
    ----------
    cfg : Config
        A validated configuration with a design.

    Returns
    -------
    (Config, tuple of str)

    Raises
    ------
    ConfigError
        A gamma range of the other sign than the design's gamma.

    Examples
    --------
    >>> from dataclasses import replace
    >>> from fl_design.app import load_config
    >>> cfg = load_config(None)
    >>> new, notes = fit_ranges(replace(cfg, sweep=replace(cfg.sweep, eps=(1e-3, 0.01))))
    >>> new.sweep.eps, notes[0].split(":")[0]
    ((0.001, 0.1), '[sweep] eps widened from [0.001, 0.01] to [0.001, 0.1]')
    """
    from dataclasses import replace

    from ._config import ConfigError

    d = cfg.design
    if d is None or getattr(d, "eps", None) is None or not getattr(d, "gamma", None):
        return cfg, ()
    notes, tables = [], {}
    for table, key, value in (("sweep", "eps", d.eps), ("sweep", "gamma", d.gamma),
                              ("certify", "eps_range", d.eps), ("certify", "gamma", d.gamma)):
        obj = tables.get(table, getattr(cfg, table))
        rng = getattr(obj, key)
        if rng is None:
            continue
        lo, hi = float(rng[0]), float(rng[1])
        if lo <= value <= hi:
            continue
        if key == "gamma" and lo * value <= 0 and hi * value <= 0:
            raise ConfigError(f"{cfg.source}: [{table}] {key} = [{lo:g}, {hi:g}] has the other "
                              f"sign than the design's gamma = {value:g}: give a range of its "
                              "sign (gamma takes the sign of b)")
        new = (_round(min(lo, value / 2.0) if value > 0 else min(lo, 2.0 * value)),
               _round(max(hi, 2.0 * value) if value > 0 else max(hi, value / 2.0)))
        notes.append(f"[{table}] {key} widened from [{lo:g}, {hi:g}] to [{new[0]:g}, "
                     f"{new[1]:g}]: the design's {key.split('_')[0]} = {value:g} lay outside it")
        tables[table] = replace(obj, **{key: new})
    return (replace(cfg, **tables) if tables else cfg), tuple(notes)


__all__ = ["DERIVED", "config_toml", "default_ranges", "fill_ranges", "fit_ranges", "full_tables",
           "library_tables", "render"]
