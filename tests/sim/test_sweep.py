"""sweep / StabilityMap / estimate_eps_star: classification, eps*, executors, speed path."""

from __future__ import annotations

import json
import math
import subprocess
import sys
import tracemalloc
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest
import sympy as sp

import fl_design as fl
from fl_design.errors import DesignMismatchError, DimensionError, ParameterError
from fl_design.sim import StabilityMap

T = 1e-3
ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("kernels")


@pytest.fixture(scope="module")
def small_map(pendulum_design, pendulum, cache):
    """A 4 x 3 map with noise: converged, converging and diverged points."""
    return fl.sweep(pendulum, pendulum_design(), fl.Scenario(0.05, 8.0, noise=fl.Noise(std=1e-4)), eps=[0.01, 0.03, 0.1, 0.3], gamma=[3e-3, 1e-2, 3e-2], progress=False, classifier=fl.Classifier(tolerance=0.1), kernel=fl.Kernel(cache_dir=cache))


def test_each_point_equals_its_own_simulation(pendulum_design, pendulum, small_map):
    """Running sums in the compiled kernel == NumPy metrics of the full trajectory."""
    for i, eps in enumerate(small_map.eps):
        for j, gamma in enumerate(small_map.gamma):
            d = pendulum_design().replace(eps=float(eps), gamma=float(gamma))
            resp = fl.simulate(pendulum, d, fl.Scenario(0.05, 8.0, noise=fl.Noise(std=1e-4)), classifier=fl.Classifier(tolerance=0.1))
            assert small_map.status[i, j] == fl.sim.Status.from_label(resp.status)
            for name, value in resp.metrics.items():
                if name == "status":
                    continue
                np.testing.assert_allclose(small_map.metrics[name][i, j], value, rtol=1e-9,
                                           atol=1e-12, err_msg=f"{name} at ({eps}, {gamma})")
    assert {-1, 2} <= set(np.unique(small_map.status)) and len(np.unique(small_map.status)) >= 3


def test_grid_layout_and_to_dict(small_map):
    assert small_map.status.shape == (4, 3)
    assert small_map.metrics["estimation_rms"].shape == (4, 3, 3)
    assert all(v.shape[:2] == (4, 3) for v in small_map.metrics.values())
    d = json.loads(json.dumps(small_map.to_dict()))
    assert d["status"][0][0] in ("converged", "converging", "oscillating", "stalled", "undecided", "diverged")
    assert np.array_equal(small_map.labels == "converged", small_map.status == 2)
    assert np.array_equal(small_map.labels == "diverged", small_map.status == -1)
    fig = small_map.plot(curves={"1/gamma law": lambda g: 3e-4 / g,
                                 "points": ([3e-3, 3e-2], [0.05, 0.02])})
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert "1/gamma law" in labels and "points" in labels and "eps* (this map)" in labels


def test_eps_star_and_gamma_bounds_definitions():
    status = np.array([[2, 1, 2, 0, 2],     # converging (1) counts as convergent
                       [2, 0, 2, 2, 2],
                       [1, 2, -1, 2, 2],
                       [-1, 2, 2, 2, 1]])
    m = StabilityMap(eps=np.array([0.01, 0.02, 0.04, 0.08]),
                     gamma=np.array([1e-3, 1e-2, 1e-1, 1.0, 3.0]), status=status, metrics={},
                     T=T, duration=1.0, tol=1e-3)
    stars = [m.eps_star(g) for g in m.gamma]
    assert [(b.lower, b.upper) for b in stars[:3]] == [(0.04, 0.08), (0.01, 0.02), (0.02, 0.04)]
    assert math.isnan(stars[3].lower) and stars[3].upper == 0.01 and str(stars[3]) == "< 0.01"
    assert stars[4].above_range and str(stars[4]) == "> 0.08" and stars[4].value is None
    assert m.gamma_bounds(0.01) == (1e-3, 1e-1)
    assert m.gamma_bounds(0.02) == (0.1, 3.0)            # the longest run
    assert m.gamma_bounds(0.02, around=1e-3) == (1e-3, 1e-3)
    assert m.gamma_bounds(0.04, around=1e-1) == (math.nan, math.nan) or all(
        math.isnan(v) for v in m.gamma_bounds(0.04, around=1e-1))
    with pytest.raises(ParameterError, match="gamma=0.5 is not on the sweep's grid"):
        m.eps_star(0.5)
    with pytest.raises(ParameterError, match="eps=0.03 is not on the sweep's grid"):
        m.gamma_bounds(0.03)


def test_empirical_eps_star_agrees_with_linearized(pendulum_design, pendulum, cache):
    """Pendulum, K = (2, 4), gamma = 0.01, ki = 0, small step: within 10 % (issue criterion)."""
    design = pendulum_design()
    lin = fl.linearized_eps_star(pendulum, design, eps_range=(0.005, 1.0)).value
    est = fl.estimate_eps_star(pendulum, design, fl.Scenario(0.05, 20.0), eps_range=(0.005, 1.0), rtol=0.01, kernel=fl.Kernel(cache_dir=cache))
    assert est.converged and est.bracket[1] / est.bracket[0] - 1 <= 0.01
    assert abs(est.eps_star / lin - 1.0) <= 0.10
    assert est.history[0][1] in ("converged", "converging") and est.history[1][1] == "diverged"
    # the map's eps* on a grid around it brackets the same value
    grid = lin * np.array([0.7, 0.8, 0.9, 0.95, 1.05, 1.1, 1.2])
    smap = fl.sweep(pendulum, design, fl.Scenario(0.05, 20.0), eps=grid, gamma=[1e-2], progress=False, kernel=fl.Kernel(cache_dir=cache))
    assert smap.eps_star(1e-2).lower in (lin * 0.9, lin * 0.95)
    json.dumps(est.to_dict())


def test_estimate_eps_star_range_ends(pendulum_design, pendulum, cache):
    design = pendulum_design()
    low = fl.estimate_eps_star(pendulum, design, fl.Scenario(0.05, 5.0), eps_range=(0.2, 1.0), kernel=fl.Kernel(cache_dir=cache))
    assert math.isnan(low.eps_star) and not low.converged and low.n_simulations == 1
    high = fl.estimate_eps_star(pendulum, design.replace(gamma=1e-3), fl.Scenario(0.0, 1.0), eps_range=(0.01, 0.02), kernel=fl.Kernel(cache_dir=cache))
    assert high.eps_star == 0.02 and high.bracket == (0.02, math.inf) and not high.converged


def test_diverging_runs_stop_early_and_are_classified(cache):
    """Finite escape on a grid: classified, never raised; the compiled driver skips the rest."""
    x, u = sp.symbols("x u")
    plant = fl.Plant.from_ode([x], u, [x**2 + u], x, name="escape")
    design = fl.Design(estimator=fl.EHGO(rho=1, eps=0.05, T=1e-2),
                       controller=fl.DynamicController((1,), 1e-3))
    for compiled in (True, False):
        smap = fl.sweep(plant, design, fl.Scenario(0.0, 50.0, x0=[2.0]), eps=[0.05, 0.1], gamma=[1e-3, 1e-2], progress=False, classifier=fl.Classifier(divergence_bound=1e300), kernel=fl.Kernel(compiled=compiled, cache_dir=cache))
        assert np.all(smap.labels == "diverged")
        assert np.all((smap.metrics["divergence_time"] > 0.45)
                      & (smap.metrics["divergence_time"] < 0.7))
        assert np.all(np.isnan(smap.metrics["iae"]))


def test_chunking_and_threads_do_not_change_results(pendulum_design, pendulum, small_map, cache):
    kw = {"eps": small_map.eps, "gamma": small_map.gamma, "progress": False,
          "classifier": fl.Classifier(tolerance=0.1)}
    sc = fl.Scenario(0.05, 8.0, noise=fl.Noise(std=1e-4))
    other = fl.sweep(pendulum, pendulum_design(), sc,
                     kernel=fl.Kernel(cache_dir=cache, chunk_size=5, threads=1), **kw)
    assert_same(small_map, other)
    with ThreadPoolExecutor(2) as pool:
        assert_same(small_map, fl.sweep(pendulum, pendulum_design(), sc, executor=pool,
                                        kernel=fl.Kernel(cache_dir=cache, chunk_size=4), **kw))


def assert_same(a: StabilityMap, b: StabilityMap) -> None:
    np.testing.assert_array_equal(a.status, b.status)
    assert a.metrics.keys() == b.metrics.keys()
    for name in a.metrics:
        np.testing.assert_array_equal(a.metrics[name], b.metrics[name])


def test_dask_cluster_gives_identical_results(pendulum_design, pendulum, small_map, cache):
    distributed = pytest.importorskip("dask.distributed")
    kw = {"eps": small_map.eps, "gamma": small_map.gamma, "progress": False,
          "classifier": fl.Classifier(tolerance=0.1),
          "kernel": fl.Kernel(cache_dir=cache, chunk_size=3)}
    sc = fl.Scenario(0.05, 8.0, noise=fl.Noise(std=1e-4))
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        remote = fl.sweep(pendulum, pendulum_design(), sc, executor=client.get_executor(), **kw)
    assert_same(small_map, remote)


def test_interpreted_kernel_equals_compiled(pendulum_design, pendulum, small_map, tmp_path,
                                            monkeypatch):
    """The interpreter equals the compiled kernel with glibc's scalar math to 1e-12; the
    default kernel (libmvec's vector sin) classifies every run the same (its metrics are
    compared in tests/sim/test_kernel_lanes.py)."""
    kw = {"eps": small_map.eps[:2], "gamma": small_map.gamma, "progress": False,
          "classifier": fl.Classifier(tolerance=0.1)}
    sc = fl.Scenario(0.05, 8.0, noise=fl.Noise(1e-4))
    interp = fl.sweep(pendulum, pendulum_design(), sc, kernel=fl.Kernel(compiled=False), **kw)
    monkeypatch.setenv("FL_DESIGN_VECTOR_MATH", "0")
    exact = fl.sweep(pendulum, pendulum_design(), sc, kernel=fl.Kernel(cache_dir=tmp_path),
                     **kw)
    np.testing.assert_array_equal(interp.status, small_map.status[:2])
    np.testing.assert_array_equal(interp.status, exact.status)
    for name, value in interp.metrics.items():
        np.testing.assert_allclose(value, exact.metrics[name], rtol=1e-12, atol=0)


def test_memory_does_not_grow_with_run_length(pendulum_design, pendulum, cache):
    kw = {"eps": [0.01, 0.02], "gamma": [1e-2, 3e-2], "progress": False,
          "kernel": fl.Kernel(cache_dir=cache)}
    fl.sweep(pendulum, pendulum_design(), fl.Scenario(0.05, 1.0), **kw)  # warm-up (compile)
    peaks = []
    for duration in (2.0, 20.0):
        tracemalloc.start()
        smap = fl.sweep(pendulum, pendulum_design(), fl.Scenario(0.05, duration), **kw)
        peaks.append(tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
    # only the shared N-sample reference/noise inputs grow: 18000 more samples, < 60 bytes each
    assert peaks[1] - peaks[0] < 60 * 18000
    assert all(np.shape(v)[:2] == (2, 2) for v in smap.metrics.values())


def test_progress_bar_and_fallback_counter(pendulum_design, pendulum, cache, capsys, monkeypatch):
    kw = {"eps": [0.01, 0.02], "gamma": [1e-2], "kernel": fl.Kernel(cache_dir=cache)}
    sc = fl.Scenario(0.05, 0.2)
    fl.sweep(pendulum, pendulum_design(), sc, progress=False, **kw)
    assert capsys.readouterr().err == ""
    fl.sweep(pendulum, pendulum_design(), sc, progress=True, **kw)
    assert "2/2" in capsys.readouterr().err  # tqdm
    monkeypatch.setitem(sys.modules, "tqdm", None)
    monkeypatch.setitem(sys.modules, "tqdm.auto", None)
    fl.sweep(pendulum, pendulum_design(), sc, progress=True, **kw)
    assert "sweep: 2/2 runs" in capsys.readouterr().err


# --- bad input ---------------------------------------------------------------------------------
@pytest.mark.parametrize("kwargs, error, match", [
    ({"eps": [0.01, 0.0]}, ParameterError, "eps values must be finite and > 0, got \\[0.0\\]"),
    ({"eps": [-0.01]}, ParameterError, "eps values must be finite and > 0"),
    ({"gamma": []}, ParameterError, "gamma must contain at least one value"),
    ({"gamma": [1e-2, 1e-2]}, ParameterError, "gamma has repeated values"),
    ({"scenario": lambda: fl.Scenario(np.zeros(3), 0.1)}, DimensionError,
     "N = round\\(duration/T\\) = 100 samples"),
    ({"scenario": lambda: (0.05, 0.1)}, ParameterError, "scenario must be a fl.Scenario"),
    ({"executor": "threads"}, ParameterError, "executor must be a concurrent.futures.Executor"),
    ({"kernel": lambda: fl.Kernel(chunk_size=0)}, ParameterError, "chunk_size must be >= 1"),
    ({"kernel": lambda: {"threads": 2}}, ParameterError, "kernel must be a fl.Kernel"),
])
def test_sweep_bad_input(pendulum_design, pendulum, cache, kwargs, error, match):
    args = {"eps": [0.01], "gamma": [1e-2], "progress": False,
            "scenario": lambda: fl.Scenario(0.05, 0.1), "kernel": lambda: fl.Kernel(cache_dir=cache)}
    args.update(kwargs)
    with pytest.raises(error, match=match):
        args = {k: (v() if k in ("scenario", "kernel") else v) for k, v in args.items()}
        fl.sweep(pendulum, pendulum_design(), **args)


def test_sweep_refuses_mismatched_or_eps_less_designs(pendulum):
    d1 = fl.Design(estimator=fl.EHGO(rho=1, eps=0.05, T=T),
                   controller=fl.DynamicController((1,), 1e-2))
    with pytest.raises(DesignMismatchError, match="relative degree 2"):
        fl.sweep(pendulum, d1, fl.Scenario(0.0, 0.1), eps=[0.01], gamma=[1e-2], progress=False)
    ls = fl.Design(estimator=fl.LeastSquaresEstimator(rho=2, T=T, window=10),
                   controller=fl.DynamicController((2, 4), 1e-2))
    with pytest.raises(ParameterError, match="has no eps"):
        fl.sweep(pendulum, ls, fl.Scenario(0.0, 0.1), eps=[0.01], gamma=[1e-2], progress=False, kernel=fl.Kernel(compiled=False))


@pytest.mark.parametrize("kwargs, match", [
    ({"eps_range": (0.0, 1.0)}, "eps_range must satisfy 0 < lo < hi"),
    ({"eps_range": (0.1, 0.01)}, "lo < hi"),
    ({"rtol": -1.0}, "rtol must be > 0"),
    ({"max_simulations": 1}, "max_simulations must be >= 2"),
    ({"gamma": 0.0}, "gamma must be nonzero"),
])
def test_estimate_eps_star_bad_input(pendulum_design, pendulum, kwargs, match):
    with pytest.raises(ParameterError, match=match):
        fl.estimate_eps_star(pendulum, pendulum_design(), fl.Scenario(0.05, 0.1), **kwargs)


def test_bench_quick_runs():
    proc = subprocess.run([sys.executable, str(ROOT / "verify" / "bench_sweep.py"), "--quick"],
                          capture_output=True, text=True, timeout=300, check=False)
    assert proc.returncode == 0, proc.stderr
    for text in ("ns per step per grid point per core", "numpy", "plain C", "lanes per vector",
                 "RK4 substeps per sample", "verdicts against fl.sweep's (checked)",
                 "against fl.Kernel(vector_math=False)", "solve_ivp",
                 "TRMS map", "from an empty cache", "bytes per extra run",
                 "10,000 RK4 substeps", "where a sweep's time goes", "two threads"):
        assert text in proc.stdout
    # every peer and the kernel give every run the sweep's verdict
    assert "verdicts: NO" not in proc.stdout and "results check: FAIL" not in proc.stdout
    assert "results check: PASS" in proc.stdout


def test_sweep_stays_callable_whatever_is_imported_first():
    """Importing the module fl_design.sim (and the lazy names) keeps fl.sweep the function."""
    code = (
        "import fl_design as fl\n"
        "from fl_design.sim import StabilityMap\n"
        "d = fl.Design(estimator=fl.EHGO(rho=2, eps=0.02, T=1e-3),\n"
        "              controller=fl.DynamicController((2, 4), 1e-2))\n"
        "m = fl.sweep(fl.plants.pendulum(), d, fl.Scenario(0.0, 0.1), eps=[0.02], gamma=[0.01],\n"
        "             progress=False, kernel=fl.Kernel(compiled=False))\n"
        "print(isinstance(m, StabilityMap), isinstance(fl.StabilityMap, type))\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, check=False)
    assert proc.stdout.split() == ["True", "True"], proc.stderr
