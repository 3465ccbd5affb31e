"""All of fl_design's matplotlib code: results' ``.plot()`` methods delegate here.

matplotlib is imported only when a plot is drawn. Figures are made with ``pyplot.subplots``,
which picks a non-interactive backend (Agg) when no display is available, so plotting works on
servers and in CI; pass ``ax``/``axes`` to draw into your own figure.

Examples
--------
>>> import numpy as np
>>> from fl_design.sim import StabilityMap
>>> from fl_design.plotting import plot_stability_map
>>> m = StabilityMap(np.array([0.1, 0.2]), np.array([1.0, 2.0]), np.array([[1, 1], [0, -1]]),
...                  {}, 1e-3, 1.0, 0.1)
>>> fig = plot_stability_map(m, curves={"theory": (np.array([1.0, 2.0]), np.array([0.2, 0.1]))})
>>> fig.axes[0].get_xscale(), fig.axes[0].get_yscale()
('log', 'log')
"""

from __future__ import annotations

import numpy as np

from .errors import ParameterError

#: Colours of the classification by status code -2 .. 4: solver failed, diverged, oscillating,
#: converging, converged, undecided (too short to tell: a cool colour, neither good nor bad),
#: stalled (bounded at an offset: a muted purple).
STATUS_COLORS = ("#7f7f7f", "#d62728", "#ff9f1c", "#a6d96a", "#1a9641", "#9ecae1", "#9467bd")
STATUS_LABELS = ("solver failed", "diverged", "oscillating", "converging", "converged",
                 "undecided (run longer)", "stalled")


#: Time buckets per line in the report's figures (:func:`thin_line`): more than the pixel
#: columns of any axes it draws (at most about 700 at 100 dpi).
REPORT_BUCKETS = 2000


def thin_line(t, y, buckets: int | None = REPORT_BUCKETS):
    """The samples of a line that decide its picture at ``buckets`` columns or fewer (M4).

    ``t`` is cut into ``buckets`` runs of consecutive samples; each keeps its first and last
    sample, its smallest and its largest finite value, and its first NaN (where the drawn line
    breaks), in time order. Drawn on axes narrower than ``buckets`` pixel columns, the line
    covers the same pixels as the full one (up to antialiasing), at a fraction of the drawing
    time (a 300 000-sample run: 10 000 points instead). Short lines come back unchanged; so
    does everything with ``buckets=None``. Zoomed in, the thinned line shows less: for
    interactive figures keep every sample.

    Parameters
    ----------
    t : array_like, shape (n,)
        Times, increasing.
    y : array_like, shape (n,)
        Values (NaN allowed).
    buckets : int or None, optional
        Number of runs (default :data:`REPORT_BUCKETS`); None: no thinning.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        The kept times and values.

    Raises
    ------
    ParameterError
        ``t`` and ``y`` differ in length, or ``buckets`` is not a positive integer.

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.plotting import thin_line
    >>> t = np.arange(100_000) * 1e-3
    >>> tt, yy = thin_line(t, np.sin(t), buckets=100)
    >>> len(tt) <= 500, bool(yy.max() == np.sin(t).max()), bool(tt[-1] == t[-1])
    (True, True, True)
    """
    t, y = np.asarray(t), np.asarray(y)
    if t.shape != y.shape or t.ndim != 1:
        raise ParameterError(f"t and y must be 1-D of one length, got shapes {t.shape} "
                             f"and {y.shape}")
    if buckets is None:
        return t, y
    if isinstance(buckets, bool) or not isinstance(buckets, (int, np.integer)) or buckets < 1:
        raise ParameterError(f"buckets must be a positive integer or None, got {buckets!r}")
    n = len(y)
    k = -(-n // buckets)  # samples per bucket
    if n <= 5 * buckets or k < 2:
        return t, y
    m = n // k * k  # whole buckets; the rest is kept as is
    yb = y[:m].reshape(-1, k)
    bad = np.isnan(yb)
    base = np.arange(0, m, k)[:, None]
    lo = np.argmin(np.where(bad, np.inf, yb), axis=1)[:, None]
    hi = np.argmax(np.where(bad, -np.inf, yb), axis=1)[:, None]
    first_nan = np.where(bad.any(axis=1), np.argmax(bad, axis=1), 0)[:, None]
    idx = base + np.sort(np.hstack([np.zeros_like(lo), lo, hi, first_nan,
                                    np.full_like(lo, k - 1)]), axis=1)
    idx = np.concatenate([idx.ravel(), np.arange(m, n)])
    return t[idx], y[idx]


def _new_axes(nrows: int, sharex: bool = True, figsize=(7.0, 6.0)):
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(nrows, 1, sharex=sharex, figsize=figsize, squeeze=False)
    # fixed margins with room on the right for the legends (a layout engine's solve costs
    # about half of a figure's rendering time)
    fig.subplots_adjust(left=0.12, right=0.74, top=0.93, bottom=0.1, hspace=0.18)
    return fig, list(axes[:, 0])


def log_axes(ax, x: bool = True, y: bool = True) -> None:
    """Log scale on ``ax``'s x and/or y axis, labelled in plain text (``0.01``, ``2e-05``).

    matplotlib's default log labels are mathtext (``10^{-2}``): the first one drawn builds the
    mathtext parser (about 0.4 s), and minor ticks get labels laid out, which overlap on short
    axes. Here the labelled ticks are the decades (more than 2.5 decades shown), else 1, 2 and
    5 per decade (more than 0.6), else every digit; the other ticks are unlabelled minor
    ticks. Call it after the data (and any limits) are set: the choice reads the view.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes.
    x, y : bool, optional
        Which axes get the log scale.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> from fl_design.plotting import log_axes
    >>> fig, ax = plt.subplots()
    >>> _ = ax.plot([0.02, 0.5], [1.0, 2.0])
    >>> log_axes(ax, y=False)
    >>> lo, hi = ax.get_xlim()
    >>> [ax.xaxis.get_major_formatter()(v) for v in ax.get_xticks() if lo <= v <= hi]
    ['0.02', '0.05', '0.1', '0.2', '0.5']
    >>> plt.close(fig)
    """
    import math

    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    plain = FuncFormatter(lambda v, _pos: f"{v:g}")
    for on, axis, scale, view in ((x, ax.xaxis, ax.set_xscale, ax.get_xlim),
                                  (y, ax.yaxis, ax.set_yscale, ax.get_ylim)):
        if not on:
            continue
        scale("log")
        lo, hi = sorted(abs(v) for v in view())
        decades = math.log10(hi / lo) if lo > 0 and math.isfinite(hi / lo) else 10.0
        subs = (1.0,) if decades > 2.5 else (1.0, 2.0, 5.0) if decades > 0.6 else \
            tuple(float(k) for k in range(1, 10))
        axis.set_major_locator(LogLocator(subs=subs))
        axis.set_major_formatter(plain)
        axis.set_minor_locator(LogLocator(subs=tuple(float(k) for k in range(2, 10))
                                          if decades <= 2.5 else (2.0, 5.0)))
        axis.set_minor_formatter(NullFormatter())


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

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.plotting import plot_response
    >>> d = fl.presets.pendulum_design()
    >>> fig = plot_response(fl.simulate(fl.plants.pendulum(), d, fl.Scenario(0.1, 0.5)))
    >>> [ax.get_ylabel() for ax in fig.axes]
    ['output y', 'input u', 'sigma']
    """
    if axes is None:
        fig, axes = _new_axes(3)
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
    _legend_outside(ax)
    axes[1].step(*line(resp.u), where="post", color="C2", lw=1.0)
    axes[1].set_ylabel("input u")
    axes[2].plot(*line(resp.sigma), color="C0", lw=1.2, label="sigma (true)")
    axes[2].plot(*line(resp.sigmahat), color="C1", lw=0.8, label="sigma estimate")
    axes[2].set_ylabel("sigma")
    axes[2].set_xlabel("time (s)")
    _legend_outside(axes[2])
    if resp.diverged:
        for a in axes:
            a.axvline(resp.divergence_time, color=STATUS_COLORS[0], lw=1.0)
    if title is None:
        title = f"{resp.status}, overshoot {resp.overshoot:.3g} %"
    axes[0].set_title(title)
    return fig


def _legend_outside(ax, **kwargs):
    """A legend to the right of ``ax``, outside the data (the figure's margins make room)."""
    return ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0,
                     fontsize="small", **kwargs)


def _edges(values: np.ndarray) -> np.ndarray:
    """Cell edges of a log-spaced (or single-valued) grid for pcolormesh."""
    v = np.log(np.asarray(values, dtype=float))
    if v.size == 1:
        return np.exp(np.array([v[0] - 0.1, v[0] + 0.1]))
    mid = (v[:-1] + v[1:]) / 2
    return np.exp(np.concatenate([[2 * v[0] - mid[0]], mid, [2 * v[-1] - mid[-1]]]))


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


def _is_bracket(obj) -> bool:
    """Anything shaped like :class:`~fl_design.sim.EpsStar` (a protocol, not an import of
    ``sim``: results are drawn here, the simulation layer draws with this module)."""
    return all(hasattr(obj, name) for name in ("lower", "upper", "upper_status"))


def _holds_eps_stars(curve) -> bool:
    """A pair ``(gamma_values, [EpsStar, ...])``."""
    return (isinstance(curve, (tuple, list)) and len(curve) == 2
            and not callable(curve) and np.ndim(curve[1]) == 1 and len(curve[1]) > 0
            and all(_is_bracket(s) for s in curve[1]))


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
    >>> from fl_design.sim import EpsStar
    >>> from fl_design.plotting import plot_eps_star
    >>> fig, ax = plt.subplots()
    >>> hs = plot_eps_star(ax, [1e-3, 1e-2], [EpsStar(1.0, float("inf")), EpsStar(0.1, 0.2)],
    ...                    label="linearized")
    >>> [h.get_label() for h in hs]
    ['linearized', 'linearized: eps* above the range (> top)']
    """
    g = np.abs(np.asarray(gamma, dtype=float).ravel())  # gamma < 0 (b < 0): at |gamma|
    stars = list(stars)
    if len(stars) != g.size:
        raise ParameterError(f"gamma has {g.size} values but {len(stars)} eps* brackets were "
                             "given; give one bracket per gamma")
    value = np.array([s.lower if s.value is not None else np.nan for s in stars])
    handles = []
    if np.any(np.isfinite(value)):
        (h,) = ax.plot(g, value, color=color, ls=ls, marker=marker, ms=4, label=label)
        handles.append(h)
    undecided = [bool(getattr(s, "undecided", False)) for s in stars]
    outside = ((lambda s, u: s.above_range, "lower", "^", "eps* above the range (> top)"),
               (lambda s, u: s.below_range and not u, "upper", "v",
                "eps* below the range (< bottom)"),
               (lambda s, u: s.below_range and u, "upper", "d",
                "undecided at the bottom (run longer)"))
    for pick, edge, mark, words in outside:
        pts = [(gi, getattr(s, edge)) for gi, s, u in zip(g, stars, undecided) if pick(s, u)]
        if pts:
            (h,) = ax.plot(*zip(*pts), ls="none", marker=mark, ms=8, color=color, mfc="none",
                           mew=1.5, label=f"{label}: {words}")
            handles.append(h)
    return handles


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

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.sim import StabilityMap
    >>> from fl_design.plotting import plot_stability_map
    >>> m = StabilityMap(np.array([0.1, 0.2]), np.array([1.0]), np.array([[1], [-1]]), {},
    ...                  1e-3, 1.0, 0.1)
    >>> plot_stability_map(m).axes[0].get_xlabel()
    'controller gain gamma'
    """
    from matplotlib.colors import BoundaryNorm, ListedColormap
    from matplotlib.patches import Patch

    if ax is None:
        fig, (ax,) = _new_axes(1, figsize=(9.0, 5.0))
    fig = ax.figure
    cmap = ListedColormap(list(STATUS_COLORS))
    norm = BoundaryNorm(np.arange(-2.5, 5.0), cmap.N)
    gx = np.abs(np.asarray(smap.gamma, dtype=float))  # gamma < 0 (b < 0): plotted as |gamma|
    negative = bool(np.any(np.asarray(smap.gamma) < 0))
    ax.pcolormesh(_edges(gx), _edges(smap.eps), np.asarray(smap.status), cmap=cmap,
                  norm=norm, shading="flat")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("controller gain |gamma| (gamma < 0, as b)" if negative
                  else "controller gain gamma")
    ax.set_ylabel("observer time constant eps (s)")
    present = set(np.unique(np.asarray(smap.status)).tolist())
    handles = [Patch(color=c, label=n) for code, c, n in zip(range(-2, 5), STATUS_COLORS,
                                                              STATUS_LABELS) if code in present]
    if show_eps_star:
        stars = [smap.eps_star(g) for g in smap.gamma]
        inside = [(g, b.lower) for g, b in zip(gx, stars) if b.value is not None]
        above = [(g, b.lower) for g, b in zip(gx, stars) if b.above_range]
        if inside:
            (h,) = ax.plot(*zip(*inside), "w^", mec="k", ms=6, label="eps* (this map)")
            handles.append(h)
        if above:
            (h,) = ax.plot(*zip(*above), "w^", mec="k", ms=6, alpha=0.5,
                           label="eps* > largest eps scanned")
            handles.append(h)
    for i, (label, curve) in enumerate((curves or {}).items()):
        if _holds_eps_stars(curve):
            handles += plot_eps_star(ax, *curve, label=str(label), color=f"C{i % 10}")
            continue
        g, e = _curve_points(curve, np.asarray(smap.gamma))
        (h,) = ax.plot(np.abs(g), e, color=f"C{i % 10}", lw=1.8, label=str(label))
        handles.append(h)
    ax.set_xlim(np.sort(_edges(gx)[[0, -1]]))
    ax.set_ylim(_edges(smap.eps)[[0, -1]])
    log_axes(ax)
    _legend_outside(ax, handles=handles)
    ax.set_title(f"closed-loop runs of {smap.duration:g} s")
    return fig


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

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.analysis import EpsStarCurve
    >>> from fl_design.plotting import plot_eps_star_curve
    >>> c = EpsStarCurve(np.array([1e-3, 2e-3]), np.array([0.1, 0.05]),
    ...                  np.array([0.09, np.nan]), (1.0, 2.0), 1e-3, (1e-3, 1.0))
    >>> [l.get_label() for l in plot_eps_star_curve(c).axes[0].get_lines()]
    ['eps* frozen b grid', 'eps* certified (LMI)']
    """
    if ax is None:
        fig, (ax,) = _new_axes(1, figsize=(7.0, 5.0))
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


__all__ = ["REPORT_BUCKETS", "STATUS_COLORS", "STATUS_LABELS", "log_axes", "plot_eps_star",
           "plot_eps_star_curve", "plot_response", "plot_stability_map", "thin_line"]
