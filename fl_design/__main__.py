"""``python -m fl_design``: the command-line interface (see :mod:`fl_design.cli`)."""

from .cli import main

raise SystemExit(main())
