"""pandas, optional: one ``to_frame`` for every result with ``columns()`` (a clear error without it).

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

from __future__ import annotations


class ColumnFrame:
    """Mixin of a result whose ``columns()`` is a ``{name: 1-D array}`` table: ``to_frame()``.

    A subclass names its pandas-free exports in ``_FRAME_INSTEAD`` (space-separated method
    names): the error raised without pandas points there.

    Examples
    --------
    See the module.
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
        See :mod:`fl_design._frames`.
        """
        name = type(self).__name__
        try:
            import pandas as pd
        except ImportError:
            from .errors import MissingDependencyError

            instead = " / ".join(f"{name}.{m}" for m in self._FRAME_INSTEAD.split())
            raise MissingDependencyError(
                f"{name}.to_frame needs pandas, which is not installed: pip install pandas "
                f"(or use {instead}, which need nothing)") from None
        return pd.DataFrame(self.columns())


__all__ = ["ColumnFrame"]
