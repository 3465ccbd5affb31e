"""pandas, optional: one ``to_frame`` for every result with ``columns()`` (a clear error without it).

Examples
--------
>>> import fl_design as fl
>>> from fl_design._frames import data_frame
>>> try:
...     frame = data_frame({"t": [0.0, 0.1]}, "Response.to_frame", "Response.columns")
... except fl.errors.MissingDependencyError:
...     frame = None  # pandas is optional
>>> frame is None or frame.shape == (2, 1)
True
"""

from __future__ import annotations


def data_frame(columns: dict, what: str, instead: str):
    """``pandas.DataFrame(columns)``; :class:`~fl_design.errors.MissingDependencyError` naming
    ``what`` and the pandas-free ``instead`` when pandas is not installed.

    Parameters
    ----------
    columns : dict
        Column name -> 1-D array.
    what : str
        The method asking (e.g. ``"Ensemble.to_frame"``).
    instead : str
        What needs nothing (e.g. ``"Ensemble.to_dict / Ensemble.columns"``).

    Returns
    -------
    pandas.DataFrame

    Raises
    ------
    MissingDependencyError
        pandas is not installed.

    Examples
    --------
    See the module.
    """
    try:
        import pandas as pd
    except ImportError:
        from .errors import MissingDependencyError

        raise MissingDependencyError(
            f"{what} needs pandas, which is not installed: pip install pandas (or use "
            f"{instead}, which need nothing)") from None
    return pd.DataFrame(columns)


class ColumnFrame:
    """Mixin of a result whose ``columns()`` is a ``{name: 1-D array}`` table: ``to_frame()``.

    A subclass names its pandas-free exports in ``_FRAME_INSTEAD`` (the error message points
    there when pandas is missing).

    Examples
    --------
    >>> import fl_design as fl
    >>> resp = fl.simulate(fl.plants.pendulum(), fl.presets.pendulum_design(),
    ...                    fl.Scenario(0.1, 0.05))
    >>> try:
    ...     frame = resp.to_frame()
    ... except fl.errors.MissingDependencyError:
    ...     frame = None  # pandas is optional
    >>> frame is None or list(frame.columns) == list(resp.columns())
    True
    """

    _FRAME_INSTEAD = "columns"

    def to_frame(self):
        """The table :meth:`columns` as a ``pandas.DataFrame``, one row per entry.

        Returns
        -------
        pandas.DataFrame

        Raises
        ------
        MissingDependencyError
            pandas is not installed (``pip install pandas``); the message names the exports
            that need nothing.

        Examples
        --------
        See :class:`ColumnFrame`.
        """
        name = type(self).__name__
        instead = " / ".join(f"{name}.{m}" for m in self._FRAME_INSTEAD.split())
        return data_frame(self.columns(), f"{name}.to_frame", instead)


__all__ = ["ColumnFrame", "data_frame"]
