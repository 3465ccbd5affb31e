"""The main job's certify and derive stages cached on disk by content (signed, private).

The certify stage (LMI certificates through CVXPY/Clarabel, the frozen and linearized eps*
curves, the margins) and the derive stage (normal form, sampled model, the printed and
rendered maths) depend only on the plant's definition, the configuration tables they read and
the code computing them; they cost seconds (CVXPY's import alone about 1.5 s, SymPy's printers
and series a few tenths) and give the same results every time. :func:`cached_stage` stores
their results in the private cache folder (:func:`fl_design._cache.cache_directory`) through
the signed store of :mod:`fl_design.symbolic._derivation_cache`: an entry is unpickled only
when its HMAC under the per-user key verifies, so a file another user wrote is never loaded.
The key is the SHA-256 of

* the stage's name and the plant's derivation key (its definition and the deriving code,
  :func:`fl_design.symbolic._derivation_cache.plant_key`);
* the tables the stage reads (:data:`TABLES`; JSON, floats exact) and whether the run is
  quick;
* every source file of fl_design (for certify: but the presentation, :data:`PRESENTATION`:
  plots, report, console, command line), and the versions of Python, NumPy, SciPy, CVXPY and
  Clarabel (read from the installed metadata: nothing is imported).

Errors are never cached; a plant without a key (not representable) is always computed.

Examples
--------
>>> from fl_design.app._stage_cache import source_version
>>> len(source_version())
64
"""

from __future__ import annotations

import functools
import hashlib
import json
import sys
from pathlib import Path

from ..symbolic._derivation_cache import PlantStore, versions_and_sources

#: Bumped when the layout of the stored results changes.
FORMAT = "fl_design stage results 1"
_PACKAGES = ("numpy", "scipy", "cvxpy", "clarabel")
#: Sources that only present results (never part of the key): editing a figure or the report's
#: wording keeps the cached certificates.
PRESENTATION = ("plotting/*.py", "app/_report*.py", "app/_text.py", "app/_brief.py",
                "app/_console.py", "app/_cli.py", "app/_commands.py")
#: Stage -> the configuration it reads (``sweep_eps``: ``[sweep] eps``, the certificates'
#: default range).
TABLES = {"certify": ("plant", "design", "certify", "uncertainty", "sweep_eps"),
          "derive": ("plant",)}


@functools.lru_cache(maxsize=2)
def source_version(presentation: bool = False) -> str:
    """SHA-256 of fl_design's sources and the libraries' versions.

    Parameters
    ----------
    presentation : bool, optional
        Include the :data:`PRESENTATION` sources (the derive stage's text is written by
        ``app/_report.py``); default: leave them out.

    Returns
    -------
    str
        The hex digest of :func:`~fl_design.symbolic._derivation_cache.versions_and_sources`.

    Examples
    --------
    >>> from fl_design.app._stage_cache import source_version
    >>> source_version() == source_version() != source_version(True)
    True
    """
    root = Path(__file__).resolve().parent.parent
    paths = [p for p in root.rglob("*.py") if presentation or
             not any(p.relative_to(root).match(pattern) for pattern in PRESENTATION)]
    return versions_and_sources((FORMAT, sys.version), _PACKAGES, paths)


def stage_key(setup, stage: str, quick: bool) -> str | None:
    """The content key of ``stage`` for ``setup``; None when the plant has no derivation key.

    Parameters
    ----------
    setup : Setup
        The config's objects (:func:`fl_design.app._build.build_setup`): its config and plant
        are read.
    stage : str
        ``"certify"`` or ``"derive"`` (:data:`TABLES`).
    quick : bool
        The quick mode (fewer points).

    Returns
    -------
    str or None
        A SHA-256 hex digest of the stage's tables, the plant's key and the sources.

    Examples
    --------
    The quick mode and every table the stage reads are part of the key:

    >>> from fl_design.app import load_config
    >>> from fl_design.app._build import build_setup
    >>> from fl_design.app._stage_cache import stage_key
    >>> s = build_setup(load_config(None))
    >>> stage_key(s, "certify", True) != stage_key(s, "certify", False)
    True
    """
    plant_key = getattr(getattr(setup.plant, "_store", None), "key", None)
    if plant_key is None:
        return None
    from ._tables import table_dict

    cfg = setup.config
    read = {"sweep_eps": cfg.sweep.eps} if "sweep_eps" in TABLES[stage] else {}
    read |= {name: None if getattr(cfg, name) is None else table_dict(getattr(cfg, name))
             for name in TABLES[stage] if name != "sweep_eps"}
    try:
        tables = json.dumps({**read, "quick": bool(quick)}, sort_keys=True, allow_nan=True)
    except (TypeError, ValueError):
        return None
    parts = (FORMAT, stage, source_version(stage == "derive"), plant_key, tables)
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()


def cached_stage(setup, stage: str, quick: bool, compute) -> tuple[dict, bool]:
    """A stage's results: from the signed cache, else ``compute()`` (then stored).

    Parameters
    ----------
    setup : Setup
        The config's objects (its config and plant are read).
    stage : str
        ``"certify"`` or ``"derive"``.
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
    A setup whose plant has no derivation key is always computed:

    >>> from types import SimpleNamespace
    >>> from fl_design.app._stage_cache import cached_stage
    >>> cached_stage(SimpleNamespace(plant=None), "certify", True, lambda: {"skipped": "no key"})
    ({'skipped': 'no key'}, False)
    """
    hit = []

    def fresh():
        hit.append(False)
        return compute()

    store = PlantStore(stage_key(setup, stage, quick), prefix=stage)
    return store.get("results", fresh, dict), not hit


class _Miss(Exception):
    """Raised by :func:`cached_results`'s compute: nothing is cached (nothing is stored)."""


def cached_results(setup, stage: str, quick: bool) -> dict | None:
    """A stage's cached results, or None: a lookup that never computes (nor stores).

    Parameters
    ----------
    setup : Setup
    stage : str
        ``"certify"`` or ``"derive"``.
    quick : bool

    Returns
    -------
    dict or None
        The results as :func:`cached_stage` stored them; None when they are not cached (or
        the plant has no derivation key).

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> from fl_design.app._stage_cache import cached_results
    >>> cached_results(SimpleNamespace(plant=None), "certify", True) is None  # no key
    True
    """
    def miss():
        raise _Miss

    try:
        return cached_stage(setup, stage, quick, miss)[0]
    except _Miss:
        return None


__all__ = ["FORMAT", "PRESENTATION", "TABLES", "cached_results", "cached_stage",
           "source_version", "stage_key"]
