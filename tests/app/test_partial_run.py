"""``fl-design run`` when a worker dies mid-sweep: the partial map is the report's map.

The worker is killed deterministically (as in ``tests/sim/test_worker_lost.py``): a process
pool of one forked worker whose ``at``-th task is ``os._exit(3)``, given to ``fl-design run``
in place of a Dask cluster's executor. The quick map's 25 runs go out as two strided tasks
(task ``i``: runs ``i, i + 2, ...``), so killing task 2 loses runs 1, 3, ..., 23 (12 of 25)
and keeps the rest, which must equal a clean run's. The job must go on, write the whole report
(marked partial), exit 3, and a later run must recompute the map (nothing cached).
"""

from __future__ import annotations

import json
import os
import sys
import textwrap

import numpy as np
import pytest

from tests.processes import run_script

_SCRIPT = textwrap.dedent("""
    import json, os, sys
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor

    class DiesAt(ProcessPoolExecutor):
        '''One forked worker; its task number `at` (1-based) kills the worker.'''
        def __init__(self, at):
            super().__init__(1, mp_context=mp.get_context("fork"))
            self.n, self.at = 0, at
        def submit(self, fn, /, *args, **kwargs):
            self.n += 1
            if self.n == self.at:
                return super().submit(os._exit, 3)
            return super().submit(fn, *args, **kwargs)

    if __name__ == "__main__":
        from fl_design.app import _cli, _commands
        config, out, at, command = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
        ex = DiesAt(at) if at else None
        _commands._executor = lambda address: ex
        args = ["--out", out, "--static-report"] if command == "run" else []
        try:
            code = _cli.main([command, config, "--quick", "--no-progress", *args])
        finally:
            if ex is not None:
                ex.shutdown(wait=True, cancel_futures=True)
        print(json.dumps({"code": code, "tasks": ex.n if ex else 0}))
""")

_CONFIG = '[plant]\nlibrary = "pendulum"\n[codegen]\nenabled = false\n'


def _run(tmp_path, out: str, at: int, command: str = "run",
         timeout: float = 240.0) -> tuple[dict, str, str]:
    script, config = tmp_path / "dies_run.py", tmp_path / "quick.toml"
    script.write_text(_SCRIPT)
    config.write_text(_CONFIG)
    env = {**os.environ, "FL_DESIGN_CACHE": str(tmp_path / "cache"), "MPLBACKEND": "Agg"}
    code, stdout, stderr = run_script(script, str(config), str(tmp_path / out), str(at),
                                      command, timeout=timeout, env=env)
    if code is None:
        pytest.fail(f"no answer within {timeout} s (a hang)\n{stdout}\n{stderr[-2000:]}")
    assert code == 0, stderr[-3000:]
    return json.loads(stdout.strip().splitlines()[-1]), stdout, stderr


@pytest.mark.slow
@pytest.mark.skipif(sys.platform == "win32", reason="POSIX process pools")
def test_a_worker_lost_mid_sweep_gives_a_partial_report_exit_3_and_nothing_cached(tmp_path):
    from fl_design.app._brief import DASH

    res, stdout, stderr = _run(tmp_path, "partial", at=2)
    assert res["tasks"] == 2, res  # the quick map's two tasks: the second one killed
    assert res["code"] == 3, stderr[-2000:]  # written but partial: not 0, not 2
    part = json.loads((tmp_path / "partial" / "summary.json").read_text())
    lost = set(range(1, 25, 2))  # task 2 of 2, strided: runs 1, 3, ..., 23
    mask = np.asarray(part["sweep"]["lost"], bool).ravel()
    assert set(np.flatnonzero(mask)) == lost
    assert part["complete"] is False
    assert (part["sweep"]["n_lost"], part["sweep"]["n_runs"]) == (12, 25)
    line = part["lost"]["sweep"]
    assert line.startswith("map: 12 of 25 runs lost (worker process ")
    assert "exit code 3) died); those points are undecided" in line
    assert part["sweep"]["lost_reason"].startswith("worker lost: worker process ")
    # the one line in the console (the summary's first row, and last) and in both reports
    assert f"PARTIAL {DASH} {line}" in stdout or f"PARTIAL - {line}" in stdout
    assert f"PARTIAL REPORT (exit 3): {line}" in stdout.splitlines()[-2]
    md = (tmp_path / "partial" / "report.md").read_text()
    assert f"PARTIAL REPORT: {line}" in md and "PARTIAL MAP" in md
    assert "PARTIAL" in (tmp_path / "partial" / "report.html").read_text()
    assert (tmp_path / "partial" / "stability_map.png").stat().st_size > 0
    # the later stages ran in full
    assert part["simulate"]["main"]["status"] and "certify" in part

    # the same job again, no worker killed: the map is recomputed, complete (never cached)
    res, stdout, _ = _run(tmp_path, "clean", at=0)
    assert res["code"] == 0 and "PARTIAL" not in stdout
    clean = json.loads((tmp_path / "clean" / "summary.json").read_text())
    assert clean["complete"] is True and clean["lost"] == {}
    assert clean["sweep"]["n_lost"] == 0 and "lost" not in clean["sweep"]
    # the finished runs are exactly the clean run's; the lost ones undecided, NaN metrics
    ps, cs = (np.asarray(s["sweep"]["status"]).ravel() for s in (part, clean))
    kept = ~mask
    assert np.array_equal(ps[kept], cs[kept]) and (ps[mask] == "undecided").all()
    for name, values in part["sweep"]["metrics"].items():
        pv = np.asarray(values, dtype=float).reshape(25, -1)
        cv = np.asarray(clean["sweep"]["metrics"][name], dtype=float).reshape(25, -1)
        assert np.array_equal(pv[kept], cv[kept], equal_nan=True), name
        assert np.isnan(pv[mask]).all(), name


@pytest.mark.slow
@pytest.mark.skipif(sys.platform == "win32", reason="POSIX process pools")
def test_the_sweep_command_prints_the_partial_map_and_exits_3(tmp_path):
    res, stdout, stderr = _run(tmp_path, "unused", at=2, command="sweep")
    assert res["code"] == 3, stderr[-2000:]
    assert stdout.splitlines()[-2].startswith("PARTIAL (exit 3): map: 12 of 25 runs lost")


def _partial_map():
    from fl_design.sim._partial import PartialStabilityMap

    lost = np.array([[False, True], [True, False]])
    return PartialStabilityMap(np.array([0.01, 0.02]), np.array([-1e-3, -2e-3]),
                               np.array([[2, 3], [3, 1]]), {}, 1e-3, 1.0, 0.1, lost=lost,
                               lost_reason="worker lost: worker process 7 (exit code 3)")


def test_the_sweep_stage_keeps_the_partial_map_and_the_job_says_it_lost_runs(monkeypatch):
    import fl_design.sim
    from fl_design.app import load_config, run_job
    from fl_design.errors import WorkerLostError

    part = _partial_map()

    def dies(*args, **kwargs):
        raise WorkerLostError("a worker died", lost=[1, 2], partial=part,
                              workers=["worker process 7 (exit code 3)"])

    monkeypatch.setattr(fl_design.sim, "sweep", dies)
    job = run_job(load_config(None), quick=True, stages=("sweep",), progress=False)
    assert job.results["sweep"] is part and job.partial
    assert job.lost == {"sweep": "map: 2 of 4 runs lost (worker process 7 (exit code 3) "
                                 "died); those points are undecided"}

    def dies_without_partial(*args, **kwargs):
        raise WorkerLostError("a worker died, nothing kept")

    monkeypatch.setattr(fl_design.sim, "sweep", dies_without_partial)
    with pytest.raises(WorkerLostError, match="nothing kept"):
        run_job(load_config(None), quick=True, stages=("sweep",), progress=False)


def test_the_map_figures_cross_exactly_the_lost_cells():
    import matplotlib

    matplotlib.use("Agg")
    from fl_design.plotting import FigureContext, plot_stability_map
    from fl_design.plotting._plotly import stability_map_spec
    from fl_design.plotting._report import stability_map_figure

    m = _partial_map()
    want = {(2e-3, 0.01), (1e-3, 0.02)}  # (|gamma|, eps) of the lost cells
    (line,) = [h for h in plot_stability_map(m).axes[0].get_lines()
               if h.get_label().startswith("lost: worker died (2 runs")]
    assert set(zip(line.get_xdata(), line.get_ydata())) == want
    ctx = FigureContext("p", design_gamma=-1e-3, design_eps=0.01)
    assert "PARTIAL: 2 of 4 runs lost" in stability_map_figure(m, ctx).axes[0].get_title()
    spec = stability_map_spec(m, ctx)
    (trace,) = [d for d in spec["data"] if d["name"].startswith("lost: worker died")]
    assert set(zip(trace["x"], trace["y"])) == want
    assert "PARTIAL" in json.dumps(spec["layout"]["title"])
    # a complete map has no lost marks
    import fl_design as fl

    full = fl.StabilityMap(m.eps, m.gamma, m.status, {}, 1e-3, 1.0, 0.1)
    assert not [h for h in plot_stability_map(full).axes[0].get_lines()
                if h.get_label().startswith("lost")]


def test_the_run_help_documents_exit_3():
    from fl_design.app import build_parser
    from fl_design.app._cli import EXIT_PARTIAL

    run = build_parser()._subparsers._group_actions[0].choices["run"]
    assert EXIT_PARTIAL == 3 and "3 the report is written but PARTIAL" in run.format_help()


def test_the_robust_map_figure_crosses_the_cells_with_a_lost_run():
    import matplotlib

    matplotlib.use("Agg")
    from fl_design.plotting import plot_robust_map
    from fl_design.sim._partial import PartialRobustMap

    lost = np.array([[[False, False], [True, False]]])  # cell (eps 0.1, gamma 2): 1 of 2 runs
    m = PartialRobustMap(np.array([0.1]), np.array([1.0, 2.0]), np.array([[[2, 1], [3, 0]]]),
                         {}, {"b": np.array([0.9, 1.1])}, 1e-3, 1.0, lost=lost)
    ax = plot_robust_map(m).axes[0]
    (line,) = [h for h in ax.get_lines() if h.get_label().startswith("lost: worker died (1 ")]
    assert list(zip(line.get_xdata(), line.get_ydata())) == [(2.0, 0.1)]
    assert "PARTIAL: 1 lost" in ax.get_title()
