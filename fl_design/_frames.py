"""pandas, optional: one rule for every ``to_frame`` (a clear error when it is missing).

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


__all__ = ["data_frame"]
