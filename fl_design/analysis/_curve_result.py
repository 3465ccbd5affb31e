"""The result of :func:`fl_design.eps_star_curve` (``eps*`` against ``gamma``).

Examples
--------
>>> import numpy as np
>>> EpsStarCurve(np.array([1e-3]), np.array([0.1]), np.array([0.09]), (1.0, 2.0), 1e-3,
...              (1e-3, 1.0)).covers
'frozen'
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._cert_results import _fmt, _OfClass


@dataclass(frozen=True, repr=False)
class EpsStarCurve(_OfClass):
    """``eps*`` against ``gamma`` (result of :func:`fl_design.eps_star_curve`).

    Parameters
    ----------
    gamma : numpy.ndarray
        The gains.
    eps_star_frozen : numpy.ndarray
        Frozen-b eps* per gamma (NaN: unstable at the lowest eps).
    eps_star_certified : numpy.ndarray
        Certified eps* per gamma (NaN: none).
    b_bounds : tuple of float
        The interval of ``b``.
    T : float
        Sampling time.
    eps_range : tuple of float
        The eps search interval.
    covers : str
        What the certified curve covers: ``"frozen"`` (every constant ``b``; the curve is the
        fast search, see :func:`fl_design.certify_eps` for varying ``b``).

    Examples
    --------
    >>> import numpy as np
    >>> c = EpsStarCurve(np.array([1e-3]), np.array([0.1]), np.array([0.09]), (1.0, 2.0),
    ...                  1e-3, (1e-3, 1.0))
    >>> c.ratio.round(2).tolist(), c.to_dict()["eps_star_certified"]
    ([0.9], [0.09])
    """

    gamma: np.ndarray
    eps_star_frozen: np.ndarray
    eps_star_certified: np.ndarray
    b_bounds: tuple
    T: float
    eps_range: tuple
    covers: str = "frozen"

    @property
    def ratio(self) -> np.ndarray:
        """``eps_star_certified / eps_star_frozen`` (NaN where either is missing)."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return self.eps_star_certified / self.eps_star_frozen

    def plot(self, *, ax=None):
        """Both curves on log axes (see :func:`fl_design.plotting.plot_eps_star_curve`).

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Where to draw.

        Returns
        -------
        matplotlib.figure.Figure

        Examples
        --------
        >>> import numpy as np
        >>> c = EpsStarCurve(np.array([1e-3, 2e-3]), np.array([0.1, 0.05]),
        ...                  np.array([0.09, 0.04]), (1.0, 2.0), 1e-3, (1e-3, 1.0))
        >>> c.plot().axes[0].get_xlabel()
        'gamma'
        """
        from ..plotting import plot_eps_star_curve

        return plot_eps_star_curve(self, ax=ax)

    def _repr_lines(self):
        return self._class_lines() + [(f"{self.gamma.size} gains in [{self.gamma.min():.3g}, {self.gamma.max():.3g}],"
                f" b in [{self.b_bounds[0]:g}, {self.b_bounds[1]:g}], T = {self.T:g}, "
                f"certified for {self.covers} b"),
                f"median certified/frozen ratio {_fmt(float(np.nanmedian(self.ratio)))}"
                if np.any(np.isfinite(self.ratio)) else "no certified point"]


__all__ = ["EpsStarCurve"]
