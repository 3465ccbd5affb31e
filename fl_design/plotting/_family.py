"""Plots of a family of plants: :class:`~fl_design.sim.Ensemble` histograms and verdicts (the
robust stability map is drawn with the other maps, :mod:`fl_design.plotting._maps`).

matplotlib is imported only when a plot is drawn (:mod:`fl_design.plotting`'s axes and colours).

Examples
--------
>>> from fl_design.plotting import plot_ensemble
>>> callable(plot_ensemble)
True
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError
from ._base import literal, status_legend


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
    >>> from fl_design.sim._ensemble import Ensemble
    >>> from fl_design.plotting import plot_ensemble
    >>> ens = Ensemble({"c": np.array([0.1, 0.5])}, np.array([2, 1]),
    ...                {"iae": np.array([0.1, 0.2])}, 1e-3, 1.0, np.ones(2))
    >>> len(plot_ensemble(ens, metrics=("iae",)).axes)
    2
    """
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

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
        ax.set_xlabel(literal(name))
        ax.set_ylabel("samples")
        ax.set_title(f"{v.size} of {ens.n} finite", fontsize=9)
    ax = axes[-1]
    codes = np.asarray(ens.status)
    xs = np.asarray(ens.params[x])
    ys = np.asarray(ens.params[y]) if y is not None else codes.astype(float)
    handles = []
    for code, color, label in status_legend(codes):
        sel = codes == code
        ax.scatter(xs[sel], ys[sel], s=10, color=color)
        handles.append(Patch(color=color, label=f"{label} ({sel.sum()})"))
    ax.set_xlabel(literal(x))
    ax.set_ylabel(literal(y) if y is not None else "status code")
    ax.legend(handles=handles, fontsize=8)
    fig.tight_layout()
    return fig


__all__ = ["plot_ensemble"]
