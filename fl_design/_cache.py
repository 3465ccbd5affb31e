"""The on-disk cache of fl_design: one private directory, files named by content hash, verified.

Shared by every layer that caches work across processes: compiled kernels
(:func:`fl_design.codegen.build`) and plant derivations (:mod:`fl_design.symbolic._derivation_cache`).
Each file is written atomically (a ``mkstemp`` temporary file, created with ``O_EXCL`` and mode
0600 in the same folder, then ``os.replace``), then a sidecar ``<file>.json`` records its size,
SHA-256 and an HMAC-SHA256 of its name, size and hash under the per-user key
(:func:`user_key`), also written atomically. A cached file is used only when it matches its
sidecar and the sidecar's HMAC verifies (:func:`verified`, :func:`read_verified`) and it is a
regular file owned by the user: a truncated, empty, overwritten, foreign or symlinked file, a
missing, disagreeing or unsigned sidecar, counts as absent. So every entry that can run code
(a pickled derivation, a compiled kernel ``dlopen``-ed) was written by someone holding the
key.

Location, in order: the ``cache_dir`` argument, ``$FL_DESIGN_CACHE``,
``$XDG_CACHE_HOME/fl_design`` (only when absolute, as the XDG specification says; a relative
value is ignored with one :class:`~fl_design.errors.UnsafeCacheWarning`),
``~/.cache/fl_design`` (:func:`cache_directory`). The folder is created with mode 0700 and,
like ``ssh`` with its keys, refused (:class:`~fl_design.errors.UnsafeCacheError`; callers
then compute without the cache, with one warning) when it is not owned by the user or is
group- or world-writable. :func:`user_key` is a per-user secret kept OUTSIDE that folder, in
the user's config folder (``$XDG_CONFIG_HOME/fl_design/cache.key`` or
``~/.config/fl_design/cache.key``, mode 0600, folder 0700: :func:`key_path`): a cache folder
copied from someone else, or unpacked from an archive, carries no signing power, and every
entry in it is recomputed.

Examples
--------
>>> from fl_design._cache import read_verified, write_verified
>>> path = write_verified("example.bin", b"payload", cache_dir="kernels")
>>> read_verified(path)
b'payload'
"""

from __future__ import annotations

import hashlib
import hmac
import json
import os
import secrets
import stat
import tempfile
import warnings
from pathlib import Path

from .errors import ComputationError, UnsafeCacheError, UnsafeCacheWarning

#: Suffix of the sidecar recording a cached file's size and SHA-256.
SIDECAR_SUFFIX = ".json"
#: Name of the per-user secret in the user's config folder (:func:`key_path`, :func:`user_key`).
KEY_NAME = "cache.key"
_KEY_BYTES = 32
_MAC_FORMAT = "fl_design cache entry 2"
_PROCESS_KEY = secrets.token_bytes(_KEY_BYTES)  # when the user's key cannot be used
_WARNED: set = set()  # messages already warned in this process


def _warn_once(message: str) -> None:
    if message not in _WARNED:
        _WARNED.add(message)
        warnings.warn(message, UnsafeCacheWarning, stacklevel=4)


def _default_location() -> str:
    explicit = os.environ.get("FL_DESIGN_CACHE", "")
    if explicit.strip():
        return explicit
    xdg = os.environ.get("XDG_CACHE_HOME", "")
    if xdg and not os.path.isabs(xdg):
        _warn_once(f"$XDG_CACHE_HOME={xdg!r} is a relative path, which the XDG specification "
                   "says to ignore: the cache is in ~/.cache/fl_design; set an absolute path "
                   "or $FL_DESIGN_CACHE")
        xdg = ""
    return os.path.join(xdg or os.path.join(os.path.expanduser("~"), ".cache"), "fl_design")


def check_private(path: str | os.PathLike) -> Path:
    """``path`` if it is a directory owned by the user and not group/world-writable.

    Parameters
    ----------
    path : path-like
        The folder to check (not created).

    Returns
    -------
    pathlib.Path
        ``path`` itself, once checked.

    Raises
    ------
    UnsafeCacheError
        Not a directory, owned by another user, or writable by group or others (anyone else
        could plant a library or an entry in it); the message says how to fix it.

    Examples
    --------
    >>> import os
    >>> from fl_design._cache import check_private
    >>> os.makedirs("private", mode=0o700)
    >>> check_private("private").name
    'private'
    >>> os.chmod("private", 0o777)
    >>> check_private("private")
    Traceback (most recent call last):
    ...
    fl_design.errors.UnsafeCacheError: the cache folder ... is writable by group or others ...
    """
    path = Path(path)
    st = os.stat(path)
    where = str(path.resolve())
    if not stat.S_ISDIR(st.st_mode):
        raise UnsafeCacheError(f"the cache folder {where!r} is not a directory")
    if st.st_uid != os.geteuid():
        raise UnsafeCacheError(
            f"the cache folder {where!r} is owned by uid {st.st_uid}, not by you (uid "
            f"{os.geteuid()}): it is not used; set $FL_DESIGN_CACHE to a folder of your own")
    if st.st_mode & 0o022:
        raise UnsafeCacheError(
            f"the cache folder {where!r} is writable by group or others (mode "
            f"{stat.S_IMODE(st.st_mode):04o}): anyone could plant code in it, so it is not used; "
            f"run chmod 700 {where} or set $FL_DESIGN_CACHE to a private folder")
    return path


def cache_directory(cache_dir: str | os.PathLike | None = None) -> Path:
    """The private directory holding cached files (created with mode 0700 if needed).

    Parameters
    ----------
    cache_dir : path-like, optional
        Explicit directory; default ``$FL_DESIGN_CACHE``, else ``$XDG_CACHE_HOME/fl_design``
        (when absolute), else ``~/.cache/fl_design``.

    Returns
    -------
    pathlib.Path
        The directory, existing and private.

    Raises
    ------
    UnsafeCacheError
        The directory exists but is not private (:func:`check_private`).
    ComputationError
        The directory cannot be created (a regular file in the way, no permission, read-only
        file system...); the message names it and ``FL_DESIGN_CACHE``.

    Examples
    --------
    >>> from fl_design._toolchain import cache_directory
    >>> oct(cache_directory("kernels").stat().st_mode & 0o777)
    '0o700'
    """
    default = cache_dir is None
    path = Path(_default_location() if default else cache_dir)
    try:
        path.mkdir(mode=0o700, parents=True, exist_ok=True)
        st = os.stat(path)
    except OSError as exc:
        raise ComputationError(f"cannot use {str(path)!r} as the compiled-kernel cache ({exc}); "
                               "give a writable directory as cache_dir or in $FL_DESIGN_CACHE"
                               ) from exc
    if default and st.st_uid == os.geteuid() and stat.S_IMODE(st.st_mode) & 0o077 \
            and not st.st_mode & 0o022:
        try:  # our own default folder, readable by others (made 0755 by older versions)
            os.chmod(path, 0o700)
        except OSError:
            pass
    return check_private(path)


def _owned_regular(path: Path) -> bool:
    """True when ``path`` is a regular file (not a symlink) owned by the user."""
    try:
        st = os.lstat(path)
    except OSError:
        return False
    return stat.S_ISREG(st.st_mode) and st.st_uid == os.geteuid()


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
    if not (_owned_regular(path) and _owned_regular(Path(str(path) + SIDECAR_SUFFIX))):
        return None
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
    >>> from fl_design._toolchain import verified
    >>> verified("no-such-library.so")
    False
    """
    path = Path(path)
    record = _record(path)
    try:
        if record is None or os.stat(path).st_size != record.get("size") \
                or not _signed(path, record):
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
    if record is None or not _signed(path, record):
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
    replace_bytes(path, text.encode())


def replace_bytes(path: Path, data: bytes, *, mode: int | None = None) -> None:
    """Write ``data`` to ``path`` atomically: a ``mkstemp`` file (O_EXCL, 0600, or ``mode``
    set before the rename, e.g. ``0o755`` for a program), renamed.

    Examples
    --------
    >>> from pathlib import Path
    >>> from fl_design._cache import replace_bytes
    >>> replace_bytes(Path("blob.bin"), b"fl", mode=0o644)
    >>> Path("blob.bin").read_bytes(), oct(Path("blob.bin").stat().st_mode & 0o777)
    (b'fl', '0o644')
    """
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        if mode is not None:
            os.chmod(tmp, mode)
        os.replace(tmp, path)
    finally:
        if os.path.lexists(tmp):
            os.unlink(tmp)


def key_path() -> Path:
    """Where the per-user signing key lives: outside every cache folder, in the user's config.

    ``$XDG_CONFIG_HOME/fl_design/cache.key`` when ``$XDG_CONFIG_HOME`` is absolute, else
    ``~/.config/fl_design/cache.key``. Copying or unpacking a cache folder never copies it.

    Examples
    --------
    >>> from fl_design._cache import key_path
    >>> key_path().name
    'cache.key'
    """
    xdg = os.environ.get("XDG_CONFIG_HOME", "")
    base = xdg if xdg and os.path.isabs(xdg) else os.path.join(os.path.expanduser("~"), ".config")
    return Path(base) / "fl_design" / KEY_NAME


def _inside(inner: Path, outer: Path) -> bool:
    try:
        inner.resolve().relative_to(outer.resolve())
    except (ValueError, OSError):
        return False
    return True


def user_key(cache_dir: str | os.PathLike | None = None) -> bytes:
    """The per-user secret (32 bytes) that signs the cache, created once with mode 0600.

    It is kept in the user's config folder (:func:`key_path`, folder 0700), never inside the
    cache folder it protects: a cache folder copied from someone else (or unpacked from an
    archive) carries no signing power, and its entries are recomputed.

    Parameters
    ----------
    cache_dir : path-like, optional
        The cache folder the key will sign (see :func:`cache_directory`); the key is refused
        when it would lie inside it.

    Raises
    ------
    UnsafeCacheError
        The key file is not a regular 32-byte file of the user readable by no one else, its
        folder is not private, or it lies inside the cache folder.
    OSError
        The config folder cannot be created or read.

    Examples
    --------
    >>> from fl_design._cache import user_key
    >>> key = user_key("kernels")
    >>> len(key), key == user_key("kernels")
    (32, True)
    """
    path = key_path()
    if cache_dir is not None and _inside(path, Path(cache_dir)):
        raise UnsafeCacheError(
            f"the cache key {str(path)!r} lies inside the cache folder {str(cache_dir)!r}: a copy "
            "of the folder would carry it; set $FL_DESIGN_CACHE or $XDG_CONFIG_HOME apart")
    path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
    check_private(path.parent)
    if not os.path.lexists(path):
        fd, tmp = tempfile.mkstemp(prefix=".key.", dir=path.parent)
        try:
            with os.fdopen(fd, "wb") as fh:
                fh.write(secrets.token_bytes(_KEY_BYTES))
            try:
                os.link(tmp, path)  # atomic and never replaces: a concurrent key wins
            except FileExistsError:
                pass
        finally:
            os.unlink(tmp)
    # O_NONBLOCK: a FIFO (or device) planted at the key's name is refused, never waited on
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0))
    try:
        st = os.fstat(fd)
        data = os.read(fd, _KEY_BYTES + 1) if stat.S_ISREG(st.st_mode) else b""
    finally:
        os.close(fd)
    if not stat.S_ISREG(st.st_mode) or st.st_uid != os.geteuid() or st.st_mode & 0o077 \
            or len(data) != _KEY_BYTES:
        raise UnsafeCacheError(
            f"the cache key {str(path)!r} is not a private 32-byte file of yours (mode "
            f"{stat.S_IMODE(st.st_mode):04o}, uid {st.st_uid}): signed cache entries are not "
            "used; delete it to make a new one")
    return data


def signing_key(cache_dir: str | os.PathLike | None = None) -> bytes:
    """:func:`user_key`, or, when it cannot be used, a key of this process only (one warning).

    With the process key, entries written by other processes never verify (they are
    recomputed) and nothing is lost but speed.

    Examples
    --------
    >>> from fl_design._cache import signing_key
    >>> len(signing_key())
    32
    """
    try:
        return user_key(cache_dir)
    except (OSError, UnsafeCacheError) as exc:
        _warn_once(f"{exc}; the cache is signed with a key of this process only (entries of "
                   "other processes are recomputed)")
        return _PROCESS_KEY


def _mac(key: bytes, name: str, record: dict) -> str:
    text = f"{_MAC_FORMAT}\0{name}\0{record.get('size')}\0{record.get('sha256')}"
    return hmac.new(key, text.encode(), hashlib.sha256).hexdigest()


def signed_record(path: str | os.PathLike, record: dict, cache_dir=None) -> dict:
    """``record`` (``{"size", "sha256"}`` of ``path``) with its HMAC under :func:`signing_key`.

    The MAC binds the file name, size and SHA-256: a file is trusted only if whoever wrote its
    sidecar held this user's key (:func:`verified`).

    Examples
    --------
    >>> from fl_design._cache import signed_record
    >>> sorted(signed_record("a.so", {"size": 1, "sha256": "00"}))
    ['mac', 'sha256', 'size']
    """
    key = signing_key(cache_dir if cache_dir is not None else Path(path).parent)
    return {"size": record["size"], "sha256": record["sha256"],
            "mac": _mac(key, Path(path).name, record)}


def _signed(path: Path, record: dict) -> bool:
    mac = record.get("mac")
    if not isinstance(mac, str):
        return False
    key = signing_key(path.parent)
    return hmac.compare_digest(mac, _mac(key, path.name, record))


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
    replace_bytes(out, data)
    record = {"size": len(data), "sha256": hashlib.sha256(data).hexdigest()}
    replace_text(Path(str(out) + SIDECAR_SUFFIX), json.dumps(signed_record(out, record)))
    return out


__all__ = ["KEY_NAME", "SIDECAR_SUFFIX", "cache_directory", "check_private", "digest",
           "key_path", "read_verified", "replace_bytes", "replace_text", "signed_record", "signing_key",
           "user_key", "verified", "write_verified"]
