"""Sweeps with any executor and any start method, after threads, in any order; dying workers.

The child processes run with a timeout and in their own process group, so a deadlock fails the
test (it never hangs the suite).
"""

from __future__ import annotations

import sys
import textwrap

import pytest

from tests.processes import run_script

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="POSIX start methods")

_SEQUENCE = textwrap.dedent("""
    import multiprocessing as mp, sys
    from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor
    import numpy as np
    import fl_design as fl

    def status(m):
        return [str(s) for s in np.ravel(m.status)]

    def has_sympy():
        return "sympy" in sys.modules

    def main(method):
        p = fl.plants.pendulum()
        d = fl.Design(estimator=fl.EHGO(rho=2, eps=0.02, T=1e-3),
                      controller=fl.DynamicController((2, 4), 1e-2))
        sc = fl.Scenario(0.2, 2.0)
        kw = dict(eps=np.geomspace(0.005, 0.2, 6), gamma=np.geomspace(1e-3, 0.05, 6),
                  progress=False)
        k = fl.Kernel(threads=2)       # one kernel object, its threads started here first
        a = fl.sweep(p, d, sc, kernel=k, **kw)
        with ProcessPoolExecutor(2, mp_context=mp.get_context(method)) as ex:
            b = fl.sweep(p, d, sc, kernel=k, executor=ex, **kw)
            sympy_in_worker = ex.submit(has_sympy).result()
        with ThreadPoolExecutor(2) as ex:
            c = fl.sweep(p, d, sc, kernel=k, executor=ex, **kw)
        e = fl.sweep(p, d, sc, kernel=k, **kw)   # in-process again, after the pools
        assert len(set(status(a))) > 1
        print("SAME", status(a) == status(b) == status(c) == status(e),
              np.array_equal(a.metrics["overshoot"], b.metrics["overshoot"], equal_nan=True))
        print("SYMPY", method != "fork" and sympy_in_worker)

    if __name__ == "__main__":
        main(sys.argv[1])
""")


@pytest.mark.parametrize("method", ["fork", "forkserver", "spawn"])
def test_process_pool_after_threaded_sweep_finishes_with_identical_results(tmp_path, method):
    script = tmp_path / "seq.py"  # spawn/forkserver re-import __main__: a real file
    script.write_text(_SEQUENCE)
    rc, out, err = run_script(script, method)
    assert rc is not None, f"{method}: deadlocked (killed after 240 s)\n{out}\n{err[-2000:]}"
    assert rc == 0, err[-2000:]
    assert "SAME True True" in out, out
    assert "SYMPY False" in out, "a worker imported SymPy: it should get the compiled kernel only"


_DIES = textwrap.dedent("""
    import os, signal, sys, threading, time
    from concurrent.futures import ProcessPoolExecutor
    import numpy as np
    import fl_design as fl
    from fl_design.errors import WorkerLostError

    if __name__ == "__main__":
        p, d = fl.plants.pendulum(), fl.presets.pendulum_design()
        grid = dict(eps=np.geomspace(0.01, 0.05, 16), gamma=np.geomspace(3e-3, 3e-2, 16))
        with ProcessPoolExecutor(2) as ex:
            fl.sweep(p, d, fl.Scenario(0.05, 0.05), executor=ex, progress=False, **grid)
            victim = next(iter(ex._processes))
            threading.Timer(0.5, os.kill, (victim, signal.SIGKILL)).start()
            try:
                fl.sweep(p, d, fl.Scenario(0.05, 300.0), executor=ex, progress=False, **grid)
                print("NO ERROR")
            except WorkerLostError as exc:
                lost = exc.lost
                blank = exc.partial.lost.ravel()  # a partial StabilityMap
                print("LOST", len(lost), int((~blank).sum()),
                      np.flatnonzero(blank).tolist() == sorted(lost))
                print("MESSAGE", "grid indices" in str(exc) and "new executor" in str(exc))
""")


def test_a_killed_worker_gives_a_clear_error_with_the_finished_chunks(tmp_path):
    script = tmp_path / "dies.py"
    script.write_text(_DIES)
    rc, out, err = run_script(script)
    assert rc == 0, (out, err[-2000:])
    words = dict(line.split(" ", 1) for line in out.splitlines() if " " in line)
    assert "LOST" in words, out
    n_lost, n_kept, consistent = words["LOST"].split()
    assert int(n_lost) > 0 and int(n_lost) + int(n_kept) == 256 and consistent == "True"
    assert words["MESSAGE"] == "True"


def test_a_hung_executor_is_a_clear_error_not_a_hang(monkeypatch):
    """An executor whose tasks never come back: the wait ends at its limit with the reason."""
    import time
    from concurrent.futures import Executor, Future

    import fl_design as fl
    from fl_design.errors import WorkerLostError
    from fl_design.sim import _executor

    class Hangs(Executor):
        _max_workers = 2

        def submit(self, fn, /, *args, **kwargs):
            return Future()  # never completes

    monkeypatch.setattr(_executor, "STUCK_GRACE_SECONDS", 0.5)
    monkeypatch.setattr(_executor, "STUCK_STEP_SECONDS", 0.0)
    started = time.perf_counter()
    with pytest.raises(WorkerLostError, match="had not returned after 0 s") as info:
        fl.sweep(fl.plants.pendulum(), fl.presets.pendulum_design(), fl.Scenario(0.05, 0.1),
                 eps=[0.01, 0.02], gamma=[1e-2, 3e-2], executor=Hangs(), progress=False)
    assert time.perf_counter() - started < 30
    assert info.value.lost == [0, 1, 2, 3] and info.value.partial.lost.all()
    assert (info.value.partial.labels == "undecided").all()
