"""A plant's derivations cached on disk by content, across processes.

What a :class:`fl_design.Plant` derives (its operating point and equilibrium input, relative
degree and Lie chain, normal form, the bounds of ``b``, the CasADi functions ``f, h, sigma,
b``) depends only on its definition and on the code deriving it. Each quantity is stored
(pickled; CasADi functions pickle through their own serialization) in the private cache
directory of the compiled kernels (:func:`fl_design._cache.cache_directory`,
``$FL_DESIGN_CACHE``), under a name made from the SHA-256 of

* the definition: ``srepr`` of the states, input, right-hand side and output (symbol
  assumptions included), every parameter value (``float.hex``), name, input range, region and
  operating point as given;
* the code: the SHA-256 of the sources of :mod:`fl_design.symbolic` and of fl_design's private
  top-level modules, and the versions of fl_design, Python, SymPy, CasADi, NumPy and SciPy
  (read from the installed packages' metadata, without importing them);

(a library plant, known before SymPy by its recipe, is keyed by
:meth:`~fl_design.symbolic._recipe.Recipe.key` instead: its values, this code version and its
package's sources), with the size/SHA-256 sidecar of :mod:`fl_design._cache`, and signed: each
file starts with an HMAC-SHA256 of its name and payload under the per-user key, which lives
outside the cache folder, in the user's config folder (:func:`fl_design._cache.user_key`,
mode 0600), and the sidecar is signed with it too. Nothing is unpickled unless its signature
verifies, so a file written by anyone who cannot read that key (a planted pickle, an entry
re-signed with a key shipped inside a copied folder, a folder copied from another machine or
user) is never loaded. A quantity read from the cache is
identical to a fresh derivation (tests compare every one). A file that does not match its
sidecar or signature, or does not unpickle to the expected type, is recomputed and rewritten,
with one :class:`~fl_design.errors.CacheWarning` per process. A cache folder that is not
private (:func:`fl_design._cache.check_private`) is not used, with one
:class:`~fl_design.errors.UnsafeCacheWarning`; a cache that cannot be read or written is
silently bypassed (the plant computes, as without a cache). Errors are never cached.

Examples
--------
>>> import fl_design as fl
>>> from fl_design.symbolic._derivation_cache import code_version
>>> len(code_version())
64
"""

from __future__ import annotations

import functools
import hashlib
import hmac
import pickle
import sys
import warnings
from pathlib import Path

from .._cache import cache_directory, read_verified, user_key, write_verified
from ..errors import CacheWarning, ComputationError, UnsafeCacheError, UnsafeCacheWarning

#: Bumped when the layout of the stored quantities changes.
FORMAT = "fl_design plant derivations 2 (HMAC-SHA256 signed)"
_MAC_BYTES = 32
_WARNED: set = set()  # the process has warned about a bad entry


def versions_and_sources(parts, packages, paths) -> str:
    """SHA-256 of text ``parts``, the installed versions of ``packages`` and the source files.

    Versions come from the packages' metadata (nothing is imported; ``"absent"`` when not
    installed); each file adds its folder and name, then its bytes (``?`` when unreadable:
    still a key, only less specific).

    Parameters
    ----------
    parts : iterable of str
        Format tags, versions, anything else the key depends on.
    packages : iterable of str
        Distribution names (``"sympy"``...).
    paths : iterable of pathlib.Path
        Source files, hashed in sorted order.

    Returns
    -------
    str
        64 hexadecimal digits, equal for equal inputs and equal file contents.

    Examples
    --------
    >>> from fl_design.symbolic._derivation_cache import versions_and_sources
    >>> a = versions_and_sources(["x"], ["numpy"], [])
    >>> a == versions_and_sources(["x"], ["numpy"], []) != versions_and_sources(["y"], [], [])
    True
    """
    from importlib import metadata

    def version(package: str) -> str:
        try:
            return metadata.version(package)
        except metadata.PackageNotFoundError:
            return "absent"

    h = hashlib.sha256()
    for part in (*parts, *(f"{p} {version(p)}" for p in packages)):
        h.update(f"{part}\n".encode())
    for path in sorted(paths):
        h.update(f"{path.parent.name}/{path.name}\n".encode())
        try:
            h.update(path.read_bytes())
        except OSError:
            h.update(b"?")
    return h.hexdigest()


@functools.lru_cache(maxsize=1)
def code_version() -> str:
    """SHA-256 of the deriving code (sources, library versions): part of every plant key.

    Returns
    -------
    str
        64 hexadecimal digits; they change with any source of :mod:`fl_design.symbolic` or
        ``fl_design/_*.py``, fl_design's version, Python's, or SymPy, CasADi, NumPy, SciPy's.

    Examples
    --------
    >>> from fl_design.symbolic._derivation_cache import code_version
    >>> code_version() == code_version()
    True
    """
    from .. import __version__

    here = Path(__file__).resolve().parent
    return versions_and_sources((FORMAT, __version__, sys.version),
                                ("sympy", "casadi", "numpy", "scipy"),
                                [*here.glob("*.py"), *here.parent.glob("_*.py")])


def plant_key(states, input, rhs, output, params, name, input_range, region,
              operating_point) -> str | None:
    """SHA-256 of a plant definition and :func:`code_version`; None if not representable.

    Parameters
    ----------
    states, input, rhs, output
        SymPy symbols and expressions (validated).
    params : dict
        ``{Symbol: float}``.
    name : str
    input_range : (float, float) or None
    region : dict or None
        ``{Symbol: (lo, hi)}``.
    operating_point : dict or None
        As given to :class:`fl_design.Plant` (keys symbols or names, values numbers).

    Returns
    -------
    str or None
        64 hexadecimal digits; None when an expression is too deep to write out (not cached).

    Examples
    --------
    >>> import sympy as sp
    >>> from fl_design.symbolic._derivation_cache import plant_key
    >>> x, u = sp.symbols("x u")
    >>> k = plant_key((x,), u, sp.Matrix([u - x]), x, {}, "p", None, None, None)
    >>> k == plant_key((x,), u, sp.Matrix([u - x]), x, {}, "p", None, None, {x: 0.5})
    False
    """
    import sympy as sp

    def num(v) -> str:
        return float(v).hex() if isinstance(v, (int, float)) or hasattr(v, "__float__") \
            else repr(v)

    def sym(k) -> str:
        return sp.srepr(k) if isinstance(k, sp.Basic) else repr(k)

    try:
        parts = [code_version(), repr(name), sp.srepr(tuple(states)), sp.srepr(input),
                 sp.srepr(tuple(rhs)), sp.srepr(output),
                 repr(sorted((sym(k), num(v)) for k, v in params.items())),
                 repr(None if input_range is None else tuple(num(v) for v in input_range)),
                 repr(None if region is None else sorted(
                     (sym(k), tuple(num(v) for v in lohi)) for k, lohi in region.items())),
                 repr(None if operating_point is None else sorted(
                     (sym(k), num(v)) for k, v in dict(operating_point).items()))]
    except (TypeError, ValueError, AttributeError, OverflowError, RecursionError):
        return None  # a very deep expression: not cached (computed, as without a cache)
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()


def _as_stored(value) -> tuple[object, bytes | None]:
    """``(value as a later process reads it, its pickle)``; ``(value, None)`` if unpicklable.

    A fresh result goes through the same pickle round trip as a cached one, so the two are
    identical whether or not a cache is in use: SymPy rebuilds an expression from its arguments
    when unpickling, which may regroup it (``-(c*w + g)`` becomes ``-c*w - g``, equal but not the
    same tree).
    """
    try:
        data = pickle.dumps(value, protocol=pickle.HIGHEST_PROTOCOL)
    except (pickle.PicklingError, TypeError, AttributeError, RecursionError, RuntimeError):
        return value, None  # not stored: computed each time, as without a cache
    try:
        return pickle.loads(data), data
    except Exception:  # noqa: BLE001 (what does not load back is not stored)
        return value, None


def _warn_once(message: str, category=CacheWarning) -> None:
    if category not in _WARNED:
        _WARNED.add(category)
        warnings.warn(message, category, stacklevel=4)


def _mac(key: bytes, name: str, payload: bytes) -> bytes:
    return hmac.new(key, name.encode() + b"\0" + payload, hashlib.sha256).digest()


class PlantStore:
    """Disk cache of one plant's derived quantities (see the module docstring).

    Parameters
    ----------
    key : str or None
        :func:`plant_key` of the plant; None disables the store (every quantity is computed).
    prefix : str, optional
        Start of the file names (``"plant"``); another user of the same signed store (the main
        job's certificates) takes its own, so that keys of different kinds never meet.

    Examples
    --------
    >>> from fl_design.symbolic._derivation_cache import PlantStore
    >>> PlantStore(None).get("rho", lambda: 2)
    2
    """

    def __init__(self, key: str | None, prefix: str = "plant"):
        self.key = key
        self.prefix = prefix

    def _name(self, what: str) -> str:
        return f"{self.prefix}_{self.key[:32]}_{what}.pkl"

    def get(self, what: str, compute, check=None):
        """The quantity ``what``: from the cache, else ``compute()`` (then stored).

        Parameters
        ----------
        what : str
            Name of the quantity (part of the file name).
        compute : callable
            Computes it (exceptions propagate and nothing is stored).
        check : type or tuple of types, optional
            A loaded value must be an instance of it, else the entry counts as corrupted.

        Returns
        -------
        object
        """
        if self.key is None:
            return _as_stored(compute())[0]
        try:
            path = cache_directory() / self._name(what)
            secret = user_key(path.parent)
        except UnsafeCacheError as exc:
            _warn_once(f"{exc}; {self.prefix} results are computed without the cache",
                       UnsafeCacheWarning)
            return _as_stored(compute())[0]
        except (OSError, ComputationError):
            return _as_stored(compute())[0]
        if path.exists():
            value, ok = self._load(path, check, secret)
            if ok:
                return value
            _warn_once(f"the cached {self.prefix} result {path} is corrupted (it does not match its "
                       "recorded size and SHA-256 or its signature, or does not load); "
                       "recomputed and rewritten")
        value, data = _as_stored(compute())
        if data is not None:
            try:
                write_verified(path.name, _mac(secret, path.name, data) + data,
                               cache_dir=path.parent)
            except (OSError, ComputationError):
                pass  # unwritable cache: computed each time, as without a cache
        return value

    @staticmethod
    def _load(path: Path, check, secret: bytes) -> tuple[object, bool]:
        data = read_verified(path)
        if data is None or len(data) <= _MAC_BYTES:
            return None, False
        mac, payload = data[:_MAC_BYTES], data[_MAC_BYTES:]
        if not hmac.compare_digest(mac, _mac(secret, path.name, payload)):
            return None, False  # not written by this user: never unpickled
        try:
            value = pickle.loads(payload)
        except Exception:  # noqa: BLE001 (any failure to unpickle is a bad entry)
            return None, False
        return value, check is None or isinstance(value, check)


__all__ = ["FORMAT", "PlantStore", "code_version", "plant_key", "versions_and_sources"]
