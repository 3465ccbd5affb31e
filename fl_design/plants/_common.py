"""Helpers shared by the plant modules: validated parameter dictionaries.

Examples
--------
>>> from fl_design.plants._common import positive_params
>>> positive_params(m=0.5, l=1)
{'m': 0.5, 'l': 1.0}
"""

from __future__ import annotations

from .. import _validate as V


def positive_params(**values) -> dict:
    """``{name: float}`` with every value checked finite and > 0 (a ``ParameterError`` names it).

    Parameters
    ----------
    **values : float
        ``name=value`` pairs.

    Returns
    -------
    dict

    Examples
    --------
    >>> from fl_design.plants._common import positive_params
    >>> positive_params(g=9.81)
    {'g': 9.81}
    """
    return {k: V.positive(k, v) for k, v in values.items()}


__all__ = ["positive_params"]
