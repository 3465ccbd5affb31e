"""Every wait is bounded and said: a scheduler that accepts and never answers, a tls://
scheduler without certificates, a Dask cluster whose workers all die, a scheduler that stops
answering; finished chunks are kept in the error's partial result."""

from __future__ import annotations

import socket
import subprocess
import sys
import threading
import time
from concurrent.futures import Executor, Future

import numpy as np
import pytest

import fl_design as fl
from fl_design.errors import ParameterError, WorkerLostError
from fl_design.sim import _executor
from fl_design.sim._executor import bounded_call, connect_scheduler

pytest.importorskip("distributed")


@pytest.fixture
def silent_server():
    """A TCP server that accepts connections and never says anything."""
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(8)
    held, stop = [], threading.Event()

    def serve():
        srv.settimeout(0.2)
        while not stop.is_set():
            try:
                held.append(srv.accept()[0])
            except OSError:
                pass

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    yield f"tcp://127.0.0.1:{srv.getsockname()[1]}"
    stop.set()
    thread.join(5)
    for c in held:
        c.close()
    srv.close()


def test_a_scheduler_that_never_answers_is_a_clear_error_in_bounded_time(silent_server):
    start = time.perf_counter()
    with pytest.raises(ParameterError, match=r"no answer within 1 s .*dask scheduler"):
        connect_scheduler(silent_server, timeout=1.0)
    assert time.perf_counter() - start < 10.0


def test_a_tls_scheduler_without_certificates_says_what_to_configure(silent_server):
    with pytest.raises(ParameterError, match="tls:// scheduler needs certificates"):
        connect_scheduler(silent_server.replace("tcp://", "tls://"), timeout=2.0)


@pytest.mark.parametrize("address", ["", "gopher://h:1", 42])
def test_a_bad_address_is_refused(address):
    with pytest.raises(ParameterError, match="scheduler address"):
        connect_scheduler(address)


def test_the_cli_refuses_a_tls_scheduler_with_one_line(tmp_path, silent_server):
    proc = subprocess.run(
        [sys.executable, "-m", "fl_design", "run", "--quick", "--out", str(tmp_path / "o"),
         "--scheduler", silent_server.replace("tcp://", "tls://")],
        capture_output=True, text=True, timeout=240, check=False)
    assert proc.returncode == 2, proc.stderr[-2000:]
    assert "Traceback" not in proc.stderr and "tls:// scheduler needs certificates" in proc.stderr


def test_bounded_call_returns_raises_and_times_out():
    assert bounded_call(lambda: 3, 1.0, "x") == 3
    with pytest.raises(ZeroDivisionError):
        bounded_call(lambda: 1 / 0, 1.0, "x")
    with pytest.raises(TimeoutError, match="the sleeper did not answer within 0.1 s"):
        bounded_call(lambda: time.sleep(5), 0.1, "the sleeper")


class _Client:
    def __init__(self, answers):
        self.answers = list(answers)

    def nthreads(self):
        answer = self.answers.pop(0) if len(self.answers) > 1 else self.answers[0]
        if answer == "hang":
            time.sleep(30)
        return answer


class _DaskLike(Executor):
    """Finishes its first ``finish`` tasks at once; the others never come back."""

    _max_workers = 2

    def __init__(self, answers, finish=2):
        self._client = _Client(answers)
        self.finish = finish

    def submit(self, fn, /, *args, **kwargs):
        fut = Future()
        if self.finish > 0:
            self.finish -= 1
            fut.set_result(args[1])  # the task's initial accumulators: a finished chunk
        return fut


def _sweep(executor):
    return fl.sweep(fl.plants.pendulum(), fl.presets.pendulum_design(), fl.Scenario(0.05, 0.1),
                    eps=np.geomspace(0.01, 0.05, 4), gamma=np.geomspace(3e-3, 3e-2, 4),
                    executor=executor, progress=False, kernel=fl.Kernel(chunk_size=2))


def test_a_cluster_whose_workers_all_die_names_them_within_seconds(monkeypatch):
    monkeypatch.setattr(_executor, "HEARTBEAT_SECONDS", 0.1)
    monkeypatch.setattr(_executor, "WORKERLESS_SECONDS", 0.5)
    ex = _DaskLike([{"tcp://10.0.0.7:4001": 1, "tcp://10.0.0.8:4001": 1}, {}])
    start = time.perf_counter()
    with pytest.raises(WorkerLostError, match=r"no worker for 0.5 s .*tcp://10.0.0.7:4001, "
                                              r"tcp://10.0.0.8:4001") as info:
        _sweep(ex)
    assert time.perf_counter() - start < 10.0
    kept = ~info.value.partial.lost.ravel()  # a partial StabilityMap
    assert kept.sum() == 4 and len(info.value.lost) == 12  # 2 finished tasks of 2 runs kept
    assert sorted(np.flatnonzero(~kept).tolist()) == info.value.lost
    assert (info.value.partial.labels.ravel()[~kept] == "undecided").all()
    assert info.value.workers == ["Dask worker tcp://10.0.0.7:4001",
                                  "Dask worker tcp://10.0.0.8:4001"]


def test_a_scheduler_that_stops_answering_is_a_lost_grid_not_a_hang(monkeypatch):
    monkeypatch.setattr(_executor, "HEARTBEAT_SECONDS", 0.1)
    monkeypatch.setattr(_executor, "ASK_SECONDS", 0.3)
    start = time.perf_counter()
    with pytest.raises(WorkerLostError, match="stopped answering"):
        _sweep(_DaskLike([{"tcp://w:1": 1}, "hang"], finish=0))
    assert time.perf_counter() - start < 10.0
