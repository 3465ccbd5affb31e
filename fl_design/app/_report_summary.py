"""The report's first section: the answers, each linked to the section that shows why.

A newcomer reads, before any derivation: the plant and its operating point, the design, what is
certified (and what the certificate covers), whether this design works in simulation (its
verdict), the comparison's key numbers and whether the generated C passes its software-in-the-
loop test. Each row links to its section (:func:`anchor`).

Examples
--------
>>> from fl_design.app._report_summary import anchor
>>> anchor("Stability map and eps*")
'stability-map-and-eps'
"""

from __future__ import annotations

import re

import numpy as np

from ._report_sections import fmt

#: Section titles, in the report's order (the summary links to them).
SIMULATIONS = "Simulations: this design and the paper's comparison"
MAP = "Stability map and eps*"
CERTIFICATES = "Certificates"
CODE = "C code"
DERIVATION = "Derivation"


def anchor(title: str) -> str:
    """The HTML ``id`` (and Markdown anchor) of a section title: lower case, dashes.

    Parameters
    ----------
    title : str
        Section title.

    Returns
    -------
    str

    Examples
    --------
    >>> from fl_design.app._report_summary import anchor
    >>> anchor("C code")
    'c-code'
    """
    return re.sub(r"[^a-z0-9]+", "-", title.lower()).strip("-")


def _design_text(job) -> str:
    est, ctl = job.design.estimator, job.design.controller
    what = (f"EHGO eps = {est.eps:g} s" if est.has_time_constant else
            f"least squares over {est.window} samples")
    return (f"{what}, gamma = {ctl.gamma:g}, gains {tuple(float(k) for k in ctl.gains)}, "
            f"T = {job.design.T:g} s")


def _certified_text(job) -> str:
    cert = job.results.get("certify")
    if not cert:
        return "not run"
    if "eps" not in cert:
        return cert.get("skipped", "no b-range to certify")
    g, e, b = cert["gamma"], cert["eps"], job.derivation["b_bounds"]
    box = cert.get("box")
    if box:
        b = box["b_bounds"]
        ranges = ", ".join(f"{k} in [{lo:.4g}, {hi:.4g}]" for k, (lo, hi) in box["params"].items())
        family = (f" over the [uncertainty] box {ranges}" +
                  (f" (not {', '.join(box['not_covered'])}: a normal distribution has no box)"
                   if box["not_covered"] else ""))
    else:
        family = ""
    return (f"eps* = {fmt(e.eps_star_certified, 'none in range')} s, gamma in "
            f"({fmt(g.gamma_min, 'none')}, {fmt(g.gamma_max, 'none')}); this eps "
            f"{'certified' if e.certified else 'NOT certified'}. Covers the sampled linear "
            f"surrogate (chain of integrators, sigma = b u, b anywhere in [{b[0]:.3g}, "
            f"{b[1]:.3g}]{family}). The nonlinear plant: "
            f"{cert.get('nonlinear_summary', 'no certificate (the plant gives no region)')}")


def _comparison_text(job) -> str:
    sim = job.results.get("simulate")
    if not sim:
        return "not run"
    std = max(sim["stds"])
    parts = []
    for name in sim["designs"]:
        r = sim["runs"][(name, std)]
        over = "" if not np.isfinite(r.overshoot) else f", overshoot {r.overshoot:.3g} %"
        parts.append(f"{name}: {r.status}{over}")
    return f"at noise std {std:.3g}: " + "; ".join(parts)


def _disturbance_text(job):
    """The main run against ``[scenario.disturbance]``: what acted, its peak and recovery."""
    dist = job.config.scenario.disturbance
    sim = job.results.get("simulate")
    if dist is None or not sim:
        return None
    parts = []
    for where, spec in dist.to_dict().items():
        if spec:
            args = ", ".join(f"{k} {v:g}" for k, v in spec.items()
                             if k != "kind" and isinstance(v, (int, float)))
            parts.append(f"{where} {spec.get('kind', 'signal')} ({args})" if args else
                         f"{where} {spec.get('kind', 'signal')}")
    what = " and ".join(parts) or "a disturbance"
    main = sim["main"]
    m = main.disturbance
    if m is None:
        return f"{what}: did not act within this run's {main.duration:g} s (run longer)"
    rec = m["recovery_time"]
    back = (f"back within the band {rec:.3g} s later" if np.isfinite(rec) else
            f"not back within the band by the end ({main.duration:g} s)")
    return (f"{what}: from t = {m['disturbance_at']:g} s, peak |y - r| "
            f"{m['disturbance_peak']:.3g}, {back}")


def _code_text(job) -> str:
    cg = job.results.get("codegen")
    if not cg:
        return "not run"
    if "skipped" in cg:
        return cg["skipped"]
    sil = cg["sil"]
    cost = cg["costs"].rows[0]
    ns = f", {cost.ns_per_step:.3g} ns per step" if np.isfinite(cost.ns_per_step) else ""
    return (f"SIL {'PASSED' if sil.passed else 'FAILED'} (max relative error "
            f"{sil.max_rel_error:.2g}, bound {sil.bound:g}); {cost.name}: {cost.flops} "
            f"operations{ns}, {cost.stack_bytes} B stack")


def summary_blocks(job, figures) -> list:
    """The summary section's blocks: a table of answers linked to their sections, then the
    design's response figure.

    Parameters
    ----------
    job : Job
        A finished (or partial) job.
    figures : sequence of str
        Figures written.

    Returns
    -------
    list

    Examples
    --------
    >>> from fl_design.app import load_config, run_job
    >>> from fl_design.app._report_summary import summary_blocks
    >>> job = run_job(load_config(None), quick=True, stages=("derive",), progress=False)
    >>> [row[0] for row in summary_blocks(job, [])[0][1]][:2]
    ['Plant', 'Design']
    """
    d = job.derivation
    op = ", ".join(f"{s} = {v:.4g}" for s, v in zip(d.get("states", []), d.get("x_op", [])))
    plant = (f"{job.plant.name}: relative degree {d.get('rho')}, operating point x_op = ({op}), "
             f"u_eq = {d.get('u_eq', float('nan')):.4g}")
    sim = job.results.get("simulate")
    verdict = sim["main"].verdict() if sim else "not run"
    smap = job.results.get("sweep")
    empirical = "not run"
    if smap is not None:
        g = float(smap.gamma[np.argmin(np.abs(np.log(smap.gamma
                                                     / job.design.controller.gamma)))])
        empirical = (f"{smap.eps_star(g)} s at gamma = {g:.3g} (the grid's nearest to this "
                     f"design's), from {smap.eps.size} x {smap.gamma.size} noise-free runs of "
                     f"{smap.duration:g} s")
    rows = [("Plant", plant, DERIVATION), ("Design", _design_text(job), SIMULATIONS),
            ("Does it work? (this design's run)", verdict, SIMULATIONS),
            *([("Disturbance", dtext, SIMULATIONS)]
              if (dtext := _disturbance_text(job)) is not None else []),
            ("Certified", _certified_text(job), CERTIFICATES),
            ("Empirical eps*", empirical, MAP),
            ("Comparison", _comparison_text(job), SIMULATIONS),
            ("Generated C", _code_text(job), CODE)]
    blocks = [("links", rows)]
    if "response.png" in figures:
        blocks.append(("fig", "response.png", (
            f"This design's run, {sim['main'].duration:g} s ({sim['main'].status}): output and "
            "reference, input (the operating point's u_eq dotted), sigma and its estimate")))
    return blocks


__all__ = ["CERTIFICATES", "CODE", "DERIVATION", "MAP", "SIMULATIONS", "anchor",
           "summary_blocks"]
