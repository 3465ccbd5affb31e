"""The result of a robust sweep: :class:`RobustMap`, the fraction of a family that converges.

``fl.sweep(..., params=...)`` runs every (eps, gamma) point of a grid against the same
``samples`` plants of a family (:mod:`fl_design.sim._family`); each point is coloured by the
fraction of those plants whose run converges (converging or converged), and the *robust* eps*
is the stability boundary of the points where (at least a ``level`` of) the plants converge.

Examples
--------
>>> import numpy as np
>>> from fl_design.sim._robust_map import RobustMap
>>> m = RobustMap(eps=np.array([0.01, 0.02, 0.04]), gamma=np.array([1e-2]),
...               status=np.array([[[2, 2]], [[2, -1]], [[-1, -1]]]), metrics={},
...               params={"c": np.array([0.1, 0.9])}, T=1e-3, duration=1.0)
>>> m.fraction[:, 0].tolist(), str(m.eps_star(1e-2)), str(m.eps_star(1e-2, level=0.5))
([1.0, 0.5, 0.0], '0.01 (fails at 0.02)', '0.02 (fails at 0.04)')
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import _validate as V
from .._json import jsonable
from ..errors import ParameterError
from ._ensemble import SEVERITY
from ._eps_star import EpsStar, eps_boundary, grid_index
from ._status import CONVERGENT_CODES, Status


@dataclass(frozen=True)
class RobustMap:
    """Verdicts of every (eps, gamma) point of a grid on every plant of a family.

    Parameters
    ----------
    eps, gamma : numpy.ndarray
        ``(n_e,)`` and ``(n_g,)`` increasing grid values (gamma as given to the sweep).
    status : numpy.ndarray
        ``(n_e, n_g, n)`` codes of :class:`fl_design.sim.Status`, one per plant.
    metrics : dict
        Name -> ``(n_e, n_g, n)`` array (``estimation_rms``: a trailing ``rho + 1`` axis).
    params : dict
        ``{name: (n,) values}`` of the plants (the same plants at every grid point).
    T, duration : float
        Sampling time and run length.
    distributions : dict, optional
        ``{name: distribution}`` drawn from; ``seed`` its seed.
    seed : int or None, optional
        Seed of the draw.
    duration_reason : str, optional
        How ``duration`` was chosen: ``"given"``, else the adaptive rule's words (applied to
        the nominal plant, as :class:`~fl_design.Ensemble`).

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.sim._robust_map import RobustMap
    >>> m = RobustMap(np.array([0.1]), np.array([1.0, 2.0]), np.array([[[2, 1], [2, 0]]]), {},
    ...               {"b": np.array([0.9, 1.1])}, 1e-3, 1.0)
    >>> m.fraction.tolist(), m.n
    ([[1.0, 0.5]], 2)
    """

    eps: np.ndarray
    gamma: np.ndarray
    status: np.ndarray
    metrics: dict = field(repr=False)
    params: dict = field(repr=False)
    T: float
    duration: float
    distributions: dict = field(default_factory=dict)
    seed: int | None = None
    duration_reason: str = "given"

    @property
    def n(self) -> int:
        """Plants per grid point."""
        return int(np.shape(self.status)[-1])

    @property
    def fraction(self) -> np.ndarray:
        """``(n_e, n_g)`` fraction of the plants whose run converges (converging or
        converged)."""
        return np.mean(np.isin(np.asarray(self.status), CONVERGENT_CODES), axis=-1)

    def fraction_of(self, label: str) -> np.ndarray:
        """``(n_e, n_g)`` fraction of the plants with verdict ``label`` (e.g. ``"diverged"``).

        Examples
        --------
        >>> import numpy as np
        >>> from fl_design.sim._robust_map import RobustMap
        >>> m = RobustMap(np.array([0.1]), np.array([1.0]), np.array([[[2, -1, -1, 1]]]), {},
        ...               {"b": np.ones(4)}, 1e-3, 1.0)
        >>> m.fraction_of("diverged").tolist()
        [[0.5]]
        """
        try:
            code = int(Status.from_label(str(label)))
        except KeyError:
            raise ParameterError(f"unknown verdict {label!r}; choose one of "
                                 f"{[s.label for s in Status]}") from None
        return np.mean(np.asarray(self.status) == code, axis=-1)

    def eps_star(self, gamma: float, *, level: float = 1.0) -> EpsStar:
        """Robust eps*: the boundary of the eps at which at least ``level`` of the plants
        converge, at a grid ``gamma``.

        Parameters
        ----------
        gamma : float
            A gamma of the grid.
        level : float, optional
            Required fraction of converging plants, in ``(0, 1]`` (default 1: every sampled
            plant converges).

        Returns
        -------
        EpsStar
            As :meth:`fl_design.StabilityMap.eps_star`; ``upper_status`` is the worst verdict
            among the plants at ``upper``.

        Examples
        --------
        >>> import numpy as np
        >>> from fl_design.sim._robust_map import RobustMap
        >>> m = RobustMap(np.array([0.1, 0.2]), np.array([1.0]), np.array([[[2, 2]], [[2, 3]]]),
        ...               {}, {"b": np.ones(2)}, 1e-3, 1.0)
        >>> str(m.eps_star(1.0))
        '0.1 (undecided at 0.2: run longer)'
        """
        level = V.real_scalar("level", level)
        if not 0 < level <= 1:
            raise ParameterError(f"level must be in (0, 1], got {level!r}")
        j = grid_index(self.gamma, gamma, "gamma")
        def worst(i: int) -> str | None:  # the worst verdict among the plants at eps[i]
            codes = np.asarray(self.status)[i, j]
            failing = [Status(int(c)) for c in codes if int(c) not in CONVERGENT_CODES]
            return min(failing, key=SEVERITY.index).label if failing else None

        return eps_boundary(self.eps, self.fraction[:, j] >= level - 1e-12, worst)

    def to_dict(self) -> dict:
        """Grid, plants, per-point fractions, robust eps* per gamma and the verdicts (labels).

        Examples
        --------
        >>> import numpy as np
        >>> from fl_design.sim._robust_map import RobustMap
        >>> m = RobustMap(np.array([0.1]), np.array([1.0]), np.array([[[2, -1]]]), {},
        ...               {"b": np.array([0.9, 1.1])}, 1e-3, 1.0)
        >>> d = m.to_dict()
        >>> d["fraction"], d["eps_star"][0]["text"], d["status"]
        ([[0.5]], '< 0.1', [[['converged', 'diverged']]])
        """
        labels = np.array([Status(int(c)).label for c in np.ravel(self.status)],
                          dtype=object).reshape(np.shape(self.status))
        return jsonable({"eps": self.eps, "gamma": self.gamma, "n": self.n, "seed": self.seed,
                         "T": self.T, "duration": self.duration,
                         "duration_reason": self.duration_reason,
                         "distributions": {k: str(v) for k, v in self.distributions.items()},
                         "params": self.params, "fraction": self.fraction,
                         "eps_star": [self.eps_star(g) for g in self.gamma],
                         "status": labels.tolist(), "metrics": self.metrics})

    def _repr_html_(self) -> str:
        """A short HTML table for Jupyter: grid, plants, robust eps* per gamma."""
        from ._response import _html_table

        grid = (f"{self.eps.size} eps in [{self.eps.min():.3g}, {self.eps.max():.3g}] x "
                f"{self.gamma.size} gamma")
        rows = [("grid", grid),
                ("plants", f"{self.n}: " + ", ".join(f"{k} ~ {v}" for k, v in
                                                    self.distributions.items())),
                ("runs", f"{self.duration:g} s each, T = {self.T:g} s")]
        return _html_table(rows + [(f"robust eps* at gamma {g:.3g}", str(self.eps_star(g)))
                                   for g in self.gamma])

    def plot(self, *, ax=None, level: float = 1.0):
        """Heat map of the converging fraction over (gamma, eps), with the robust eps*.

        Parameters
        ----------
        ax, level
            As in :func:`fl_design.plotting.plot_robust_map`, which draws it: the axes
            (default a new figure) and the fraction the drawn eps* requires (default 1).

        Returns
        -------
        matplotlib.figure.Figure
            The heat map, the robust eps* drawn at ``level`` over it.

        Examples
        --------
        >>> import numpy as np
        >>> from fl_design.sim._robust_map import RobustMap
        >>> m = RobustMap(np.array([0.1, 0.2]), np.array([1.0, 2.0]),
        ...               np.array([[[2, 2], [2, 1]], [[2, -1], [-1, -1]]]), {},
        ...               {"b": np.ones(2)}, 1e-3, 1.0)
        >>> m.plot().axes[0].get_ylabel()
        'observer time constant eps (s)'
        """
        from ..plotting import plot_robust_map

        return plot_robust_map(self, ax=ax, level=level)


__all__ = ["RobustMap"]
