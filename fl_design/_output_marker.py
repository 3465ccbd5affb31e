"""The marker of an output folder and the walk that checks a folder against it.

The marker (:data:`MARKER`, JSON) records the SHA-256 of every file fl_design wrote into the
folder and, while a run holds the folder, when it opened it (``open_since_ns``); it is signed
with the user's key (:func:`fl_design._cache.signing_key`, HMAC-SHA256 over the folder's
resolved path, the files and that time), so a marker someone else wrote, or one copied from
another folder, is trusted for nothing. :func:`_scan` walks a folder without following links
and lists what is a link (or a special or hard-linked file) and what no trusted marker
accounts for. Used by :mod:`fl_design._output`.

Examples
--------
A file fl_design wrote is accounted for by the marker until its content changes:

>>> from fl_design._output import claim_output_folder, release_output_folder, write_output
>>> from fl_design._output_marker import _scan
>>> folder = claim_output_folder("scanned")
>>> _ = write_output(folder, "ours.txt", "x")
>>> release_output_folder(folder)
>>> _scan(folder, set())
([], [])
>>> _ = (folder / "ours.txt").write_text("changed")
>>> _scan(folder, set())
([], ['ours.txt'])
"""

from __future__ import annotations

import hashlib
import hmac
import json
import os
import stat
import tempfile
import time
from pathlib import Path

from .errors import OutputExistsError

#: Name of the marker file recording what fl_design wrote into a folder.
MARKER = ".fl_design_output.json"
#: Name of the lock file of a folder being written.
LOCK = ".fl_design_output.lock"
_FORMAT = "fl_design output 2"
_TEMP = ".fl_design_output."  # start of the marker's temporary files
_MAX_ENTRIES = 20_000  # a folder holding more is not scanned (refused: choose another)
_MAX_MARKER = 8 << 20
_CLOCK_SLACK_NS = 2_000_000_000  # file times come from a coarser clock than time.time_ns


def _digest(path: Path) -> str | None:
    """SHA-256 of a regular file, read without following a link (None otherwise)."""
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0))
    except OSError:
        return None
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            return None
        h = hashlib.sha256()
        with os.fdopen(fd, "rb", closefd=False) as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                h.update(block)
        return h.hexdigest()
    except OSError:
        return None
    finally:
        os.close(fd)


def _marker_mac(folder: Path, files: dict, since) -> str:
    from ._cache import signing_key

    text = json.dumps([_FORMAT, str(folder.resolve()), sorted(files.items()), since])
    return hmac.new(signing_key(), text.encode("utf-8"), hashlib.sha256).hexdigest()


def _marker(folder: Path) -> tuple[dict, int | None] | None:
    """``({relative path: sha256}, open since [ns] or None)`` of a marker this user wrote for
    this folder (its HMAC verifies), or None."""
    try:
        fd = os.open(folder / MARKER, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0)
                     | getattr(os, "O_NONBLOCK", 0))
    except OSError:
        return None
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            return None
        raw = os.read(fd, _MAX_MARKER + 1)
        data = json.loads(raw.decode("utf-8")) if len(raw) <= _MAX_MARKER else None
    except (OSError, ValueError, UnicodeDecodeError, RecursionError):
        return None
    finally:
        os.close(fd)
    if not isinstance(data, dict) or data.get("format") != _FORMAT:
        return None
    files, since, mac = data.get("files"), data.get("open_since_ns"), data.get("mac")
    if not isinstance(files, dict) or not all(isinstance(k, str) and isinstance(v, str)
                                              for k, v in files.items()) \
            or not (since is None or (isinstance(since, int) and not isinstance(since, bool))) \
            or not isinstance(mac, str):
        return None
    try:
        if not hmac.compare_digest(mac, _marker_mac(folder, files, since)):
            return None  # written by someone else, or for another folder: trusted for nothing
    except (OSError, ValueError):
        return None
    return files, since


def _recorded(folder: Path) -> dict | None:
    """``{relative path: sha256}`` of the folder's (verified) marker, or None."""
    marker = _marker(folder)
    return None if marker is None else marker[0]


def _replace_bytes(folder: Path, name: str, data: bytes) -> None:
    """Write ``data`` as ``folder/name``: a temporary file there (O_EXCL), then os.replace."""
    fd, tmp = tempfile.mkstemp(prefix=_TEMP if name == MARKER else f".{name}.", suffix=".tmp",
                               dir=folder)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.chmod(tmp, 0o644)  # as an ordinary file (mkstemp makes 0600)
        os.replace(tmp, folder / name)
    finally:
        if os.path.lexists(tmp):
            os.unlink(tmp)


def _write_marker(folder: Path, files: dict, since: int | None = None) -> None:
    files = dict(sorted(files.items()))
    text = json.dumps({"format": _FORMAT, "files": files, "open_since_ns": since,
                       "mac": _marker_mac(folder, files, since)}, indent=1)
    _replace_bytes(folder, MARKER, text.encode("utf-8"))


def _walk(folder: Path):
    """Every entry below ``folder`` (links not followed): ``(name, path, st, marker, base)``
    with the marker governing it (``(files, since)`` or None; a subfolder's own verified marker
    governs what is below it) and the governing folder's relative prefix ``base``."""
    count = 0
    stack = [(folder, "", _marker(folder), "", folder)]
    while stack:
        here, rel, marker, base, gov = stack.pop()
        with os.scandir(here) as entries:
            for entry in entries:
                count += 1
                if count > _MAX_ENTRIES:
                    raise OutputExistsError(
                        f"the folder {str(folder)!r} holds more than {_MAX_ENTRIES} entries: "
                        "not checked; choose an empty or new folder")
                st = entry.stat(follow_symlinks=False)
                if entry.name in (MARKER, LOCK) or (entry.name.startswith(_TEMP)
                                                    and stat.S_ISREG(st.st_mode)):
                    continue
                name = f"{rel}{entry.name}"
                if stat.S_ISDIR(st.st_mode):
                    own = _marker(Path(entry.path))
                    stack.append((Path(entry.path), f"{name}/", own or marker,
                                  f"{name}/" if own is not None else base,
                                  Path(entry.path) if own is not None else gov))
                else:
                    yield name, Path(entry.path), st, marker, base, gov


def _ours_since(st, marker) -> bool:
    """Written while a run of ours held the folder open (its files are ours)."""
    return marker is not None and marker[1] is not None and st.st_mtime_ns >= marker[1]


def _scan(folder: Path, held) -> tuple[list[str], list[str]]:
    """``(links, foreign)``: relative names of links/special files, and of regular files no
    trusted marker records with their content (nor wrote while open: a folder in ``held``,
    resolved paths this process holds, may have rewritten its recorded files)."""
    links, foreign = [], []
    for name, path, st, marker, base, gov in _walk(folder):
        if not stat.S_ISREG(st.st_mode) or st.st_nlink > 1:
            links.append(name)
            continue
        rel = name[len(base):]
        ours = marker is not None and (
            rel.startswith("build/")  # a package's compiler outputs, rebuilt by each run
            or (_ours_since(st, marker)
                and (rel not in marker[0] or str(gov.resolve()) in held))
            or marker[0].get(rel) == _digest(path))
        if not ours:
            foreign.append(name)
    return sorted(links), sorted(foreign)


def _close_marker(folder: Path, *, reopen: bool) -> None:
    """Record the files written while the folder's marker was open (regular, one name, newer
    than its opening), then close it, or reopen it from now (``reopen``)."""
    own = _marker(folder)
    files = dict(own[0]) if own is not None else {}
    for name, path, st, marker, base, _ in _walk(folder):
        if base == "" and stat.S_ISREG(st.st_mode) and st.st_nlink == 1 and _ours_since(st, marker):
            sha = _digest(path)
            if sha is not None:
                files[name] = sha
    _write_marker(folder, files, time.time_ns() - _CLOCK_SLACK_NS if reopen else None)


def _unlink_links(folder: Path, links: list[str]) -> None:
    for rel in links:
        try:
            os.unlink(folder / rel)  # the link itself (or the FIFO), never what it points to
        except IsADirectoryError:
            pass
        except FileNotFoundError:
            pass
