"""The on-disk cache of fl_design: one directory, files named by content hash, each verified.

Shared by every layer that caches work across processes: compiled kernels
(:func:`fl_design.codegen.build`) and plant derivations (:mod:`fl_design.symbolic._stored`).
Each file is written atomically (temporary name, then ``os.replace``), then a sidecar
``<file>.json`` records its size and SHA-256, also written atomically. A cached file is used
only when it matches its sidecar (:func:`verified`, :func:`read_verified`): a truncated, empty
or overwritten file, a missing or disagreeing sidecar, counts as absent.

Location, in order: the ``cache_dir`` argument, ``$FL_DESIGN_CACHE``,
``$XDG_CACHE_HOME/fl_design``, ``~/.cache/fl_design`` (:func:`cache_directory`).

Examples
--------
>>> from fl_design._cache import read_verified, write_verified
>>> path = write_verified("example.bin", b"payload", cache_dir="kernels")
>>> read_verified(path)
b'payload'
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

from .errors import ComputationError

#: Suffix of the sidecar recording a cached file's size and SHA-256.
SIDECAR_SUFFIX = ".json"


def cache_directory(cache_dir: str | os.PathLike | None = None) -> Path:
    """The directory holding cached files (created if needed).

    Parameters
    ----------
    cache_dir : path-like, optional
        Explicit directory; default ``$FL_DESIGN_CACHE``, else ``$XDG_CACHE_HOME/fl_design``,
        else ``~/.cache/fl_design``.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    ComputationError
        The directory cannot be created (a regular file in the way, no permission, read-only
        file system...); the message names it and ``FL_DESIGN_CACHE``.

    Examples
    --------
    >>> from fl_design._toolchain import cache_directory
    >>> cache_directory("kernels").is_dir()
    True
    """
    if cache_dir is None:
        cache_dir = os.environ.get("FL_DESIGN_CACHE") or os.path.join(
            os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"),
            "fl_design")
    path = Path(cache_dir)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ComputationError(f"cannot use {str(path)!r} as the compiled-kernel cache ({exc}); "
                               "give a writable directory as cache_dir or in $FL_DESIGN_CACHE"
                               ) from exc
    return path


def digest(path: str | os.PathLike) -> dict:
    """``{"size": bytes, "sha256": hex}`` of a file (read in 1 MiB blocks).

    Examples
    --------
    >>> from fl_design._cache import digest, write_verified
    >>> digest(write_verified("example.bin", b"payload", cache_dir="kernels"))["size"]
    7
    """
    h = hashlib.sha256()
    size = 0
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
            size += len(block)
    return {"size": size, "sha256": h.hexdigest()}


def _record(path: Path) -> dict | None:
    try:
        record = json.loads(Path(str(path) + SIDECAR_SUFFIX).read_text())
    except (OSError, ValueError, UnicodeDecodeError):
        return None
    return record if isinstance(record, dict) else None


def verified(path: str | os.PathLike) -> bool:
    """True when ``path`` exists and matches the size and SHA-256 recorded in its sidecar.

    A missing, unreadable or malformed sidecar, or any difference, gives False (never raises).

    Examples
    --------
    >>> from fl_design.codegen._build import verified
    >>> verified("no-such-library.so")
    False
    """
    path = Path(path)
    record = _record(path)
    try:
        if record is None or os.stat(path).st_size != record.get("size"):
            return False
        return digest(path) == {"size": record["size"], "sha256": record.get("sha256")}
    except OSError:
        return False


def read_verified(path: str | os.PathLike) -> bytes | None:
    """The bytes of ``path`` when they match its sidecar, else None (read once; never raises).

    Examples
    --------
    >>> from fl_design._cache import read_verified
    >>> read_verified("no-such-file.bin") is None
    True
    """
    path = Path(path)
    record = _record(path)
    if record is None:
        return None
    try:
        data = path.read_bytes()
    except OSError:
        return None
    ok = len(data) == record.get("size") and \
        hashlib.sha256(data).hexdigest() == record.get("sha256")
    return data if ok else None


def replace_text(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` atomically (a temporary name in the same folder, then rename).

    Examples
    --------
    >>> from pathlib import Path
    >>> from fl_design._cache import cache_directory, replace_text
    >>> replace_text(cache_directory("kernels") / "note.txt", "hi")
    >>> (Path("kernels") / "note.txt").read_text()
    'hi'
    """
    _replace_bytes(path, text.encode())


def _replace_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically: a temporary name in the same folder, renamed."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "wb") as fh:
            fh.write(data)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def write_verified(name: str, data: bytes, *, cache_dir=None) -> Path:
    """Store ``data`` as ``name`` in the cache, atomically, with its sidecar; the file's path.

    Parameters
    ----------
    name : str
        File name inside the cache directory.
    data : bytes
        Content.
    cache_dir : path-like, optional
        See :func:`cache_directory`.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    OSError, ComputationError
        The cache cannot be written (callers that can compute instead catch both).

    Examples
    --------
    >>> from fl_design._cache import verified, write_verified
    >>> verified(write_verified("example.bin", b"payload", cache_dir="kernels"))
    True
    """
    out = cache_directory(cache_dir) / name
    _replace_bytes(out, data)
    replace_text(Path(str(out) + SIDECAR_SUFFIX),
                 json.dumps({"size": len(data), "sha256": hashlib.sha256(data).hexdigest()}))
    return out


__all__ = ["SIDECAR_SUFFIX", "cache_directory", "digest", "read_verified", "replace_text",
           "verified", "write_verified"]
