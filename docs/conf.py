"""Sphinx configuration of fl_design's documentation site.

Why Sphinx (and not MkDocs): every docstring in fl_design is numpydoc, which Sphinx renders
natively (``numpydoc`` extension) and ``autodoc`` reads through the package's lazy names; the
guides are Markdown (MyST) so the same text reads on GitHub. ``make docs`` builds with warnings
as errors (``-W --keep-going``); CI runs it after the tests.
"""

from __future__ import annotations

import os
import sys

sys.path.insert(0, os.path.abspath(".."))
os.environ.setdefault("MPLBACKEND", "Agg")

import fl_design  # noqa: E402

project = "fl_design"
author = "the fl_design developers"
copyright = "2026, the fl_design developers"  # noqa: A001 - Sphinx's name
release = version = fl_design.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
    "myst_parser",
]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store", "**/.ipynb_checkpoints", "_generated/*_index.md"]
myst_enable_extensions = ["dollarmath", "colon_fence", "deflist"]
myst_heading_anchors = 3

autosummary_generate = True
autodoc_typehints = "none"          # numpydoc's Parameters section carries the types
autodoc_member_order = "bysource"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_validation_checks: set[str] = set()

# MathJax is loaded from the package bundled with the docs build, not a CDN, when available.
html_theme = "furo"
html_title = f"fl_design {release}"

html_last_updated_fmt = None
nitpicky = False
templates_path = ["_templates"]
suppress_warnings = ["myst.header"]
