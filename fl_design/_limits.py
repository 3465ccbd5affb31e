"""Resource limits that a user can lift with an environment variable: one reader for all.

Work that could exhaust memory or time is refused up front with a
:class:`~fl_design.errors.ResourceLimitError` naming the limit and its variable:
``FL_DESIGN_MAX_SAMPLES`` (samples of one run), ``FL_DESIGN_MAX_MEMORY_GB`` (results of a
grid), ``FL_DESIGN_MAX_WINDOW`` (least-squares window).

Examples
--------
>>> from fl_design._limits import env_limit
>>> env_limit("FL_DESIGN_NO_SUCH_LIMIT", 5, unit="samples")
5
"""

from __future__ import annotations

import os

from .errors import ParameterError


def env_limit(name: str, default: float, *, unit: str, scale: float = 1.0,
              integer: bool = True):
    """``$name`` (times ``scale``) if set, else ``default``; a bad value is a clear error.

    Parameters
    ----------
    name : str
        Environment variable.
    default : float
        Value when the variable is unset or empty (already scaled).
    unit : str
        What the number counts, for the error message (``"samples"``, ``"GiB"``).
    scale : float, optional
        Factor applied to the variable's value (e.g. ``2**30`` for GiB -> bytes).
    integer : bool, optional
        Return an int (default) or a float.

    Returns
    -------
    int or float

    Raises
    ------
    ParameterError
        The variable is set to something that is not a positive number.

    Examples
    --------
    >>> import os
    >>> from fl_design._limits import env_limit
    >>> os.environ["FL_DOC_LIMIT"] = "2"
    >>> env_limit("FL_DOC_LIMIT", 1.0, unit="GiB", scale=2**30, integer=False)
    2147483648.0
    """
    text = os.environ.get(name, "").strip()
    if not text:
        return default
    try:
        value = float(text) * scale
    except ValueError:
        value = float("nan")
    if not value > 0:
        raise ParameterError(f"${name}={text!r} must be a positive number of {unit}")
    return int(value) if integer else value


__all__ = ["env_limit"]
