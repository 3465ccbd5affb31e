"""Bounded, interruptible work: blocks of samples give the same results, Ctrl-C stops a sweep."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

import fl_design as fl
from fl_design.errors import ResourceLimitError
from fl_design.sim._grid import block_length, parameter_columns
from fl_design.sim._run import prepare_run


@pytest.mark.parametrize("kernel", [fl.Kernel(compiled=False), fl.Kernel(lanes=False),
                                    fl.Kernel(lanes=True, vector_math=False)],
                         ids=["interpreted", "scalar", "lanes"])
def test_running_in_blocks_of_samples_changes_nothing(tmp_path, kernel):
    """A run advanced block by block equals the run advanced in one call (bitwise)."""
    kernel = fl.Kernel(**{**kernel.__dict__, "cache_dir": tmp_path})
    d = fl.presets.pendulum_design()
    run = prepare_run(fl.plants.pendulum(), d, fl.Scenario(0.05, 3.0))
    P = parameter_columns(d, [0.01, 0.05, 0.3], [3e-3, 1e-2, 3e-2])  # diverging points too
    runner = run.loop.runner(kernel=kernel)
    acc0 = run.initial_accumulator(P)
    whole = runner.run(acc0.copy(), run.D, threads=2)
    blocks = acc0.copy()
    for a in range(0, run.N, 377):  # blocks that do not divide N
        blocks = runner.run(blocks, run.D[:, a:a + 377], threads=2)
    np.testing.assert_array_equal(blocks, whole)
    assert np.any(run.loop.layout.unpack(whole)["diverged"] == 1)


def test_block_length_bounds_the_work_of_one_call():
    assert block_length(64, 2, True) * 64 / 2 * 400e-9 <= 0.21
    assert block_length(1, 1, True) >= 10_000
    assert block_length(10**9, 1, True) == 64  # never below a useful block


def test_a_grid_too_large_for_memory_is_refused_before_any_work(monkeypatch):
    d = fl.presets.pendulum_design()
    started = time.perf_counter()
    with pytest.raises(ResourceLimitError, match="FL_DESIGN_MAX_MEMORY_GB"):
        fl.sweep(fl.plants.pendulum(), d, fl.Scenario(0.05, 1.0),
                 eps=np.geomspace(1e-3, 1, 10_000), gamma=np.geomspace(1e-4, 1, 10_000),
                 progress=False)
    assert time.perf_counter() - started < 10.0
    monkeypatch.setenv("FL_DESIGN_MAX_MEMORY_GB", "1e-9")
    with pytest.raises(ResourceLimitError, match=r"above (the limit of )?1e-09 GiB"):
        fl.sweep(fl.plants.pendulum(), d, fl.Scenario(0.05, 0.01), eps=[0.02, 0.03],
                 gamma=[1e-2], progress=False, kernel=fl.Kernel(compiled=False))


_CHILD = textwrap.dedent("""
    import sys, time
    from concurrent.futures import ProcessPoolExecutor
    import numpy as np
    import fl_design as fl
    kind, cache = sys.argv[1], sys.argv[2]
    plant, d = fl.plants.pendulum(), fl.presets.pendulum_design()
    kernel = fl.Kernel(cache_dir=cache, chunk_size=8, threads=2)
    grid = dict(eps=np.geomspace(0.005, 0.02, 16), gamma=np.geomspace(3e-3, 3e-2, 16))
    fl.sweep(plant, d, fl.Scenario(0.05, 0.1), kernel=kernel, progress=False, **grid)  # warm
    long = fl.Scenario(0.05, 400.0)
    try:
        if kind == "process":
            with ProcessPoolExecutor(2) as pool:
                fl.sweep(plant, d, fl.Scenario(0.05, 0.1), kernel=kernel, executor=pool,
                         progress=False, **grid)  # workers warm
                print("ready", flush=True)
                fl.sweep(plant, d, long, kernel=kernel, executor=pool, progress=False, **grid)
        else:
            print("ready", flush=True)
            fl.sweep(plant, d, long, kernel=kernel, progress=False, **grid)
        print("finished", flush=True)
    except KeyboardInterrupt:
        print("interrupted", flush=True)
        sys.exit(130)
""")


def _readline(stream, timeout: float) -> str | None:
    """One line from ``stream`` within ``timeout`` seconds, else None (never blocks longer)."""
    import queue
    import threading

    box: queue.Queue = queue.Queue()
    threading.Thread(target=lambda: box.put(stream.readline()), daemon=True).start()
    try:
        return box.get(timeout=timeout)
    except queue.Empty:
        return None


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
@pytest.mark.parametrize("kind", ["threads", "process"])
def test_sigint_stops_a_sweep_within_two_seconds(tmp_path, kind):
    proc = subprocess.Popen([sys.executable, "-c", _CHILD, kind, str(tmp_path)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    try:
        line = _readline(proc.stdout, 180.0)
        if line is None:
            os.killpg(proc.pid, signal.SIGKILL)
            pytest.fail(f"{kind}: the child printed nothing within 180 s (hung before the "
                        f"interrupted sweep): {proc.communicate()[1][-2000:]}")
        assert line.strip() == "ready", line + proc.communicate(timeout=30)[1]
        time.sleep(1.0)  # well inside the 256 runs x 400 s sweep (minutes of work)
        sent = time.perf_counter()
        os.kill(proc.pid, signal.SIGINT)
        rest = proc.communicate(timeout=30)[0]
        elapsed = time.perf_counter() - sent
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)  # the child and its pool workers
            proc.communicate()
    assert "interrupted" in rest and proc.returncode == 130
    assert elapsed <= 2.0, f"{kind}: the process ended {elapsed:.2f} s after SIGINT"
