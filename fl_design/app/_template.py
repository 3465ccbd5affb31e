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

from ._library_tables import (  # noqa: F401 - re-exported for existing callers
    UNITS,
    default_ranges,
    fill_ranges,
    full_tables,
    library_tables,
    plain_toml,
    round_sig,
    toml_value,
)

_PLANT_DOC = {
    "trms": "the paper's TRMS yaw (rho = 2, b in [3.6, 6.8], input [-2.5, 2.5] V)",
    "trms-lag": "the TRMS yaw with its motor lag (rho = 3, input [-2.5, 2.5] V)",
    "pendulum": "a damped pendulum (rho = 2, b = 1, torque [-20, 20] N m)",
    "flexible-joint": "a flexible-joint robot (rho = 4, b = 418.5, input [-10, 10])",
    "cart-pendulum": "a gantry crane, output the cart (rho = 2, force [-10, 10] N)",
    "maglev": "a magnetic levitation at a 6 mm gap (rho = 3, b < 0: gamma < 0, coil [0, 24] V)",
}


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
                line = f"{f.name} = {toml_value(value)}  # {doc}"
            lines.append(line.rstrip(" #"))
    return "\n".join(lines) + "\n"


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

    cfg = parse_config(plain_toml({"plant": _EXAMPLE_PLANT}), source="init")
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
    return render(parse_config(plain_toml(full_tables(plant)), source="init"), head)


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
        new = (round_sig(min(lo, value / 2.0) if value > 0 else min(lo, 2.0 * value)),
               round_sig(max(hi, 2.0 * value) if value > 0 else max(hi, value / 2.0)))
        notes.append(f"[{table}] {key} widened from [{lo:g}, {hi:g}] to [{new[0]:g}, "
                     f"{new[1]:g}]: the design's {key.split('_')[0]} = {value:g} lay outside it")
        tables[table] = replace(obj, **{key: new})
    return (replace(cfg, **tables) if tables else cfg), tuple(notes)


__all__ = ["DERIVED", "config_toml", "default_ranges", "fill_ranges", "fit_ranges", "full_tables",
           "library_tables", "render"]


#: The embedded default: the paper's TRMS experiment, as ``fl-design init`` writes it.
DEFAULT_TOML = config_toml("trms")
