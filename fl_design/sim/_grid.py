"""Running many closed-loop runs: chunks of parameter columns over threads or an executor.

Every grid point is one column of accumulators (:func:`fl_design.sim.accumulator_layout`);
chunks of columns run in the compiled kernel (or the interpreter) in this process with
``threads`` threads, or as tasks of any ``concurrent.futures.Executor`` (thread or process
pools, a Dask cluster's ``client.get_executor()``); results do not depend on how the grid is
cut.

Examples
--------
>>> import fl_design as fl
>>> from fl_design.sim import parameter_columns
>>> d = fl.presets.pendulum_design()
>>> parameter_columns(d, [0.01, 0.02], [1e-3, 1e-2, 0.1]).shape
(28, 6)
"""

from __future__ import annotations

import os
import pickle
import sys
import threading
from collections import OrderedDict
from concurrent.futures import Executor, as_completed

import numpy as np

from ..errors import ParameterError
from ._options import Kernel
from ._run import RunSetup

# --- running grids ---------------------------------------------------------------------------
_RUNNERS: OrderedDict = OrderedDict()  # per-process memo: loop structure -> runner
_RUNNERS_LOCK = threading.Lock()


def _runner(run: RunSetup, kernel: Kernel):
    """The runner of ``run.loop``, memoised per process (tasks of one sweep share it)."""
    try:
        key = pickle.dumps((run.loop.plant, run.loop.design, run.loop.substeps, kernel))
    except (pickle.PicklingError, TypeError, AttributeError):  # unpicklable: no memo
        return run.loop.runner(kernel=kernel)
    with _RUNNERS_LOCK:
        if key in _RUNNERS:
            _RUNNERS.move_to_end(key)
            return _RUNNERS[key]
        runner = run.loop.runner(kernel=kernel)
        _RUNNERS[key] = runner
        while len(_RUNNERS) > 8:
            _RUNNERS.popitem(last=False)
        return runner


def _run_chunk(run: RunSetup, P: np.ndarray, kernel: Kernel, threads: int):
    """One task: the final accumulators of the parameter columns ``P`` (module level: picklable)."""
    runner = _runner(run, kernel)
    return runner.run(run.initial_accumulator(P), run.D, threads=threads)


class _Progress:
    """tqdm when installed, else a plain counter on stderr; silent when disabled."""

    def __init__(self, total: int, enabled: bool, desc: str):
        self.total, self.done, self.bar = total, 0, None
        self.enabled = enabled
        if enabled:
            try:
                from tqdm.auto import tqdm
                self.bar = tqdm(total=total, desc=desc, unit="run")
            except ImportError:
                self.desc = desc

    def update(self, n: int) -> None:
        self.done += n
        if self.bar is not None:
            self.bar.update(n)
        elif self.enabled:
            print(f"\r{self.desc}: {self.done}/{self.total} runs", end="", file=sys.stderr)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
        elif self.enabled:
            print(file=sys.stderr)


def parameter_columns(design, eps, gamma) -> np.ndarray:
    """``(n_p, n_e * n_g)`` parameter vectors of the (eps, gamma) grid, eps-major.

    One estimator is built per ``eps`` (its discretization depends on it); ``gamma`` only
    fills the last row (:attr:`fl_design.Design.parameter_layout`), so a 64 x 64 map costs
    64 discretizations, not 4096.

    Parameters
    ----------
    design : Design
        The design (an estimator with ``eps``, the EHGO).
    eps, gamma : array_like
        Grid values.

    Returns
    -------
    numpy.ndarray

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim import parameter_columns
    >>> d = fl.Design(estimator=fl.EHGO(rho=1, eps=0.1, T=1e-3),
    ...               controller=fl.DynamicController((1.0,), 1e-2))
    >>> parameter_columns(d, [0.1], [1e-3, 2e-3])[-1].tolist()
    [0.001, 0.002]
    """
    lay = design.parameter_layout
    eps, gamma = np.atleast_1d(eps).astype(float), np.atleast_1d(gamma).astype(float)
    P = np.empty((lay.size, eps.size * gamma.size))
    for i, e in enumerate(eps):
        cols = slice(i * gamma.size, (i + 1) * gamma.size)
        P[lay["estimator"], cols] = design.estimator.replace(eps=float(e)).parameter_vector()[:, None]
        P[lay["gamma"], cols] = gamma
    return P


def _cores() -> int:
    """Cores this process may use (the affinity mask when the OS has one)."""
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return os.cpu_count() or 1


def run_grid(run: RunSetup, P: np.ndarray, *, kernel: Kernel | None = None,
             executor: Executor | None = None, progress: bool = True,
             desc: str = "sweep") -> np.ndarray:
    """Final accumulators of the runs with parameter columns ``P``, chunked.

    Parameters
    ----------
    run : RunSetup
        Loop, samples and constants shared by every run.
    P : numpy.ndarray
        ``(n_p, n_runs)`` design parameter vectors.
    kernel : Kernel, optional
        Compiled or interpreted, cache, threads per process and chunk size (default
        ``fl.Kernel()``).
    executor : concurrent.futures.Executor, optional
        Runs the chunks as tasks (default: in this process, ``kernel.threads`` threads).
    progress : bool, optional
        Progress bar (tqdm if installed, else a counter on stderr).
    desc : str, optional
        Label of the progress bar.

    Returns
    -------
    numpy.ndarray
        ``(nacc, n_runs)``.

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim import parameter_columns, prepare_run, run_grid
    >>> d = fl.presets.pendulum_design()
    >>> run = prepare_run(fl.plants.pendulum(), d, fl.Scenario(0.05, 0.5))
    >>> acc = run_grid(run, parameter_columns(d, [0.02, 0.05], [1e-2]),
    ...                kernel=fl.Kernel(compiled=False), progress=False)
    >>> acc.shape, run.loop.layout.unpack(acc)["k"].tolist()
    ((72, 2), [500.0, 500.0])
    """
    kernel = Kernel() if kernel is None else kernel
    if not isinstance(kernel, Kernel):
        raise ParameterError(f"kernel must be a fl.Kernel, got {kernel!r}")
    threads = kernel.threads
    n_runs = P.shape[1]
    chunk = kernel.chunk_size if kernel.chunk_size is not None else 64
    pieces = [(a, min(a + chunk, n_runs)) for a in range(0, n_runs, chunk)]
    out = np.empty((run.loop.layout.size, n_runs))
    bar = _Progress(n_runs, bool(progress), desc)
    try:
        if executor is None:
            n_thr = threads if threads is not None else _cores()
            for a, b in pieces:
                out[:, a:b] = _run_chunk(run, P[:, a:b], kernel, n_thr)
                bar.update(b - a)
        else:
            if not isinstance(executor, Executor):
                raise ParameterError(f"executor must be a concurrent.futures.Executor (e.g. "
                                     f"a Dask client.get_executor()), got {executor!r}")
            futures = {executor.submit(_run_chunk, run, P[:, a:b], kernel,
                                       threads or 1): (a, b) for a, b in pieces}
            for fut in as_completed(futures):
                a, b = futures[fut]
                out[:, a:b] = fut.result()
                bar.update(b - a)
    finally:
        bar.close()
    return out


__all__ = ["parameter_columns", "run_grid"]
