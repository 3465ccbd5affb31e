"""Figures of the model-free route: the identification page and the class map.

:func:`plot_identification` draws what :func:`fl_design.identify` read from a log (the local fit
over the most informative window, ``b`` per window against the visited output for both
estimators, the fit's residual against the noise level, the residual's spectrum);
:func:`plot_class_map` draws the surrogate loop's stability margin over the class's ``b`` range
at three observer time constants (``fl-design run CLASS.toml``).

Examples
--------
>>> from fl_design.plotting._identify import plot_class_map
>>> fig = plot_class_map({"b": [1.0, 10.0], "radius": {"0.01": [0.99, 0.995]}})
>>> fig.axes[0].get_xscale()
'log'
"""

from __future__ import annotations

import numpy as np

from ._base import literal


def plot_identification(cls, fit=None) -> dict:
    """The three figures of an identified class: ``fit``, ``residuals``, ``noise``.

    Parameters
    ----------
    cls : IdentifiedClass
        What :func:`fl_design.identify` returned (its ``evidence`` carries the log).
    fit : tuple of (t, y, y_fit, b) or None, optional
        The local fit over the most informative window
        (:func:`fl_design.identification._page.best_window_fit`); None draws no fit.

    Returns
    -------
    dict
        ``{"fit": Figure, "residuals": Figure, "noise": Figure}`` (pyplot figures).

    Examples
    --------
    >>> from fl_design.sim._rig import chain_rig
    >>> d = fl.tune(fl.PlantClass(rho=2, T=1e-3, b=(2, 10)), reference=1.0).design
    >>> log = chain_rig(2, b=4.0, T=1e-3, noise_std=1e-3).run(d, lambda t: (t // 2) % 2, 12.0)
    >>> sorted(plot_identification(fl.identify(log.columns(), rho=2)))
    ['fit', 'noise', 'residuals']
    """
    import matplotlib.pyplot as plt

    ev, L = cls.evidence, cls.evidence.log
    est = ev.windows["local-ls"]
    figs = {}
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 6))
    if fit is not None:
        t, y, y_fit, b = fit
        ax1.plot(t, y, ".", ms=2, label="y (log)")
        ax1.plot(t, y_fit, "-", label=f"local fit, b = {b:.4g}")
        ax1.legend(loc="best", fontsize=8)
    ax1.set_xlabel("t [s]")
    ax1.set_title("the most informative window of the log")
    for name, e in ev.windows.items():
        m = e.informative(0.1)
        ax2.errorbar(e.y_mid[m], e.b[m], yerr=3 * e.se[m], fmt="o", ms=3, label=literal(name))
    lo, hi = cls.b
    ax2.axhspan(lo, hi, alpha=0.15, label="the class's b range")
    ax2.set_xlabel("mean y over the window")
    ax2.set_ylabel("b (+-3 standard errors)")
    ax2.legend(loc="best", fontsize=8)
    fig.tight_layout()
    figs["fit"] = fig
    fig, ax = plt.subplots(figsize=(8, 3))
    ax.plot(L.t[est.start], est.residual, ".", ms=3, label="local fit's residual (rms)")
    ax.axhline(ev.noise_std, color="k", lw=1, label=f"noise std {ev.noise_std:.3g}")
    ax.set_xlabel("window start [s]")
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    figs["residuals"] = fig
    fig, ax = plt.subplots(figsize=(8, 3))
    f, p = np.asarray(ev.spectrum["f"]), np.asarray(ev.spectrum["psd"])
    if f.size > 1:
        ax.loglog(f[1:], p[1:])
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("PSD of the residual")
    fig.tight_layout()
    figs["noise"] = fig
    return figs


def plot_class_map(cmap: dict):
    """The surrogate loop's stability margin ``1 - spectral radius`` over the class's ``b``.

    Parameters
    ----------
    cmap : dict
        ``{"b": [...], "radius": {eps label: [radius per b]}}``.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> fig = plot_class_map({"b": [-1.0, -5.0], "radius": {"0.02": [0.9, 0.99]}})
    >>> fig.axes[0].get_xlabel()
    '|b|'
    """
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 3))
    for e, v in cmap["radius"].items():
        ax.semilogx(np.abs(cmap["b"]), 1.0 - np.asarray(v), label=f"eps {literal(e)} s")
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set_xlabel("|b|")
    ax.set_ylabel("1 - spectral radius")
    ax.set_title("stability margin of the class's frozen members (> 0: stable)")
    ax.legend(loc="lower left", fontsize=8)
    fig.tight_layout()
    return fig


__all__ = ["plot_class_map", "plot_identification"]
