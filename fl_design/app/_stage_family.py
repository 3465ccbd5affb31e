"""The family stages: ``fl.monte_carlo`` over ``[uncertainty]`` and the robust stability map.

With ``[uncertainty] params`` the robustness stage runs the design against plants drawn from
the family, then (``map_samples`` > 0) ``fl.sweep(..., params=..., samples=map_samples,
seed=seed)`` on the grid of the nominal stability map (the same eps and gamma points, run
length, scenario and classifier; quick mode: :data:`QUICK_MAP_SAMPLES` plants), so the robust
eps* stands beside the nominal eps* at the same gamma. The report's words and figure are in
:mod:`fl_design.app._report_family`.

Examples
--------
One setup, both stages (quick: 16 plants in the Monte Carlo, :data:`QUICK_MAP_SAMPLES` per map
point), and the map skipped for a design without eps:

>>> from dataclasses import replace
>>> from fl_design.app import parse_config
>>> from fl_design.app._build import build_setup
>>> from fl_design.app._stage_family import robust_map, robustness
>>> s = build_setup(parse_config('[plant]\\nlibrary = "pendulum"\\n'
...                              '[uncertainty.params]\\nc = [0.1, 1.0]'))
>>> out = robustness(s, True)
>>> out["robustness"].n, out["robust_map"].status.shape
(16, (5, 5, 8))
>>> robust_map(s, True, samples=2)["robust_map"].status.shape
(5, 5, 2)
>>> robust_map(replace(s, design=fl.presets.least_squares_design(9)), True)
{'robust_map_skipped': "no robust map: it runs over the observer's eps, ... has none"}
"""

from __future__ import annotations

import time

import numpy as np

from ._build import Setup
from ._stages import QUICK
from ._uncertainty import QUICK_SAMPLES

#: Plants per grid point in quick mode.
QUICK_MAP_SAMPLES = 8


def map_grid(config, quick: bool) -> tuple:
    """``(eps, gamma, duration)`` of the nominal stability map (``[sweep]``, as its stage).

    Parameters
    ----------
    config : Config
        The job's configuration.
    quick : bool
        The quick grid and run length.

    Examples
    --------
    >>> from fl_design.app import load_config
    >>> from fl_design.app._stage_family import map_grid
    >>> eps, gamma, duration = map_grid(load_config(None), True)
    >>> eps.size, gamma.size, duration
    (5, 5, 3.0)
    """
    cfg = config.sweep
    n = QUICK["sweep_points"] if quick else cfg.points
    duration = QUICK["sweep_duration"] if quick else cfg.duration
    return np.geomspace(*cfg.eps, n), np.geomspace(*cfg.gamma, n), duration


def robust_map(setup: Setup, quick: bool, executor=None, progress: bool = False, *,
               samples: int | None = None) -> dict:
    """``fl.sweep(..., params=...)`` of the design on the ``[sweep]`` grid.

    Parameters
    ----------
    setup : Setup
        The config's objects.
    quick : bool
        The quick grid and at most :data:`QUICK_MAP_SAMPLES` plants.
    executor : concurrent.futures.Executor, optional
        Runs chunks of the grid.
    progress : bool, optional
        Progress bar.
    samples : int, optional
        Plants per point instead of ``map_samples`` (``--samples``).

    Returns
    -------
    dict
        ``robust_map`` (:class:`~fl_design.sim.RobustMap`) and ``robust_map_seconds``; or
        ``robust_map_skipped`` (a design without eps); empty without params or samples.
    """
    from ..sim import sweep

    table = setup.config.uncertainty
    if samples is None:
        samples = min(QUICK_MAP_SAMPLES, table.map_samples) if quick else table.map_samples
    if not table.params or not samples:
        return {}
    if not setup.design.estimator.has_time_constant:  # the map runs over eps
        return {"robust_map_skipped": (
            f"no robust map: it runs over the observer's eps, and this design's estimator "
            f"({type(setup.design.estimator).__name__}) has none")}
    eps, gamma, duration = map_grid(setup.config, quick)
    start = time.perf_counter()
    rmap = kept_partial(lambda: sweep(
        setup.plant, setup.design, setup.run_scenario(duration=duration, noise_std=0.0),
        eps=eps, gamma=gamma, classifier=setup.classifier, executor=executor,
        progress=progress, params=table.distributions(), samples=samples, seed=table.seed))
    return {"robust_map": rmap, "robust_map_seconds": time.perf_counter() - start}


def kept_partial(call):
    """``call()``; when a worker of its executor dies, the error's partial result instead
    (finished runs exact, lost ones ``undecided``, ``n_lost`` > 0: the job goes on and the
    report says so, as the sweep stage does). A lost worker with no partial is re-raised.

    Examples
    --------
    >>> from fl_design.app._stage_family import kept_partial
    >>> from fl_design.errors import WorkerLostError
    >>> def lost():
    ...     raise WorkerLostError("x", partial="the finished runs")
    >>> kept_partial(lost), kept_partial(lambda: 1)
    ('the finished runs', 1)
    """
    from ..errors import WorkerLostError

    try:
        return call()
    except WorkerLostError as err:
        if err.partial is None:
            raise
        return err.partial


def robustness(setup: Setup, quick: bool, executor=None, progress: bool = False) -> dict:
    """The robustness stage: ``fl.monte_carlo`` of the design over the family, then
    :func:`robust_map`.

    Returns
    -------
    dict
        ``robustness`` (:class:`~fl_design.Ensemble`) and :func:`robust_map`'s keys.
    """
    from ..sim import monte_carlo

    table = setup.config.uncertainty
    duration = QUICK["duration"] if quick else table.duration
    ens = kept_partial(lambda: monte_carlo(
        setup.plant, setup.design, setup.run_scenario(duration=duration, noise_std=0.0),
        params=table.distributions(), n=QUICK_SAMPLES if quick else table.samples,
        seed=table.seed, classifier=setup.classifier, executor=executor, progress=progress))
    return {"robustness": ens, **robust_map(setup, quick, executor, progress)}


__all__ = ["QUICK_MAP_SAMPLES", "kept_partial", "map_grid", "robust_map", "robustness"]
