"""The tuner's buttons: save the design as TOML, write the C package, a Python snippet.

Everything goes into the one output folder chosen on the command line (``fl-design ui --out
DIR``); the page names no path. The folder is claimed with the project's no-overwrite rule
(:func:`fl_design._output.claim_output_folder`: empty, new, or holding only fl_design's own
unchanged output) at each write, and every file gets a new numbered name (``design_1.toml``,
``design_2.toml``, ``c_1/``, ``snippet_1.py``), so nothing is ever replaced.

Examples
--------
>>> from fl_design.app._cli import ui_setup
>>> from fl_design.ui._model import Tuner
>>> from fl_design.ui._export import save_toml
>>> tuner = Tuner(ui_setup())
>>> save_toml(tuner, tuner.defaults() | {"gamma": 1e-3}, "tuned").name
'design_1.toml'
"""

from __future__ import annotations

from pathlib import Path

from .._output import claim_output_folder, record_outputs


def _fresh(folder: Path, stem: str, suffix: str) -> Path:
    i = 1
    while (folder / f"{stem}_{i}{suffix}").exists() or (folder / f"{stem}_{i}{suffix}"
                                                        ).is_symlink():
        i += 1
    return folder / f"{stem}_{i}{suffix}"


def _write_new(out, stem: str, suffix: str, text: str) -> Path:
    """Claim ``out`` (the no-overwrite rule), write ``text`` to a new ``stem_N.suffix``, record it."""
    folder = claim_output_folder(out, what="ui output folder")
    path = _fresh(folder, stem, suffix)
    with open(path, "x", encoding="utf-8") as fh:  # "x": never replaces a file
        fh.write(text)
    record_outputs(folder, [path])
    return path


def toml_text(tuner, values: dict) -> str:
    """The whole config, with the controls' numbers, as commented TOML.

    Parameters
    ----------
    tuner : fl_design.ui._model.Tuner
        The tuner.
    values : dict
        The page's controls, checked (:meth:`~fl_design.ui.Tuner.check`).

    Returns
    -------
    str
        Text that :func:`fl_design.app.parse_config` reads back to the same design.
    """
    return tuner.setup.render(tuner.config_for(values),
                  f"fl_design configuration saved by `fl-design ui` from {tuner.config.source}")


def save_toml(tuner, values: dict, out) -> Path:
    """Write ``design_N.toml`` (a new name) into the output folder ``out``.

    Parameters
    ----------
    tuner, values
        As for :func:`toml_text` (the controls are checked here).
    out : path-like
        The output folder (claimed under the no-overwrite rule).

    Returns
    -------
    pathlib.Path
        The file written.

    Raises
    ------
    OutputExistsError
        ``out`` holds files fl_design did not write.
    """
    return _write_new(out, "design", ".toml", toml_text(tuner, tuner.check(values)))


def write_c(tuner, values: dict, out):
    """Generate the design's C package into ``c_N/`` (a new folder) of ``out``.

    Parameters
    ----------
    tuner, values, out
        As for :func:`save_toml`.

    Returns
    -------
    fl_design.CPackage
        The package, in a new folder ``c_N`` of ``out``.
    """
    from ..codegen import generate_c

    v = tuner.check(values)
    folder = claim_output_folder(out, what="ui output folder")
    cg = tuner.config.codegen
    target = _fresh(folder, "c", "")
    return generate_c(tuner.design_for(v), target, precision=cg.precision, prefix=cg.prefix)


def _constructor(obj) -> str:
    """``fl.Name(field=value, ...)`` of a frozen dataclass, every number to its last digit
    (the objects' own reprs round for reading)."""
    import dataclasses

    args = ", ".join(f"{f.name}={getattr(obj, f.name)!r}" for f in dataclasses.fields(obj)
                     if f.init)
    return f"fl.{type(obj).__name__}({args})"


def snippet_text(tuner, values: dict) -> str:
    """Python that reproduces the page's response (plant, design, scenario, simulate, plot).

    A library plant without disturbances is written with the API's constructors; any other
    config is embedded as TOML and read back with :func:`fl_design.app.parse_config` (its
    plant's expressions are parsed by the project's grammar, never evaluated).

    Parameters
    ----------
    tuner, values
        As for :func:`toml_text`.

    Returns
    -------
    str
        The script's text (it runs on its own with fl_design installed).

    Examples
    --------
    >>> from fl_design.app._cli import ui_setup
    >>> from fl_design.ui import Tuner
    >>> t = Tuner(ui_setup())
    >>> from fl_design.ui._export import snippet_text
    >>> print(snippet_text(t, t.defaults()).splitlines()[2])
    plant = fl.plants.trms_yaw()
    """
    v = tuner.check(values)
    p = tuner.config.plant
    if p.expression or tuner.config.scenario.disturbance is not None:
        text = toml_text(tuner, v).replace('"""', '\\"\\"\\"')
        return ("# the view of `fl-design ui`, reproduced\nimport fl_design as fl\n"
                f'cfg = fl.app.parse_config("""{text}""")\n'
                "plant = fl.app.build_plant(cfg)\n"
                "design = fl.app.build_design(cfg, rho=plant.relative_degree())\n"
                "scenario = fl.app.build_scenario(cfg)\n"
                "resp = fl.simulate(plant, design, scenario, classifier=cfg.classifier)\n"
                "print(resp.verdict())\nresp.plot()\n")
    factory, kwargs = tuner.setup.library[p.library]
    kw = ({"motor_lag": True} if p.motor_lag else {}) | kwargs
    args = ", ".join(f"{k}={val!r}" for k, val in kw.items())
    d = tuner.design_for(v)
    s = tuner.scenario_for(v)
    c = tuner.classifier
    return ("# the view of `fl-design ui`, reproduced\nimport fl_design as fl\n"
            f"plant = fl.plants.{factory}({args})\n"
            f"design = fl.Design(estimator={_constructor(d.estimator)},\n"
            f"                   controller={_constructor(d.controller)})\n"
            f"scenario = fl.Scenario({s.reference!r}, {s.duration!r}, "
            f"noise=fl.Noise(std={s.noise.std!r}, seed={s.noise.seed!r}))\n"
            f"resp = fl.simulate(plant, design, scenario, classifier={_constructor(c)})\n"
            "print(resp.verdict())\nresp.plot()\n")


def save_snippet(tuner, values: dict, out) -> tuple:
    """Write ``snippet_N.py`` into ``out``; return its path and text (the page copies it).

    Parameters
    ----------
    tuner, values
        As for :func:`snippet_text`.
    out : path-like
        As for :func:`save_toml`.

    Returns
    -------
    (pathlib.Path, str)
        The file written and its text.
    """
    text = snippet_text(tuner, values)
    return _write_new(out, "snippet", ".py", text), text


__all__ = ["save_snippet", "save_toml", "snippet_text", "toml_text", "write_c"]
