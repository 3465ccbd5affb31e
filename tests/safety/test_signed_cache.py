"""The cache's signing key lives outside the cache folder: a copied folder, a folder carrying
its own key, a planted library with a matching size/SHA-256 sidecar, never run code."""

from __future__ import annotations

import hashlib
import hmac
import json
import os
import pickle
import shutil
import warnings
from pathlib import Path

import pytest

import fl_design as fl
from fl_design import _cache, _toolchain
from fl_design._cache import (
    KEY_NAME,
    SIDECAR_SUFFIX,
    key_path,
    read_verified,
    user_key,
    verified,
    write_verified,
)
from fl_design.errors import CacheWarning, UnsafeCacheError
from fl_design.symbolic import _derivation_cache as _stored
from fl_design.symbolic import _plant_derived as _plant


@pytest.fixture(autouse=True)
def _isolated(own_user_key, tmp_path, monkeypatch):
    monkeypatch.setenv("FL_DESIGN_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(_stored, "_WARNED", set())
    monkeypatch.setattr(_cache, "_WARNED", set())


def _chain_calls(monkeypatch) -> list:
    calls = []
    original = _plant.lie_chain
    monkeypatch.setattr(_plant, "lie_chain", lambda p: calls.append(1) or original(p))
    assert fl.plants.trms_yaw().relative_degree() == 2
    return calls


def test_the_key_is_in_the_config_folder_not_in_the_cache(tmp_path):
    write_verified("a.bin", b"x", cache_dir=tmp_path / "cache")
    assert key_path() == tmp_path / "config" / "fl_design" / KEY_NAME
    assert key_path().is_file() and oct(key_path().stat().st_mode & 0o777) == "0o600"
    assert oct(key_path().parent.stat().st_mode & 0o777) == "0o700"
    assert sorted(p.name for p in (tmp_path / "cache").iterdir()) == ["a.bin", "a.bin.json"]


def test_a_relative_xdg_config_home_is_not_used(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CONFIG_HOME", "rel")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert key_path() == tmp_path / "home" / ".config" / "fl_design" / KEY_NAME


def test_a_key_inside_the_cache_folder_is_refused(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "cache"))
    with pytest.raises(UnsafeCacheError, match="inside the cache folder"):
        user_key(tmp_path / "cache")


def _attacker_sign(folder: Path, name: str, payload: bytes, key: bytes) -> None:
    """Re-sign an entry as an attacker would with a key shipped in the folder."""
    data = hmac.new(key, name.encode() + b"\0" + payload, hashlib.sha256).digest() + payload
    (folder / name).write_bytes(data)
    record = {"size": len(data), "sha256": hashlib.sha256(data).hexdigest()}
    text = f"fl_design cache entry 2\0{name}\0{record['size']}\0{record['sha256']}"
    record["mac"] = hmac.new(key, text.encode(), hashlib.sha256).hexdigest()
    (folder / (name + SIDECAR_SUFFIX)).write_text(json.dumps(record))


def test_a_folder_carrying_its_own_key_runs_nothing(tmp_path, monkeypatch):
    cache = tmp_path / "cache"
    assert _chain_calls(monkeypatch) == [1]
    shipped = b"k" * 32
    (cache / ".fl_design_key").write_bytes(shipped)  # the old layout: a key in the folder
    os.chmod(cache / ".fl_design_key", 0o600)
    marker = tmp_path / "pwned"

    class Boom:
        def __reduce__(self):
            return (open, (str(marker), "w"))

    for entry in [p for p in cache.glob("plant_*") if not p.name.endswith(".json")]:
        _attacker_sign(cache, entry.name, pickle.dumps(Boom()), shipped)
    with pytest.warns(CacheWarning, match="corrupted"):
        assert _chain_calls(monkeypatch) == [1]  # recomputed
    assert not marker.exists()


def test_a_cache_copied_from_another_user_is_recomputed(tmp_path, monkeypatch):
    assert _chain_calls(monkeypatch) == [1]
    assert _chain_calls(monkeypatch) == []  # our own: read
    theirs = tmp_path / "copied"
    shutil.copytree(tmp_path / "cache", theirs)
    os.chmod(theirs, 0o700)
    monkeypatch.setenv("FL_DESIGN_CACHE", str(theirs))
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "someone_else"))
    with pytest.warns(CacheWarning):
        assert _chain_calls(monkeypatch) == [1]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert _chain_calls(monkeypatch) == []  # rewritten under this user's key


def test_an_unsigned_or_foreign_sidecar_is_not_verified(tmp_path):
    out = write_verified("e.bin", b"data", cache_dir=tmp_path / "cache")
    assert verified(out) and read_verified(out) == b"data"
    record = json.loads(Path(str(out) + SIDECAR_SUFFIX).read_text())
    del record["mac"]  # the old, unsigned sidecar format: size and SHA-256 match
    Path(str(out) + SIDECAR_SUFFIX).write_text(json.dumps(record))
    assert not verified(out) and read_verified(out) is None


def test_a_signed_entry_moved_to_another_name_is_not_verified(tmp_path):
    cache = tmp_path / "cache"
    out = write_verified("a.bin", b"data", cache_dir=cache)
    os.replace(out, cache / "b.bin")
    os.replace(str(out) + SIDECAR_SUFFIX, str(cache / "b.bin") + SIDECAR_SUFFIX)
    assert not verified(cache / "b.bin")


CONSTRUCTOR = r"""
#include <stdio.h>
__attribute__((constructor)) static void boom(void) {
    FILE *f = fopen(MARKER, "w"); if (f) { fputs("ran", f); fclose(f); } }
int answer(void) { return 42; }
"""


def test_a_planted_library_with_a_matching_sidecar_is_not_loaded(tmp_path):
    cc = _toolchain.find_compiler()
    if cc is None:
        pytest.skip("no C compiler")
    marker = tmp_path / "ran"
    good = _toolchain.build("int answer(void) { return 42; }\n", "planted", cache_dir=tmp_path / "cache")
    assert good is not None and verified(good)
    _toolchain.open_verified(good)
    src = tmp_path / "evil.c"
    src.write_text(CONSTRUCTOR.replace("MARKER", json.dumps(str(marker))))
    evil = tmp_path / "evil.so"
    import subprocess
    subprocess.run([cc, "-shared", "-fPIC", "-o", str(evil), str(src)], check=True, timeout=120)
    os.replace(evil, good)  # the attacker's library with a matching size/SHA-256 sidecar
    data = good.read_bytes()
    Path(str(good) + SIDECAR_SUFFIX).write_text(json.dumps(
        {"size": len(data), "sha256": hashlib.sha256(data).hexdigest()}))
    with pytest.raises(_toolchain.UnverifiedLibrary):
        _toolchain.open_verified(good)
    assert not marker.exists()
    rebuilt = _toolchain.build("int answer(void) { return 42; }\n", "planted",
                               cache_dir=tmp_path / "cache")
    assert rebuilt == good and verified(rebuilt)
    _toolchain.open_verified(rebuilt)
    assert not marker.exists()
