"""The job's robust stability map: the ``[sweep]`` grid run against the ``[uncertainty]`` family.

With ``[uncertainty] params`` (and ``map_samples`` > 0) the robustness stage also runs
``fl.sweep(..., params=..., samples=map_samples, seed=seed)`` on the grid of the nominal
stability map (the same eps and gamma points, run length, scenario and classifier; quick mode:
:data:`QUICK_MAP_SAMPLES` plants), so the robust eps* stands beside the nominal eps* at the
same gamma. ``fl-design sweep`` prints it; the report's *Robustness* section shows it.

Examples
--------
>>> from fl_design.app._robust_map import LEVELS, QUICK_MAP_SAMPLES
>>> LEVELS, QUICK_MAP_SAMPLES
((1.0, 0.9), 8)
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

#: Plants per grid point in quick mode.
QUICK_MAP_SAMPLES = 8
#: Fractions of converging plants the robust eps* is given for (every plant; 90 %).
LEVELS = (1.0, 0.9)


def map_grid(config, quick: bool) -> tuple:
    """``(eps, gamma, duration)`` of the nominal stability map (``[sweep]``, as its stage).

    Parameters
    ----------
    config : Config
        The job's configuration.
    quick : bool
        The quick grid and run length.

    Returns
    -------
    tuple

    Examples
    --------
    >>> from fl_design.app import load_config
    >>> from fl_design.app._robust_map import map_grid
    >>> eps, gamma, duration = map_grid(load_config(None), True)
    >>> eps.size, gamma.size, duration
    (5, 5, 3.0)
    """
    from ._job import QUICK

    cfg = config.sweep
    n = QUICK["sweep_points"] if quick else cfg.points
    duration = QUICK["sweep_duration"] if quick else cfg.duration
    return np.geomspace(*cfg.eps, n), np.geomspace(*cfg.gamma, n), duration


def run_robust_map(job, quick: bool, executor, progress: bool, *,
                   samples: int | None = None) -> None:
    """``fl.sweep(..., params=...)`` of the job's design on the ``[sweep]`` grid.

    Stores the :class:`~fl_design.sim.RobustMap` in ``job.results["robust_map"]`` and its
    seconds in ``job.timings["robust_map"]``; nothing without ``[uncertainty] params`` or
    (``samples`` not given) with ``map_samples = 0``; for a design without eps (least
    squares) the reason in ``job.results["robust_map_skipped"]``.

    Parameters
    ----------
    job : Job
        A prepared job.
    quick : bool
        The quick grid and at most :data:`QUICK_MAP_SAMPLES` plants.
    executor : concurrent.futures.Executor or None
        Runs chunks of the grid.
    progress : bool
        Progress bar.
    samples : int, optional
        Plants per point instead of ``map_samples`` (or the quick mode's; ``--samples``).

    Examples
    --------
    >>> from fl_design.app import parse_config
    >>> from fl_design.app._job import prepare
    >>> from fl_design.app._robust_map import run_robust_map
    >>> job = prepare(parse_config('[plant]\\nlibrary = "pendulum"\\n'
    ...                            '[uncertainty.params]\\nc = [0.1, 1.0]'))
    >>> run_robust_map(job, True, None, False)
    >>> job.results["robust_map"].status.shape
    (5, 5, 8)
    """
    from ..sim import sweep
    from ._build import build_classifier, build_scenario

    table = job.config.uncertainty
    if samples is None:
        samples = min(QUICK_MAP_SAMPLES, table.map_samples) if quick else table.map_samples
    if not table.params or not samples:
        return
    if not job.design.estimator.has_time_constant:  # the map runs over eps
        job.results["robust_map_skipped"] = (
            f"no robust map: it runs over the observer's eps, and this design's estimator "
            f"({type(job.design.estimator).__name__}) has none")
        return
    eps, gamma, duration = map_grid(job.config, quick)
    start = time.perf_counter()
    job.results["robust_map"] = sweep(
        job.plant, job.design, build_scenario(job.config, duration=duration, noise_std=0.0),
        eps=eps, gamma=gamma, classifier=build_classifier(job.config), executor=executor,
        progress=progress, params=table.distributions(),
        samples=samples, seed=table.seed)
    job.timings["robust_map"] = time.perf_counter() - start


def _nearest(grid, gamma: float) -> float:
    return float(grid[np.argmin(np.abs(np.log(np.asarray(grid) / gamma)))])


def at_design_gamma(job) -> dict:
    """Robust eps* (each of :data:`LEVELS`) and the nominal eps* at the grid's gamma nearest
    to the design's.

    Parameters
    ----------
    job : Job
        After :func:`run_robust_map` (the nominal map only if the sweep stage ran).

    Returns
    -------
    dict
        ``{"gamma": g, "design_gamma": ..., "robust": {level: EpsStar}, "nominal": EpsStar or
        None}``.

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.sim._robust_map import RobustMap
    >>> from fl_design.app._robust_map import at_design_gamma
    >>> class Job:
    ...     class design:
    ...         class controller:
    ...             gamma = 1.1
    ...     results = {"robust_map": RobustMap(
    ...         np.array([0.1, 0.2]), np.array([1.0, 2.0]),
    ...         np.array([[[2, 2], [2, 2]], [[2, -1], [-1, -1]]]), {}, {"b": np.ones(2)},
    ...         1e-3, 1.0)}
    >>> d = at_design_gamma(Job())
    >>> d["gamma"], str(d["robust"][1.0]), str(d["robust"][0.9]), d["nominal"]
    (1.0, '0.1 (fails at 0.2)', '0.1 (fails at 0.2)', None)
    """
    rmap, smap = job.results["robust_map"], job.results.get("sweep")
    g = _nearest(rmap.gamma, job.design.controller.gamma)
    robust = {lv: rmap.eps_star(g, level=lv) for lv in LEVELS}
    nominal = smap.eps_star(_nearest(smap.gamma, g)) if smap is not None else None
    return {"gamma": g, "design_gamma": float(job.design.controller.gamma),
            "robust": robust, "nominal": nominal}


def covers(rmap) -> str:
    """What the robust map covers, one phrase: ``"k plants drawn from ..., seed s"``.

    Parameters
    ----------
    rmap : RobustMap
        A robust sweep's result.

    Returns
    -------
    str

    Examples
    --------
    >>> import numpy as np
    >>> import fl_design as fl
    >>> from fl_design.sim._robust_map import RobustMap
    >>> from fl_design.app._robust_map import covers
    >>> covers(RobustMap(np.array([0.1]), np.array([1.0]), np.array([[[2, 2]]]), {},
    ...                  {"b": np.ones(2)}, 1e-3, 1.0, {"b": fl.Uniform(0.5, 2.0)}, 3))
    '2 plants drawn from b ~ Uniform(0.5, 2), seed 3'
    """
    dists = ", ".join(f"{k} ~ {v}" for k, v in rmap.distributions.items())
    return f"{rmap.n} plants drawn from {dists}, seed {rmap.seed}"


def summary(job) -> dict:
    """The robust map's numbers for ``summary.json`` (empty without a robust map).

    Grid, plants, fraction converging per point, robust eps* per gamma at each of
    :data:`LEVELS`, the comparison at the design's gamma, and the seconds it took (the
    per-plant verdicts stay out: ``RobustMap.to_dict()`` has them).

    Parameters
    ----------
    job : Job
        A finished job.

    Returns
    -------
    dict

    Examples
    --------
    >>> from fl_design.app._robust_map import summary
    >>> class Job:
    ...     results = {}
    >>> summary(Job())
    {}
    """
    rmap = job.results.get("robust_map")
    if rmap is None:
        skipped = job.results.get("robust_map_skipped")
        return {"skipped": skipped} if skipped else {}
    out = {k: v for k, v in rmap.to_dict().items() if k not in ("status", "metrics")}
    out["eps_star"] = [{"gamma": float(g), **{f"level_{lv:g}": rmap.eps_star(g, level=lv)
                                              .to_dict() for lv in LEVELS}}
                       for g in rmap.gamma]
    here = at_design_gamma(job)
    out["at_design_gamma"] = {
        "gamma": here["gamma"], "design_gamma": here["design_gamma"],
        **{f"robust_level_{lv:g}": e.to_dict() for lv, e in here["robust"].items()},
        "nominal": here["nominal"].to_dict() if here["nominal"] is not None else None}
    out["covers"] = covers(rmap)
    out["seconds"] = job.timings.get("robust_map")
    return out


def figure(job):
    """The report's ``robust_map.png``: :meth:`RobustMap.plot` with this design's point.

    Parameters
    ----------
    job : Job
        After :func:`run_robust_map`.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> from fl_design.app import parse_config
    >>> from fl_design.app._job import prepare
    >>> from fl_design.app._robust_map import figure, run_robust_map
    >>> job = prepare(parse_config('[plant]\\nlibrary = "pendulum"\\n'
    ...                            '[uncertainty.params]\\nc = [0.1, 1.0]'))
    >>> run_robust_map(job, True, None, False)
    >>> figure(job).axes[0].get_ylabel()
    'observer time constant eps (s)'
    """
    fig = job.results["robust_map"].plot(level=LEVELS[0])
    ax = fig.axes[0]
    ax.plot([abs(job.design.controller.gamma)], [job.design.estimator.eps], marker="*",
            color="black", markersize=14, linestyle="none", label="this design")
    rmap = job.results["robust_map"]
    ax.set_title(f"Robust stability map: {rmap.n} plants, seed {rmap.seed}")
    fig.set_size_inches(10.0, 5.0)  # the legend right of the colour bar and its label
    ax.legend(loc="upper left", bbox_to_anchor=(0.77, ax.get_position().y1),
              bbox_transform=fig.transFigure, borderaxespad=0.0, fontsize="small")
    return fig


def save_figure(job, folder) -> list:
    """Write ``robust_map.png`` (:func:`figure`) into the report's folder if the job has a
    robust map; return the names written.

    Parameters
    ----------
    job : Job
        A finished job.
    folder : pathlib.Path
        The report's folder.

    Returns
    -------
    list of str
        ``["robust_map.png"]`` or empty.

    Examples
    --------
    >>> from fl_design.app._robust_map import save_figure
    >>> class Job:
    ...     results = {}
    >>> save_figure(Job(), ".")
    []
    """
    import matplotlib.pyplot as plt

    if "robust_map" not in job.results:
        return []
    fig = figure(job)
    fig.savefig(Path(folder) / "robust_map.png", dpi=100)
    plt.close(fig)
    return ["robust_map.png"]


def blocks(job, figures) -> list:
    """The robust map's part of the report's *Robustness* section (empty without one).

    Parameters
    ----------
    job : Job
        A finished job.
    figures : sequence of str
        The figure files written (``robust_map.png`` is shown only if among them).

    Returns
    -------
    list

    Examples
    --------
    >>> from fl_design.app._robust_map import blocks
    >>> class Job:
    ...     results = {}
    >>> blocks(Job(), [])
    []
    """
    rmap = job.results.get("robust_map")
    if rmap is None:
        skipped = job.results.get("robust_map_skipped")
        return [("p", skipped[0].upper() + skipped[1:] + ".")] if skipped else []
    here = at_design_gamma(job)
    seconds = job.timings.get("robust_map")
    took = f", computed in {seconds:.3g} s" if seconds is not None else ""
    out = [("p", (f"Robust stability map: the stability map's {rmap.eps.size} x "
                  f"{rmap.gamma.size} (eps, gamma) grid, noise-free runs of {rmap.duration:g} s, "
                  f"every point run against the same {covers(rmap)} "
                  f"({rmap.eps.size * rmap.gamma.size * rmap.n} runs{took}); each point is "
                  f"coloured by the fraction of those plants that "
                  f"converge (converging or converged)."))]
    if "robust_map.png" in figures:
        out.append(("fig", "robust_map.png", (
            f"Fraction of the {rmap.n} plants converging at each (gamma, eps); the triangles "
            "mark the robust eps* per gamma (every sampled plant converges up to it), the star "
            "this design")))
    g = here["gamma"]
    rows = [[f"every sampled plant converges ({rmap.n} of {rmap.n})", str(here["robust"][1.0])],
            ["at least 90 % of the plants converge", str(here["robust"][0.9])],
            ["the nominal plant (the stability map above)",
             str(here["nominal"]) if here["nominal"] is not None else "not run"]]
    head = (f"eps* (s) at gamma = {g:.3g} (the grid's nearest to this design's "
            f"{here['design_gamma']:.3g})")
    out.append(("table", ["", head], rows))
    return out


def print_robust_map(job) -> None:
    """Print the robust map: per gamma, the robust eps* (every plant; 90 %), the nominal eps*
    and the fraction of the plants converging at the grid eps nearest to the design's.

    Parameters
    ----------
    job : Job
        After :func:`run_robust_map` (and the sweep stage for the nominal column).

    Examples
    --------
    >>> from fl_design.app import parse_config
    >>> from fl_design.app._job import prepare
    >>> from fl_design.app._robust_map import print_robust_map, run_robust_map
    >>> job = prepare(parse_config('[plant]\\nlibrary = "pendulum"\\n'
    ...                            '[uncertainty.params]\\nc = [0.1, 1.0]'))
    >>> run_robust_map(job, True, None, False)
    >>> print_robust_map(job)  # doctest: +ELLIPSIS
    Robust stability map 5 x 5 (eps x gamma), 3 s runs, 8 plants drawn from c ~ ...
    """
    rmap, smap = job.results["robust_map"], job.results.get("sweep")
    seconds = job.timings.get("robust_map")
    print(f"Robust stability map {rmap.eps.size} x {rmap.gamma.size} (eps x gamma), "
          f"{rmap.duration:g} s runs, {covers(rmap)}"
          + (f": {seconds:.3g} s" if seconds is not None else ""))
    e = float(rmap.eps[np.argmin(np.abs(np.log(rmap.eps / job.design.estimator.eps)))])
    at_e = rmap.fraction[list(rmap.eps).index(e)]
    cols = [[str(rmap.eps_star(g, level=lv)) for lv in LEVELS] for g in rmap.gamma]
    nominal = [str(smap.eps_star(_nearest(smap.gamma, g))) if smap is not None else "-"
               for g in rmap.gamma]
    heads = [f"eps* (s), {100 * lv:g} % converge" for lv in LEVELS]
    widths = [max([len(h), *(len(c[i]) for c in cols)]) for i, h in enumerate(heads)]
    nom_w = max([16, *map(len, nominal)])
    print(f"  {'gamma':<10} " + " ".join(f"{h:<{w}}" for h, w in zip(heads, widths))
          + f" {'nominal eps* (s)':<{nom_w}} converging at eps = {e:.3g}")
    for g, row, nom, f in zip(rmap.gamma, cols, nominal, at_e):
        print(f"  {g:<10.3g} " + " ".join(f"{c:<{w}}" for c, w in zip(row, widths))
              + f" {nom:<{nom_w}} {100 * f:.0f} %")


__all__ = ["LEVELS", "QUICK_MAP_SAMPLES", "at_design_gamma", "blocks", "covers", "figure",
           "map_grid", "print_robust_map", "run_robust_map", "save_figure", "summary"]
