"""The result of a sweep: :class:`StabilityMap` over (eps, gamma), and :class:`EpsStarEstimate`.

Examples
--------
>>> import numpy as np
>>> from fl_design.sim import StabilityMap
>>> m = StabilityMap(eps=np.array([0.01, 0.02]), gamma=np.array([1e-3]),
...                  status=np.array([[1], [-1]]), metrics={}, T=1e-3, duration=1.0, tol=1e-3)
>>> m.eps_star(1e-3)
0.01
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .. import _validate as V
from .._json import jsonable
from ..errors import ParameterError
from ._metrics import STATUS_CODES, Status


# --- the result ------------------------------------------------------------------------------
@dataclass(frozen=True)
class StabilityMap:
    """Classification and metrics of every (eps, gamma) run of a sweep.

    Parameters
    ----------
    eps : numpy.ndarray
        ``(n_e,)`` increasing observer time constants.
    gamma : numpy.ndarray
        ``(n_g,)`` increasing controller gains.
    status : numpy.ndarray
        ``(n_e, n_g)`` int codes of :class:`fl_design.sim.Status` (1 stable, 0 undecided, -1
        diverged).
    metrics : dict
        Name -> ``(n_e, n_g)`` array (``estimation_rms``: ``(n_e, n_g, rho + 1)``), see
        :mod:`fl_design.sim`.
    T, duration, tol : float
        Sampling time, run length, absolute tolerance of the classification.

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.sim import StabilityMap
    >>> m = StabilityMap(eps=np.array([0.01, 0.02, 0.04]), gamma=np.array([1e-3, 1e-2]),
    ...                  status=np.array([[1, 1], [1, 0], [-1, 1]]), metrics={},
    ...                  T=1e-3, duration=1.0, tol=1e-3)
    >>> m.eps_star(1e-3), m.eps_star(1e-2), m.gamma_bounds(0.02)
    (0.02, 0.01, (0.001, 0.001))
    """

    eps: np.ndarray
    gamma: np.ndarray
    status: np.ndarray
    metrics: dict = field(repr=False)
    T: float
    duration: float
    tol: float

    @property
    def labels(self) -> np.ndarray:
        """``status`` as strings ``'stable'``, ``'undecided'``, ``'diverged'``."""
        labels = np.array([Status(int(c)).label for c in np.ravel(self.status)], dtype=object)
        return labels.reshape(np.shape(self.status)).astype(str)

    def _index(self, grid: np.ndarray, value, name: str) -> int:
        value = V.positive(name, value)
        hits = np.flatnonzero(np.isclose(grid, value, rtol=1e-9, atol=0.0))
        if hits.size == 0:
            raise ParameterError(
                f"{name}={value!r} is not on the sweep's grid; choose one of "
                f"{[float(g) for g in grid]}"
            )
        return int(hits[0])

    def eps_star(self, gamma: float) -> float:
        """Empirical eps*: the largest grid eps such that every grid eps' <= eps is stable.

        Parameters
        ----------
        gamma : float
            A gamma of the grid.

        Returns
        -------
        float
            NaN if the smallest eps is not stable; the largest eps if all are (a lower bound).

        Examples
        --------
        >>> import numpy as np
        >>> from fl_design.sim import StabilityMap
        >>> StabilityMap(np.array([1.0, 2.0]), np.array([0.5]), np.array([[0], [1]]), {},
        ...              1e-3, 1.0, 0.1).eps_star(0.5)
        nan
        """
        col = np.asarray(self.status)[:, self._index(self.gamma, gamma, "gamma")]
        bad = np.flatnonzero(col != STATUS_CODES["stable"])
        if bad.size and bad[0] == 0:
            return math.nan
        return float(self.eps[(bad[0] if bad.size else col.size) - 1])

    def gamma_bounds(self, eps: float, *, around: float | None = None) -> tuple[float, float]:
        """``(lowest, highest)`` grid gamma of a contiguous run of stable gammas at ``eps``.

        The run is the one containing ``around`` (e.g. the design's gamma) when given, else the
        longest one (the lowest-gamma one among equally long runs).

        Parameters
        ----------
        eps : float
            An eps of the grid.
        around : float, optional
            A gamma of the grid the run must contain.

        Returns
        -------
        (float, float)
            ``(nan, nan)`` when there is no such run.

        Examples
        --------
        >>> import numpy as np
        >>> from fl_design.sim import StabilityMap
        >>> m = StabilityMap(np.array([0.1]), np.array([1.0, 2.0, 3.0, 4.0, 5.0]),
        ...                  np.array([[1, 0, 1, 1, 0]]), {}, 1e-3, 1.0, 0.1)
        >>> m.gamma_bounds(0.1), m.gamma_bounds(0.1, around=1.0)
        ((3.0, 4.0), (1.0, 1.0))
        """
        row = np.asarray(self.status)[self._index(self.eps, eps, "eps")] == STATUS_CODES["stable"]
        runs, start = [], None
        for j, ok in enumerate([*row, False]):
            if ok and start is None:
                start = j
            elif not ok and start is not None:
                runs.append((start, j - 1))
                start = None
        if around is not None:
            j = self._index(self.gamma, around, "around")
            runs = [run for run in runs if run[0] <= j <= run[1]]
        if not runs:
            return (math.nan, math.nan)
        lo, hi = max(runs, key=lambda run: (run[1] - run[0], -run[0]))
        return (float(self.gamma[lo]), float(self.gamma[hi]))

    def to_dict(self) -> dict:
        """Grid, status labels and metrics as lists (NaN as None), ready for JSON.

        Examples
        --------
        >>> import numpy as np
        >>> from fl_design.sim import StabilityMap
        >>> m = StabilityMap(np.array([0.1]), np.array([1.0]), np.array([[1]]),
        ...                  {"iae": np.array([[np.nan]])}, 1e-3, 1.0, 0.1)
        >>> m.to_dict()["metrics"], m.to_dict()["status"]
        ({'iae': [[None]]}, [['stable']])
        """
        return jsonable({"eps": self.eps, "gamma": self.gamma, "status": self.labels.tolist(),
                         "T": self.T, "duration": self.duration, "tol": self.tol,
                         "metrics": self.metrics})

    def plot(self, *, ax=None, curves=None, show_eps_star: bool = True):
        """Heat map of the classification over (gamma, eps), log axes, with eps*(gamma) curves.

        Parameters
        ----------
        ax : matplotlib Axes, optional
            Where to draw (default a new figure).
        curves : dict, optional
            ``{label: curve}`` overlaid, a curve being a callable ``gamma -> eps`` (evaluated on
            the grid's gammas) or a pair ``(gamma_values, eps_values)``.
        show_eps_star : bool, optional
            Also draw this map's empirical ``eps_star`` (default True).

        Returns
        -------
        matplotlib.figure.Figure

        Examples
        --------
        >>> import numpy as np
        >>> from fl_design.sim import StabilityMap
        >>> m = StabilityMap(np.array([0.1, 0.2]), np.array([1.0, 2.0]),
        ...                  np.array([[1, 1], [0, -1]]), {}, 1e-3, 1.0, 0.1)
        >>> fig = m.plot(curves={"bound": lambda g: 0.15 / g})
        >>> len(fig.axes) >= 1
        True
        """
        from ..plotting import plot_stability_map

        return plot_stability_map(self, ax=ax, curves=curves, show_eps_star=show_eps_star)


@dataclass(frozen=True)
class EpsStarEstimate:
    """Result of :func:`estimate_eps_star` (bisection in ``log eps``).

    Parameters
    ----------
    eps_star : float
        Largest eps found stable below the first non-stable one (``bracket[0]``); NaN if the
        lower end of the range is not stable.
    bracket : (float, float)
        ``(stable eps, not stable eps)``; ``(hi, inf)`` when the whole range is stable.
    n_simulations : int
        Closed-loop runs made.
    history : tuple
        ``(eps, status, divergence_time)`` of every run, in order.
    converged : bool
        The bracket is narrower than ``rtol``.

    Examples
    --------
    >>> from fl_design.sim import EpsStarEstimate
    >>> EpsStarEstimate(0.04, (0.04, 0.0405), 9, (), True).to_dict()["bracket"]
    [0.04, 0.0405]
    """

    eps_star: float
    bracket: tuple
    n_simulations: int
    history: tuple
    converged: bool

    def to_dict(self) -> dict:
        """Plain numbers, ready for JSON (inf and NaN as None).

        Examples
        --------
        >>> from fl_design.sim import EpsStarEstimate
        >>> EpsStarEstimate(1.0, (1.0, float("inf")), 2, (), False).to_dict()["bracket"]
        [1.0, None]
        """
        return jsonable({"eps_star": self.eps_star, "bracket": self.bracket,
                         "n_simulations": self.n_simulations, "converged": self.converged,
                         "history": self.history})


__all__ = ["EpsStarEstimate", "StabilityMap"]
