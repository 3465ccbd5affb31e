"""The report's figures: each names its design, every axis has its unit; figures are returned.

Examples
--------
>>> from fl_design.app._report_figures import design_label
>>> import fl_design as fl
>>> design_label(fl.presets.paper_design())
'EHGO eps = 0.05 s, gamma = 0.0003, K = (2, 4), k_I = 0.001, T = 0.001 s'
"""

from __future__ import annotations

import math

import numpy as np

from ..plotting import REPORT_BUCKETS, log_axes, plot_eps_star, plot_response, thin_line
from ._report_sections import overshoot_text, paper_gamma_bound


def design_label(design) -> str:
    """One line naming a design's numbers (used in every figure title).

    Parameters
    ----------
    design : fl_design.Design
        The design.

    Returns
    -------
    str

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.app._report_figures import design_label
    >>> design_label(fl.presets.least_squares_design(9))[:5]
    'LS(9)'
    """
    est, ctrl = design.estimator, design.controller
    head = f"EHGO eps = {est.eps:g} s" if est.has_time_constant else f"LS({est.window})"
    gains = ", ".join(f"{k:g}" for k in ctrl.gains)
    return (f"{head}, gamma = {ctrl.gamma:g}, K = ({gains}), k_I = {ctrl.ki:g}, "
            f"T = {design.T:g} s")


def _gamma_unit(job) -> str:
    rho = job.plant.relative_degree()
    return f"{job.config.plant.input_unit} s^{rho}/{_y(job)}"


def _y(job) -> str:
    return job.config.plant.output_unit


def stability_map_figure(job):
    """The empirical stability map with the curves, the design point and ``1/b_max``.

    Parameters
    ----------
    job : Job
        After the sweep (and the certification, when run).

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> from fl_design.app import load_config, run_job
    >>> from fl_design.app._report_figures import stability_map_figure
    >>> job = run_job(load_config(None), quick=True, stages=("sweep",), progress=False)
    >>> stability_map_figure(job).axes[0].get_xscale()
    'log'
    """
    smap = job.results["sweep"]
    curves = {}
    cert = job.results.get("certify", {})
    if "curve" in cert:
        curves["certified eps* (LMI)"] = (cert["curve"].gamma, cert["curve"].eps_star_certified)
    if "linearized" in cert:
        lin = cert["linearized"]
        curves["linearized eps*"] = (lin["gamma"], lin["eps_star"])
    fig = smap.plot(curves=curves)
    ax = fig.axes[0]
    d = job.design
    ax.plot([d.controller.gamma], [d.estimator.eps], marker="*", ms=16, color="k",
            mfc="yellow", ls="none", label="this design")
    b = job.derivation.get("b_bounds")
    if b is not None:
        bound, text = paper_gamma_bound(b)
        if math.isfinite(bound):
            where = "" if bound <= abs(smap.gamma[-1]) * 1.5 else ", right of this map"
            ax.axvline(bound, color="k", ls=":", lw=1.2, label=f"paper's {text}{where}")
    handles, _labels = ax.get_legend_handles_labels()
    old = ax.get_legend()
    keep = list(old.legend_handles) if old is not None else []
    ax.legend(handles=keep + handles[-2:], loc="upper left", bbox_to_anchor=(1.01, 1.0),
              borderaxespad=0.0, fontsize="x-small")
    ax.set_xlabel(f"controller gain gamma ({_gamma_unit(job)})")
    ax.set_ylabel("observer time constant eps (s)")
    ax.set_title(f"{job.plant.name}: stability map", fontsize="small")
    fig.set_size_inches(10.0, 5.0)
    fig.subplots_adjust(left=0.09, right=0.58)  # room for the legend on the right
    return fig


def eps_star_figure(job):
    """Certified, frozen, linearized and empirical ``eps*(gamma)`` with ``gamma < 1/b_max``.

    Parameters
    ----------
    job : Job
        After the certification and the sweep.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> from fl_design.app import load_config, run_job
    >>> from fl_design.app._report_figures import eps_star_figure
    >>> job = run_job(load_config(None), quick=True, stages=("certify",), progress=False)
    >>> eps_star_figure(job).axes[0].get_ylabel()
    'eps* (s)'
    """
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(10.0, 4.6))
    fig.subplots_adjust(left=0.08, right=0.56, top=0.92, bottom=0.12)
    cert = job.results.get("certify", {})
    if "curve" in cert:
        c = cert["curve"]
        ax.plot(c.gamma, c.eps_star_frozen, "k-", lw=1.4, label="frozen b grid (surrogate)")
        ax.plot(c.gamma, c.eps_star_certified, "C2o-", ms=4, label="certified (LMI)")
    if "linearized" in cert:
        lin = cert["linearized"]
        plot_eps_star(ax, lin["gamma"], lin["eps_star"], label="linearized nonlinear loop",
                      color="C0", ls="--")
    smap = job.results.get("sweep")
    if smap is not None:
        plot_eps_star(ax, smap.gamma, [smap.eps_star(g) for g in smap.gamma],
                      label="empirical (sweep; grid lower bound)", color="C3", ls="none",
                      marker="o")
    b = job.derivation.get("b_bounds")
    if b is not None:
        bound, text = paper_gamma_bound(b)
        if math.isfinite(bound):
            ax.axvline(bound, color="k", ls=":", label=text)
    d = job.design
    ax.plot([d.controller.gamma], [d.estimator.eps], "k*", ms=12, mfc="yellow",
            label="this design")
    log_axes(ax)
    ax.set_xlabel(f"controller gain gamma ({_gamma_unit(job)})")
    ax.set_ylabel("eps* (s)")
    ax.set_title(f"{job.plant.name}: eps*(gamma)", fontsize="small")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0,
              fontsize="x-small")
    return fig


def step_figure(job):
    """Step responses of every compared design, one panel per noise level.

    Parameters
    ----------
    job : Job
        After the simulations.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> from fl_design.app import load_config, run_job
    >>> from fl_design.app._report_figures import step_figure
    >>> job = run_job(load_config(None), quick=True, stages=("simulate",), progress=False)
    >>> len(step_figure(job).axes)
    3
    """
    import matplotlib.pyplot as plt

    sim = job.results["simulate"]
    stds = sim["stds"]
    fig, axes = plt.subplots(len(stds), 1, sharex=True, figsize=(9.0, 2.4 * len(stds)),
                             squeeze=False)
    fig.subplots_adjust(left=0.09, right=0.66, top=0.9, bottom=0.1, hspace=0.35)
    for ax, std in zip(axes[:, 0], stds):
        for i, name in enumerate(sim["designs"]):
            r = sim["runs"][(name, std)]
            over = overshoot_text(r)
            over = f"{over} %" if over[:1].isdigit() else "never reaches r"
            ax.plot(*thin_line(r.t, r.y), color=f"C{i}", lw=1.1,
                    label=f"{name}: {r.status}, {over}")
        ax.plot(*thin_line(r.t, r.r), "k--", lw=0.9, label="reference")
        ax.set_ylabel(f"y ({_y(job)})")
        ax.set_title(f"noise std {std:.3g} {_y(job)}" if std else "noise-free",
                     fontsize="small")
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0,
                  fontsize="x-small")
    axes[-1, 0].set_xlabel("time (s)")
    fig.suptitle(f"{job.plant.name}: EHGO vs least squares", fontsize="small")
    return fig


def tradeoff_figure(job):
    """Noise of ``sigmahat`` and ``u`` against eps (the EHGO's noise trade-off).

    Parameters
    ----------
    job : Job
        After the simulations (EHGO designs only).

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> from fl_design.app import load_config, run_job
    >>> from fl_design.app._report_figures import tradeoff_figure
    >>> job = run_job(load_config(None), quick=True, stages=("simulate",), progress=False)
    >>> tradeoff_figure(job).axes[1].get_xlabel()
    'observer time constant eps (s)'
    """
    import matplotlib.pyplot as plt

    rows = job.results["simulate"]["tradeoff"]
    fig, axes = plt.subplots(2, 1, sharex=True, figsize=(7.0, 4.8))
    fig.subplots_adjust(left=0.14, right=0.96, top=0.9, bottom=0.12, hspace=0.12)
    eps = np.array([r["eps"] for r in rows])
    axes[0].plot(eps, [r["sigmahat_noise"] for r in rows], "C1o-")
    axes[0].set_ylabel(f"sigmahat noise ({_y(job)}/s^{job.plant.relative_degree()})")
    axes[1].plot(eps, [r["u_noise"] for r in rows], "C2o-")
    axes[1].set_ylabel(f"u noise ({job.config.plant.input_unit})")
    axes[1].set_xlabel("observer time constant eps (s)")
    for ax in axes:
        log_axes(ax)
    std = rows[0]["noise_std"] if rows else 0.0
    fig.suptitle(f"{job.plant.name}: noise against eps (noise std {std:.3g} {_y(job)})",
                 fontsize="small")
    return fig


def main_response_figure(job):
    """The configured design's own run: output, input and ``sigma`` with its estimate.

    Parameters
    ----------
    job : Job
        After the simulations.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> from fl_design.app import load_config, run_job
    >>> from fl_design.app._report_figures import main_response_figure
    >>> job = run_job(load_config(None), quick=True, stages=("simulate",), progress=False)
    >>> main_response_figure(job).axes[2].get_xlabel()
    'time (s)'
    """
    resp = job.results["simulate"]["main"]
    # a short title; the verdict is the caption
    fig = plot_response(resp, title=f"{job.plant.name}: this design ({resp.status})",
                        buckets=REPORT_BUCKETS)  # a PNG: M4-thinned lines, same pixels
    fig.axes[0].title.set_fontsize("small")
    fig.axes[0].set_ylabel(f"output y ({_y(job)})")
    fig.axes[1].set_ylabel(f"input u ({job.config.plant.input_unit})")
    fig.axes[2].set_ylabel(f"sigma ({_y(job)}/s^{job.plant.relative_degree()})")
    u_eq = job.derivation.get("u_eq")
    if u_eq is not None:  # the operating point's input
        fig.axes[1].axhline(u_eq, color="k", ls=":", lw=1.0, label=f"u_eq = {u_eq:.3g}")
        fig.axes[1].legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0,
                           fontsize="small")
    return fig


__all__ = ["design_label", "eps_star_figure", "main_response_figure", "stability_map_figure",
           "step_figure", "tradeoff_figure"]
