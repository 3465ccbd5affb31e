"""The report's words on a family of plants: the Monte Carlo (``[uncertainty]``) and the robust
stability map (tables, ``summary.json``, the console); the stage is
:mod:`fl_design.app._stage_family`, the figure :func:`fl_design.plotting._report.robust_map_figure`.

Examples
--------
One quick robustness job on the pendulum family, printed and summarized:

>>> from fl_design.app import parse_config, run_job
>>> from fl_design.app._report_family import print_robust_map, summary
>>> job = run_job(parse_config('[plant]\\nlibrary = "pendulum"\\n'
...                            '[uncertainty.params]\\nc = [0.1, 1.0]'), quick=True,
...               stages=("robustness",), progress=False)
>>> print_robust_map(job)  # doctest: +ELLIPSIS
Robust stability map 5 x 5 (eps x gamma), 3 s runs, 8 plants drawn from c ~ ...
>>> mc = summary(job)["monte_carlo"]
>>> mc["n"], mc["distributions"], round(sum(mc["fractions"].values()), 9)
(16, {'c': 'Uniform(0.1, 1)'}, 1.0)
"""

from __future__ import annotations

import math

import numpy as np

from .._json import jsonable
from ._text import run_length_note

#: Fractions of converging plants the robust eps* is given for (every plant; 90 %).
LEVELS = (1.0, 0.9)


def _robust_map(job) -> tuple:
    """The job's robust map, or None and why it was skipped (None if it was not asked for)."""
    rmap = job.results.get("robust_map")
    return rmap, (job.results.get("robust_map_skipped") if rmap is None else None)


def _nearest(grid, gamma: float) -> float:
    return float(grid[np.argmin(np.abs(np.log(np.asarray(grid) / gamma)))])


def at_design_gamma(job) -> dict:
    """Robust eps* (each of :data:`LEVELS`) and the nominal eps* at the grid's gamma nearest
    to the design's.

    Parameters
    ----------
    job : Job
        After the robustness stage (the nominal map only if the sweep stage ran).

    Returns
    -------
    dict
        ``{"gamma": g, "design_gamma": ..., "robust": {level: EpsStar}, "nominal": EpsStar or
        None}``.

    Examples
    --------
    >>> from fl_design.app._report_family import at_design_gamma
    >>> class Job:
    ...     class design:
    ...         class controller:
    ...             gamma = 1.1
    ...     results = {"robust_map": fl.RobustMap(
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

    Examples
    --------
    >>> from fl_design.app._report_family import covers
    >>> covers(fl.RobustMap(np.array([0.1]), np.array([1.0]), np.array([[[2, 2]]]), {},
    ...                     {"b": np.ones(2)}, 1e-3, 1.0, {"b": fl.Uniform(0.5, 2.0)}, 3))
    '2 plants drawn from b ~ Uniform(0.5, 2), seed 3'
    """
    dists = ", ".join(f"{k} ~ {v}" for k, v in rmap.distributions.items())
    return f"{rmap.n} plants drawn from {dists}, seed {rmap.seed}"


def map_summary(job) -> dict:
    """The robust map's numbers for ``summary.json`` (empty without a robust map).

    Grid, plants, fraction converging per point, robust eps* per gamma at each of
    :data:`LEVELS`, the comparison at the design's gamma, and the seconds it took (the
    per-plant verdicts stay out: ``RobustMap.to_dict()`` has them).

    Parameters
    ----------
    job : Job
        A finished job (its robust map, the sweep's map for the nominal eps*, the timings).

    Returns
    -------
    dict
        ``{"skipped": why}`` when the stage skipped the map (a design without eps).

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> from fl_design.app._report_family import map_summary
    >>> map_summary(SimpleNamespace(results={"robust_map_skipped": "no robust map: no eps"}))
    {'skipped': 'no robust map: no eps'}
    """
    rmap, skipped = _robust_map(job)
    if rmap is None:
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


def blocks(job, figures) -> list:
    """The robust map's part of the report's *Robustness* section (empty without one).

    Parameters
    ----------
    job : Job
        A finished job.
    figures : sequence of str
        The figure files written (``robust_map.png`` is shown only if among them).

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> from fl_design.app._report_family import blocks
    >>> blocks(SimpleNamespace(results={"robust_map_skipped": "no robust map: no eps"}), [])
    [('p', 'No robust map: no eps.')]
    """
    rmap, skipped = _robust_map(job)
    if rmap is None:
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
        After the robustness stage (and the sweep stage for the nominal column).
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


def report_blocks(job, figures=()) -> list:
    """The report's *Robustness* section (blocks as :mod:`fl_design.app._report_sections`).

    Parameters
    ----------
    job : Job
        A finished job.
    figures : sequence of str, optional
        The figure files written (the robust map's is shown only if among them).

    Examples
    --------
    >>> from fl_design.app._report_family import report_blocks
    >>> class Job:
    ...     results = {}
    >>> report_blocks(Job())
    [('p', 'Not run (no [uncertainty] params).')]
    """
    ens = job.results.get("robustness")
    if ens is None:
        return [("p", "Not run (no [uncertainty] params).")]
    dists = ", ".join(f"{k} ~ {v}" for k, v in ens.distributions.items())
    verdicts = ", ".join(f"{100 * v:.1f} % {k}" for k, v in ens.fractions.items() if v > 0)
    out = [("p", (f"The design against {ens.n} plants drawn from {dists} (seed {ens.seed}; "
                    f"each the plant with those parameter values, its own equilibrium input), "
                    f"noise-free runs of {ens.duration:g} s classified as the simulations: "
                    f"{verdicts} ({100 * ens.convergent_fraction:.1f} % converge: converging "
                    f"or converged)."))]
    note = run_length_note(ens, "on the nominal plant")
    if note:
        out.append(("p", note))
    names = list(ens.params)
    rows = [[str(w["index"]), *(f"{w[k]:.4g}" for k in names), w["status"],
             f"{w['tail_error']:.3g}" if math.isfinite(w["tail_error"]) else "-",
             f"{w['divergence_time']:.3g}" if math.isfinite(w["divergence_time"]) else "-"]
            for w in ens.worst(5)]
    out.append(("table", ["sample", *names, "verdict", "tail error", "diverged at (s)"],
                   rows))
    return out + blocks(job, figures)


def summary(job) -> dict:
    """``summary.json``'s ``robustness``: the Monte Carlo's fractions and the robust map.

    Parameters
    ----------
    job : Job
        A job, with or without its robustness stage.

    Returns
    -------
    dict
        ``{"monte_carlo": ..., "robust_map": ...}`` (:func:`map_summary`, None without a
        map); empty when the robustness stage did not run.
    """
    ens = job.results.get("robustness")
    if ens is None:
        return {}
    mc = {"n": ens.n, "seed": ens.seed, "duration": ens.duration,
          "duration_reason": ens.duration_reason,
          "distributions": {k: str(v) for k, v in ens.distributions.items()},
          "fractions": dict(ens.fractions), "convergent_fraction": ens.convergent_fraction}
    return jsonable({"monte_carlo": mc, "robust_map": map_summary(job) or None})


__all__ = ["LEVELS", "at_design_gamma", "blocks", "covers", "map_summary", "print_robust_map",
           "report_blocks", "summary"]
