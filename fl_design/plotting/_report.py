"""The report's figures, from result objects and a :class:`FigureContext` (names and units).

Each figure has a one-line title, its units on every axis, its legend inside or below the axes,
and the same colours as the others: the configured design is always ``C0`` and a yellow star,
the least-squares baselines ``C1``, ``C2``, ..., the reference black dashed, the paper's gamma
bound black dotted. Every name the user chose (plant, units, parameters) is drawn literally
(:func:`~fl_design.plotting._base.literal`).

Examples
--------
>>> from fl_design.plotting import FigureContext
>>> FigureContext("trms_yaw", y_unit="rad", u_unit="V", rho=2).gamma_unit
'V s^2/rad'
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ._base import REPORT_BUCKETS, legend_below, legend_inside, literal, log_axes, thin_line
from ._maps import plot_eps_star, plot_robust_map, plot_stability_map
from ._response import plot_response

#: The configured design's marker (every map and curve figure).
STAR = {"marker": "*", "ms": 15, "color": "k", "mfc": "#ffd700", "ls": "none"}


@dataclass(frozen=True)
class FigureContext:
    """What the report's figures say besides the results: names, units, the design's point.

    Parameters
    ----------
    plant : str
        The plant's name (drawn literally).
    y_unit, u_unit : str, optional
        Units of the output and the input.
    rho : int, optional
        Relative degree (the unit of gamma and sigma).
    design_gamma : float, optional
        The configured design's gamma (NaN: none).
    design_eps : float or None, optional
        Its eps (None: an estimator without one).
    gamma_bound : float, optional
        The paper's bound ``1/max|b|`` on ``|gamma|`` (NaN: none).
    gamma_bound_text : str, optional
        The bound in words (the legend).
    u_eq : float or None, optional
        The operating point's input (a dotted line on the input axis).

    Examples
    --------
    >>> from fl_design.plotting import FigureContext
    >>> print(FigureContext("p", y_unit="$m$").y_label("output y"))
    output y (\\$m\\$)
    """

    plant: str
    y_unit: str = ""
    u_unit: str = ""
    rho: int = 1
    design_gamma: float = math.nan
    design_eps: float | None = None
    gamma_bound: float = math.nan
    gamma_bound_text: str = ""
    u_eq: float | None = None

    @property
    def name(self) -> str:
        """The plant's name, literal."""
        return literal(self.plant)

    @property
    def gamma_unit(self) -> str:
        """The unit of gamma: input unit times s^rho over output unit (literal)."""
        return literal(f"{self.u_unit} s^{self.rho}/{self.y_unit}")

    @property
    def gamma_label(self) -> str:
        """The gamma axis' label: ``controller gain |gamma| (unit)``."""
        return f"controller gain |gamma| ({self.gamma_unit})"

    def y_label(self, what: str) -> str:
        """``what (output unit)`` (literal)."""
        return f"{what} ({literal(self.y_unit)})" if self.y_unit else what

    def u_label(self, what: str) -> str:
        """``what (input unit)`` (literal)."""
        return f"{what} ({literal(self.u_unit)})" if self.u_unit else what

    def star(self, ax) -> None:
        """The configured design's point on (|gamma|, eps) axes (nothing without eps)."""
        if self.design_eps is not None and math.isfinite(self.design_gamma):
            ax.plot([abs(self.design_gamma)], [self.design_eps], label="this design", **STAR)

    def finish_map(self, ax, title: str) -> None:
        """A map's last touches: the legend below (the map's own entries first, then what was
        drawn since, such as the star), the gamma label in units, the plant's name and
        ``title`` on top."""
        old = ax.get_legend()
        handles = list(old.legend_handles) if old is not None else []
        known = {h.get_label() for h in handles}
        handles += [h for h in ax.get_legend_handles_labels()[0] if h.get_label() not in known]
        legend_below(ax, ncol=2, handles=handles)
        ax.set_xlabel(self.gamma_label)
        ax.set_title(f"{self.name}: {title}", fontsize="medium")

    def bound_line(self, ax, right: float | None = None) -> None:
        """The paper's ``|gamma| < 1/max|b|``, a dotted vertical line (if inside the view)."""
        if not math.isfinite(self.gamma_bound):
            return
        where = "" if right is None or self.gamma_bound <= right else " (off the map)"
        ax.axvline(self.gamma_bound, color="k", ls=":", lw=1.2,
                   label=f"paper's bound |gamma| < {self.gamma_bound:.3g}{where}")


def stability_map_figure(smap, ctx: FigureContext, *, curves=None):
    """The stability map with the design's point, the paper's bound and eps* curves.

    Parameters
    ----------
    smap : fl_design.StabilityMap
        The sweep.
    ctx : FigureContext
        Names, units, the design's point.
    curves : dict, optional
        ``{label: (gamma, eps or EpsStar brackets)}`` overlaid.

    Returns
    -------
    matplotlib.figure.Figure
        :func:`~fl_design.plotting.plot_stability_map`'s, in ``ctx``'s units, with the
        design's star and the paper's bound.

    Examples
    --------
    >>> from fl_design.plotting import FigureContext
    >>> from fl_design.plotting._report import stability_map_figure
    >>> m = fl.StabilityMap(np.array([0.1, 0.2]), np.array([1.0]), np.array([[1], [-1]]), {},
    ...                     1e-3, 1.0, 0.1)
    >>> stability_map_figure(m, FigureContext("p", design_gamma=1.0, design_eps=0.1)
    ...                      ).axes[0].get_title()
    'p: stability map, noise-free runs of 1 s'
    """
    fig = plot_stability_map(smap, curves=curves)
    ctx.star(fig.axes[0])
    ctx.bound_line(fig.axes[0], right=float(np.max(np.abs(smap.gamma))) * 1.5)
    lost = int(getattr(smap, "n_lost", 0))  # a partial map says so in its title
    ctx.finish_map(fig.axes[0], f"stability map, noise-free runs of {smap.duration:g} s"
                   + (f" (PARTIAL: {lost} of {np.size(smap.status)} runs lost, x)" if lost
                      else ""))
    return fig


def eps_star_figure(ctx: FigureContext, *, curve=None, linearized=None, smap=None):
    """Certified, frozen, linearized and empirical ``eps*(gamma)``, the paper's bound.

    Parameters
    ----------
    ctx : FigureContext
        Names, units, the design's point.
    curve : fl_design.EpsStarCurve, optional
        The certified and frozen curves.
    linearized : (array, list of EpsStar), optional
        The linearized loop's brackets per gamma.
    smap : fl_design.StabilityMap, optional
        The empirical brackets.

    Returns
    -------
    matplotlib.figure.Figure
        One axes, log-log once a curve is drawn.

    Examples
    --------
    >>> from fl_design.plotting import FigureContext
    >>> from fl_design.plotting._report import eps_star_figure
    >>> eps_star_figure(FigureContext("p", design_gamma=1e-3, design_eps=0.05)).axes[0].get_ylabel()
    'eps* (s)'
    """
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8.0, 5.2))
    fig.subplots_adjust(left=0.1, right=0.97, top=0.93, bottom=0.3)
    if curve is not None:
        ax.plot(np.abs(curve.gamma), curve.eps_star_frozen, "k-", lw=1.4,
                label="frozen b (surrogate)")
        ax.plot(np.abs(curve.gamma), curve.eps_star_certified, "C2o-", ms=4,
                label="certified (LMI)")
    if linearized is not None:
        plot_eps_star(ax, *linearized, label="linearized loop", color="C0", ls="--")
    if smap is not None:
        plot_eps_star(ax, smap.gamma, [smap.eps_star(g) for g in smap.gamma],
                      label="empirical (sweep)", color="C3", ls="none", marker="o")
    ctx.bound_line(ax)
    ctx.star(ax)
    if ax.has_data():
        log_axes(ax)
    ax.set_xlabel(ctx.gamma_label)
    ax.set_ylabel("eps* (s)")
    ax.set_title(f"{ctx.name}: largest stable eps against gamma", fontsize="medium")
    if ax.get_legend_handles_labels()[0]:
        legend_below(ax, ncol=2)
    return fig


def step_figure(runs, designs, stds, ctx: FigureContext, *, labels=None, window: str = ""):
    """Step responses of the compared designs, one panel per noise level, same colours.

    Parameters
    ----------
    runs : dict
        ``{(design name, noise std): Response}``.
    designs : sequence of str
        The design names in order (the first is the configured design: ``C0``).
    stds : sequence of float
        Noise levels (one panel each).
    ctx : FigureContext
        Names and units.
    labels : dict, optional
        ``{(name, std): legend text}`` (default: the name and the status); the legends sit
        below each panel, the reference is the black dashed line.
    window : str, optional
        Which window the runs show and why (the title's second half).

    Returns
    -------
    matplotlib.figure.Figure
        One axes per noise level, top to bottom, sharing the time axis.

    Examples
    --------
    >>> from fl_design.plotting import FigureContext
    >>> from fl_design.plotting._report import step_figure
    >>> r = fl.simulate(fl.plants.pendulum(), fl.presets.pendulum_design(), fl.Scenario(0.1, 1.0))
    >>> len(step_figure({("a", 0.0): r}, ["a"], [0.0], FigureContext("p")).axes)
    1
    """
    import matplotlib.pyplot as plt

    n = len(stds)
    fig, axes = plt.subplots(n, 1, sharex=True, figsize=(8.0, 1.0 + 2.7 * n), squeeze=False)
    fig.subplots_adjust(left=0.1, right=0.97, top=1 - 0.55 / fig.get_figheight(),
                        bottom=1.0 / fig.get_figheight(), hspace=0.5)
    r = None
    for k, (ax, std) in enumerate(zip(axes[:, 0], stds)):
        for i, name in enumerate(designs):
            r = runs[(name, std)]
            text = (labels or {}).get((name, std), f"{name}: {r.status}")
            ax.plot(*thin_line(r.t, r.y), color=f"C{i}", lw=1.1, label=literal(text))
        if r is not None:
            ax.plot(*thin_line(r.t, r.r), "k--", lw=0.9)  # the reference (the caption says)
        ax.set_ylabel(ctx.y_label("y"))
        ax.set_title(f"sensor noise std {std:.3g} {literal(ctx.y_unit)}" if std else
                     "noise-free", loc="left", fontsize="small")
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.34 if k == n - 1 else -0.07),
                  ncol=min(3, len(designs)), fontsize="small", frameon=False,
                  borderaxespad=0.0, handlelength=1.5, columnspacing=1.2)
    axes[-1, 0].set_xlabel("time (s)")
    head = f"{ctx.name}: compared estimators under one controller"
    fig.suptitle(head + (f", {literal(window)}" if window else ""), fontsize="medium")
    return fig


def tradeoff_figure(rows, ctx: FigureContext):
    """Noise of ``sigmahat`` and ``u`` against eps (the EHGO's trade-off).

    Parameters
    ----------
    rows : list of dict
        ``eps``, ``sigmahat_noise``, ``u_noise``, ``noise_std`` per run.
    ctx : FigureContext
        Names and units.

    Returns
    -------
    matplotlib.figure.Figure
        Two axes sharing eps: the estimate's noise above, the input's below.

    Examples
    --------
    >>> from fl_design.plotting import FigureContext
    >>> from fl_design.plotting._report import tradeoff_figure
    >>> rows = [{"eps": e, "sigmahat_noise": 1 / e, "u_noise": 0.1 / e, "noise_std": 0.01}
    ...         for e in (0.01, 0.1)]
    >>> tradeoff_figure(rows, FigureContext("p")).axes[1].get_xlabel()
    'observer time constant eps (s)'
    """
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 1, sharex=True, figsize=(8.0, 4.8))
    fig.subplots_adjust(left=0.12, right=0.97, top=0.92, bottom=0.12, hspace=0.12)
    eps = np.array([r["eps"] for r in rows])
    axes[0].plot(eps, [r["sigmahat_noise"] for r in rows], "C0o-")
    axes[0].set_ylabel(f"sigmahat noise ({literal(ctx.y_unit) or '1'}/s^{ctx.rho})")
    axes[1].plot(eps, [r["u_noise"] for r in rows], "C0o-")
    axes[1].set_ylabel(ctx.u_label("u noise"))
    axes[1].set_xlabel("observer time constant eps (s)")
    for ax in axes:
        if ax.has_data() and np.any(np.isfinite(ax.lines[0].get_ydata())):
            log_axes(ax)
    std = rows[0]["noise_std"] if rows else 0.0
    fig.suptitle(f"{ctx.name}: estimate and input noise against eps (sensor noise std "
                 f"{std:.3g} {literal(ctx.y_unit)})", fontsize="medium")
    return fig


def response_figure(resp, ctx: FigureContext, *, title: str):
    """The configured design's run: output and reference, input (``u_eq`` dotted), sigma.

    Parameters
    ----------
    resp : fl_design.Response
        The run.
    ctx : FigureContext
        Names, units, ``u_eq``.
    title : str
        One line (the short verdict).

    Returns
    -------
    matplotlib.figure.Figure
        :func:`~fl_design.plotting.plot_response`'s three axes (output, input, sigma)
        in ``ctx``'s units.

    Examples
    --------
    >>> from fl_design.plotting import FigureContext
    >>> from fl_design.plotting._report import response_figure
    >>> r = fl.simulate(fl.plants.pendulum(), fl.presets.pendulum_design(), fl.Scenario(0.1, 1.0))
    >>> response_figure(r, FigureContext("p", y_unit="rad"), title="t").axes[0].get_ylabel()
    'output y (rad)'
    """
    fig = plot_response(resp, title=literal(title), buckets=REPORT_BUCKETS)
    fig.set_size_inches(8.0, 6.0)
    fig.axes[0].title.set_fontsize("medium")
    fig.axes[0].set_ylabel(ctx.y_label("output y"))
    fig.axes[1].set_ylabel(ctx.u_label("input u"))
    fig.axes[2].set_ylabel(f"sigma ({literal(ctx.y_unit) or '1'}/s^{ctx.rho})")
    if ctx.u_eq is not None and math.isfinite(ctx.u_eq):
        fig.axes[1].axhline(ctx.u_eq, color="k", ls=":", lw=1.0, label=f"u_eq = {ctx.u_eq:.3g}")
        legend_inside(fig.axes[1])
    return fig


def robust_map_figure(rmap, ctx: FigureContext, *, level: float = 1.0):
    """The robust stability map with the design's point.

    Parameters
    ----------
    rmap : fl_design.sim.RobustMap
        The robust sweep.
    ctx : FigureContext
        Names, the design's point.
    level : float, optional
        The fraction of plants its eps* requires.

    Returns
    -------
    matplotlib.figure.Figure
        Log-log axes of the fractions (the colour bar has its own axes); the star marks
        this design.

    Examples
    --------
    >>> from fl_design.plotting import FigureContext
    >>> from fl_design.plotting._report import robust_map_figure
    >>> m = fl.RobustMap(np.array([0.1, 0.2]), np.array([1.0]), np.array([[[2, 2]], [[2, -1]]]),
    ...                  {}, {"b": np.ones(2)}, 1e-3, 1.0)
    >>> robust_map_figure(m, FigureContext("p", design_gamma=1.0, design_eps=0.1)
    ...                   ).axes[0].get_ylabel()
    'observer time constant eps (s)'
    """
    fig = plot_robust_map(rmap, level=level)
    ctx.star(fig.axes[0])
    lost = int(getattr(rmap, "n_lost", 0))  # a partial map says so in its title
    ctx.finish_map(fig.axes[0], f"robust stability map, {rmap.n} plants, seed {rmap.seed}"
                   + (f" (PARTIAL: {lost} of {np.size(rmap.status)} runs lost, x)" if lost
                      else ""))
    return fig


__all__ = ["STAR", "FigureContext", "eps_star_figure", "response_figure", "robust_map_figure",
           "stability_map_figure", "step_figure", "tradeoff_figure"]
