"""Shared pieces of every figure: status colours, axes, log labels, legends, literal text.

matplotlib is imported only inside functions (when a plot is drawn).

Examples
--------
>>> from fl_design.plotting._base import literal
>>> literal("rad") == "rad", "$" in literal("$x$").replace("\\$", "")
(True, False)
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError

#: Colours of the classification by status code -2 .. 4: solver failed, diverged, oscillating,
#: converging, converged, undecided (too short to tell: a cool colour, neither good nor bad),
#: stalled (bounded at an offset: a muted purple).
STATUS_COLORS = ("#7f7f7f", "#d62728", "#ff9f1c", "#a6d96a", "#1a9641", "#9ecae1", "#9467bd")
STATUS_LABELS = ("solver failed", "diverged", "oscillating", "converging", "converged",
                 "undecided (run longer)", "stalled")


def status_legend(status) -> list:
    """``(code, colour, label)`` of each status code present in ``status``, in code order.

    Examples
    --------
    >>> from fl_design.plotting._base import status_legend
    >>> [label for _, _, label in status_legend([[1, -1], [1, 1]])]
    ['diverged', 'converging']
    """
    present = set(np.unique(np.asarray(status)).tolist())
    return [(code, color, label) for code, color, label
            in zip(range(-2, 5), STATUS_COLORS, STATUS_LABELS) if code in present]


#: How an eps* bracket outside the scanned range is drawn, by kind (:func:`bracket_points`):
#: legend words, matplotlib marker, Plotly symbol.
OUTSIDE_RANGE = {
    "above": ("eps* above the range (> top)", "^", "triangle-up-open"),
    "below": ("eps* below the range (< bottom)", "v", "triangle-down-open"),
    "undecided": ("undecided at the bottom (run longer)", "d", "diamond-open"),
}


def is_bracket(obj) -> bool:
    """Whether ``obj`` is shaped like :class:`~fl_design.sim.EpsStar` (a protocol, not an
    import of ``sim``: results are drawn here, the simulation layer draws with this package).

    Examples
    --------
    >>> from fl_design.plotting._base import is_bracket
    >>> is_bracket(fl.sim.EpsStar(0.1, 0.2)), is_bracket(0.1)
    (True, False)
    """
    return all(hasattr(obj, name) for name in ("lower", "upper", "upper_status"))


def bracket_points(gamma, stars) -> dict:
    """Where the eps* brackets ``stars`` over ``gamma`` (one each) are drawn: kind -> list of
    ``(|gamma|, eps)`` points, kinds without points left out.

    ``"value"``: a line over every gamma at the brackets' ``lower`` ends inside the range, NaN
    where a bracket is outside (the line breaks there); then the kinds of
    :data:`OUTSIDE_RANGE`: ``"above"`` at ``lower`` (the range's top), ``"below"`` and
    ``"undecided"`` at ``upper`` (the range's bottom; undecided: the run there is too short to
    call, not a failure). An outside bracket is never drawn as a value. Lengths that differ
    raise :class:`~fl_design.errors.ParameterError`.

    Examples
    --------
    >>> from fl_design.plotting._base import bracket_points
    >>> bracket_points([1e-3, -1e-2], [fl.sim.EpsStar(1.0, float("inf")), fl.sim.EpsStar(0.1, 0.2)])
    {'value': [(0.001, nan), (0.01, 0.1)], 'above': [(0.001, 1.0)]}
    """
    g = np.abs(np.asarray(gamma, dtype=float).ravel()).tolist()
    stars = list(stars)
    if len(stars) != len(g):
        raise ParameterError(f"gamma has {len(g)} values but {len(stars)} eps* brackets were "
                             "given; give one bracket per gamma")
    value = [(gi, s.lower if s.value is not None else float("nan")) for gi, s in zip(g, stars)]
    out = {"value": value} if any(s.value is not None for s in stars) else {}
    for kind in OUTSIDE_RANGE:
        pts = [(gi, s.lower if kind == "above" else s.upper) for gi, s in zip(g, stars)
               if _outside(s) == kind]
        if pts:
            out[kind] = pts
    return out


def _outside(star) -> str | None:
    """Which kind of :data:`OUTSIDE_RANGE` a bracket is (None: inside the range)."""
    if star.above_range:
        return "above"
    if star.below_range:
        return "undecided" if getattr(star, "undecided", False) else "below"
    return None


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


def new_axes(nrows: int, sharex: bool = True, figsize=(7.0, 6.0), *, bottom: float = 0.1):
    """A figure of ``nrows`` stacked axes with fixed margins (``bottom``: room for a legend
    below); returns ``(fig, [axes])``.

    Fixed margins, not a layout engine: its solve costs about half of a figure's rendering.

    Examples
    --------
    >>> from fl_design.plotting._base import close_figure, new_axes
    >>> fig, axes = new_axes(2)
    >>> len(axes)
    2
    >>> close_figure(fig)
    """
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(nrows, 1, sharex=sharex, figsize=figsize, squeeze=False)
    fig.subplots_adjust(left=0.12, right=0.96, top=0.93, bottom=bottom, hspace=0.18)
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


def legend_inside(ax, **kwargs):
    """A small legend inside ``ax`` where it hides the least data (``loc="best"``).

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> from fl_design.plotting._base import legend_inside
    >>> fig, ax = plt.subplots()
    >>> _ = ax.plot([1, 2], label="a")
    >>> legend_inside(ax).get_texts()[0].get_text()
    'a'
    >>> plt.close(fig)
    """
    return ax.legend(loc="best", fontsize="small", framealpha=0.85, **kwargs)


def edges(values: np.ndarray) -> np.ndarray:
    """Cell edges of a log-spaced (or single-valued) grid for pcolormesh."""
    v = np.log(np.asarray(values, dtype=float))
    if v.size == 1:
        return np.exp(np.array([v[0] - 0.1, v[0] + 0.1]))
    mid = (v[:-1] + v[1:]) / 2
    return np.exp(np.concatenate([[2 * v[0] - mid[0]], mid, [2 * v[-1] - mid[-1]]]))



def literal(text) -> str:
    r"""``text`` drawn as written, on one line: every ``$`` escaped, so a user's name or unit is
    never parsed as mathtext (``"$\foo{$"`` would make matplotlib raise when the figure is
    drawn); newlines become spaces.

    Parameters
    ----------
    text : object
        Anything; ``str()`` of it is used.

    Examples
    --------
    >>> from fl_design.plotting._base import literal
    >>> print(literal("m/s$^2$"))
    m/s\$^2\$
    """
    one_line = " ".join(str(text).split())  # a newline would make a second title line
    return one_line.replace("\\$", "$").replace("$", "\\$")


def legend_below(ax, ncol: int = 3, **kwargs):
    """A legend under ``ax``, centred, in ``ncol`` columns (the axes keep the figure's width).

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes.
    ncol : int, optional
        Columns.
    **kwargs
        Passed to ``ax.legend`` (e.g. ``handles``).

    Returns
    -------
    matplotlib.legend.Legend

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> from fl_design.plotting._base import legend_below
    >>> fig, ax = plt.subplots()
    >>> lines = ax.plot([1, 2], label="a") + ax.plot([2, 1], label="b")
    >>> [t.get_text() for t in legend_below(ax, ncol=2, handles=lines[::-1]).get_texts()]
    ['b', 'a']
    >>> plt.close(fig)
    """
    return ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), borderaxespad=0.0,
                     fontsize="small", ncol=ncol, frameon=False, **kwargs)


def save_figure(fig, path, *, dpi: int = 110) -> None:
    """Write ``fig`` as PNG to ``path`` and close it (frees its memory in long jobs).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    path : str or pathlib.Path
        The file.
    dpi : int, optional
        Resolution.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> import matplotlib.pyplot as plt
    >>> from fl_design.plotting._base import save_figure
    >>> fig, ax = plt.subplots()
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "a.png"
    >>> save_figure(fig, p); p.stat().st_size > 0
    True
    """
    import matplotlib.pyplot as plt

    try:
        fig.savefig(path, dpi=dpi)
    finally:
        plt.close(fig)


def close_figure(fig) -> None:
    """Close ``fig`` (drop it from pyplot's list of open figures).

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> from fl_design.plotting._base import close_figure
    >>> close_figure(plt.figure())
    """
    import matplotlib.pyplot as plt

    plt.close(fig)


__all__ = ["REPORT_BUCKETS", "STATUS_COLORS", "STATUS_LABELS", "close_figure", "edges",
           "legend_below", "legend_inside", "literal", "log_axes", "new_axes", "save_figure",
           "thin_line"]
