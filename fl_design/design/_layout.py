"""Named layouts of flat vectors: the design state, the parameter vector, the sweep accumulator.

CasADi functions take and return flat vectors; a :class:`Layout` names their parts once so that
the design, the simulator's accumulator, the C header of :func:`fl_design.generate_c` and the
tests all read the same positions. A layout is also a read-only mapping ``name -> slice``.

Examples
--------
>>> from fl_design.design import Layout
>>> lay = Layout((("xi", 3), ("u", 1), ("z", 1)))
>>> lay["u"], lay.size, lay.offset("z")
(slice(3, 4, None), 5, 4)
>>> lay.unpack([1.0, 2.0, 3.0, 4.0, 5.0])["z"]
array([5.])
"""

from __future__ import annotations

import functools
from collections.abc import Iterator, Mapping
from dataclasses import dataclass

import numpy as np

from ..errors import DimensionError, ParameterError


@dataclass(frozen=True)
class Layout(Mapping):
    """Names and lengths of the consecutive parts of a flat vector.

    Parameters
    ----------
    fields : tuple of (str, int)
        Names (unique) and lengths (>= 1), in order.

    Raises
    ------
    ParameterError
        A repeated name or a length < 1.

    Examples
    --------
    >>> from fl_design.design import Layout
    >>> Layout((("a", 1), ("b", 2))).pack(a=1.0, b=[2.0, 3.0]).ravel().tolist()
    [1.0, 2.0, 3.0]
    """

    fields: tuple

    def __post_init__(self) -> None:
        names = [name for name, _ in self.fields]
        if len(set(names)) != len(names):
            raise ParameterError(f"layout field names must be unique, got {names}")
        bad = [(name, n) for name, n in self.fields if int(n) < 1]
        if bad:
            raise ParameterError(f"layout field lengths must be >= 1, got {bad}")
        object.__setattr__(self, "fields", tuple((str(nm), int(n)) for nm, n in self.fields))

    @functools.cached_property
    def slices(self) -> dict[str, slice]:
        """``{name: slice}`` into the vector."""
        out, start = {}, 0
        for name, length in self.fields:
            out[name] = slice(start, start + length)
            start += length
        return out

    def __getitem__(self, name: str) -> slice:
        return self.slices[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self.slices)

    def __len__(self) -> int:
        return len(self.fields)

    def __hash__(self) -> int:
        return hash(self.fields)

    def __eq__(self, other) -> bool:
        if isinstance(other, Layout):
            return self.fields == other.fields
        if isinstance(other, Mapping):
            return dict(self.slices) == dict(other)
        return NotImplemented

    @property
    def size(self) -> int:
        """Length of the vector."""
        return sum(length for _, length in self.fields)

    def offset(self, name: str) -> int:
        """Index of the first entry of ``name``.

        Parameters
        ----------
        name : str
            A field name.

        Returns
        -------
        int
            Its position in the flat vector.

        Examples
        --------
        >>> from fl_design.design import Layout
        >>> Layout((("a", 2), ("b", 1))).offset("b")
        2
        """
        return self.slices[name].start

    def pack(self, **values) -> np.ndarray:
        """A vector (or a matrix with one column per run) from named values.

        Every field must be given; a value is a scalar, a vector of the field's length, or a
        matrix ``(length, m)`` for ``m`` columns.

        Parameters
        ----------
        **values
            One value per field.

        Returns
        -------
        numpy.ndarray
            ``(size, m)``.

        Raises
        ------
        ParameterError
            A field is missing or unknown.

        Examples
        --------
        >>> from fl_design.design import Layout
        >>> Layout((("a", 1), ("b", 1))).pack(a=0.0, b=[[1.0, 2.0]]).shape
        (2, 2)
        """
        missing = [name for name, _ in self.fields if name not in values]
        unknown = sorted(set(values) - set(self.slices))
        if missing or unknown:
            raise ParameterError(f"layout fields missing: {missing}, unknown: {unknown}")
        cols = max(np.shape(v)[1] if np.ndim(v) == 2 else 1 for v in values.values())
        out = np.empty((self.size, cols))
        for name, length in self.fields:
            value = np.asarray(values[name], dtype=float)
            out[self.slices[name]] = value.reshape(length, -1) if value.ndim else value
        return out

    def unpack(self, vector) -> dict[str, np.ndarray]:
        """Named rows of a vector or of a matrix ``(size, m)`` (length-1 fields as ``(m,)``).

        Parameters
        ----------
        vector : array_like
            ``(size,)`` or ``(size, m)``.

        Returns
        -------
        dict

        Raises
        ------
        DimensionError
            The leading dimension is not :attr:`size`.

        Examples
        --------
        >>> import numpy as np
        >>> from fl_design.design import Layout
        >>> Layout((("a", 1), ("b", 2))).unpack(np.arange(3.0))["b"].ravel().tolist()
        [1.0, 2.0]
        """
        arr = np.asarray(vector, dtype=float)
        if arr.shape[:1] != (self.size,):
            raise DimensionError(f"expected a vector of {self.size} entries ({self.names()}), "
                                 f"got shape {arr.shape}")
        arr = arr.reshape(self.size, -1)
        return {name: (arr[self.slices[name]][0] if length == 1 else arr[self.slices[name]])
                for name, length in self.fields}

    def names(self) -> str:
        """``"a (1), b (2)"``: the fields, for messages and headers.

        Examples
        --------
        >>> from fl_design.design import Layout
        >>> Layout((("a", 1), ("b", 2))).names()
        'a (1), b (2)'
        """
        return ", ".join(f"{name} ({length})" for name, length in self.fields)

    def to_dict(self) -> dict:
        """``{name: [start, length]}`` in order (strict JSON).

        Examples
        --------
        >>> from fl_design.design import Layout
        >>> Layout((("a", 1), ("b", 2))).to_dict()
        {'a': [0, 1], 'b': [1, 2]}
        """
        return {name: [self.slices[name].start, length] for name, length in self.fields}


__all__ = ["Layout"]
