"""Output folders: fl_design writes only into a folder that is empty or holds its own output.

A folder we write into (``fl.generate_c``, ``fl-design run --out``, ``codegen DIR``, the
report) gets a marker file, :data:`MARKER`, recording the size and SHA-256 of every file we
wrote there. :func:`claim_output_folder` accepts a folder that does not exist, is empty, or
holds the marker with every recorded file unchanged; anything else (a project with its own
``Makefile``, ``README.md``, ``main.c``; a generated file edited by hand since) is refused with
an :class:`~fl_design.errors.OutputExistsError` naming the files, unless ``force=True``
(``--force`` on the command line). :func:`record_outputs` adds the files just written.

Examples
--------
>>> from pathlib import Path
>>> from fl_design._output import claim_output_folder, record_outputs
>>> folder = claim_output_folder("made_here")
>>> (folder / "a.txt").write_text("ours")
4
>>> record_outputs(folder, [folder / "a.txt"])
>>> claim_output_folder("made_here").name  # our own earlier output: fine
'made_here'
>>> (folder / "a.txt").write_text("edited by hand")
14
>>> claim_output_folder("made_here")
Traceback (most recent call last):
...
fl_design.errors.OutputExistsError: the output folder 'made_here' holds files fl_design did not write or that changed since: a.txt; ...
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from pathlib import Path

from .errors import OutputExistsError, OutputPathError

#: Name of the marker file recording what fl_design wrote into a folder.
MARKER = ".fl_design_output.json"
_FORMAT = "fl_design output 1"


def _digest(path: Path) -> str | None:
    try:
        if path.is_symlink() or not path.is_file():
            return None
        h = hashlib.sha256()
        with open(path, "rb") as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                h.update(block)
        return h.hexdigest()
    except OSError:
        return None


def _recorded(folder: Path) -> dict | None:
    """``{relative path: sha256}`` of the marker, or None when there is no valid marker."""
    try:
        data = json.loads((folder / MARKER).read_text(encoding="utf-8"))
    except (OSError, ValueError, UnicodeDecodeError):
        return None
    files = data.get("files") if isinstance(data, dict) and data.get("format") == _FORMAT \
        else None
    if not isinstance(files, dict) or not all(isinstance(v, str) for v in files.values()):
        return None
    return files


def _write_marker(folder: Path, files: dict) -> None:
    text = json.dumps({"format": _FORMAT, "files": dict(sorted(files.items()))}, indent=1)
    fd, tmp = tempfile.mkstemp(prefix=".fl_design_output.", dir=folder)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        os.replace(tmp, folder / MARKER)
    finally:
        if os.path.lexists(tmp):
            os.unlink(tmp)


def _foreign(folder: Path) -> list[str]:
    """Entries of ``folder`` that stop us: all of them without a marker, else changed files."""
    recorded = _recorded(folder)
    if recorded is None:
        return sorted(p.name for p in folder.iterdir())
    return sorted(rel for rel, sha in recorded.items()
                  if os.path.lexists(folder / rel) and _digest(folder / rel) != sha)


def claim_output_folder(path, *, force: bool = False, what: str = "output folder") -> Path:
    """``path`` created if needed, after checking that writing into it loses nothing.

    Parameters
    ----------
    path : path-like
        The folder.
    force : bool, optional
        Write even into a folder holding files we did not write (they may be replaced).
    what : str, optional
        How the folder is named in messages (``"--out"``, ``"out_dir"``).

    Returns
    -------
    pathlib.Path

    Raises
    ------
    OutputExistsError
        The folder holds files fl_design did not write, or files it wrote that changed since
        (the message names up to five and says ``--force`` / ``force=True``).
    OutputPathError
        The path is empty, not a folder, or cannot be created or written.

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
    try:
        folder.mkdir(parents=True, exist_ok=True)
        foreign = [] if force else _foreign(folder)
    except OSError as exc:
        raise OutputPathError(f"the {what} {str(path)!r} cannot be used as the output folder "
                              f"({exc.strerror or exc}); give a folder that can be created and "
                              "written") from None
    if foreign:
        shown = ", ".join(foreign[:5]) + (f" and {len(foreign) - 5} more" if len(foreign) > 5
                                          else "")
        raise OutputExistsError(
            f"the {what} {str(path)!r} holds files fl_design did not write or that changed "
            f"since: {shown}; choose an empty or new folder, or pass --force (force=True) to "
            "write there anyway")
    try:
        files = _recorded(folder) or {}
        _write_marker(folder, files)
    except OSError as exc:
        raise OutputPathError(f"cannot write to the {what} {str(path)!r}: "
                              f"{exc.strerror or exc}") from None
    return folder


def record_outputs(folder, paths) -> None:
    """Add ``paths`` (files just written into ``folder`` or below) to its marker.

    Parameters
    ----------
    folder : path-like
        A folder returned by :func:`claim_output_folder`.
    paths : iterable of path-like
        Files written (absolute, or relative to the working directory).

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
    files = _recorded(folder) or {}
    base = folder.resolve()
    for p in paths:
        p = Path(p)
        sha = _digest(p)
        if sha is None:
            continue
        try:
            rel = p.resolve().relative_to(base)
        except ValueError:
            continue  # not inside the folder
        files[rel.as_posix()] = sha
    try:
        _write_marker(folder, files)
    except OSError as exc:
        raise OutputPathError(f"cannot write the marker {MARKER} into {str(folder)!r}: "
                              f"{exc.strerror or exc}") from None


__all__ = ["MARKER", "claim_output_folder", "record_outputs"]
