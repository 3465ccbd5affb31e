"""The one serializer of fl_design: strict JSON (no bare ``NaN``/``Infinity``).

Every ``to_dict()`` returns plain Python built by :func:`jsonable`; :func:`dumps` writes it with
``allow_nan=False`` so that a file never holds a bare ``NaN``. Non-finite floats become ``None``
(the result objects say why a number is missing in a field of their own).

Examples
--------
>>> import numpy as np
>>> from fl_design._json import dumps, jsonable
>>> jsonable({"a": np.array([1.0, np.nan]), "b": np.float64(np.inf), "c": (1, 2)})
{'a': [1.0, None], 'b': None, 'c': [1, 2]}
>>> dumps({"x": float("nan")})
'{"x": null}'
"""

from __future__ import annotations

import enum
import json
import math
from pathlib import PurePath

import numpy as np


def jsonable(value):
    """``value`` as plain JSON types: dicts, lists, str, int, finite float, bool, None.

    Parameters
    ----------
    value : object
        Nested dicts/lists/tuples, NumPy arrays and scalars, enums, paths, objects with
        ``to_dict()``; a callable becomes ``"<callable NAME>"``.

    Returns
    -------
    object

    Raises
    ------
    TypeError
        A value with no JSON form (the message names its type).

    Examples
    --------
    >>> from fl_design._json import jsonable
    >>> jsonable([1, float("-inf"), None])
    [1, None, None]
    """
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, enum.Enum):
        return value.name.lower()
    if isinstance(value, (int, np.integer)) and not isinstance(value, np.bool_):
        return int(value)
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, PurePath):
        return str(value)
    if hasattr(value, "to_dict"):
        return jsonable(value.to_dict())
    if callable(value):  # a function has no JSON form: named, so the record says what it was
        return f"<callable {getattr(value, '__name__', type(value).__name__)}>"
    raise TypeError(f"no JSON form for {type(value).__name__}: {value!r}")


def dumps(value, **kwargs) -> str:
    """Strict JSON text of :func:`jsonable` ``(value)`` (``allow_nan=False``).

    Parameters
    ----------
    value : object
        As for :func:`jsonable`.
    **kwargs
        Passed to ``json.dumps`` (e.g. ``indent=2``).

    Returns
    -------
    str
        Strict JSON text (a non-finite float written as ``null``).

    Examples
    --------
    >>> from fl_design._json import dumps
    >>> dumps([1.5, None])
    '[1.5, null]'
    """
    return json.dumps(jsonable(value), allow_nan=False, **kwargs)


__all__ = ["dumps", "jsonable"]
