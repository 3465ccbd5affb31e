"""eps* on a sweep's grid: :class:`EpsStar` (``lower <= eps* < upper``), the boundary where
the loops first fail along eps (:func:`eps_boundary`) and a grid value's index
(:func:`grid_index`); :class:`~fl_design.sim.StabilityMap` and
:class:`~fl_design.sim.RobustMap` read their eps* through these.

Examples
--------
>>> import numpy as np
>>> from fl_design.sim._eps_star import eps_boundary
>>> print(eps_boundary(np.array([0.01, 0.02]), np.array([True, False]), lambda i: "diverged"))
0.01 (fails at 0.02)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import _validate as V
from .._json import jsonable
from ..errors import ParameterError
from ._status import Status


@dataclass(frozen=True)
class EpsStar:
    """Where the boundary eps* lies on a grid: ``lower <= eps* < upper``.

    ``lower`` is the largest grid eps such that every grid eps' <= it converges (converging or
    converged); ``upper`` the first grid eps that does not. No boundary in the scanned range
    is said as such: ``upper = inf`` ("> eps_max": every eps converged, eps* lies above the
    range) or ``lower = nan`` ("< eps_min": even the smallest eps failed). When the run at
    ``upper`` is ``undecided`` (bounded, a trend the run is too short to call),
    the text says so instead of "fails at": the bracket is then a lower bound that a longer run
    may raise.

    Parameters
    ----------
    lower, upper : float
        The bracket on the grid.
    upper_status : str, optional
        Status label of the run at ``upper`` (None when unknown or ``upper`` is infinite).

    Examples
    --------
    >>> from fl_design.sim import EpsStar
    >>> str(EpsStar(1.0, float("inf"))), EpsStar(1.0, float("inf")).value
    ('> 1', None)
    >>> str(EpsStar(float("nan"), 0.01)), EpsStar(0.02, 0.04).value
    ('< 0.01', 0.02)
    >>> str(EpsStar(0.0417487, 0.04174874))  # a narrow bracket keeps the digits it needs
    '0.0417487 (fails at 0.04174874)'
    >>> str(EpsStar(0.35, 0.49, "undecided")), str(EpsStar(float("nan"), 0.005, "undecided"))
    ('0.35 (undecided at 0.49: run longer)', '< 0.005 (undecided at 0.005: run longer)')
    """

    lower: float
    upper: float
    upper_status: str | None = None

    @property
    def undecided(self) -> bool:
        """The first eps that does not converge is ``undecided``, not a failure."""
        return self.upper_status == Status.UNDECIDED.label

    @property
    def value(self) -> float | None:
        """``lower`` when the boundary lies inside the range, else None (it is outside)."""
        return self.lower if math.isfinite(self.lower) and math.isfinite(self.upper) else None

    @property
    def above_range(self) -> bool:
        """Every scanned eps converged: eps* is larger than the range."""
        return not math.isfinite(self.upper)

    @property
    def below_range(self) -> bool:
        """Even the smallest scanned eps failed: eps* is below the range."""
        return math.isnan(self.lower)

    def __str__(self) -> str:
        if self.above_range:
            return f"> {self.lower:g}"
        if self.below_range:
            return f"< {self.upper:g}" + (
                f" (undecided at {self.upper:g}: run longer)" if self.undecided else "")
        digits = next((n for n in range(6, 18) if f"{self.lower:.{n}g}" != f"{self.upper:.{n}g}"),
                      17)  # enough digits to tell a narrow bisection bracket's ends apart
        if self.undecided:
            return f"{self.lower:.{digits}g} (undecided at {self.upper:.{digits}g}: run longer)"
        return f"{self.lower:.{digits}g} (fails at {self.upper:.{digits}g})"

    def to_dict(self) -> dict:
        """Strict JSON: ``lower``, ``upper`` (None when unbounded), ``upper_status``, ``text``.

        Examples
        --------
        >>> from fl_design.sim import EpsStar
        >>> EpsStar(0.5, float("inf")).to_dict()
        {'lower': 0.5, 'upper': None, 'upper_status': None, 'text': '> 0.5'}
        """
        return jsonable({"lower": self.lower, "upper": self.upper,
                         "upper_status": self.upper_status, "text": str(self)})


def grid_index(grid: np.ndarray, value, name: str) -> int:
    """The index of ``value`` in a sweep's ``grid`` (equal to a relative ``1e-9``).

    Parameters
    ----------
    grid : numpy.ndarray
        The sweep's eps or gamma values.
    value : float
        A value of the grid: positive, or for ``gamma`` nonzero (negative when ``b < 0``).
    name : str
        The argument's name, for the error.

    Returns
    -------
    int
        The position of ``value`` in ``grid`` (the first, were it there twice).

    Raises
    ------
    ParameterError
        ``value`` is not on the grid (the message lists the grid).

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.sim._stability_map import grid_index
    >>> grid_index(np.array([0.01, 0.02]), 0.02, "eps")
    1
    """
    value = V.nonzero(name, value) if name == "gamma" else V.positive(name, value)
    hits = np.flatnonzero(np.isclose(grid, value, rtol=1e-9, atol=0.0))
    if hits.size == 0:
        raise ParameterError(f"{name}={value!r} is not on the sweep's grid; choose one of "
                             f"{[float(g) for g in grid]}")
    return int(hits[0])


def eps_boundary(eps: np.ndarray, ok: np.ndarray, status_at) -> EpsStar:
    """The empirical eps* along an increasing eps grid: where ``ok`` first fails.

    Parameters
    ----------
    eps : numpy.ndarray
        ``(n_e,)`` increasing grid values.
    ok : numpy.ndarray
        ``(n_e,)`` bool: the loop (or enough of a family's loops) converges at ``eps[i]``.
    status_at : callable
        ``status_at(i)``: the verdict label given as ``upper_status`` at the first failure.

    Returns
    -------
    EpsStar
        ``lower`` the grid eps before the first failure (NaN when the first one fails),
        ``upper`` the first failure (``inf`` when none fails).

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.sim._stability_map import eps_boundary
    >>> str(eps_boundary(np.array([0.1, 0.2, 0.4]), np.array([True, True, False]),
    ...                  lambda i: "diverged"))
    '0.2 (fails at 0.4)'
    """
    bad = np.flatnonzero(~np.asarray(ok, dtype=bool))
    if not bad.size:
        return EpsStar(float(eps[-1]), math.inf)
    lower = math.nan if bad[0] == 0 else float(eps[bad[0] - 1])
    return EpsStar(lower, float(eps[bad[0]]), status_at(int(bad[0])))


__all__ = ["EpsStar", "eps_boundary", "grid_index"]
