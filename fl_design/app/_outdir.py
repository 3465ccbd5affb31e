"""The command line's output folder: created, proved writable and claimed before any work.

Examples
--------
>>> from fl_design.app._outdir import check_out_dir
>>> check_out_dir("out_ok").is_dir()
True
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from .._output import claim_output_folder
from ..errors import OutputPathError


def check_out_dir(path, *, force: bool = False) -> Path:
    """Create ``path`` if needed and prove it writable, before any work (else OutputPathError).

    The folder must be empty or hold fl_design's own earlier output, unchanged
    (:func:`fl_design._output.claim_output_folder`), unless ``force``.

    Parameters
    ----------
    path : str or pathlib.Path
        The output folder.
    force : bool, optional
        Accept a folder holding other files (``--force``).

    Returns
    -------
    pathlib.Path
        The folder, existing and writable.

    Raises
    ------
    OutputPathError
        Empty, not a folder, or not writable.
    OutputExistsError
        Holds files fl_design did not write and ``force`` is False.

    Examples
    --------
    >>> from fl_design.app._outdir import check_out_dir
    >>> check_out_dir("out_ok").is_dir()
    True
    >>> check_out_dir("")
    Traceback (most recent call last):
    ...
    fl_design.errors.OutputPathError: --out is empty: give a folder, e.g. --out out
    """
    if not str(path).strip():
        raise OutputPathError("--out is empty: give a folder, e.g. --out out")
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise OutputPathError(f"--out {str(path)!r} exists and is not a folder")
    try:
        p.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=p, prefix=".fl-design-probe"):
            pass
    except OSError as err:
        raise OutputPathError(f"cannot write to --out {str(path)!r}: "
                              f"{err.strerror or type(err).__name__}") from None
    return claim_output_folder(p, force=force, what="--out")


__all__ = ["check_out_dir"]
