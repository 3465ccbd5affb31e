"""Application layer: the command line (``fl-design``), the TOML config, the main job, the report.

Library layers never import this package. Modules: ``_config`` (TOML schema), ``_build``
(config -> plant, design, scenario), ``_job`` (the stages), ``_console`` (stdout tables),
``_report`` (derivation text), ``_report_figures``, ``_report_sections``, ``_report_write``
(HTML, Markdown, summary.json), ``_cli``.

Examples
--------
>>> from fl_design.app import build_parser
>>> build_parser().prog
'fl-design'
"""

from ._build import build_classifier, build_design, build_plant, build_scenario
from ._cli import build_parser, check_out_dir, main
from ._config import DEFAULT_TOML, Config, ConfigError, load_config, parse_config  # noqa: F401
from ._console import (
    print_certificates,
    print_codegen,
    print_derive,
    print_job,
    print_simulate,
    print_sweep,
)
from ._job import QUICK, STAGES, Job, noise_levels, note, prepare, run_job
from ._report import derivation_report
from ._report_figures import (
    design_label,
    eps_star_figure,
    main_response_figure,
    stability_map_figure,
    step_figure,
    tradeoff_figure,
)
from ._report_sections import bounded_up_to, fmt, linearized_text, overshoot_text, sections
from ._report_write import render_html, render_markdown, summary, write_report

__all__ = [
    "DEFAULT_TOML",
    "QUICK",
    "STAGES",
    "Config",
    "Job",
    "bounded_up_to",
    "build_classifier",
    "build_design",
    "build_parser",
    "build_plant",
    "build_scenario",
    "check_out_dir",
    "derivation_report",
    "design_label",
    "eps_star_figure",
    "fmt",
    "linearized_text",
    "load_config",
    "main",
    "main_response_figure",
    "noise_levels",
    "note",
    "overshoot_text",
    "parse_config",
    "prepare",
    "print_certificates",
    "print_codegen",
    "print_derive",
    "print_job",
    "print_simulate",
    "print_sweep",
    "render_html",
    "render_markdown",
    "run_job",
    "sections",
    "stability_map_figure",
    "step_figure",
    "summary",
    "tradeoff_figure",
    "write_report",
]
