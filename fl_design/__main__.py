"""``python -m fl_design``: the command-line interface (see :mod:`fl_design.app`)."""

from .app._cli import main

raise SystemExit(main())
