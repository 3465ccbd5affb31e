"""Maps over (gamma, eps): the stability map (:func:`plot_stability_map`), eps*(gamma) brackets
(:func:`plot_eps_star`) and curves (:func:`plot_eps_star_curve`), the robust map
(:func:`plot_robust_map`); each function's docstring has its example.
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError
from ._base import (
    OUTSIDE_RANGE,
    STATUS_COLORS,
    bracket_points,
    edges,
    is_bracket,
    legend_below,
    literal,
    log_axes,
    new_axes,
    status_legend,
)


def _curve_points(curve, gamma: np.ndarray):
    if callable(curve):
        g = np.geomspace(gamma[0], gamma[-1], 200) if gamma.size > 1 else gamma
        return g, np.asarray(curve(g), dtype=float) * np.ones_like(g)
    try:
        g, e = (np.asarray(a, dtype=float) for a in curve)
    except (TypeError, ValueError):
        raise ParameterError("a curve must be a callable gamma -> eps or a pair "
                             f"(gamma_values, eps_values), got {curve!r}") from None
    if g.shape != e.shape:
        raise ParameterError(f"a curve's gamma and eps arrays differ in shape: {g.shape} vs "
                             f"{e.shape}")
    return g, e


def _holds_eps_stars(curve) -> bool:
    """A pair ``(gamma_values, [EpsStar, ...])``."""
    return (isinstance(curve, (tuple, list)) and len(curve) == 2
            and not callable(curve) and np.ndim(curve[1]) == 1 and len(curve[1]) > 0
            and all(is_bracket(s) for s in curve[1]))


def plot_eps_star(ax, gamma, stars, *, label: str, color: str = "C0", ls: str = "-",
                  marker: str = "s") -> list:
    """Draw ``eps*(gamma)`` brackets: values as a line, boundaries outside the range as such.

    A :class:`~fl_design.sim.EpsStar` inside its range is drawn at its ``lower`` end (the
    largest eps found stable/converging); one above the range (``> eps_max``) as an upward
    open triangle at the range's top, one below it (``< eps_min``) as a downward open triangle
    at the range's bottom, or an open diamond when the run there is ``undecided`` (a trend
    the run is too short to call, not a failure), each with its own legend entry: never as a
    value.

    Parameters
    ----------
    ax : matplotlib Axes
        Where to draw.
    gamma : array_like
        ``(n,)`` controller gains.
    stars : sequence of EpsStar
        ``n`` brackets (:func:`fl_design.linearized_eps_star`,
        :meth:`fl_design.StabilityMap.eps_star`).
    label : str
        Legend text of the curve.
    color, ls, marker : str, optional
        Line colour, line style (``"none"``: markers only) and marker of the values.

    Returns
    -------
    list
        The legend handles drawn.

    Raises
    ------
    ParameterError
        ``gamma`` and ``stars`` of different lengths.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> from fl_design.plotting import plot_eps_star
    >>> fig, ax = plt.subplots()
    >>> hs = plot_eps_star(ax, [1e-3, 1e-2], [fl.EpsStar(1.0, float("inf")), fl.EpsStar(0.1, 0.2)],
    ...                    label="linearized")
    >>> [h.get_label() for h in hs]
    ['linearized', 'linearized: eps* above the range (> top)']
    """
    points = bracket_points(gamma, stars)
    handles = []
    if "value" in points:
        (h,) = ax.plot(*zip(*points["value"]), color=color, ls=ls, marker=marker, ms=4,
                       label=label)
        handles.append(h)
    for kind, (words, mark, _) in OUTSIDE_RANGE.items():
        if kind in points:
            (h,) = ax.plot(*zip(*points[kind]), ls="none", marker=mark, ms=8, color=color,
                           mfc="none", mew=1.5, label=f"{label}: {words}")
            handles.append(h)
    return handles


#: The map's own eps* markers (white triangles), by :func:`bracket_points` kind: legend text
#: and opacity (above the range: pale, eps* lies beyond the largest eps scanned).
MAP_EPS_STAR = (("value", "eps* (this map)", 1.0), ("above", "eps* > largest eps scanned", 0.5))


def plot_stability_map(smap, *, ax=None, curves=None, show_eps_star: bool = True):
    """Heat map of a :class:`~fl_design.sim.StabilityMap` over (gamma, eps), log axes.

    Parameters
    ----------
    smap : StabilityMap
        The sweep result.
    ax : Axes, optional
        Where to draw (default a new figure).
    curves : dict, optional
        ``{label: callable gamma -> eps, or (gamma_values, eps_values)}`` overlaid as lines;
        ``eps_values`` may be :class:`~fl_design.sim.EpsStar` brackets (drawn by
        :func:`plot_eps_star`: outside-the-range ones as triangles at the edge).
    show_eps_star : bool, optional
        Draw the map's empirical ``eps_star(gamma)`` (white markers).

    Returns
    -------
    matplotlib.figure.Figure
        ``ax``'s figure, or a new one: the map on log-log axes, its legend below.

    Examples
    --------
    >>> from fl_design.plotting import plot_stability_map
    >>> m = fl.StabilityMap(np.array([0.1, 0.2]), np.array([1.0]), np.array([[1], [-1]]), {},
    ...                     1e-3, 1.0, 0.1)
    >>> plot_stability_map(m).axes[0].get_xlabel()
    'controller gain gamma'
    """
    from matplotlib.colors import BoundaryNorm, ListedColormap
    from matplotlib.patches import Patch

    if ax is None:
        fig, (ax,) = new_axes(1, figsize=(8.0, 5.6), bottom=0.31)
    fig = ax.figure
    cmap = ListedColormap(list(STATUS_COLORS))
    norm = BoundaryNorm(np.arange(-2.5, 5.0), cmap.N)
    gx = np.abs(np.asarray(smap.gamma, dtype=float))  # gamma < 0 (b < 0): plotted as |gamma|
    negative = bool(np.any(np.asarray(smap.gamma) < 0))
    ax.pcolormesh(edges(gx), edges(smap.eps), np.asarray(smap.status), cmap=cmap,
                  norm=norm, shading="flat")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("controller gain |gamma| (gamma < 0, as b)" if negative
                  else "controller gain gamma")
    ax.set_ylabel("observer time constant eps (s)")
    handles = [Patch(color=c, label=n) for _, c, n in status_legend(smap.status)]
    lost = lost_points(smap)
    if lost:  # a partial map (a worker died): its lost cells crossed, never read as results
        (h,) = ax.plot(*zip(*lost), ls="none", marker="x", ms=7, mew=1.6, color="k",
                       label=LOST_LABEL.format(n=len(lost)))
        handles.append(h)
    if show_eps_star:
        points = bracket_points(smap.gamma, [smap.eps_star(g) for g in smap.gamma])
        for kind, label, alpha in MAP_EPS_STAR:
            if kind in points:
                (h,) = ax.plot(*zip(*points[kind]), "w^", mec="k", ms=6, alpha=alpha,
                               label=label)
                handles.append(h)
    for i, (label, curve) in enumerate((curves or {}).items()):
        if _holds_eps_stars(curve):
            handles += plot_eps_star(ax, *curve, label=str(label), color=f"C{i % 10}")
            continue
        g, e = _curve_points(curve, np.asarray(smap.gamma))
        (h,) = ax.plot(np.abs(g), e, color=f"C{i % 10}", lw=1.8, label=str(label))
        handles.append(h)
    ax.set_xlim(np.sort(edges(gx)[[0, -1]]))
    ax.set_ylim(edges(smap.eps)[[0, -1]])
    log_axes(ax)
    legend_below(ax, ncol=2, handles=handles)
    ax.set_title(f"closed-loop runs of {smap.duration:g} s"
                 + (f" (PARTIAL: {len(lost)} lost)" if lost else ""))
    return fig


#: Legend text of a partial map's lost cells (``n``: how many).
LOST_LABEL = "lost: worker died ({n} runs, undecided)"


def lost_points(smap) -> list:
    """``[(|gamma|, eps)]`` of the cells a partial map lost a run of (empty for a complete
    map; a robust map's cell: any of its plants' runs).

    Examples
    --------
    >>> from fl_design.plotting._maps import lost_points
    >>> from fl_design.sim._partial import PartialStabilityMap
    >>> m = PartialStabilityMap(np.array([0.1, 0.2]), np.array([-1.0]), np.array([[2], [3]]),
    ...                         {}, 1e-3, 1.0, 0.1, lost=np.array([[False], [True]]))
    >>> lost_points(m)
    [(1.0, 0.2)]
    """
    mask = getattr(smap, "lost", None)
    if mask is None:
        return []
    cells = np.asarray(mask, bool).reshape(len(smap.eps), len(smap.gamma), -1).any(axis=2)
    rows, cols = np.nonzero(cells)
    return [(float(abs(smap.gamma[j])), float(smap.eps[i])) for i, j in zip(rows, cols)]


def plot_eps_star_curve(curve, *, ax=None):
    """Frozen and certified ``eps*`` against ``gamma`` (an :class:`~fl_design.EpsStarCurve`).

    Parameters
    ----------
    curve : EpsStarCurve
        The result of :func:`fl_design.eps_star_curve`.
    ax : Axes, optional
        Where to draw (default a new figure).

    Returns
    -------
    matplotlib.figure.Figure
        ``ax``'s figure, or a new one: both curves on log-log axes.

    Examples
    --------
    >>> from fl_design.plotting import plot_eps_star_curve
    >>> c = fl.EpsStarCurve(np.array([1e-3, 2e-3]), np.array([0.1, 0.05]),
    ...                     np.array([0.09, np.nan]), (1.0, 2.0), 1e-3, (1e-3, 1.0))
    >>> [l.get_label() for l in plot_eps_star_curve(c).axes[0].get_lines()]
    ['eps* frozen b grid', 'eps* certified (LMI)']
    """
    if ax is None:
        fig, (ax,) = new_axes(1, figsize=(7.0, 5.0))
    fig = ax.figure
    ax.plot(curve.gamma, curve.eps_star_frozen, "k-", lw=1.4, label="eps* frozen b grid")
    ax.plot(curve.gamma, curve.eps_star_certified, "C2o-", ms=3, lw=1.0,
            label="eps* certified (LMI)")
    log_axes(ax)
    ax.set_xlabel("gamma")
    ax.set_ylabel("eps")
    lo, hi = curve.b_bounds
    ax.set_title(f"linear surrogate, b in [{lo:g}, {hi:g}], T = {curve.T:g} s")
    ax.legend(loc="best", fontsize="small")
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
        ``ax``'s figure, or a new one, with a colour bar for the fractions.

    Examples
    --------
    >>> from fl_design.plotting import plot_robust_map
    >>> m = fl.RobustMap(np.array([0.1, 0.2]), np.array([1.0]), np.array([[[2, 2]], [[2, -1]]]),
    ...                  {}, {"b": np.ones(2)}, 1e-3, 1.0)
    >>> plot_robust_map(m).axes[0].get_xlabel()
    'controller gain gamma'
    """
    if ax is None:
        fig, (ax,) = new_axes(1, figsize=(8.0, 5.6), bottom=0.26)
    fig = ax.figure
    gx = np.abs(np.asarray(rmap.gamma, dtype=float))
    mesh = ax.pcolormesh(edges(gx), edges(rmap.eps), rmap.fraction, cmap="RdYlGn",
                         vmin=0.0, vmax=1.0, shading="flat")
    fig.colorbar(mesh, ax=ax, label=f"fraction of {rmap.n} plants converging")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("controller gain |gamma| (gamma < 0, as b)" if np.any(rmap.gamma < 0)
                  else "controller gain gamma")
    ax.set_ylabel("observer time constant eps (s)")
    points = bracket_points(rmap.gamma, [rmap.eps_star(g, level=level) for g in rmap.gamma])
    inside = [(g, e) for g, e in points.get("value", []) + points.get("above", [])
              if np.isfinite(e)]
    handles = []
    if inside:
        (h,) = ax.plot(*zip(*inside), "w^", mec="k", ms=6,
                       label=f"robust eps* ({100 * level:g}% of plants)")
        handles.append(h)
    lost = lost_points(rmap)
    if lost:  # a partial robust map: the cells with a lost run crossed
        (h,) = ax.plot(*zip(*lost), ls="none", marker="x", ms=7, mew=1.6, color="k",
                       label=LOST_LABEL.format(n=rmap.n_lost))
        handles.append(h)
    if handles:
        legend_below(ax, ncol=2, handles=handles)
    ax.set_title(f"{rmap.n} plants ({literal(', '.join(rmap.params))}), runs of "
                 f"{rmap.duration:g} s" + (f" (PARTIAL: {rmap.n_lost} lost)" if lost else ""))
    return fig


__all__ = ["plot_eps_star", "plot_eps_star_curve", "plot_robust_map", "plot_stability_map"]
