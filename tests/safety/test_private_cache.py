"""The cache is private: created 0700, refused when foreign or writable by others, never a
planted pickle loaded, temp files by mkstemp, symlinks and foreign files ignored."""

from __future__ import annotations

import os
import pickle
import stat
import warnings
from pathlib import Path

import pytest

import fl_design as fl
from fl_design import _cache
from fl_design._cache import (
    KEY_NAME,
    cache_directory,
    check_private,
    read_verified,
    user_key,
    verified,
    write_verified,
)
from fl_design.errors import CacheWarning, UnsafeCacheError, UnsafeCacheWarning
from fl_design.symbolic import _derivation_cache as _stored
from fl_design.symbolic import _plant_derived as _plant  # where the derivations are called

pytestmark = pytest.mark.usefixtures("own_user_key")


@pytest.fixture
def fresh(monkeypatch):
    monkeypatch.setattr(_stored, "_WARNED", set())
    monkeypatch.setattr(_cache, "_WARNED", set())


def _mode(path: Path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


def test_default_folder_is_created_0700(tmp_path, monkeypatch):
    monkeypatch.delenv("FL_DESIGN_CACHE", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    path = cache_directory()
    assert path == tmp_path / "xdg" / "fl_design" and _mode(path) == 0o700


def test_our_default_folder_made_0755_by_an_older_version_is_tightened(tmp_path, monkeypatch):
    monkeypatch.delenv("FL_DESIGN_CACHE", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    (tmp_path / "fl_design").mkdir(mode=0o755)
    os.chmod(tmp_path / "fl_design", 0o755)
    assert _mode(cache_directory()) == 0o700


def test_relative_xdg_cache_home_is_ignored_with_one_warning(tmp_path, monkeypatch, fresh):
    monkeypatch.delenv("FL_DESIGN_CACHE", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/cache")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    monkeypatch.chdir(tmp_path)
    with pytest.warns(UnsafeCacheWarning, match="relative path.*XDG specification"):
        path = cache_directory()
    assert path == tmp_path / "home" / ".cache" / "fl_design"
    assert not (tmp_path / "relative").exists()


@pytest.mark.parametrize("mode", [0o777, 0o775, 0o707, 0o1777])
def test_group_or_world_writable_folder_is_refused(tmp_path, mode):
    folder = tmp_path / "shared"
    folder.mkdir()
    os.chmod(folder, mode)
    with pytest.raises(UnsafeCacheError, match=f"writable by group or others \\(mode {mode:04o}"):
        cache_directory(folder)
    assert not (folder / KEY_NAME).exists()


def test_folder_owned_by_someone_else_is_refused(tmp_path, monkeypatch):
    folder = tmp_path / "theirs"
    folder.mkdir(mode=0o700)
    me = os.geteuid()
    monkeypatch.setattr(os, "geteuid", lambda: me + 4242)  # we are now someone else
    with pytest.raises(UnsafeCacheError, match=f"owned by uid {me}, not by you"):
        check_private(folder)


def _trms_chain(monkeypatch) -> list:
    calls = []
    original = _plant.lie_chain
    monkeypatch.setattr(_plant, "lie_chain", lambda p: calls.append(1) or original(p))
    plant = fl.plants.trms_yaw()
    assert plant.relative_degree() == 2
    return calls


def test_unsafe_cache_is_bypassed_with_one_warning(tmp_path, monkeypatch, fresh):
    folder = tmp_path / "open"
    folder.mkdir()
    os.chmod(folder, 0o777)
    monkeypatch.setenv("FL_DESIGN_CACHE", str(folder))
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        computed = list(_trms_chain(monkeypatch))
        fl.plants.pendulum().normal_form()
    assert computed == [1]  # computed, not read
    assert any("writable by group or others" in str(w.message) for w in record)
    assert len([w for w in record if issubclass(w.category, UnsafeCacheWarning)]) == 1
    assert list(folder.iterdir()) == []  # nothing written into it


def _payload(marker: Path):
    class Boom:
        def __reduce__(self):
            return (open, (str(marker), "w"))
    return pickle.dumps(Boom())


def test_a_planted_pickle_is_never_loaded(tmp_path, monkeypatch, fresh):
    cache = tmp_path / "cache"
    monkeypatch.setenv("FL_DESIGN_CACHE", str(cache))
    assert _trms_chain(monkeypatch) == [1]
    marker = tmp_path / "pwned"
    entries = sorted(cache.glob("plant_*"))
    entries = [p for p in entries if not p.name.endswith(".json")]
    assert entries
    for entry in entries:  # a planted entry with a correct sidecar, but no valid signature
        write_verified(entry.name, b"\0" * 32 + _payload(marker), cache_dir=cache)
    with pytest.warns(CacheWarning, match="corrupted"):
        assert _trms_chain(monkeypatch) == [1]  # recomputed, not loaded
    assert not marker.exists()
    with warnings.catch_warnings():  # rewritten and signed: loaded again
        warnings.simplefilter("error")
        assert _trms_chain(monkeypatch) == []


def test_an_entry_signed_with_another_key_is_not_loaded(tmp_path, monkeypatch, fresh):
    cache = tmp_path / "cache"
    monkeypatch.setenv("FL_DESIGN_CACHE", str(cache))
    _trms_chain(monkeypatch)
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "other"))  # another user's key
    with pytest.warns(CacheWarning, match="corrupted"):
        assert _trms_chain(monkeypatch) == [1]


def test_an_exposed_key_is_refused(tmp_path):
    key = user_key(tmp_path / "c")
    where = tmp_path / "config" / "fl_design" / KEY_NAME
    assert len(key) == 32 and _mode(where) == 0o600 and not (tmp_path / "c").exists()
    os.chmod(where, 0o644)
    with pytest.raises(UnsafeCacheError, match="not a private 32-byte file"):
        user_key(tmp_path / "c")


def test_writes_go_through_mkstemp_and_replace_a_planted_symlink(tmp_path):
    cache = tmp_path / "c"
    cache.mkdir(mode=0o700)
    victim = tmp_path / "victim.txt"
    victim.write_text("user data")
    (cache / "entry.bin").symlink_to(victim)
    assert read_verified(cache / "entry.bin") is None
    out = write_verified("entry.bin", b"ours", cache_dir=cache)
    assert victim.read_text() == "user data"
    assert not out.is_symlink() and read_verified(out) == b"ours" and _mode(out) == 0o600
    assert sorted(p.name for p in cache.iterdir()) == ["entry.bin", "entry.bin.json"]


def test_a_file_of_another_user_is_never_verified(tmp_path, monkeypatch):
    out = write_verified("entry.bin", b"ours", cache_dir=tmp_path / "c")
    assert verified(out)
    me = os.geteuid()
    monkeypatch.setattr(os, "geteuid", lambda: me + 1)
    assert not verified(out) and read_verified(out) is None
