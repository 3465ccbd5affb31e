"""Kernel threads kept for a runner's life, fork-safe, and the accumulators' row layout.

Shared by the compiled runners (:mod:`fl_design.sim.kernel._runners`,
:mod:`fl_design.sim.kernel._lanes`): a sweep calls the kernel once per chunk and block of
samples, so its threads are created once; a process forked from this one gets fresh ones.

Examples
--------
>>> from fl_design.sim.kernel._threads import ThreadsOwner
>>> ThreadsOwner()._pool(2) is not None
True
"""

from __future__ import annotations

import os
import threading
import weakref
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from ...errors import DimensionError

_LIVE: weakref.WeakSet = weakref.WeakSet()  # runners of this process (reset in a forked child)


def _after_fork_in_child() -> None:
    for runner in list(_LIVE):
        runner._forget_threads()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork_in_child)


def check_rows(cols: np.ndarray, nacc: int) -> None:
    """Raise unless ``cols`` holds accumulators one run per row, as the kernels store them.

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.sim.kernel._threads import check_rows
    >>> check_rows(np.zeros((3, 5)), 5)
    """
    if cols.dtype != np.float64 or not cols.flags.c_contiguous or cols.ndim != 2 or \
            cols.shape[1] != nacc:
        raise DimensionError(f"the kernel needs C-contiguous float64 (ncols, {nacc}) "
                             f"accumulators, one run per row; got {cols.dtype} {cols.shape}")


class ThreadsOwner:
    """Kernel threads kept for a runner's life, fork-safe, and :meth:`run` over the subclass's
    ``advance_rows`` (base of the compiled runners).

    A sweep calls the kernel once per chunk and block of samples: its threads are created
    once, on first use. A process forked from this one inherits the pool objects but not
    their threads: the at-fork hook (and the owner's pid, a second check) gives the child
    fresh ones instead of a wait that would never end (see
    :mod:`fl_design.sim.kernel._lanes`).

    Examples
    --------
    >>> from fl_design.sim.kernel._threads import ThreadsOwner
    >>> owner = ThreadsOwner()
    >>> owner._pool(1) is owner._pool(1)
    True
    """

    def __init__(self):
        self._forget_threads()
        _LIVE.add(self)

    def run(self, acc: np.ndarray, D: np.ndarray, *, threads: int = 1) -> np.ndarray:
        """Advance every column of ``acc`` (``(nacc, ncols)``) over the samples ``D``
        (``(n_d, nsteps)``): the subclass's ``advance_rows`` on a row-per-run copy.

        Parameters
        ----------
        acc : numpy.ndarray
            ``(nacc, ncols)`` accumulators (not modified).
        D : numpy.ndarray
            ``(n_d, nsteps)`` samples (``(r_k, w_k)``...).
        threads : int, optional
            Threads sharing the columns (default 1).

        Returns
        -------
        numpy.ndarray
            ``(nacc, ncols)`` final accumulators.

        Examples
        --------
        >>> from fl_design.sim.kernel._lanes import LanesRunner
        >>> from fl_design.sim.kernel._runners import NativeRunner
        >>> LanesRunner.run is NativeRunner.run is ThreadsOwner.run
        True
        """
        cols = np.array(np.asarray(acc, dtype=float).reshape(self.nacc, -1).T, order="C")
        self.advance_rows(cols, D, threads=threads)  # a copy: the caller's acc is kept
        return cols.T.copy()

    def _forget_threads(self) -> None:
        """A fresh lock and no pool (at creation, and in a child forked from this process:
        the inherited pool's threads do not exist there, waiting on them would hang)."""
        self._lock = threading.Lock()
        self._pools: list[tuple[int, ThreadPoolExecutor]] = []
        self._owner = os.getpid()

    def _pool(self, n: int) -> ThreadPoolExecutor:
        """``n`` threads or more, kept for the runner's life.

        A larger request adds a larger pool; pools are only shut down with the runner, so a
        concurrent call never meets a closed one. Pools belong to the process that made them.
        """
        if self._owner != os.getpid():  # forked without the at-fork hook (e.g. no os support)
            self._forget_threads()
        with self._lock:
            if not self._pools or self._pools[-1][0] < n:
                self._pools.append((n, ThreadPoolExecutor(n, thread_name_prefix="fl_kernel")))
            return self._pools[-1][1]

    def _share(self, work, threads: int) -> None:
        """``work(i)`` for ``i < threads``: the calling thread runs share 0, the pool the rest
        (no hand-over to a waiting pool thread); returns when every share has."""
        pool = self._pool(threads - 1) if threads > 1 else None
        others = [pool.submit(work, i) for i in range(1, threads)]
        try:
            work(0)
        finally:  # the other shares end with the samples given (an interrupt waits for them)
            for task in others:
                task.result()

    def __del__(self, _getpid=os.getpid):  # bound now: module globals may be gone at exit
        if getattr(self, "_owner", None) == _getpid():
            for _, pool in getattr(self, "_pools", ()):
                pool.shutdown(wait=False)


__all__ = ["ThreadsOwner", "check_rows"]
