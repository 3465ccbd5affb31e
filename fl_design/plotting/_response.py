"""A run over time: output and reference, input, and ``sigma`` with its estimate.

Examples
--------
>>> from fl_design.plotting import plot_response
>>> fig = plot_response(fl.simulate(fl.plants.pendulum(), fl.presets.pendulum_design(),
...                                 fl.Scenario(0.1, 0.2)))
>>> len(fig.axes)
3
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError
from ._base import STATUS_COLORS, legend_inside, new_axes, thin_line


def plot_response(resp, *, axes=None, title: str | None = None, buckets: int | None = None):
    """Output and reference, input, and ``sigma`` with its estimate, over time.

    Parameters
    ----------
    resp : Response
        A simulation result.
    axes : sequence of 3 Axes, optional
        Where to draw (default a new figure).
    title : str, optional
        Title (default: status and key metrics).
    buckets : int, optional
        Draw each line from :func:`thin_line` with this many buckets (the report: a PNG at
        a fixed size); default every sample.

    Returns
    -------
    matplotlib.figure.Figure
        ``axes``' figure, or a new one: output, input and sigma, top to bottom, sharing time.

    Examples
    --------
    >>> from fl_design.plotting import plot_response
    >>> d = fl.presets.pendulum_design()
    >>> fig = plot_response(fl.simulate(fl.plants.pendulum(), d, fl.Scenario(0.1, 0.5)))
    >>> [ax.get_ylabel() for ax in fig.axes]
    ['output y', 'input u', 'sigma']
    """
    if axes is None:
        fig, axes = new_axes(3)
    else:
        axes = list(axes)
        if len(axes) != 3:
            raise ParameterError(f"axes must be 3 matplotlib Axes, got {len(axes)}")
        fig = axes[0].figure
    def line(y):
        return thin_line(resp.t, y, buckets)

    ax = axes[0]
    if np.any(resp.ym != resp.y):
        ax.plot(*line(resp.ym), color="0.75", lw=0.6, label="measured")
    ax.plot(*line(resp.r), "k--", lw=1.0, label="reference")
    ax.plot(*line(resp.y), color="C0", lw=1.4, label="y")
    ax.plot(*line(resp.xhat[:, 0]), color="C1", lw=0.8, ls=":", label="estimate")
    ax.set_ylabel("output y")
    legend_inside(ax)
    axes[1].step(*line(resp.u), where="post", color="C2", lw=1.0)
    axes[1].set_ylabel("input u")
    axes[2].plot(*line(resp.sigma), color="C0", lw=1.2, label="sigma (true)")
    axes[2].plot(*line(resp.sigmahat), color="C1", lw=0.8, label="sigma estimate")
    axes[2].set_ylabel("sigma")
    axes[2].set_xlabel("time (s)")
    legend_inside(axes[2])
    if resp.diverged:
        for a in axes:
            a.axvline(resp.divergence_time, color=STATUS_COLORS[1], lw=1.0)  # diverged
    if title is None:
        title = f"{resp.status}, overshoot {resp.overshoot:.3g} %"
    axes[0].set_title(title)
    return fig


__all__ = ["plot_response"]
