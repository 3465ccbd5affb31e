"""Output folders: fl_design writes only into a folder that is empty or holds its own output,
and never writes through a link.

A folder we write into (``fl.generate_c``, ``fl-design run --out``, ``codegen DIR``, the
report) gets a marker file, :data:`MARKER`, recording the SHA-256 of every file we wrote there.
:func:`claim_output_folder` walks the whole folder (every name, in every subfolder, without
following links) and accepts it only when each regular file is recorded by a marker (its own
folder's or an enclosing one's) with that content: a marker is trusted only as far as the
folder matches it, so a planted marker (``{"files": {}}``) protects nothing. Anything else (a
project's ``Makefile``, a generated file edited by hand, a file no marker names) is refused
with an :class:`~fl_design.errors.OutputExistsError` naming it, unless ``force=True``
(``--force``). Links are never followed: a symbolic link, a hard-linked file (another name of
a file elsewhere), a FIFO or a device anywhere in the folder is refused, and with ``force``
removed (the link, never what it points to), so no later write can land outside the folder.
Writes made here (:func:`write_output`, the marker) go to a temporary file in the same folder,
then ``os.replace`` over the name; :func:`output_path` gives writers that need a path (a
compiler's ``-o``, ``savefig``) one whose folders are real folders and whose name is no link.

A lock (:data:`LOCK`, ``fcntl.lockf``, held by the process from the claim until
:func:`record_outputs` (or :func:`release_output_folder`, or the process's exit; released by
the system if the process dies); a second claim by the same process re-enters it) makes a second run
into the same folder fail at once with an :class:`~fl_design.errors.OutputPathError` naming
the process holding it, or wait up to ``wait`` seconds.

Examples
--------
>>> from pathlib import Path
>>> from fl_design._output import claim_output_folder, record_outputs, release_output_folder
>>> folder = claim_output_folder("made_here")
>>> (folder / "a.txt").write_text("ours")
4
>>> record_outputs(folder, [folder / "a.txt"])  # done: the folder is released
>>> claim_output_folder("made_here").name  # our own earlier output: fine
'made_here'
>>> release_output_folder(folder)
>>> (folder / "a.txt").write_text("edited by hand")
14
>>> claim_output_folder("made_here")
Traceback (most recent call last):
...
fl_design.errors.OutputExistsError: the output folder 'made_here' holds files fl_design did not write or that changed since: a.txt; ...
"""

from __future__ import annotations

import atexit
import os
import stat
import time
from pathlib import Path

from ._output_marker import (
    LOCK,
    MARKER,
    _close_marker,
    _digest,
    _marker,
    _recorded,  # noqa: F401 - used by the report's writer (app/_report_write.py)
    _replace_bytes,
    _scan,
    _unlink_links,
    _write_marker,
)
from .errors import OutputExistsError, OutputPathError, ParameterError

_HELD: dict[str, tuple[int, Path]] = {}  # resolved folder -> (lock's descriptor, folder)


def _shown(names: list[str]) -> str:
    return ", ".join(names[:5]) + (f" and {len(names) - 5} more" if len(names) > 5 else "")


def _lock(folder: Path, what: str, path, wait: float) -> bool | None:
    """Hold the folder's lock for this process (re-entrant), or raise naming its holder.
    None when already held (or no locks on this system), else whether the lock file is new."""
    key = str(folder.resolve())
    if key in _HELD:
        return None
    try:
        import fcntl
    except ImportError:  # no POSIX locks (Windows): no lock, as before
        return None
    where = folder / LOCK
    created = not os.path.lexists(where)
    flags = os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(where, flags, 0o600)
    except OSError:
        if os.path.islink(where) or (os.path.lexists(where) and not os.path.isdir(where)):
            os.unlink(where)  # a link or special file at our reserved name: replaced
            fd = os.open(where, flags, 0o600)
        else:
            raise
    deadline = time.monotonic() + max(0.0, wait)
    while True:
        try:
            fcntl.lockf(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            break
        except OSError:
            if time.monotonic() >= deadline:
                try:
                    holder = os.pread(fd, 200, 0).decode("utf-8", "replace").strip()
                except OSError:
                    holder = ""
                os.close(fd)
                raise OutputPathError(
                    f"the {what} {str(path)!r} is being written by another fl_design run "
                    f"({holder or 'another process'}); wait for it to finish or choose "
                    "another folder") from None
            time.sleep(0.1)
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        raise OutputPathError(f"the {what} {str(path)!r}: {LOCK} is not a regular file")
    os.ftruncate(fd, 0)
    os.pwrite(fd, f"pid {os.getpid()}, since {time.strftime('%H:%M:%S')}".encode(), 0)
    if not _HELD:
        atexit.register(_release_all)
    _HELD[key] = (fd, folder)
    return created


def _unlock_refused(folder: Path, taken: bool | None) -> None:
    """Release a lock this claim took on a refused folder (its file too, if new); the folder
    is left as it was."""
    if taken is None:
        return
    held = _HELD.pop(str(folder.resolve()), None)
    if taken:
        try:
            os.unlink(folder / LOCK)
        except OSError:
            pass
    if held is not None:
        os.close(held[0])


def release_output_folder(path) -> None:
    """Release this process's lock on an output folder (no-op when not held).

    Examples
    --------
    >>> from fl_design._output import claim_output_folder, release_output_folder
    >>> release_output_folder(claim_output_folder("released"))
    """
    held = _HELD.pop(str(Path(path).resolve()), None)
    if held is None:
        return
    try:
        _close_marker(held[1], reopen=False)
    except (OSError, OutputPathError):
        pass  # left open: the next claim records what this run wrote
    finally:
        os.close(held[0])


def _release_all() -> None:
    for key in list(_HELD):
        release_output_folder(key)


def claim_output_folder(path, *, force: bool = False, what: str = "output folder",
                        wait: float = 0.0) -> Path:
    """``path`` created if needed, locked, after checking that writing into it loses nothing.

    Parameters
    ----------
    path : path-like
        The folder.
    force : bool, optional
        Write even into a folder holding files we did not write (they may be replaced); links
        and special files in it are removed (never followed).
    what : str, optional
        How the folder is named in messages (``"--out"``, ``"out_dir"``).
    wait : float, optional
        Seconds to wait for another process's lock on the folder (default: fail at once).

    Raises
    ------
    OutputExistsError
        The folder holds files fl_design did not write, files it wrote that changed since, or
        links (the message names up to five and says ``--force`` / ``force=True``).
    OutputPathError
        The path is empty, not a folder, cannot be created or written, or another process is
        writing it.

    Examples
    --------
    >>> from pathlib import Path
    >>> from fl_design._output import claim_output_folder
    >>> Path("project").mkdir()
    >>> _ = (Path("project") / "Makefile").write_text("all:")
    >>> claim_output_folder("project")
    Traceback (most recent call last):
    ...
    fl_design.errors.OutputExistsError: the output folder 'project' holds files fl_design did not write or that changed since: Makefile; ...
    >>> claim_output_folder("project", force=True).name
    'project'
    """
    if not isinstance(path, (str, os.PathLike)) or not str(path).strip():
        raise OutputPathError(f"the {what} is empty or not a path ({path!r}): give a folder, "
                              "e.g. out")
    folder = Path(path)
    if os.path.lexists(folder) and not folder.is_dir():
        raise OutputPathError(f"the {what} {str(path)!r} exists and is not a folder")
    created = None
    try:
        folder.mkdir(parents=True, exist_ok=True)
        created = _lock(folder, what, path, wait)
        links, foreign = _scan(folder, _HELD)
        if force:
            _unlink_links(folder, links)
    except OutputPathError:
        _unlock_refused(folder, created)
        raise
    except OSError as exc:
        _unlock_refused(folder, created)
        raise OutputPathError(f"the {what} {str(path)!r} cannot be used as the output folder "
                              f"({exc.strerror or exc}); give a folder that can be created and "
                              "written") from None
    if (links or foreign) and not force:
        _unlock_refused(folder, created)
    if links and not force:
        raise OutputExistsError(
            f"the {what} {str(path)!r} holds links or special files: {_shown(links)}; "
            "fl_design never writes through a link: remove them, choose another folder, or "
            "pass --force (force=True) to replace the links (their targets are kept)")
    if foreign and not force:
        raise OutputExistsError(
            f"the {what} {str(path)!r} holds files fl_design did not write or that changed "
            f"since: {_shown(foreign)}; choose an empty or new folder, or pass --force "
            "(force=True) to write there anyway")
    try:
        _close_marker(folder, reopen=True)
    except OSError as exc:
        raise OutputPathError(f"cannot write to the {what} {str(path)!r}: "
                              f"{exc.strerror or exc}") from None
    return folder


def _relative(folder: Path, rel) -> Path:
    rel = Path(rel)
    if rel.is_absolute() or not rel.parts or any(p in ("..", "") for p in rel.parts) \
            or rel.parts[-1] in (MARKER, LOCK):
        raise OutputPathError(f"{str(rel)!r} is not a file name inside the output folder "
                              f"{str(folder)!r}")
    return rel


def output_path(folder, rel) -> Path:
    """``folder/rel`` ready to be written by name: its folders created and real (no link
    followed), and ``rel`` itself no link (a link there is removed, never followed).

    Parameters
    ----------
    folder : path-like
        A claimed output folder.
    rel : str or path-like
        Relative name (``"build/sil.c"``).

    Returns
    -------
    pathlib.Path
        ``folder/rel``, its folders existing.

    Raises
    ------
    OutputPathError
        ``rel`` leaves the folder, or one of its folders is a link or not a folder.

    Examples
    --------
    >>> from fl_design._output import claim_output_folder, output_path
    >>> output_path(claim_output_folder("op"), "build/x.c").parent.name
    'build'
    """
    folder = Path(folder)
    rel = _relative(folder, rel)
    here = folder
    for part in rel.parts[:-1]:
        here = here / part
        try:
            os.mkdir(here, 0o777)
        except FileExistsError:
            pass
        except OSError as exc:
            raise OutputPathError(f"cannot create {str(here)!r}: {exc.strerror or exc}") from None
        if not stat.S_ISDIR(os.lstat(here).st_mode):
            raise OutputPathError(f"{str(here)!r} in the output folder is a link or not a "
                                  "folder: fl_design never writes through a link")
    target = here / rel.parts[-1]
    try:
        st = os.lstat(target)
    except FileNotFoundError:
        return target
    if stat.S_ISDIR(st.st_mode):
        raise OutputPathError(f"{str(target)!r} is a folder, where fl_design writes a file")
    if not stat.S_ISREG(st.st_mode) or st.st_nlink > 1:
        os.unlink(target)  # a link (or a second name of a file elsewhere): replaced
    return target


def write_output(folder, rel, data: bytes | str, *, record: bool = True) -> Path:
    """Write ``data`` as ``folder/rel`` without writing through anything: a temporary file in
    the same folder, then ``os.replace`` over the name; recorded in the marker.

    Parameters
    ----------
    folder : path-like
        A claimed output folder (:func:`claim_output_folder`).
    rel : str or path-like
        Relative name.
    data : bytes or str
        Content (str is written as UTF-8).
    record : bool, optional
        Add the file to the folder's marker (default).

    Examples
    --------
    >>> from fl_design._output import claim_output_folder, write_output
    >>> write_output(claim_output_folder("wo"), "a/b.txt", "hi").read_text()
    'hi'
    """
    target = output_path(folder, rel)
    raw = data.encode("utf-8") if isinstance(data, str) else bytes(data)
    try:
        _replace_bytes(target.parent, target.name, raw)
    except OSError as exc:
        raise OutputPathError(f"cannot write {str(target)!r}: {exc.strerror or exc}") from None
    if record:
        record_outputs(folder, [target], release=False)
    return target


def record_outputs(folder, paths, *, release: bool = True) -> None:
    """Add ``paths`` (files just written into ``folder`` or below) to its marker, and by
    default end the write: release the folder's lock (:func:`release_output_folder`).

    Parameters
    ----------
    folder : path-like
        A folder returned by :func:`claim_output_folder`.
    paths : iterable of path-like
        Files written (absolute, or relative to the working directory).
    release : bool, optional
        Release the folder after recording (default); False to keep writing.

    Examples
    --------
    >>> from fl_design._output import MARKER, claim_output_folder, record_outputs
    >>> folder = claim_output_folder("rec")
    >>> _ = (folder / "x.c").write_text("int x;")
    >>> record_outputs(folder, [folder / "x.c"])
    >>> "x.c" in (folder / MARKER).read_text()
    True
    """
    folder = Path(folder)
    files, since = _marker(folder) or ({}, None)
    files = dict(files)
    base = folder.resolve()
    for p in paths:
        p = Path(p)
        sha = _digest(p)
        if sha is None:
            continue
        try:
            rel = (p.parent.resolve() / p.name).relative_to(base)
        except ValueError:
            continue  # not inside the folder
        files[rel.as_posix()] = sha
    try:
        _write_marker(folder, files, since)
    except OSError as exc:
        raise OutputPathError(f"cannot write the marker {MARKER} into {str(folder)!r}: "
                              f"{exc.strerror or exc}") from None
    if release:
        release_output_folder(folder)


def check_prefix_names(prefix: str, fixed, suffixes=(".c", ".h"), *, what: str = "prefix") -> str:
    """``prefix`` if the files it names (``prefix + suffix``) collide with none of ``fixed``.

    Compared case-insensitively (``Main.c`` and ``main.c`` are one file on macOS and Windows).

    Parameters
    ----------
    prefix : str
        The name prefix (a C prefix: ``fl`` gives ``fl.c``, ``fl.h``).
    fixed : iterable of str
        The package's other file names (``"main.c"``, ``"Makefile"``, ``"pil/pil_main.c"``).
    suffixes : iterable of str, optional
        Endings of the files named by the prefix.
    what : str, optional
        The parameter's name in messages.

    Returns
    -------
    str
        ``prefix`` unchanged.

    Raises
    ------
    ParameterError
        A name made from ``prefix`` is one of ``fixed`` (it would overwrite it).

    Examples
    --------
    >>> from fl_design._output import check_prefix_names
    >>> check_prefix_names("fl", ["main.c", "Makefile"])
    'fl'
    >>> check_prefix_names("main", ["main.c", "Makefile"])
    Traceback (most recent call last):
    ...
    fl_design.errors.ParameterError: prefix='main' names main.c, a file of the package itself ...
    """
    taken = {str(n).casefold(): str(n) for n in fixed}
    clash = [taken[f"{prefix}{s}".casefold()] for s in suffixes
             if f"{prefix}{s}".casefold() in taken]
    if clash:
        raise ParameterError(
            f"{what}={prefix!r} names {', '.join(clash)}, a file of the package itself (it "
            f"would be overwritten and the package would not build); choose another prefix, "
            f"not one of {sorted({Path(n).stem for n in taken})} (e.g. 'fl')")
    return prefix


__all__ = ["LOCK", "MARKER", "check_prefix_names", "claim_output_folder", "output_path",
           "record_outputs", "release_output_folder", "write_output"]
