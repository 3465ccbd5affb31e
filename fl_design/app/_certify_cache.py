"""The main job's certification results cached on disk by content (signed, private).

The certify stage (LMI certificates through CVXPY/Clarabel, the frozen and linearized eps*
curves) depends only on the plant's definition, the configuration tables it reads and the code
computing it; it costs seconds (CVXPY's import alone about 1.5 s) and gives the same numbers
every time. :func:`cached_certify` stores its results in the private cache folder
(:func:`fl_design._cache.cache_directory`) through the signed store of
:mod:`fl_design.symbolic._derivation_cache`: an entry is unpickled only when its HMAC under
the per-user key verifies, so a file another user wrote is never loaded. The key is the
SHA-256 of

* the plant's derivation key (its definition and the deriving code,
  :func:`fl_design.symbolic._derivation_cache.plant_key`);
* the ``[plant]``, ``[design]`` and ``[certify]`` tables and ``[sweep] eps`` (JSON, floats
  exact), and whether the run is quick;
* every source file of fl_design but the presentation (:data:`PRESENTATION`: plots, report,
  console, command line), and the versions of Python, NumPy, SciPy, CVXPY and Clarabel (read
  from the installed metadata: nothing is imported).

Errors are never cached; a plant without a key (not representable) is always computed.

Examples
--------
>>> from fl_design.app._certify_cache import source_version
>>> len(source_version())
64
"""

from __future__ import annotations

import functools
import hashlib
import json
import sys
from importlib import metadata
from pathlib import Path

from ..symbolic._derivation_cache import PlantStore

#: Bumped when the layout of the stored results changes.
FORMAT = "fl_design certify results 1"
_PACKAGES = ("numpy", "scipy", "cvxpy", "clarabel")
#: Sources that only present results (never part of the key): editing a figure or the report's
#: wording keeps the cached certificates.
PRESENTATION = ("plotting.py", "app/_report*.py", "app/_console.py", "app/_cli.py")


def _version(package: str) -> str:
    try:
        return metadata.version(package)
    except metadata.PackageNotFoundError:
        return "absent"


@functools.lru_cache(maxsize=1)
def source_version() -> str:
    """SHA-256 of fl_design's sources (but :data:`PRESENTATION`) and the libraries' versions.

    Returns
    -------
    str
        64 hexadecimal digits.

    Examples
    --------
    >>> from fl_design.app._certify_cache import source_version
    >>> source_version() == source_version()
    True
    """
    root = Path(__file__).resolve().parent.parent
    h = hashlib.sha256()
    for part in (FORMAT, sys.version, *(f"{p} {_version(p)}" for p in _PACKAGES)):
        h.update(f"{part}\n".encode())
    for path in sorted(root.rglob("*.py")):
        if any(path.relative_to(root).match(pattern) for pattern in PRESENTATION):
            continue
        h.update(f"{path.relative_to(root).as_posix()}\n".encode())
        try:
            h.update(path.read_bytes())
        except OSError:  # unreadable source: still a key, only less specific
            h.update(b"?")
    return h.hexdigest()


def certify_key(job, quick: bool) -> str | None:
    """The content key of ``job``'s certify stage; None when the plant has no derivation key.

    Parameters
    ----------
    job : Job
        Prepared (plant and design set).
    quick : bool
        The quick mode (fewer points).

    Returns
    -------
    str or None
        64 hexadecimal digits.

    Examples
    --------
    >>> from fl_design.app import load_config
    >>> from fl_design.app._job import prepare
    >>> from fl_design.app._certify_cache import certify_key
    >>> job = prepare(load_config(None))
    >>> certify_key(job, True) != certify_key(job, False)
    True
    """
    plant_key = getattr(getattr(job.plant, "_store", None), "key", None)
    if plant_key is None:
        return None
    cfg = job.config
    try:
        tables = json.dumps({"plant": cfg.plant, "design": cfg.design, "certify": cfg.certify,
                             "sweep_eps": cfg.sweep.get("eps"), "quick": bool(quick)},
                            sort_keys=True, allow_nan=True)
    except (TypeError, ValueError):
        return None
    parts = (FORMAT, source_version(), plant_key, tables)
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()


def cached_certify(job, quick: bool, compute) -> tuple[dict, bool]:
    """The certify stage's results: from the signed cache, else ``compute()`` (then stored).

    Parameters
    ----------
    job : Job
        Prepared (plant and design set).
    quick : bool
        The quick mode.
    compute : callable
        Computes the results (a dict); its exceptions propagate and nothing is stored.

    Returns
    -------
    (dict, bool)
        The results and whether they came from the cache.

    Examples
    --------
    A job whose plant has no derivation key is always computed:

    >>> from types import SimpleNamespace
    >>> from fl_design.app._certify_cache import cached_certify
    >>> cached_certify(SimpleNamespace(plant=None), True, lambda: {"skipped": "no key"})
    ({'skipped': 'no key'}, False)
    """
    hit = []

    def fresh():
        hit.append(False)
        return compute()

    value = PlantStore(certify_key(job, quick), prefix="certify").get("results", fresh, dict)
    return value, not hit


__all__ = ["FORMAT", "PRESENTATION", "cached_certify", "certify_key", "source_version"]
