"""Shared set-up of the tuner's tests: the TRMS bench config's tuner, built once."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="session")
def trms_setup():
    """The tuner setup of the default config (the paper's TRMS design)."""
    from fl_design.app import load_config
    from fl_design.app._cli import ui_setup

    return ui_setup(load_config(None))


@pytest.fixture(scope="session")
def trms_tuner(trms_setup):
    """A :class:`fl_design.ui.Tuner` of the TRMS bench design."""
    from fl_design.ui import Tuner

    return Tuner(trms_setup)
