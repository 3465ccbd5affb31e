"""The report's first section: the answers, each linked to the section that shows why.

A newcomer reads, before any derivation, one short answer per question (a status word and two
or three numbers, :mod:`fl_design.app._brief`): the plant, the design, whether this design works
in simulation, what is certified, the empirical eps*, the compared estimators and whether the
generated C passes its software-in-the-loop test. Each row links to the section with the long
reason (:func:`anchor`).

Examples
--------
>>> from fl_design.app._report_summary import anchor
>>> anchor("Stability map and eps*")
'stability-map-and-eps'
"""

from __future__ import annotations

import re

import numpy as np

from ._brief import (
    Brief,
    cert_brief,
    code_brief,
    compare_brief,
    design_brief,
    map_brief,
    nonlinear_brief,
    run_brief,
)

#: Section titles, in the report's order (the summary links to them).
SIMULATIONS = "Simulations: this design and the paper's comparison"
MAP = "Stability map and eps*"
CERTIFICATES = "Certificates"
CODE = "C code"
DERIVATION = "Derivation"
ROBUSTNESS = "Robustness: a family of plants"


def anchor(title: str) -> str:
    """The HTML ``id`` (and Markdown anchor) of a section ``title``: lower case, every run of
    other characters one dash.

    Examples
    --------
    >>> from fl_design.app._report_summary import anchor
    >>> anchor("C code")
    'c-code'
    """
    return re.sub(r"[^a-z0-9]+", "-", title.lower()).strip("-")


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
        return Brief("did not act", "warn", f"{what} (after this run's {main.duration:g} s)")
    rec = m["recovery_time"]
    back = (f"back in the band {rec:.3g} s later" if np.isfinite(rec) else
            "not back in the band by the end")
    return Brief("recovered" if np.isfinite(rec) else "not recovered",
                 "good" if np.isfinite(rec) else "warn",
                 f"{what} at {m['disturbance_at']:g} s: peak |y - r| "
                 f"{m['disturbance_peak']:.3g}, {back}")


def _plant_brief(job) -> Brief:
    d = job.derivation
    b = d.get("b_bounds")
    bb = f", b in [{b[0]:.3g}, {b[1]:.3g}]" if b else ""
    mp = d.get("minimum_phase", True)
    op = ", ".join(f"{s} = {v:.4g}" for s, v in zip(d.get("states", []), d.get("x_op", [])))
    return Brief(f"rho = {d.get('rho')}", "good" if mp else "bad",
                 f"{'minimum phase' if mp else 'NOT minimum phase'}{bb}, u_eq = "
                 f"{d.get('u_eq', float('nan')):.4g}",
                 f"{job.plant.name}: relative degree {d.get('rho')}, operating point x_op = "
                 f"({op}), u_eq = {d.get('u_eq', float('nan')):.4g}")


def assumptions_fail(job) -> str:
    """Why the method's assumptions fail for this plant (empty when they hold or are unknown).

    Parameters
    ----------
    job : Job
        Only its ``derivation`` (the derive stage's results, or None) is read.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> from fl_design.app._report_summary import assumptions_fail
    >>> assumptions_fail(SimpleNamespace(derivation={"minimum_phase": False,
    ...                                              "zero_dynamics_eigenvalues": ["(1+0j)"]}))
    'NOT minimum phase (zero dynamics eigenvalues (1+0j)): no certificate covers this plant'
    """
    d = job.derivation or {}
    if d.get("minimum_phase", True):
        return ""
    eig = ", ".join(d.get("zero_dynamics_eigenvalues", [])[:3])
    return f"NOT minimum phase (zero dynamics eigenvalues {eig}): no certificate covers this plant"


def summary_rows(job) -> list:
    """The summary's rows: ``(question, Brief or str, section title)``.

    Parameters
    ----------
    job : Job
        A finished (or partial) job.

    Examples
    --------
    >>> from fl_design.app import load_config, run_job
    >>> from fl_design.app._report_summary import summary_rows
    >>> job = run_job(load_config(None), quick=True, stages=("derive",), progress=False)
    >>> [row[0] for row in summary_rows(job)][:3]
    ['Plant trms_yaw', 'Design', 'Does it work?']
    """
    sim = job.results.get("simulate")
    verdict = run_brief(sim["main"]) if sim else Brief("not run", "info")
    dtext = _disturbance_text(job)
    cert = cert_brief(job.results.get("certify"))
    nonlinear = nonlinear_brief(job.results.get("certify"))
    why = assumptions_fail(job)
    if why:  # no cell says "certified" for a plant outside the method's assumptions
        cert = Brief("assumptions fail", "bad", why, cert.long)
        nonlinear = Brief("assumptions fail", "bad", why, nonlinear.long)
    lost = [(stage, line) for stage, line in (getattr(job, "lost", None) or {}).items()]
    partial = [("Complete?", Brief("PARTIAL", "bad", line),  # first: never looks complete
                MAP if stage == "sweep" else ROBUSTNESS) for stage, line in lost]
    return [*partial,
            (f"Plant {job.plant.name}", _plant_brief(job) if job.derivation else "not derived",
             DERIVATION),
            ("Design", design_brief(job.design), SIMULATIONS),
            ("Does it work?", verdict, SIMULATIONS),
            *([("Disturbance", dtext, SIMULATIONS)] if dtext is not None else []),
            ("Certified for its class", cert, CERTIFICATES),
            ("This step certified?", nonlinear, CERTIFICATES),
            ("Empirical eps*", map_brief(job.results.get("sweep"),
                                         job.design.controller.gamma), MAP),
            ("Estimators compared", compare_brief(sim), SIMULATIONS),
            ("Generated C", code_brief(job.results.get("codegen")), CODE)]


def summary_blocks(job, figures) -> list:
    """The summary section's blocks: a table of short answers linked to their sections, then
    the design's response figure.

    Parameters
    ----------
    job : Job
        A finished (or partial) job.
    figures : sequence of str
        Figures written.

    Examples
    --------
    >>> from fl_design.app import load_config, run_job
    >>> from fl_design.app._report_summary import summary_blocks
    >>> job = run_job(load_config(None), quick=True, stages=("derive",), progress=False)
    >>> [row[0] for row in summary_blocks(job, [])[-1][1]][:2]
    ['Plant trms_yaw', 'Design']
    """
    why = assumptions_fail(job)
    blocks = ([("p", (f"The method's assumptions fail for this plant: {why}; the runs below "
                     "show the output only, its internal states may leave the region."))]
              if why else [])
    for line in (getattr(job, "lost", None) or {}).values():
        blocks.append(("p", (f"PARTIAL REPORT: {line} (a worker of the executor died; the "
                             "finished runs are exactly a complete run's).")))
    blocks.append(("links", summary_rows(job)))
    sim = job.results.get("simulate")
    if "response.png" in figures:
        blocks.append(("fig", "response.png", (
            f"This design's run, {sim['main'].duration:g} s: output and reference, input "
            "(u_eq dotted), sigma and its estimate")))
    return blocks


__all__ = ["CERTIFICATES", "CODE", "DERIVATION", "MAP", "ROBUSTNESS", "SIMULATIONS", "anchor",
           "assumptions_fail", "summary_blocks", "summary_rows"]
