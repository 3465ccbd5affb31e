"""Partial results: what a grid still gives when a worker of its executor dies.

A sweep or an ensemble run on an executor whose worker dies (killed, out of memory, a crash
in native code) or hangs loses the chunks that worker had not returned; the others are
finished runs, exactly as a complete grid gives them. :class:`~fl_design.errors.WorkerLostError`
carries them in ``.partial``: a result of the type the call returns (a subclass of it), each
finished run's status and metrics kept, each lost run ``undecided`` with NaN metrics and
flagged in the ``lost`` mask, with the reason ``lost_reason`` (``"worker lost"``, then who).

================================ ============================================================
:class:`PartialStabilityMap`     a :class:`~fl_design.sim.StabilityMap` with ``lost``
                                 (``(n_e, n_g)`` bool) and ``lost_reason``
:class:`PartialRobustMap`        a :class:`~fl_design.sim.RobustMap`, ``lost`` of shape
                                 ``(n_e, n_g, samples)``
:class:`PartialEnsemble`         a :class:`~fl_design.sim.Ensemble`, ``lost`` of shape ``(n,)``
================================ ============================================================

``to_dict()`` adds ``lost`` (the mask) and ``lost_reason``. An eps* read from a partial map
treats a lost point as ``undecided`` (never as converging), so it can only be more cautious
than the complete map's.

Examples
--------
>>> import numpy as np
>>> from fl_design.sim._partial import PartialStabilityMap
>>> m = PartialStabilityMap(eps=np.array([0.01, 0.02]), gamma=np.array([1e-2]),
...                         status=np.array([[2], [3]]), metrics={}, T=1e-3, duration=1.0,
...                         tol=1e-3, lost=np.array([[False], [True]]))
>>> m.labels.ravel().tolist(), m.to_dict()["lost"], m.lost_reason, str(m.eps_star(1e-2))
(['converged', 'undecided'], [[False], [True]], 'worker lost', '0.01 (undecided at 0.02: run longer)')
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import LOST_REASON, WorkerLostError
from ._ensemble import Ensemble
from ._robust_map import RobustMap
from ._stability_map import StabilityMap
from ._status import Status


@dataclass(frozen=True)
class _Lost:
    """The ``lost`` mask and its reason (fields after the result's own), checked against the
    status' shape, added to the result's ``to_dict()``."""

    lost: np.ndarray | None = field(default=None, repr=False)
    lost_reason: str = LOST_REASON

    def __post_init__(self) -> None:
        getattr(super(), "__post_init__", lambda: None)()
        shape = np.shape(self.status)
        lost = np.zeros(shape, bool) if self.lost is None else np.asarray(self.lost, bool)
        if lost.shape != shape:
            from ..errors import ParameterError

            raise ParameterError(f"lost must have the status' shape {shape}, got {lost.shape}")
        object.__setattr__(self, "lost", lost)

    @property
    def n_lost(self) -> int:
        """Number of lost runs."""
        return int(np.count_nonzero(self.lost))

    def to_dict(self) -> dict:
        out = super().to_dict()
        out["lost"] = np.asarray(self.lost, bool).tolist()
        out["lost_reason"] = self.lost_reason
        return out


@dataclass(frozen=True)
class PartialStabilityMap(_Lost, StabilityMap):
    """A :class:`~fl_design.sim.StabilityMap` some of whose runs were lost (module doc)."""


@dataclass(frozen=True)
class PartialRobustMap(_Lost, RobustMap):
    """A :class:`~fl_design.sim.RobustMap` some of whose runs were lost (module doc)."""


@dataclass(frozen=True)
class PartialEnsemble(_Lost, Ensemble):
    """An :class:`~fl_design.sim.Ensemble` some of whose runs were lost (module doc)."""


def lost_mask(err: WorkerLostError, n: int) -> np.ndarray:
    """``(n,)`` bool mask of the runs ``err`` lost (flat indices of the grid it ran).

    Examples
    --------
    >>> from fl_design.errors import WorkerLostError
    >>> from fl_design.sim._partial import lost_mask
    >>> lost_mask(WorkerLostError("x", lost=[0, 2]), 3).tolist()
    [True, False, True]
    """
    mask = np.zeros(n, bool)
    mask[np.asarray(err.lost, int)] = True
    return mask


def finished_only(finalize, acc: np.ndarray, lost: np.ndarray,
                  probe: np.ndarray | None = None) -> tuple[np.ndarray, dict]:
    """Flat ``(status, metrics)`` of all runs of ``acc``: ``finalize`` of the finished
    columns, the lost ones ``undecided`` with NaN metrics (never classified from NaN).

    Parameters
    ----------
    finalize : callable
        ``finalize(acc) -> (status (m,), {metric: (m, ...)})`` of finished accumulators.
    acc : numpy.ndarray
        ``(nacc, n)`` accumulators (the lost columns are ignored).
    lost : numpy.ndarray
        ``(n,)`` bool.
    probe : numpy.ndarray, optional
        ``(nacc, 1)`` initial accumulators of a run: when every run is lost, the metrics'
        names and shapes are learnt from it (its values are not used).

    Returns
    -------
    (numpy.ndarray, dict)

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.sim._partial import finished_only
    >>> fin = lambda a: (np.full(a.shape[1], 2), {"iae": a[0]})
    >>> s, m = finished_only(fin, np.array([[1.0, np.nan, 3.0]]), np.array([False, True, False]))
    >>> s.tolist(), m["iae"].tolist()
    ([2, 3, 2], [1.0, nan, 3.0])
    """
    n = acc.shape[1]
    kept = np.flatnonzero(~lost)
    # the metric names and shapes come from a finished column, or a stand-in column
    probe = acc[:, kept] if kept.size or probe is None else probe
    with np.errstate(all="ignore"):
        s, m = finalize(probe)
    status = np.full(n, int(Status.UNDECIDED), dtype=np.asarray(s).dtype)
    metrics = {}
    for k, v in m.items():
        v = np.asarray(v)
        full = np.full((n, *v.shape[1:]), np.nan, dtype=np.result_type(v.dtype, float))
        if kept.size:
            full[kept] = v
        metrics[k] = full
    if kept.size:
        status[kept] = np.asarray(s).reshape(-1)
    return status, metrics


def reason_of(err: WorkerLostError) -> str:
    """``"worker lost"`` and, when known, which worker (the ``lost_reason`` of a partial).

    Examples
    --------
    >>> from fl_design.errors import WorkerLostError
    >>> from fl_design.sim._partial import reason_of
    >>> reason_of(WorkerLostError("x", workers=["worker process 7 (killed by signal 9)"]))
    'worker lost: worker process 7 (killed by signal 9)'
    """
    return LOST_REASON + (": " + "; ".join(err.workers) if err.workers else "")


__all__ = ["PartialEnsemble", "PartialRobustMap", "PartialStabilityMap", "finished_only",
           "lost_mask", "reason_of"]


def _shaped(status: np.ndarray, metrics: dict, shape: tuple) -> tuple[np.ndarray, dict]:
    return status.reshape(shape), {k: (v.reshape(*shape, -1) if k == "estimation_rms"
                                       else v.reshape(shape)) for k, v in metrics.items()}


def grid_lost(err: WorkerLostError, run, shape: tuple) -> tuple[np.ndarray, dict, np.ndarray]:
    """``(status, metrics, lost)`` of a grid of ``shape`` whose run ``err`` interrupted:
    the finished runs classified as :func:`~fl_design.sim._adaptive.assemble` does, the lost
    ones ``undecided`` with NaN metrics.

    Examples
    --------
    >>> from fl_design.sim._partial import grid_lost
    >>> callable(grid_lost)
    True
    """
    from ._adaptive import assemble

    acc = err.accumulators
    lost = lost_mask(err, acc.shape[1])
    status, metrics = finished_only(lambda a: assemble(run, a, (a.shape[1],)), acc, lost,
                                    getattr(err, "probe", None))
    status, metrics = _shaped(status, metrics, shape)
    return status, metrics, lost.reshape(shape)


__all__ += ["grid_lost"]
