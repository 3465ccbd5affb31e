"""Shared set-up of the tuner's tests: the TRMS bench config's tuner, built once, and served."""

from __future__ import annotations

import threading

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


@pytest.fixture(scope="module")
def served_tuner(trms_tuner, tmp_path_factory):
    """``(app, httpd)``: a :class:`fl_design.ui.TunerApp` of :func:`trms_tuner` served on a free
    loopback port by a thread of this process; shut down and joined after the module."""
    from fl_design.ui import TunerApp, make_server

    app = TunerApp(trms_tuner, tmp_path_factory.mktemp("ui") / "out", background=False)
    httpd = make_server(app, 0)
    thread = threading.Thread(target=httpd.serve_forever, kwargs={"poll_interval": 0.1},
                              daemon=True)
    thread.start()
    try:
        yield app, httpd
    finally:
        httpd.shutdown()
        httpd.server_close()
        app.close()
        thread.join(timeout=10)
