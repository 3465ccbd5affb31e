"""Plots of a family of plants: :class:`~fl_design.sim.Ensemble` histograms and verdicts,
and the robust stability map (fraction of plants that converge over (gamma, eps)).

matplotlib is imported only when a plot is drawn (:mod:`fl_design.plotting`'s axes and colours).

Examples
--------
>>> from fl_design.sim._family_plots import plot_ensemble
>>> callable(plot_ensemble)
True
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError


def plot_ensemble(ens, *, metrics=("tail_error", "settling_time", "input_rms"), x=None, y=None):
    """Histograms of ``metrics`` (finite values) and each sample's verdict over parameters.

    Parameters
    ----------
    ens : Ensemble
        A Monte Carlo result.
    metrics : sequence of str, optional
        Metric names (keys of ``ens.metrics``).
    x, y : str, optional
        Parameters of the verdict scatter (default the first two; one parameter: verdict
        against it).

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    ParameterError
        An unknown metric or parameter name.

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.sim._ensemble import Ensemble
    >>> from fl_design.sim._family_plots import plot_ensemble
    >>> ens = Ensemble({"c": np.array([0.1, 0.5])}, np.array([2, 1]),
    ...                {"iae": np.array([0.1, 0.2])}, 1e-3, 1.0, np.ones(2))
    >>> len(plot_ensemble(ens, metrics=("iae",)).axes)
    2
    """
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    from ..plotting import STATUS_COLORS, STATUS_LABELS

    metrics = tuple(metrics)
    unknown = [m for m in metrics if m not in ens.metrics]
    if unknown:
        raise ParameterError(f"unknown metric(s) {unknown}; the ensemble has "
                             f"{sorted(ens.metrics)}")
    names = list(ens.params)
    x = names[0] if x is None else x
    y = (names[1] if len(names) > 1 else None) if y is None else y
    for p in (x, y):
        if p is not None and p not in ens.params:
            raise ParameterError(f"{p!r} is not a parameter of the ensemble; it has {names}")
    fig, axes = plt.subplots(1, len(metrics) + 1, figsize=(4.0 * (len(metrics) + 1), 3.6),
                             squeeze=False)
    axes = axes[0]
    for ax, name in zip(axes, metrics):
        v = np.asarray(ens.metrics[name], dtype=float).ravel()
        v = v[np.isfinite(v)]
        if v.size:
            ax.hist(v, bins=min(40, max(5, int(np.sqrt(v.size)))), color="C0")
        ax.set_xlabel(name)
        ax.set_ylabel("samples")
        ax.set_title(f"{v.size} of {ens.n} finite", fontsize=9)
    ax = axes[-1]
    codes = np.asarray(ens.status)
    xs = np.asarray(ens.params[x])
    ys = np.asarray(ens.params[y]) if y is not None else codes.astype(float)
    handles = []
    for code, color, label in zip(range(-2, 5), STATUS_COLORS, STATUS_LABELS):
        sel = codes == code
        if sel.any():
            ax.scatter(xs[sel], ys[sel], s=10, color=color)
            handles.append(Patch(color=color, label=f"{label} ({sel.sum()})"))
    ax.set_xlabel(x)
    ax.set_ylabel(y if y is not None else "status code")
    ax.legend(handles=handles, fontsize=8)
    fig.tight_layout()
    return fig


def plot_robust_map(rmap, *, ax=None, level: float = 1.0):
    """Heat map of the fraction of plants that converge over (gamma, eps), log axes, with the
    robust eps*(gamma) (at least ``level`` of the plants converge below it).

    Parameters
    ----------
    rmap : RobustMap
        A robust sweep's result.
    ax : Axes, optional
        Where to draw (default a new figure).
    level : float, optional
        The fraction the marked eps* requires (default 1).

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.sim._robust_map import RobustMap
    >>> from fl_design.sim._family_plots import plot_robust_map
    >>> m = RobustMap(np.array([0.1, 0.2]), np.array([1.0]), np.array([[[2, 2]], [[2, -1]]]),
    ...               {}, {"b": np.ones(2)}, 1e-3, 1.0)
    >>> plot_robust_map(m).axes[0].get_xlabel()
    'controller gain gamma'
    """
    from ..plotting import _edges, _legend_outside, _new_axes

    if ax is None:
        fig, (ax,) = _new_axes(1, figsize=(9.0, 5.0))
    fig = ax.figure
    gx = np.abs(np.asarray(rmap.gamma, dtype=float))
    mesh = ax.pcolormesh(_edges(gx), _edges(rmap.eps), rmap.fraction, cmap="RdYlGn",
                         vmin=0.0, vmax=1.0, shading="flat")
    fig.colorbar(mesh, ax=ax, label=f"fraction of {rmap.n} plants converging")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("controller gain |gamma| (gamma < 0, as b)" if np.any(rmap.gamma < 0)
                  else "controller gain gamma")
    ax.set_ylabel("observer time constant eps (s)")
    stars = [rmap.eps_star(g, level=level) for g in rmap.gamma]
    inside = [(g, b.lower) for g, b in zip(gx, stars) if b.value is not None or b.above_range]
    handles = []
    if inside:
        (h,) = ax.plot(*zip(*inside), "w^", mec="k", ms=6,
                       label=f"robust eps* ({100 * level:g}% of plants)")
        handles.append(h)
        _legend_outside(ax, handles=handles)
    ax.set_title(f"{rmap.n} plants ({', '.join(rmap.params)}), runs of {rmap.duration:g} s")
    return fig


__all__ = ["plot_ensemble", "plot_robust_map"]
