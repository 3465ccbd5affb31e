"""All of fl_design's figures: the results' ``.plot()`` methods and the report call this package.

The only place fl_design imports matplotlib, and only when a plot is drawn. Figures are made
with ``pyplot.subplots``, which picks a non-interactive backend (Agg) when no display is
available, so plotting works on servers and in CI; pass ``ax``/``axes`` to draw into your own
figure. Modules: ``_base`` (colours, axes, log labels, legends, literal text), ``_response``
(a run over time), ``_maps`` (stability map, eps* brackets and curves, robust map), ``_family``
(a Monte Carlo ensemble), ``_report`` (the report's figures, from result objects and a
:class:`FigureContext` of names and units).

Examples
--------
>>> from fl_design.plotting import plot_stability_map
>>> m = fl.StabilityMap(np.array([0.1, 0.2]), np.array([1.0, 2.0]), np.array([[1, 1], [0, -1]]),
...                     {}, 1e-3, 1.0, 0.1)
>>> fig = plot_stability_map(m, curves={"theory": (np.array([1.0, 2.0]), np.array([0.2, 0.1]))})
>>> fig.axes[0].get_xscale(), fig.axes[0].get_yscale()
('log', 'log')
"""

from ._base import (
    REPORT_BUCKETS,
    STATUS_COLORS,
    STATUS_LABELS,
    close_figure,
    literal,
    log_axes,
    save_figure,
    thin_line,
)
from ._family import plot_ensemble
from ._maps import plot_eps_star, plot_eps_star_curve, plot_robust_map, plot_stability_map
from ._report import FigureContext
from ._response import plot_response

__all__ = [
    "REPORT_BUCKETS",
    "STATUS_COLORS",
    "STATUS_LABELS",
    "FigureContext",
    "close_figure",
    "literal",
    "log_axes",
    "plot_ensemble",
    "plot_eps_star",
    "plot_eps_star_curve",
    "plot_response",
    "plot_robust_map",
    "plot_stability_map",
    "save_figure",
    "thin_line",
]
