"""The result of a sweep: :class:`StabilityMap` over (eps, gamma), and :class:`EpsStarEstimate`.

Examples
--------
>>> import numpy as np
>>> from fl_design.sim import StabilityMap
>>> m = StabilityMap(eps=np.array([0.01, 0.02]), gamma=np.array([1e-3]),
...                  status=np.array([[2], [-1]]), metrics={}, T=1e-3, duration=1.0, tol=1e-3)
>>> print(m.eps_star(1e-3))
0.01 (fails at 0.02)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .._json import jsonable
from ..errors import ParameterError
from ._eps_star import EpsStar, eps_boundary, grid_index
from ._status import CONVERGENT_CODES, Status


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
        ``(n_e, n_g)`` int codes of :class:`fl_design.sim.Status` (2 converged, 1 converging,
        0 oscillating, 3 undecided, -1 diverged, -2 solver failed).
    metrics : dict
        Name -> ``(n_e, n_g)`` array (``estimation_rms``: ``(n_e, n_g, rho + 1)``), see
        :mod:`fl_design.sim`.
    T, duration, tol : float
        Sampling time, run length, absolute tolerance of the classification.
    duration_reason : str, optional
        ``"given"``, or how the sweep chose its run length (once, at the design's own
        ``(eps, gamma)``: :mod:`fl_design.sim._duration`).
    durations : numpy.ndarray, optional
        ``(n_e, n_g)`` length of each point's own run (s): ``duration``, or longer where the
        sweep re-ran an ``undecided`` point (:func:`fl_design.sweep`'s ``extend``); default
        ``duration`` everywhere. Each point is classified on its own run's tail window.
    max_duration : float, optional
        The longest a re-run could be (s; NaN: no point was re-run, or not recorded).

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.sim import StabilityMap
    >>> m = StabilityMap(eps=np.array([0.01, 0.02, 0.04]), gamma=np.array([1e-3, 1e-2]),
    ...                  status=np.array([[1, 1], [1, 0], [-1, 1]]), metrics={},
    ...                  T=1e-3, duration=1.0, tol=1e-3)
    >>> m.eps_star(1e-3).value, m.eps_star(1e-2).value, m.gamma_bounds(0.02)
    (0.02, 0.01, (0.001, 0.001))
    """

    eps: np.ndarray
    gamma: np.ndarray
    status: np.ndarray
    metrics: dict = field(repr=False)
    T: float
    duration: float
    tol: float
    duration_reason: str = "given"
    durations: np.ndarray | None = field(default=None, repr=False)
    max_duration: float = math.nan

    def __post_init__(self) -> None:
        shape = np.shape(self.status)
        if self.durations is None:
            object.__setattr__(self, "durations", np.full(shape, float(self.duration)))
        elif np.shape(self.durations) != shape:
            raise ParameterError(f"durations must have the status' shape {shape}, got "
                                 f"{np.shape(self.durations)}")

    @property
    def extended(self) -> np.ndarray:
        """Mask of the points whose run is longer than :attr:`duration` (re-run because
        ``undecided`` at ``duration``).

        Examples
        --------
        >>> import numpy as np
        >>> from fl_design.sim import StabilityMap
        >>> m = StabilityMap(np.array([0.1]), np.array([1.0, 2.0]), np.array([[2, 1]]), {},
        ...                  1e-3, 10.0, 0.02, durations=np.array([[10.0, 40.0]]))
        >>> m.extended.tolist()
        [[False, True]]
        """
        return np.asarray(self.durations) > self.duration * (1 + 1e-9)

    def extension_text(self) -> str:
        """How many points were re-run longer, to how long, and what they became ("" if none).

        Returns
        -------
        str
            One sentence; "" when no point was re-run longer.

        Examples
        --------
        >>> import numpy as np
        >>> from fl_design.sim import StabilityMap
        >>> m = StabilityMap(np.array([0.1]), np.array([1.0, 2.0, 3.0]), np.array([[2, 1, 3]]),
        ...                  {}, 1e-3, 10.0, 0.02, durations=np.array([[10.0, 40.0, 40.0]]),
        ...                  max_duration=40.0)
        >>> m.extension_text()
        '2 runs undecided at 10 s re-run at 40 s: now 1 converging, 1 still undecided (at the longest re-run, 40 s: a longer max_duration decides)'
        """
        ext = self.extended
        if not ext.any():
            return ""
        lengths, counts = np.unique(np.asarray(self.durations)[ext], return_counts=True)
        to = (f"at {lengths[0]:g} s" if lengths.size == 1 else
              "longer (" + ", ".join(f"{c} at {d:g} s" for d, c in zip(lengths, counts)) + ")")
        names, n = np.unique(self.labels[ext], return_counts=True)
        became = ", ".join(f"{c} {'still ' if name == 'undecided' else ''}{name}"
                           for name, c in sorted(zip(names, n),
                                                 key=lambda t: t[0] == "undecided"))
        if "undecided" in names and math.isfinite(self.max_duration):
            became += (f" (at the longest re-run, {self.max_duration:g} s: a longer "
                       "max_duration decides)")
        runs = "run" if ext.sum() == 1 else "runs"
        return (f"{int(ext.sum())} {runs} undecided at {self.duration:g} s re-run {to}: "
                f"now {became}")

    @property
    def labels(self) -> np.ndarray:
        """``status`` as strings (``'converged'``, ``'converging'``, ``'oscillating'``, ...)."""
        labels = np.array([Status(int(c)).label for c in np.ravel(self.status)], dtype=object)
        return labels.reshape(np.shape(self.status)).astype(str)

    def _convergent(self) -> np.ndarray:
        return np.isin(np.asarray(self.status), CONVERGENT_CODES)

    def eps_star(self, gamma: float) -> EpsStar:
        """Empirical eps*: the boundary between converging/converged and the rest.

        Parameters
        ----------
        gamma : float
            A gamma of the grid.

        Returns
        -------
        EpsStar
            ``lower``: the largest grid eps such that every grid eps' <= it converges;
            ``upper``: the first one that does not (``> eps_max`` / ``< eps_min`` when the
            boundary lies outside the grid), ``upper_status`` its status (``undecided``: the
            run there was too short to tell, not a failure).

        Examples
        --------
        >>> import numpy as np
        >>> from fl_design.sim import StabilityMap
        >>> m = StabilityMap(np.array([1.0, 2.0]), np.array([0.5, 1.0]),
        ...                  np.array([[0, 2], [1, 1]]), {}, 1e-3, 1.0, 0.1)
        >>> str(m.eps_star(0.5)), str(m.eps_star(1.0))
        ('< 1', '> 2')
        """
        j = grid_index(self.gamma, gamma, "gamma")
        return eps_boundary(self.eps, self._convergent()[:, j],
                            lambda i: Status(int(np.asarray(self.status)[i, j])).label)

    def gamma_bounds(self, eps: float, *, around: float | None = None) -> tuple[float, float]:
        """``(lowest, highest)`` grid gamma of a contiguous run of converging gammas at ``eps``.

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
        ...                  np.array([[2, 0, 1, 2, -1]]), {}, 1e-3, 1.0, 0.1)
        >>> m.gamma_bounds(0.1), m.gamma_bounds(0.1, around=1.0)
        ((3.0, 4.0), (1.0, 1.0))
        """
        row = self._convergent()[grid_index(self.eps, eps, "eps")]
        runs, start = [], None
        for j, ok in enumerate([*row, False]):
            if ok and start is None:
                start = j
            elif not ok and start is not None:
                runs.append((start, j - 1))
                start = None
        if around is not None:
            j = grid_index(self.gamma, around, "around")
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
        >>> m = StabilityMap(np.array([0.1]), np.array([1.0]), np.array([[2]]),
        ...                  {"iae": np.array([[np.nan]])}, 1e-3, 1.0, 0.1)
        >>> m.to_dict()["metrics"], m.to_dict()["status"], m.to_dict()["eps_star"][0]["text"]
        ({'iae': [[None]]}, [['converged']], '> 0.1')
        """
        return jsonable({"eps": self.eps, "gamma": self.gamma, "status": self.labels.tolist(),
                         "T": self.T, "duration": self.duration,
                         "duration_reason": self.duration_reason, "tol": self.tol,
                         "durations": self.durations, "max_duration": self.max_duration,
                         "extension": self.extension_text(),
                         "eps_star": [self.eps_star(g) for g in self.gamma],
                         "metrics": self.metrics})

    def _repr_html_(self) -> str:
        """A short HTML table for Jupyter: the grid and the number of runs per status."""
        from ._response import _html_table

        names, counts = np.unique(self.labels, return_counts=True)
        grid = (f"{self.eps.size} eps in [{self.eps.min():.3g}, {self.eps.max():.3g}] x "
                f"{self.gamma.size} gamma in [{self.gamma.min():.3g}, {self.gamma.max():.3g}]")
        rows = [("grid", grid),
                ("runs", f"{self.duration:g} s each, T = {self.T:g} s, tolerance {self.tol:g}"),
                ("run length", self.duration_reason)]
        if self.extended.any():
            rows.append(("re-runs", self.extension_text()))
        return _html_table(rows + [(f"{n}", f"{c} runs") for n, c in zip(names, counts)])

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
            The verdict heat map, the curves overlaid, with a legend.

        Examples
        --------
        >>> import numpy as np
        >>> from fl_design.sim import StabilityMap
        >>> m = StabilityMap(np.array([0.1, 0.2]), np.array([1.0, 2.0]),
        ...                  np.array([[2, 1], [0, -1]]), {}, 1e-3, 1.0, 0.1)
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
        Largest eps found converging below the first one that does not (``bracket[0]``); NaN
        when even the lower end of the range fails (see :attr:`bound`: ``< lo``).
    bracket : (float, float)
        ``(converging eps, failing eps)``; ``(hi, inf)`` when the whole range converges
        (``> hi``), ``(nan, lo)`` when none does (``< lo``). The failing end may be
        ``undecided`` (see :attr:`bound`).
    n_simulations : int
        Closed-loop runs made.
    history : tuple
        ``(eps, status, divergence_time)`` of every run, in order.
    converged : bool
        The bracket is narrower than ``rtol``.
    duration : float, optional
        Length of every run (s; NaN when not recorded).
    duration_reason : str, optional
        ``"given"``, or how it was chosen (once, at the design's own ``eps``).

    Examples
    --------
    >>> from fl_design.sim import EpsStarEstimate
    >>> est = EpsStarEstimate(0.04, (0.04, 0.0405), 9, (), True)
    >>> est.to_dict()["bracket"], str(est)
    ([0.04, 0.0405], '0.04 (fails at 0.0405)')
    """

    eps_star: float
    bracket: tuple
    n_simulations: int
    history: tuple
    converged: bool
    duration: float = math.nan
    duration_reason: str = "given"

    def to_dict(self) -> dict:
        """Plain numbers, ready for JSON (inf and NaN as None).

        Examples
        --------
        >>> from fl_design.sim import EpsStarEstimate
        >>> EpsStarEstimate(1.0, (1.0, float("inf")), 2, (), False).to_dict()["bracket"]
        [1.0, None]
        """
        return jsonable({"eps_star": self.eps_star, "bracket": self.bracket,
                         "upper_status": self.bound.upper_status, "text": str(self),
                         "n_simulations": self.n_simulations, "converged": self.converged,
                         "duration": self.duration, "duration_reason": self.duration_reason,
                         "history": self.history})

    @property
    def bound(self) -> EpsStar:
        """The bracket as an :class:`EpsStar` (says ``> hi`` / ``< lo`` when outside, and
        ``undecided at`` when the run at the upper end was, from :attr:`history`).

        Examples
        --------
        >>> from fl_design.sim import EpsStarEstimate
        >>> str(EpsStarEstimate(0.04, (0.04, 0.05), 2, ((0.04, "converged", float("nan")),
        ...     (0.05, "undecided", float("nan"))), False))
        '0.04 (undecided at 0.05: run longer)'
        """
        upper = float(self.bracket[1])
        status = next((h[1] for h in self.history if math.isfinite(upper) and h[0] == upper),
                      None)
        return EpsStar(float(self.bracket[0]), upper, status)

    def __str__(self) -> str:
        return str(self.bound)


__all__ = ["EpsStarEstimate", "StabilityMap"]
