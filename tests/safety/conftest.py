"""Shared set-up of the safety tests."""

from __future__ import annotations

import pytest


@pytest.fixture
def own_user_key(tmp_path, monkeypatch):
    """This test's own user key: ``$XDG_CONFIG_HOME`` in its temporary folder (the key that
    signs cache entries and output markers is created there, never read from the user's)."""
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "config"))
    return tmp_path / "config"
