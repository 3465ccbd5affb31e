"""Running many closed-loop runs: chunks of parameter columns over threads or an executor.

Every grid point is one column of accumulators (:func:`fl_design.sim.accumulator_layout`);
chunks of columns run in the compiled kernel (or the interpreter) in this process with
``threads`` threads, or as tasks of any ``concurrent.futures.Executor`` (thread or process
pools, a Dask cluster's ``client.get_executor()``); results do not depend on how the grid is
cut.

With several threads the chunks run as a pipeline: while the kernel's threads run one
chunk, one more thread builds the next chunk's parameter columns and classifies the finished
one (``finish``), so the Python work of a sweep is not a serial part of it (measured on the
32 x 32 x 5 s TRMS sweep, AVX2, load 3-4: 23 ms of CPU outside the kernel's threads, now
5-7 ms not overlapped with them). The kernel's threads are kept for the runner's life and
the calling thread takes a share (:class:`~fl_design.sim.kernel._runners.ThreadsOwner`).

Bounded work, interruptible: a chunk advances its runs in blocks of samples sized to take
about :data:`BLOCK_SECONDS` each, so Ctrl-C (``KeyboardInterrupt``) reaches Python within a
fraction of a second; pending tasks of an executor are then cancelled and the interrupt is
re-raised (compiled kernels are only read, so the cache stays sound). Parameter columns are
built chunk by chunk (the first results and progress come at once, whatever the grid size),
and a grid whose results would not fit in :func:`max_memory` is refused up front.

Examples
--------
>>> import fl_design as fl
>>> from fl_design.sim._grid import parameter_columns
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
from concurrent.futures import Executor, ThreadPoolExecutor
from itertools import pairwise

import numpy as np

from .._limits import env_limit
from ..errors import ParameterError, ResourceLimitError
from ._options import Kernel, option
from ._run import RunSetup

# --- running grids ---------------------------------------------------------------------------
_RUNNERS: OrderedDict = OrderedDict()  # per-process memo: loop structure -> runner
_RUNNERS_LOCK = threading.Lock()


def _after_fork_in_child() -> None:
    """A forked child gets a fresh memo lock (the parent's may have been held by a thread that
    does not exist in the child); the runners reset their own threads (:mod:`._lanes`)."""
    global _RUNNERS_LOCK
    _RUNNERS_LOCK = threading.Lock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork_in_child)


def _runner(run: RunSetup, kernel: Kernel):
    """The runner of ``run.loop``, memoised per process (tasks of one sweep share it)."""
    try:
        key = pickle.dumps((run.loop.plant, run.loop.design, run.loop.substeps,
                            run.loop.uncertain, run.loop.allow_unmodeled,
                            run.loop.accumulators, kernel))
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


#: Target duration of one kernel call; Ctrl-C waits at most about this long.
BLOCK_SECONDS = 0.2
#: Pessimistic cost of one closed-loop step of one run (the scalar kernel under load).
_STEP_SECONDS = 400e-9
#: Environment variable lifting the default memory limit of a grid's results.
MAX_MEMORY_ENV = "FL_DESIGN_MAX_MEMORY_GB"


def max_memory() -> float:
    """Bytes a grid's results may take: ``$FL_DESIGN_MAX_MEMORY_GB`` GiB, default 4 GiB.

    Returns
    -------
    float
        The limit in bytes.

    Examples
    --------
    >>> from fl_design.sim._grid import max_memory
    >>> max_memory() >= 2**30
    True
    """
    return env_limit(MAX_MEMORY_ENV, 4.0 * 2**30, unit="GiB", scale=2**30, integer=False)


def block_length(ncols: int, threads: int, compiled: bool) -> int:
    """Samples per kernel call so that one call takes about :data:`BLOCK_SECONDS`.

    Parameters
    ----------
    ncols : int
        Runs advanced together.
    threads : int
        Threads sharing them.
    compiled : bool
        Compiled kernel (else the interpreter, about 20x slower per step).

    Returns
    -------
    int
        At least 64.

    Examples
    --------
    >>> from fl_design.sim._grid import block_length
    >>> block_length(64, 2, True) > block_length(64, 2, False)
    True
    """
    per_sample = _STEP_SECONDS * (1 if compiled else 20) * max(1, ncols) / max(1, threads)
    return max(64, int(BLOCK_SECONDS / per_sample))


#: Default grid points per chunk of a sweep run in this process (see :class:`Kernel`).
CHUNK_IN_PROCESS = 256


def _run_chunk(run: RunSetup, P: np.ndarray, kernel: Kernel, threads: int):
    """One task: the final accumulators of the parameter columns ``P`` (module level: picklable).

    The samples are run in blocks (:func:`block_length`): a kernel call returns within about
    :data:`BLOCK_SECONDS`, so an interrupt is handled between blocks.
    """
    return _advance(run, run.initial_accumulator(P), kernel, threads)


def _advance(run: RunSetup, acc: np.ndarray, kernel: Kernel, threads: int,
             runner=None) -> np.ndarray:
    """The initial accumulators ``acc`` (``(nacc, n)``) run over every sample, in blocks.

    A runner with ``advance_rows`` keeps the accumulators one run per row from block to block
    (the kernels' layout: no transposed copies between blocks).
    """
    runner = runner if runner is not None else _runner(run, kernel)
    rows = _rows_of(runner)
    if rows is not None:
        return _advance_rows(rows, np.array(np.asarray(acc, dtype=float).T, order="C"),
                             run, kernel, threads).T
    D = run.D
    block = block_length(acc.shape[1], threads, kernel.compiled)
    for a in range(0, D.shape[1], block):
        acc = runner.run(acc, D[:, a:a + block], threads=threads)
    return acc


def _rows_of(runner):
    """The runner's in-place method on one-run-per-row accumulators, if it has one."""
    return getattr(runner, "advance_rows", None)


def _advance_rows(rows, cols: np.ndarray, run: RunSetup, kernel: Kernel,
                  threads: int) -> np.ndarray:
    """``cols`` (``(n, nacc)``, C-contiguous) run over every sample in place, in blocks."""
    D = run.D
    block = block_length(cols.shape[0], threads, kernel.compiled)
    for a in range(0, D.shape[1], block):
        rows(cols, D[:, a:a + block], threads=threads)
    return cols


class _Columns:
    """Parameter columns of an (eps, gamma) grid, built chunk by chunk (eps-major)."""

    def __init__(self, design, eps, gamma):
        self.design, self.lay = design, design.parameter_layout
        self.eps = np.atleast_1d(eps).astype(float)
        self.gamma = np.atleast_1d(gamma).astype(float)
        self.n = self.eps.size * self.gamma.size
        self._estimator: dict[int, np.ndarray] = {}

    def _est(self, i: int) -> np.ndarray:
        if i not in self._estimator:
            from .._blas import serial_blas

            with serial_blas():
                est = self.design.estimator.replace(eps=float(self.eps[i]))
                self._estimator[i] = est.parameter_vector()
        return self._estimator[i]

    def __call__(self, a: int, b: int) -> np.ndarray:
        return self.take(np.arange(a, b))

    def take(self, idx: np.ndarray) -> np.ndarray:
        """Columns of the grid indices ``idx`` (any order)."""
        idx = np.asarray(idx)
        rows, cols = idx // self.gamma.size, idx % self.gamma.size
        P = np.empty((self.lay.size, idx.size))
        for i in np.unique(rows):
            P[self.lay["estimator"], rows == i] = self._est(int(i))[:, None]
        P[self.lay["gamma"]] = self.gamma[cols]
        return P


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

    def note(self, text: str) -> None:
        """Say what the bar waits for (the kernel being compiled); ``""`` clears it."""
        if self.bar is not None:
            self.bar.set_postfix_str(text, refresh=True)
        elif self.enabled and text:
            print(f"\r{self.desc}: {text}", end="", file=sys.stderr, flush=True)

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
        Column ``i * n_g + j`` is the parameter vector at ``(eps[i], gamma[j])``.

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim._grid import parameter_columns
    >>> d = fl.Design(estimator=fl.EHGO(rho=1, eps=0.1, T=1e-3),
    ...               controller=fl.DynamicController((1.0,), 1e-2))
    >>> parameter_columns(d, [0.1], [1e-3, 2e-3])[-1].tolist()
    [0.001, 0.002]
    """
    columns = _Columns(design, eps, gamma)
    return columns(0, columns.n)


def _cores() -> int:
    """Cores this process may use (the affinity mask when the OS has one)."""
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return os.cpu_count() or 1


def run_grid(run: RunSetup, P, *, kernel: Kernel | None = None,
             executor: Executor | None = None, progress: bool = True,
             desc: str = "sweep", finish=None) -> np.ndarray:
    """Final accumulators of the runs with parameter columns ``P``, chunked.

    Parameters
    ----------
    run : RunSetup
        Loop, samples and constants shared by every run.
    P : numpy.ndarray or callable
        ``(n_p, n_runs)`` design parameter vectors, or a column source ``P(a, b) ->
        (n_p, b - a)`` with attribute ``n`` (the number of runs), built chunk by chunk.
    kernel : Kernel, optional
        Compiled or interpreted, cache, threads per process and chunk size (default
        ``fl.Kernel()``).
    executor : concurrent.futures.Executor, optional
        Runs the chunks as tasks (default: in this process, ``kernel.threads`` threads).
    progress : bool, optional
        Progress bar (tqdm if installed, else a counter on stderr).
    desc : str, optional
        Label of the progress bar.
    finish : callable, optional
        ``finish(a, b, acc)`` is called once for each finished range of runs ``a:b``, in
        order, with their final accumulators ``acc`` (``(nacc, b - a)``, a view of the
        returned array): e.g. their classification
        (:class:`~fl_design.sim._adaptive.Assembly`), done on another thread while the kernel
        runs the next chunk when it has several threads. The ranges cover the grid (the
        chunks, :func:`chunk_bounds`; with an executor, :data:`CHUNK_IN_PROCESS` runs each).

    Returns
    -------
    numpy.ndarray
        ``(nacc, n_runs)``.

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.sim._grid import parameter_columns, run_grid
    >>> from fl_design.sim._run import prepare_run
    >>> d = fl.presets.pendulum_design()
    >>> run = prepare_run(fl.plants.pendulum(), d, fl.Scenario(0.05, 0.5))
    >>> acc = run_grid(run, parameter_columns(d, [0.02, 0.05], [1e-2]),
    ...                kernel=fl.Kernel(compiled=False), progress=False)
    >>> acc.shape, run.loop.layout.unpack(acc)["k"].tolist()
    ((106, 2), [500.0, 500.0])
    """
    kernel = option("kernel", kernel, Kernel)
    if executor is not None and not isinstance(executor, Executor):
        raise ParameterError(f"executor must be a concurrent.futures.Executor (e.g. "
                             f"a Dask client.get_executor()), got {executor!r}")
    columns = P if callable(P) else (lambda a, b: P[:, a:b])
    n_runs = int(P.n) if callable(P) else int(np.shape(P)[1])
    _check_memory(run, n_runs)
    threads = kernel.threads
    out = np.empty((run.loop.layout.size, n_runs))
    bar = _Progress(n_runs, bool(progress), desc)
    try:
        if executor is None:
            if bar.enabled and kernel.compiled:  # a first use compiles for seconds: say so
                bar.note("preparing the compiled kernel (compiled on first use, then cached)")
                runner = _runner(run, kernel)
                getattr(runner, "library", None)  # the lanes kernel is built on first use
                bar.note("")
            n_thr = threads if threads is not None else _cores()
            _run_here(run, columns, n_runs, kernel, n_thr, out, bar, finish)
        else:
            _run_on(executor, run, P, columns, n_runs, kernel, threads or 1, out, bar)
            if finish is not None:
                for a in range(0, n_runs, CHUNK_IN_PROCESS):
                    finish(a, min(a + CHUNK_IN_PROCESS, n_runs),
                           out[:, a:a + CHUNK_IN_PROCESS])
    finally:
        bar.close()
    return out


def chunk_bounds(n_runs: int, chunk_size: int | None, threads: int) -> list[tuple[int, int]]:
    """Ranges of runs run in this process one after the other.

    ``chunk_size`` runs each (the last range shorter); by default at most
    :data:`CHUNK_IN_PROCESS` per thread (each thread meets as many runs per chunk as one
    thread alone), and with several threads the first and last range a quarter of
    :data:`CHUNK_IN_PROCESS`: their columns and classification are the part of a pipelined
    grid not overlapped with the kernel (:func:`run_grid`); the rest in equal parts.

    Parameters
    ----------
    n_runs : int
        Runs of the grid.
    chunk_size : int or None
        ``fl.Kernel(chunk_size=...)``.
    threads : int
        Threads of the kernel.

    Returns
    -------
    list of (int, int)
        Consecutive ``(a, b)`` covering ``0:n_runs``.

    Examples
    --------
    >>> from fl_design.sim._grid import chunk_bounds
    >>> chunk_bounds(1024, None, 2)
    [(0, 64), (64, 512), (512, 960), (960, 1024)]
    >>> chunk_bounds(600, 256, 2), chunk_bounds(600, None, 1)
    ([(0, 256), (256, 512), (512, 600)], [(0, 256), (256, 512), (512, 600)])
    """
    threads = max(1, int(threads))
    chunk = chunk_size or CHUNK_IN_PROCESS * threads
    edge = CHUNK_IN_PROCESS // 4
    if chunk_size is not None or threads == 1 or n_runs <= 4 * edge:
        return [(a, min(a + chunk, n_runs)) for a in range(0, n_runs, chunk)]
    inner = n_runs - 2 * edge
    parts = -(-inner // chunk)  # the inner runs in equal parts of at most chunk
    cuts = [edge + round(i * inner / parts) for i in range(parts + 1)]
    return [(0, edge), *pairwise(cuts), (n_runs - edge, n_runs)]


def _initial(run: RunSetup, columns, a: int, b: int, rows: bool) -> np.ndarray:
    """Initial accumulators of runs ``a:b``: ``(nacc, b - a)``, or one run per row."""
    acc = run.initial_accumulator(columns(a, b))
    return np.array(acc.T, order="C") if rows else acc


def _store(out: np.ndarray, a: int, b: int, done: np.ndarray, rows: bool, finish) -> None:
    """Final accumulators of runs ``a:b`` into ``out`` (and ``finish`` of them)."""
    out[:, a:b] = done.T if rows else done
    if finish is not None:
        finish(a, b, out[:, a:b])


def _run_here(run, columns, n_runs, kernel, threads, out, bar, finish) -> None:
    """The grid's chunks in this process, ``threads`` threads in the kernel.

    With several threads, the serial work of a chunk is done by one more thread while the
    kernel runs the previous chunk (a pipeline): the parameter columns and initial
    accumulators of the next chunk, storing and ``finish`` of the finished one. Python work
    is then never alone on the machine with the kernel's threads waiting; results are the
    same (the same calls on the same chunks, in the same order).
    """
    bounds = chunk_bounds(n_runs, kernel.chunk_size, threads)
    runner = _runner(run, kernel)
    rows = _rows_of(runner)

    def advance(x):
        if rows is not None:
            return _advance_rows(rows, x, run, kernel, threads)
        return _advance(run, x, kernel, threads, runner)

    if threads <= 1 or len(bounds) == 1:
        for a, b in bounds:
            _store(out, a, b, advance(_initial(run, columns, a, b, rows is not None)),
                   rows is not None, finish)
            bar.update(b - a)
        return
    side = ThreadPoolExecutor(1, thread_name_prefix="fl_grid_side")
    try:
        stored = []
        ready = side.submit(_initial, run, columns, *bounds[0], rows is not None)
        for i, (a, b) in enumerate(bounds):
            x = ready.result()
            if i + 1 < len(bounds):
                ready = side.submit(_initial, run, columns, *bounds[i + 1], rows is not None)
            done = advance(x)
            # queued after the next chunk's columns: the kernel waits for those first
            stored.append(side.submit(_store, out, a, b, done, rows is not None, finish))
            bar.update(b - a)
        for task in stored:
            task.result()
    finally:  # an interrupt or an error: queued side work is dropped, running work is short
        side.shutdown(wait=True, cancel_futures=True)


def _run_on(executor, run, P, columns, n_runs, kernel, threads, out, bar) -> None:
    """The grid as tasks of ``executor`` (:mod:`fl_design.sim._executor`)."""
    from ._executor import KernelTask, executor_workers, run_tasks, task_columns

    workers = executor_workers(executor)
    groups = task_columns(n_runs, workers, kernel.chunk_size)
    per_task = max(g.size for g in groups)
    # workers share this machine's cores: a block is sized for the threads a worker really
    # gets (2 workers x 2 threads on 2 cores run at half speed), so a kernel call still
    # returns within about BLOCK_SECONDS and Ctrl-C reaches every worker quickly
    cores = os.cpu_count() or 1
    effective = max(1, min(threads, cores // max(1, min(workers, cores))))
    task = KernelTask.of(run.loop, kernel, run.D, block_length(per_task, effective,
                                                                kernel.compiled))
    if not callable(P):  # an array's columns (ndarray.take would flatten it)
        def take(idx):
            return P[:, idx]
    else:
        take = getattr(P, "take", None) or (
            lambda idx: np.concatenate([columns(int(i), int(i) + 1) for i in idx], axis=1))
    run_tasks(executor, task, lambda idx: run.initial_accumulator(take(idx)), groups,
              threads, out, bar)


def _check_memory(run: RunSetup, n_runs: int) -> None:
    need = 8.0 * n_runs * (run.loop.layout.size + 2 * (run.loop.rho + 16))
    limit = max_memory()
    if need > limit:
        raise ResourceLimitError(
            f"a grid of {n_runs:.3g} runs needs about {need / 2**30:.3g} GiB for its results, "
            f"above the limit of {limit / 2**30:.3g} GiB; use a coarser grid, or raise the "
            f"limit with ${MAX_MEMORY_ENV}")


__all__ = ["parameter_columns", "run_grid"]
