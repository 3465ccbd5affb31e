"""Application layer: the command line (``fl-design``), the TOML config, the main job, the report.

Public API: the CLI (:func:`main`, :func:`build_parser`), the config (:func:`load_config`,
:func:`parse_config`, :class:`Config`), the main job (:func:`run_job` -> :class:`Job`), the
report (:func:`write_report`, :func:`summary`, :func:`render_html`, :func:`render_markdown`,
:func:`derivation_report`) and the builders from config tables. Helpers (console printers,
figures, report sections) are imported from their modules.

Library layers never import this package. Modules, each importing only those before it:
``_tables``, ``_plant_table``, ``_design_table``, ``_uncertainty`` (one frozen dataclass per
table), ``_config`` (the TOML file -> :class:`Config`), ``_build`` (config -> ``Setup``: plant,
design, scenario, classifier, compared designs, built once), ``_stages`` and ``_stage_family``
(each stage a function of the setup and earlier results), ``_job`` (the pipeline), then the
readers of a finished job: ``_text`` and ``_brief`` (numbers and short forms in words),
``_report_summary``, ``_report_sections``, ``_report_family``, ``_report_figures`` (which
figures; drawn by :mod:`fl_design.plotting`), ``_report_render`` (HTML, Markdown),
``_report_csv``, ``_report_write``, ``_console``; ``_commands`` (the sub-commands) and
``_cli`` (the parser) on top.

Examples
--------
>>> from fl_design.app import build_parser
>>> build_parser().prog
'fl-design'
"""

from ._build import build_classifier, build_design, build_plant, build_scenario
from ._cli import build_parser, main
from ._config import Config, ConfigError, load_config, parse_config  # noqa: F401
from ._job import QUICK, STAGES, Job, run_job
from ._report import derivation_report
from ._report_write import render_html, render_markdown, summary, write_report
from ._template import DEFAULT_TOML

__all__ = [
    "DEFAULT_TOML",
    "QUICK",
    "STAGES",
    "Config",
    "Job",
    "build_classifier",
    "build_design",
    "build_parser",
    "build_plant",
    "build_scenario",
    "derivation_report",
    "load_config",
    "main",
    "parse_config",
    "render_html",
    "render_markdown",
    "run_job",
    "summary",
    "write_report",
]
