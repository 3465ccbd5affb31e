"""Pickling for our own child processes: read-only mappings pickled as themselves.

Used by the tuner's background process and the main job's certify stage (a child process).

The config's tables hold read-only mappings (``types.MappingProxyType``), which the standard
pickler refuses; :func:`dumps` pickles them as read-only mappings again. The bytes go only from
this process to its own children through a pipe (never to or from a file).

Examples
--------
>>> import pickle
>>> from fl_design._pickle import dumps
>>> pickle.loads(dumps([1, 2]))
[1, 2]
"""

from __future__ import annotations

import copyreg
import io
import pickle
from types import MappingProxyType


def read_only(d: dict) -> MappingProxyType:
    """A read-only view of ``d`` (what unpickling a pickled read-only mapping makes)."""
    return MappingProxyType(d)


class _Pickler(pickle.Pickler):
    """Pickles read-only mappings (the config's tables hold some) as themselves."""

    dispatch_table = copyreg.dispatch_table.copy()
    dispatch_table[MappingProxyType] = lambda m: (read_only, (dict(m),))


def dumps(obj) -> bytes:
    """``obj`` pickled for a child process (read-only mappings included).

    Examples
    --------
    >>> import pickle
    >>> from types import MappingProxyType
    >>> from fl_design._pickle import dumps
    >>> pickle.loads(dumps({"t": MappingProxyType({"b": 2.0})}))["t"]["b"]
    2.0
    """
    buf = io.BytesIO()
    _Pickler(buf, protocol=pickle.HIGHEST_PROTOCOL).dump(obj)
    return buf.getvalue()


__all__ = ["dumps", "read_only"]
