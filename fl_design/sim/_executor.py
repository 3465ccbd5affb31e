"""Grids run as tasks of a ``concurrent.futures.Executor``: what a worker gets, and how much.

A worker gets what the compiled kernel needs and nothing else: a :class:`KernelTask` (the
accumulating and recording steps as CasADi's serialized text, the accumulator indices, the
kernel options and the samples ``D``) and the initial accumulators of its columns, computed
here. No plant, no design, no SymPy: a worker imports only CasADi and fl_design's simulation
layer, and the first task it runs builds (or loads from the kernel cache, when the worker
shares this machine's disk) the same kernel this process uses, memoised by the task's key
for the worker's life.

Tasks are sized from the executor's workers (``_max_workers`` of a process or thread pool,
the threads of a Dask cluster behind ``client.get_executor()``): :data:`TASKS_PER_WORKER`
tasks per worker, so that one pickled payload and one kernel call cover hundreds of runs,
and the columns are dealt out strided (task ``i`` gets columns ``i, i + n, i + 2n, ...``) so
that cheap diverging runs and full-length converging ones are spread over every task.

A worker that dies (killed, out of memory, a crash in native code) breaks a process pool:
every chunk it had not returned is lost. :func:`run_tasks` keeps the finished ones and raises
:class:`~fl_design.errors.WorkerLostError`, which names the lost grid points and carries the
partial result (a map of the caller's type, the lost runs marked: :mod:`fl_design.sim._partial`);
never a raw ``BrokenProcessPool``. A stopped or deadlocked worker process is named within
seconds (:class:`_Heartbeat`).

Examples
--------
>>> from concurrent.futures import ThreadPoolExecutor
>>> from fl_design.sim._executor import executor_workers
>>> with ThreadPoolExecutor(3) as ex:
...     executor_workers(ex)
3
"""

from __future__ import annotations

import hashlib
import math
import os
import threading
import time
from collections import OrderedDict
from concurrent.futures import FIRST_COMPLETED, BrokenExecutor, Executor, wait
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError, WorkerLostError
from ._options import Kernel
from ._procs import proc_stats, tree_cpu
from ._scheduler import CONNECT_SECONDS, bounded_call, connect_scheduler  # noqa: F401 - re-exported

#: Tasks per worker of an executor (balance against per-task pickling and kernel calls).
TASKS_PER_WORKER = 4
#: Fewest runs per task (below this a task costs more to ship than to run).
MIN_TASK_RUNS = 16
#: Seconds per closed-loop step of one run that a worker may take before the grid is declared
#: stuck: 250x the pessimistic scalar cost (400 ns), so only a hung worker, never a loaded
#: machine, reaches it; plus :data:`STUCK_GRACE_SECONDS` for starting workers.
STUCK_STEP_SECONDS = 1e-4
#: Seconds added to every executor grid's time limit (worker start, imports, kernel loads).
STUCK_GRACE_SECONDS = 600.0
#: Seconds between two checks that the executor's workers are alive while a grid waits.
HEARTBEAT_SECONDS = 1.0
#: Seconds a Dask cluster may have no worker at all (a nanny restarting one) before the grid
#: is declared lost.
WORKERLESS_SECONDS = 5.0
#: Seconds allowed to one question to a Dask scheduler (how many workers it has).
ASK_SECONDS = 5.0

_MEMO: OrderedDict = OrderedDict()  # per worker process: task key -> runner
_MEMO_LOCK = threading.Lock()


def _after_fork_in_child() -> None:
    global _MEMO_LOCK
    _MEMO_LOCK = threading.Lock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork_in_child)


@dataclass(frozen=True, eq=False)
class KernelTask:
    """What a worker needs to run columns of one grid (picklable, no SymPy inside).

    Parameters
    ----------
    key : str
        SHA-256 of everything below but ``D`` (the worker's memo key of the runner).
    accumulate, record : str
        ``fl_acc`` and ``fl_rec`` as ``casadi.Function.serialize()`` text.
    indices : dict
        Accumulator positions ``k``, ``div``, ``N``.
    kernel : Kernel
        Kernel options (compiled, cache, lanes, vector math, ISA).
    D : numpy.ndarray
        ``(n_d, N)`` per-sample inputs (:attr:`fl_design.sim._run.RunSetup.D`).
    block : int
        Samples per kernel call.

    Examples
    --------
    >>> from fl_design.sim._executor import KernelTask
    >>> KernelTask.__name__
    'KernelTask'
    """

    key: str
    accumulate: str
    record: str
    indices: dict
    kernel: Kernel
    D: np.ndarray
    block: int

    @classmethod
    def of(cls, loop, kernel: Kernel, D: np.ndarray, block: int) -> KernelTask:
        """The task of ``loop`` (a :class:`~fl_design.sim.ClosedLoop`) with these samples."""
        sl = loop.layout.slices
        indices = {"k": sl["k"].start, "div": sl["diverged"].start, "N": sl["N"].start}
        acc, rec = loop.accumulate.serialize(), loop.record.serialize()
        key = hashlib.sha256("\n".join([acc, rec, repr(sorted(indices.items())),
                                        repr(kernel)]).encode()).hexdigest()
        return cls(key, acc, rec, indices, kernel, D, int(block))  # D sample-major: no copies

    def runner(self):
        """The runner of this task in this process (built once per key, then memoised)."""
        with _MEMO_LOCK:
            if self.key in _MEMO:
                _MEMO.move_to_end(self.key)
                return _MEMO[self.key]
        import casadi as ca

        from .kernel._runners import make_runner

        k = self.kernel
        runner = make_runner(ca.Function.deserialize(self.accumulate),
                             ca.Function.deserialize(self.record), self.indices,
                             compiled=k.compiled, cache_dir=k.cache_dir, lanes=k.lanes,
                             vector_math=k.vector_math, isa=k.isa)
        with _MEMO_LOCK:
            _MEMO[self.key] = runner
            while len(_MEMO) > 8:
                _MEMO.popitem(last=False)
        return runner


def run_task(task: KernelTask, acc: np.ndarray, threads: int) -> np.ndarray:
    """One task in a worker: advance the accumulators ``acc`` over ``task.D`` in blocks.

    Examples
    --------
    >>> from fl_design.sim._executor import run_task
    >>> callable(run_task)
    True
    """
    runner = task.runner()
    D = task.D
    for a in range(0, D.shape[1], task.block):
        acc = runner.run(acc, D[:, a:a + task.block], threads=threads)
    return acc


def executor_workers(executor: Executor) -> int:
    """Workers (processes or threads) of ``executor``; the cores here when it does not say.

    Examples
    --------
    >>> from concurrent.futures import ProcessPoolExecutor
    >>> from fl_design.sim._executor import executor_workers
    >>> executor_workers(ProcessPoolExecutor(2))
    2
    """
    n = getattr(executor, "_max_workers", None)
    if isinstance(n, int) and n > 0:
        return n
    client = getattr(executor, "_client", None)  # dask.distributed's ClientExecutor
    if client is not None:
        try:
            return max(1, int(sum(client.nthreads().values())))
        except Exception:  # noqa: BLE001 - a cluster that cannot say: the cores here
            return os.cpu_count() or 1
    return os.cpu_count() or 1


def task_columns(n_runs: int, workers: int, chunk_size: int | None) -> list[np.ndarray]:
    """Grid indices of each task: strided over :data:`TASKS_PER_WORKER` tasks per worker.

    ``chunk_size`` (from :class:`~fl_design.Kernel`) fixes the runs per task instead.

    Examples
    --------
    >>> from fl_design.sim._executor import task_columns
    >>> [c.tolist() for c in task_columns(5, 1, 2)]
    [[0, 3], [1, 4], [2]]
    """
    if chunk_size is None:
        n_tasks = max(1, min(TASKS_PER_WORKER * workers, math.ceil(n_runs / MIN_TASK_RUNS)))
    else:
        n_tasks = math.ceil(n_runs / chunk_size)
    n_tasks = max(1, min(n_tasks, n_runs))
    return [np.arange(i, n_runs, n_tasks) for i in range(n_tasks)]


def _ranges(idx: np.ndarray) -> str:
    """``0-3, 7, 9-12`` for sorted grid indices (what was lost, readable)."""
    idx = np.sort(idx)
    parts, start = [], 0
    for i in range(1, idx.size + 1):
        if i == idx.size or idx[i] != idx[i - 1] + 1:
            a, b = idx[start], idx[i - 1]
            parts.append(f"{a}" if a == b else f"{a}-{b}")
            start = i
    return ", ".join(parts[:12]) + (", ..." if len(parts) > 12 else "")


#: Exceptions a Dask future raises when its worker died or the cluster dropped the task
#: (matched by name: ``distributed`` is optional).
_DASK_LOST = ("KilledWorker", "CommClosedError", "FutureCancelledError", "CancelledError",
              "StreamClosedError")


def _lost_cause(exc: BaseException) -> bool:
    """Whether a task's exception says its worker was lost (not an error of the task)."""
    return isinstance(exc, BrokenExecutor) or type(exc).__name__ in _DASK_LOST


def run_tasks(executor: Executor, task: KernelTask, acc0_of, groups, threads: int,
              out: np.ndarray, bar) -> None:
    """Submit one task per group of grid indices; fill ``out``; interrupt- and death-safe.

    On an interrupt the pending tasks are cancelled and the interrupt re-raised. When a
    worker dies (a process pool breaks, a Dask task's worker is killed) or is stuck (a worker
    process stopped, or every worker process idle while tasks wait: :class:`_Heartbeat`), the
    finished tasks are kept and :class:`~fl_design.errors.WorkerLostError` names the lost grid
    points and the workers; its ``accumulators`` are ``out`` with the lost columns NaN (the
    public calls turn them into a partial result, :mod:`fl_design.sim._partial`). The wait is
    bounded: when no task has come back within :data:`STUCK_STEP_SECONDS` per step of the grid
    (over the workers) plus :data:`STUCK_GRACE_SECONDS`, the grid is declared stuck, never a
    silent hang.

    Examples
    --------
    >>> from fl_design.sim._executor import run_tasks
    >>> callable(run_tasks)
    True
    """
    futures, lost, broken = {}, [], None
    n_runs = sum(g.size for g in groups)
    limit = (STUCK_GRACE_SECONDS + STUCK_STEP_SECONDS * n_runs * task.D.shape[1]
             / max(1, executor_workers(executor)))
    watch = _Heartbeat(executor)
    try:
        for idx in groups:
            try:
                futures[executor.submit(run_task, task, acc0_of(idx), threads)] = idx
            except BrokenExecutor as exc:  # broke while tasks were submitted: these are lost
                lost.append(idx)
                broken = exc
            except RuntimeError as exc:  # shut down ("cannot schedule new futures...")
                raise ParameterError(
                    f"the executor {type(executor).__name__} takes no tasks ({exc}): it was "
                    "shut down; pass a running executor (or none: this process)") from None
        watch.note()  # the pool's processes exist once tasks are submitted
        pending, start = set(futures), time.monotonic()
        while pending:
            done, pending = wait(pending, timeout=min(HEARTBEAT_SECONDS, limit),
                                 return_when=FIRST_COMPLETED)
            for fut in done:
                idx = futures[fut]
                try:
                    out[:, idx] = fut.result()
                except Exception as exc:  # a lost worker (kept), or the task's own error (raised)
                    if not _lost_cause(exc):
                        raise
                    lost.append(idx)
                    broken = exc
                    continue
                bar.update(idx.size)
            if done:
                watch.progress()
            if not pending:
                break
            dead = watch.beat(len(pending))
            if dead is not None or time.monotonic() - start > limit:
                if watch.end_stuck():  # the pool breaks by itself: its futures fail, then
                    wait(pending, timeout=10.0)  # its `with` block can exit (no hang)
                for fut in pending:
                    fut.cancel()
                lost.extend(futures[f] for f in pending)
                broken = dead or TimeoutError(f"{len(pending)} of {len(groups)} tasks had not "
                                              f"returned after {limit:.0f} s")
                break
    except BaseException:
        for fut in futures:
            fut.cancel()
        raise
    if not lost:
        return
    named = watch.dead_named()
    workers = [w for w in named.split("; ") if w]
    if isinstance(broken, WorkerLostError):
        workers = broken.workers or workers
    elif type(broken).__name__ == "KilledWorker":
        workers = workers or [_killed_worker(broken)]
    reason = _reason(broken)
    if named and named not in reason:
        reason += f"; {named}"
    where = np.concatenate(lost)
    out[:, where] = np.nan
    done = len(groups) - len(lost)
    err = WorkerLostError(
        f"a worker of the executor died or hung ({reason}) and the "
        f"results of {where.size} of {out.shape[1]} runs were lost (grid indices "
        f"{_ranges(where)}; eps-major); {done} of {len(groups)} tasks finished and are kept "
        "in this exception's .partial (the lost runs marked 'worker lost'). Usual causes: "
        "memory exhausted (the OS killed it), a crash in native code, or a script that starts "
        "a 'spawn'/'forkserver' pool without `if __name__ == \"__main__\":`. Run the sweep "
        "again with a new executor",
        lost=where, accumulators=out.copy(), workers=workers)
    err.probe = acc0_of(where[:1])  # a column to learn the metrics' names from, all lost
    raise err


def _killed_worker(exc) -> str:
    """``"Dask worker tcp://... died running task (tries: n)"`` of a ``KilledWorker``."""
    last = getattr(exc, "last_worker", None)
    address = getattr(last, "address", last) or "(address unknown)"
    tries = getattr(exc, "allowed_failures", None)
    tries = f", {tries + 1} worker(s) tried" if isinstance(tries, int) else ""
    return f"Dask worker {address} died running a task of the grid{tries}"


def _first_line(exc) -> str:
    return (str(exc).strip().splitlines() or [type(exc).__name__])[0][:200]


def _reason(broken) -> str:
    if isinstance(broken, WorkerLostError):
        return str(broken)
    if type(broken).__name__ == "KilledWorker":
        return f"KilledWorker: {_killed_worker(broken)}"
    return f"{type(broken).__name__}: {_first_line(broken)}"


#: Seconds a worker process may stay stopped (SIGSTOP, a debugger) while tasks wait before
#: the grid is declared stuck.
STOPPED_SECONDS = 3.0
#: Seconds every worker process (with the compilers it started) may use no CPU at all while
#: tasks wait and none returns before the grid is declared stuck (a deadlocked worker; a
#: running or compiling one always uses CPU).
IDLE_SECONDS = 20.0


class _Heartbeat:
    """Who is alive among the executor's workers, checked every :data:`HEARTBEAT_SECONDS`:
    process-pool processes (exit codes; on Linux their state and CPU use, so a stopped or
    deadlocked worker is named within :data:`STOPPED_SECONDS` / :data:`IDLE_SECONDS`) or a
    Dask cluster's workers (asked with a bounded wait); :meth:`beat` returns a
    :class:`~fl_design.errors.WorkerLostError` naming them when the grid cannot go on."""

    def __init__(self, executor: Executor):
        self.executor = executor
        self.client = getattr(executor, "_client", None)
        self.processes: dict = {}
        self.workers: set = set()
        self.gone: set = set()
        self.workerless_since = None
        self.stopped_since: dict = {}
        self.cpu: dict = {}
        self.idle_since = None
        self.stuck: list = []
        self.note()

    def note(self) -> None:
        procs = getattr(self.executor, "_processes", None)
        if isinstance(procs, dict):
            self.processes.update(procs)

    def end_stuck(self) -> bool:
        """Kill the worker processes found stuck (stopped or deadlocked children of this
        process, running this grid's tasks): the pool then breaks as after a crash, fails its
        pending tasks, and can be shut down (a stopped worker would block its shutdown
        forever). True when one was killed."""
        import signal

        killed = False
        for pid in self.stuck:
            proc = self.processes.get(pid)
            if proc is None or getattr(proc, "exitcode", 0) is not None:
                continue
            try:
                os.kill(pid, signal.SIGKILL)
                killed = True
            except (ProcessLookupError, PermissionError):
                pass
        self.stuck = []
        return killed

    def progress(self) -> None:
        """A task came back: the workers are not stuck."""
        self.idle_since = None

    def dead_named(self, settle: float = 1.0) -> str:
        """The workers known dead (a killed process is reaped within ``settle`` seconds)."""
        self.note()
        deadline = time.monotonic() + settle
        while True:
            codes = {pid: getattr(p, "exitcode", None) for pid, p in self.processes.items()}
            if any(c is not None for c in codes.values()) or time.monotonic() > deadline \
                    or not codes:
                break
            time.sleep(0.05)
        dead = [f"worker process {pid} ({'killed by signal ' + str(-c) if c < 0 else f'exit code {c}'})"
                for pid, c in sorted(codes.items()) if c is not None]
        dead.extend(f"Dask worker {w} left the cluster" for w in sorted(self.gone))
        return "; ".join(dead)

    def beat(self, pending: int = 1) -> WorkerLostError | None:
        """None while the grid can go on, else the error naming the dead or stuck workers."""
        self.note()
        if self.client is None:
            return self._processes_stuck(pending) if self.processes else None
        try:
            now = set(bounded_call(self.client.nthreads, ASK_SECONDS,
                                   "the Dask scheduler (asked for its workers)"))
        except Exception as exc:  # noqa: BLE001 - an unreachable scheduler is a lost grid
            return WorkerLostError(f"the Dask scheduler stopped answering: {exc}")
        self.gone |= self.workers - now
        self.workers |= now
        if now:
            self.workerless_since = None
            return None
        self.workerless_since = self.workerless_since or time.monotonic()
        if time.monotonic() - self.workerless_since < WORKERLESS_SECONDS:
            return None
        left = ", ".join(sorted(self.gone)) or "none had joined"
        return WorkerLostError(f"the Dask cluster has had no worker for "
                               f"{WORKERLESS_SECONDS:g} s (workers that left: {left})",
                               workers=[f"Dask worker {w}" for w in sorted(self.gone)])

    def _processes_stuck(self, pending: int) -> WorkerLostError | None:
        stats = proc_stats()
        if stats is None:
            return None
        now = time.monotonic()
        alive = [pid for pid, p in self.processes.items()
                 if getattr(p, "exitcode", None) is None and pid in stats]
        stopped = []
        for pid in alive:
            if stats[pid][1] in ("T", "t"):
                since = self.stopped_since.setdefault(pid, now)
                if now - since >= STOPPED_SECONDS:
                    stopped.append(pid)
            else:
                self.stopped_since.pop(pid, None)
        if stopped:
            self.stuck = stopped
            names = [f"worker process {pid} (stopped for {now - self.stopped_since[pid]:.0f} s)"
                     for pid in stopped]
            return WorkerLostError(f"{'; '.join(names)} while {pending} task(s) wait",
                                   workers=names)
        cpu = {pid: tree_cpu(stats, pid) for pid in alive}
        moved = any(self.cpu.get(pid) != c for pid, c in cpu.items()) or not cpu
        self.cpu = cpu
        if moved:
            self.idle_since = None
            return None
        self.idle_since = self.idle_since or now
        if now - self.idle_since < IDLE_SECONDS:
            return None
        names = [f"worker process {pid} (no CPU used for {now - self.idle_since:.0f} s)"
                 for pid in sorted(cpu)]
        self.stuck = sorted(cpu)
        return WorkerLostError(f"every worker process is idle while {pending} task(s) wait "
                               f"(deadlocked or stuck): {'; '.join(names)}", workers=names)


__all__ = ["KernelTask", "bounded_call", "connect_scheduler", "executor_workers", "run_task",
           "run_tasks", "task_columns"]
