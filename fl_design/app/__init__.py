"""Application layer: the command line (``fl-design``), the derivation report and the main job.

Library layers never import this package.

Examples
--------
>>> from fl_design.app import build_parser
>>> build_parser().prog
'fl-design'
"""

from ._cli import build_parser, main
from ._demo import run_demo
from ._report import derivation_report

__all__ = ["build_parser", "derivation_report", "main", "run_demo"]
