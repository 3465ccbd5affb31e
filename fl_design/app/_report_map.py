"""The stability map in words: its runs counted by status, the slow ones told apart.

Shared by the console (``fl-design run`` and ``sweep``) and the report's map section.

Examples
--------
>>> from fl_design.app._report_map import map_counts
>>> map_counts(fl.StabilityMap(np.array([0.1]), np.array([1.0]), np.array([[2]]), {}, 1e-3, 5.0,
...                            0.02))
'1 converged'
"""

from __future__ import annotations

import numpy as np


def slow_runs(smap) -> np.ndarray:
    """Mask of the map's ``undecided`` runs that are slow rather than ambiguous.

    Slow: the run was still moving towards the reference at its end, its error envelope
    shrinking by more than :data:`~fl_design.sim._status.MIN_CHANGE` over the window (too
    slowly for the fit to call) or its controller still moving the input (``input_moving``):
    a loop slower than the run length, which a longer run decides.

    Parameters
    ----------
    smap : fl_design.StabilityMap
        A map (its ``input_moving`` and ``envelope_change`` metrics are read).

    Returns
    -------
    numpy.ndarray of bool
        The map's shape (eps x gamma).

    Examples
    --------
    >>> from fl_design.app._report_map import slow_runs
    >>> m = fl.StabilityMap(np.array([0.1]), np.array([1.0, 2.0]), np.array([[3, 3]]),
    ...                     {"input_moving": np.array([[1.0, 0.0]]),
    ...                      "envelope_change": np.array([[0.0, 0.2]])}, 1e-3, 10.0, 0.02)
    >>> slow_runs(m).tolist()
    [[True, False]]
    """
    from ..sim._status import MIN_CHANGE

    shape = np.shape(smap.status)
    moving = np.asarray(smap.metrics.get("input_moving", np.zeros(shape))) > 0
    shrinking = np.asarray(smap.metrics.get("envelope_change", np.zeros(shape))) < -MIN_CHANGE
    return (smap.labels == "undecided") & (moving | shrinking)


def map_counts(smap) -> str:
    """The stability map's runs counted by status; the undecided ones split by why.

    The ``undecided`` runs that are slow (:func:`slow_runs`) are counted apart, with the range
    of their fitted time constants (``1 / decay_rate`` where the envelope decays): loops slower
    than their run, not an ambiguous trend nor a failure. An adaptive map re-runs the points
    undecided at its duration longer (:func:`fl_design.sweep`'s ``extend``): the counts are
    those of each point's own run, and how many were re-run, to how long, follows
    (:meth:`~fl_design.StabilityMap.extension_text`).

    Parameters
    ----------
    smap : fl_design.StabilityMap
        A map.

    Returns
    -------
    str
        ``"k status, ..."``; then ``"; "`` and the undecided runs' split, the extension.

    Examples
    --------
    >>> from fl_design.app._report_map import map_counts
    >>> m = fl.StabilityMap(np.array([0.1, 0.2]), np.array([1.0, 2.0]), np.array([[2, 3], [3, 3]]),
    ...                     {"input_moving": np.array([[0.0, 1.0], [1.0, 0.0]]),
    ...                      "decay_rate": np.array([[0.0, 0.01], [0.02, 0.0]])}, 1e-3, 10.0, 0.02)
    >>> map_counts(m)
    '1 converged, 3 undecided (2 of them slow: still moving towards the reference at 10 s, fitted time constants 50-100 s)'
    >>> m = fl.StabilityMap(np.array([0.1]), np.array([1.0, 2.0]), np.array([[2, 1]]), {}, 1e-3,
    ...                     10.0, 0.02, durations=np.array([[10.0, 40.0]]), max_duration=40.0)
    >>> map_counts(m)
    '1 converged, 1 converging; 1 run undecided at 10 s re-run at 40 s: now 1 converging'
    """
    labels = smap.labels
    slow = slow_runs(smap)
    parts = []
    for name in ("converged", "converging", "oscillating", "stalled", "undecided", "diverged",
                 "solver_failed"):
        n = int(np.sum(labels == name))
        if not n:
            continue
        text = f"{n} {name}"
        if name == "undecided" and slow.any():
            rate = np.asarray(smap.metrics.get("decay_rate", np.full(slow.shape, np.nan)))[slow]
            tau = 1.0 / rate[np.isfinite(rate) & (rate > 0)]
            fitted = (f", fitted time constants {tau.min():.3g}-{tau.max():.3g} s" if tau.size
                      else "")
            ends = np.unique(np.asarray(smap.durations)[slow])
            at = " and ".join(f"{d:g}" for d in ends)
            text += (f" ({int(slow.sum())} of them slow: still moving towards the reference at "
                     f"{at} s{fitted})")
        parts.append(text)
    extension = smap.extension_text()
    return ", ".join(parts) + (f"; {extension}" if extension else "")


__all__ = ["map_counts", "slow_runs"]
