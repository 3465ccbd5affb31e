"""A worker that dies or stops mid-map: the finished chunks come back as a partial result.

The worker is killed deterministically: a process pool of one worker whose ``k``-th task is
``os._exit(3)`` (or ``SIGSTOP`` to itself), so tasks ``0 .. k-1`` finish first and the rest
are lost. The finished points must equal a clean in-process run's at those points (the grid's
result does not depend on how it is cut) and every other point must be marked lost. The
children run in their own session with a timeout (a deadlock fails, never hangs the suite).
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from tests.processes import run_script

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="POSIX process pools")

_SCRIPT = textwrap.dedent("""
    import json, os, signal, sys, time
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor
    import numpy as np
    import fl_design as fl
    from fl_design.errors import WorkerLostError
    from fl_design.sim import _executor

    def stop_self():
        os.kill(os.getpid(), signal.SIGSTOP)

    class DiesAt(ProcessPoolExecutor):
        '''One worker; its task number `at` (1-based) kills (or stops) the worker.'''
        def __init__(self, at, how):
            super().__init__(1, mp_context=mp.get_context("fork"))
            self.n, self.at, self.how = 0, at, how
        def submit(self, fn, /, *args, **kwargs):
            self.n += 1
            if self.n == self.at:
                return super().submit(os._exit, 3) if self.how == "exit" else \\
                    super().submit(stop_self)
            return super().submit(fn, *args, **kwargs)

    def as_list(a):
        return np.where(np.isnan(a), None, a).tolist() if a.dtype.kind == "f" else a.tolist()

    def main(what, how, at):
        _executor.STOPPED_SECONDS = 1.0
        p, d = fl.plants.pendulum(), fl.presets.pendulum_design()
        sc = fl.Scenario(0.05, 1.0)
        grid = dict(eps=np.geomspace(0.005, 0.2, 4), gamma=np.geomspace(3e-3, 0.1, 4),
                    progress=False, kernel=fl.Kernel(chunk_size=2))
        fam = {"c": (0.1, 0.9)}
        if what == "map":
            call = lambda ex: fl.sweep(p, d, sc, executor=ex, **grid)
        elif what == "robust":
            call = lambda ex: fl.sweep(p, d, sc, executor=ex, params=fam, samples=2, **grid)
        else:
            call = lambda ex: fl.monte_carlo(p, d, sc, params=fam, n=16, executor=ex,
                                             progress=False, kernel=fl.Kernel(chunk_size=2))
        clean = call(None)
        ex = DiesAt(at, how)
        start = time.perf_counter()
        try:
            call(ex)
            print(json.dumps({"error": None}))
            return
        except WorkerLostError as err:
            seconds = time.perf_counter() - start
            part = err.partial
            out = {"error": str(err), "seconds": seconds, "lost": err.lost,
                   "workers": err.workers, "type": type(part).__name__,
                   "same_type": isinstance(part, type(clean)),
                   "mask": np.flatnonzero(np.ravel(part.lost)).tolist(),
                   "reason": part.lost_reason,
                   "status": as_list(np.ravel(part.status)),
                   "clean_status": as_list(np.ravel(clean.status)),
                   "metrics": {k: as_list(np.asarray(v, float).reshape(np.size(part.status), -1))
                               for k, v in part.metrics.items()},
                   "clean_metrics": {k: as_list(np.asarray(v, float).reshape(
                       np.size(part.status), -1)) for k, v in clean.metrics.items()},
                   "json_lost": part.to_dict()["lost"] is not None}
            print(json.dumps(out))
        finally:
            for pid in list(ex._processes):  # a stopped worker: ours, end it
                try:
                    os.kill(pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
            ex.shutdown(wait=True, cancel_futures=True)

    if __name__ == "__main__":
        main(sys.argv[1], sys.argv[2], int(sys.argv[3]))
""")


def _run(tmp_path, *args: str, timeout: float = 240.0) -> dict:
    script = tmp_path / "dies.py"
    script.write_text(_SCRIPT)
    code, out, err = run_script(script, *args, timeout=timeout)
    if code is None:
        pytest.fail(f"no answer within {timeout} s (a hang)\n{out}\n{err[-2000:]}")
    assert code == 0, err[-3000:]
    return json.loads(out.strip().splitlines()[-1])


def _check_partial(res: dict, n: int, lost: set[int]) -> None:
    assert res["error"] is not None, "no WorkerLostError"
    assert res["same_type"], res["type"]
    assert set(res["lost"]) == lost and set(res["mask"]) == lost
    assert res["reason"].startswith("worker lost")
    kept = [i for i in range(n) if i not in lost]
    for i in kept:  # a finished run: exactly the clean run's verdict and metrics
        assert res["status"][i] == res["clean_status"][i], i
        for name, rows in res["metrics"].items():
            assert rows[i] == res["clean_metrics"][name][i], (name, i)
    for i in lost:  # a lost run: undecided (code 3), every metric NaN
        assert res["status"][i] == 3
        assert all(all(v is None for v in rows[i]) for rows in res["metrics"].values())
    assert res["json_lost"]


def _columns(tasks, n_tasks, n):
    return {c for t in tasks for c in range(t, n, n_tasks)}


@pytest.mark.slow
def test_a_worker_killed_mid_map_keeps_the_finished_chunks_as_a_map(tmp_path):
    # 16 runs, 2 per task, strided over 8 tasks (task i: columns i, i + 8); task 4 exits
    res = _run(tmp_path, "map", "exit", "4")
    _check_partial(res, 16, _columns(range(3, 8), 8, 16))
    assert res["type"] == "PartialStabilityMap"
    assert "exit code 3" in " ".join(res["workers"]) and "exit code 3" in res["reason"]
    assert "grid indices" in res["error"] and "new executor" in res["error"]


@pytest.mark.slow
def test_a_worker_killed_mid_robust_map_and_ensemble_keeps_the_finished_chunks(tmp_path):
    res = _run(tmp_path, "robust", "exit", "6")  # 32 runs (16 points x 2 plants), 16 tasks
    _check_partial(res, 32, _columns(range(5, 16), 16, 32))
    assert res["type"] == "PartialRobustMap"
    res = _run(tmp_path, "ensemble", "exit", "2")  # 16 runs, 8 tasks
    _check_partial(res, 16, _columns(range(1, 8), 8, 16))
    assert res["type"] == "PartialEnsemble"


@pytest.mark.slow
def test_a_stopped_worker_is_named_within_seconds_and_the_finished_chunks_kept(tmp_path):
    res = _run(tmp_path, "map", "stop", "3")
    _check_partial(res, 16, _columns(range(2, 8), 8, 16))
    assert any("stopped" in w for w in res["workers"]), res["workers"]
    assert res["seconds"] < 30.0, res["seconds"]


def test_finished_only_never_classifies_a_lost_column():
    from fl_design.sim._partial import finished_only

    seen = []

    def finalize(acc):
        seen.append(acc.copy())
        return np.full(acc.shape[1], 2), {"iae": acc[0], "rms": acc[:2].T}

    acc = np.array([[1.0, np.nan, 3.0], [4.0, np.nan, 6.0]])
    status, metrics = finished_only(finalize, acc, np.array([False, True, False]))
    assert not np.isnan(seen[0]).any()
    assert status.tolist() == [2, 3, 2]
    assert np.array_equal(metrics["rms"], [[1.0, 4.0], [np.nan, np.nan], [3.0, 6.0]],
                          equal_nan=True)
    status, metrics = finished_only(finalize, acc[:, 1:2], np.array([True]))  # all lost
    assert status.tolist() == [3] and np.isnan(metrics["iae"]).all()


def test_a_partial_map_checks_its_mask_shape():
    from fl_design.errors import ParameterError
    from fl_design.sim._partial import PartialStabilityMap

    with pytest.raises(ParameterError, match=r"lost must have the status' shape \(1, 2\)"):
        PartialStabilityMap(np.array([0.1]), np.array([1.0, 2.0]), np.array([[2, 3]]), {},
                            1e-3, 1.0, 0.1, lost=np.array([True]))


_DASK = textwrap.dedent("""
    import json, os, sys
    from concurrent.futures import Executor
    import numpy as np
    import dask
    import fl_design as fl
    from fl_design.errors import WorkerLostError

    class DiesAt(Executor):
        '''A Dask client's executor whose task number `at` (1-based) kills its worker.'''
        def __init__(self, inner, at):
            self.inner, self.at, self.n, self._client = inner, at, 0, inner._client
        def submit(self, fn, /, *args, **kwargs):
            self.n += 1
            return self.inner.submit(*((os._exit, 3) if self.n == self.at else (fn, *args)),
                                     **kwargs)

    if __name__ == "__main__":
        from distributed import Client, LocalCluster
        dask.config.set({"distributed.scheduler.allowed-failures": 0,
                         "logging.distributed": "critical"})
        p, d = fl.plants.pendulum(), fl.presets.pendulum_design()
        sc = fl.Scenario(0.05, 1.0)
        grid = dict(eps=np.geomspace(0.005, 0.2, 4), gamma=np.geomspace(3e-3, 0.1, 4),
                    progress=False, kernel=fl.Kernel(chunk_size=2))
        clean = fl.sweep(p, d, sc, **grid)
        with LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                          dashboard_address=None) as cluster, Client(cluster) as client:
            try:
                fl.sweep(p, d, sc, executor=DiesAt(client.get_executor(), 4), **grid)
                print(json.dumps({"error": None}))
            except WorkerLostError as err:
                part, kept = err.partial, ~err.partial.lost
                same = all(np.array_equal(np.asarray(v)[kept], np.asarray(clean.metrics[k])[kept],
                                          equal_nan=True) for k, v in part.metrics.items())
                print(json.dumps({
                    "error": str(err), "lost": err.lost, "workers": err.workers,
                    "type": type(part).__name__, "reason": part.lost_reason,
                    "mask": np.flatnonzero(part.lost.ravel()).tolist(),
                    "same": bool(same and np.array_equal(part.status[kept], clean.status[kept])),
                    "lost_undecided": bool((part.status[~kept] == 3).all()),
                    "lost_nan": all(np.isnan(np.asarray(v)[~kept]).all()
                                    for v in part.metrics.values())}))
""")


@pytest.mark.slow
def test_a_dask_worker_killed_mid_map_keeps_the_finished_chunks_and_names_the_worker(tmp_path):
    pytest.importorskip("distributed")
    script = tmp_path / "dask_dies.py"
    script.write_text(_DASK)
    proc = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        out, err = proc.communicate(timeout=240)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        pytest.fail(f"no answer within 240 s (a hang)\n{out}\n{err[-2000:]}")
    assert proc.returncode == 0, err[-3000:]
    res = json.loads(out.strip().splitlines()[-1])
    assert res["error"] is not None and res["type"] == "PartialStabilityMap"
    # task 4 (columns 3 and 11) killed its worker; Dask may lose the task it ran beside it
    assert {3, 11} <= set(res["lost"]) and res["lost"] == res["mask"] and len(res["lost"]) < 16
    assert res["same"] and res["lost_undecided"] and res["lost_nan"]
    assert re.search(r"Dask worker tcp://[\d.]+:\d+ died", res["workers"][0]), res["workers"]
    assert res["reason"].startswith("worker lost: Dask worker tcp://")


def test_the_heartbeat_names_worker_processes_idle_while_tasks_wait(monkeypatch):
    """Every worker process (with its children) using no CPU while tasks wait is a
    deadlock; CPU moving anywhere in a worker's tree (a compiler it runs) is progress."""
    import time
    from types import SimpleNamespace

    from fl_design.sim import _executor

    ticks = {"w": 10, "cc": 5}
    monkeypatch.setattr(_executor, "IDLE_SECONDS", 0.2)
    monkeypatch.setattr(_executor, "proc_stats", lambda: {
        101: (1, "S", ticks["w"]), 102: (1, "S", 3), 201: (101, "R", ticks["cc"])})
    pool = SimpleNamespace(_processes={101: SimpleNamespace(exitcode=None),
                                       102: SimpleNamespace(exitcode=None)})
    beat = _executor._Heartbeat(pool)
    assert beat.beat(2) is None  # first look
    ticks["cc"] += 1  # the compiler under worker 101 works: progress
    assert beat.beat(2) is None
    time.sleep(0.3)
    ticks["cc"] += 1
    assert beat.beat(2) is None  # still progress after the idle limit
    assert beat.beat(2) is None  # idle from now on (the limit starts)
    time.sleep(0.3)
    err = beat.beat(2)
    assert err is not None and "every worker process is idle while 2 task(s) wait" in str(err)
    assert [w.split(" (")[0] for w in err.workers] == ["worker process 101",
                                                       "worker process 102"]
    assert beat.stuck == [101, 102]


def test_a_shut_down_executor_is_a_clear_error():
    from concurrent.futures import ThreadPoolExecutor

    import fl_design as fl
    from fl_design.errors import ParameterError

    ex = ThreadPoolExecutor(2)
    ex.shutdown()
    with pytest.raises(ParameterError, match="ThreadPoolExecutor takes no tasks .* shut down"):
        fl.sweep(fl.plants.pendulum(), fl.presets.pendulum_design(), fl.Scenario(0.05, 0.2),
                 eps=[0.01, 0.02], gamma=[1e-2], executor=ex, progress=False)
