"""The report's sections: what a control engineer reads, in order, with honest verdicts.

Blocks as :mod:`fl_design.app._report_write` renders them; every number in words comes from
:mod:`fl_design.app._text` and :mod:`fl_design.app._brief` (re-exported here: ``fmt``,
``overshoot_text``, ...).

Examples
--------
>>> from fl_design.app._report_sections import fmt
>>> fmt(float("nan"), "no boundary"), fmt(0.123456)
('no boundary', '0.1235')
"""

from __future__ import annotations

import numpy as np

from . import _report_summary as S
from ._brief import gamma_words, window_brief
from ._report_family import report_blocks
from ._report_map import map_counts
from ._text import (
    bounded_up_to,
    design_label,
    fmt,
    linearized_text,
    overshoot_text,
    paper_gamma_bound,
    run_length_note,
)


def _derivation(job) -> list:
    d = job.derivation
    if not d:
        return [("p", "Not run.")]
    blocks = [("p", f"Relative degree rho = {d['rho']} (n = {d['n']}); sigma = a + b u with"),
              ("math", "a =", d["a_mathml"], d["a_latex"]),
              ("math", "b =", d["b_mathml"], d["b_latex"])]
    if d["b_bounds"]:
        lo, hi = d["b_bounds"]
        blocks.append(("p", (f"b over the plant's region and input range: [{lo:.4g}, {hi:.4g}]; "
                            f"the paper asks {paper_gamma_bound((lo, hi))[1]}.")))
    zd = ("no zero dynamics (n = rho)" if d["n"] == d["rho"] else
          f"zero dynamics eigenvalues {', '.join(d['zero_dynamics_eigenvalues'])}: "
          f"{'minimum phase' if d['minimum_phase'] else 'NOT minimum phase'}")
    blocks += [("p", zd), ("details", "The full derivation (text)", d["text"])]
    return blocks


def _lyapunov_blocks(lyap) -> list:
    return [("p", (f"Gains K = {tuple(float(k) for k in lyap.gains)}: P_x from "
                  f"(A + B K)^T P_x + P_x (A + B K) = -Q, lambda_x = {lyap.lambda_x:g}, decrease "
                  f"along F^a at T: {lyap.decrease_holds}; certified: {lyap.certified}.")),
            ("pre", "P_x =\n" + np.array2string(np.asarray(lyap.P_x), precision=5))]


def _certificates(job) -> list:
    cert = job.results.get("certify")
    if not cert:
        return [("p", "Not run.")]
    blocks = _lyapunov_blocks(cert["lyapunov"])
    if "gamma" in cert:
        g, e = cert["gamma"], cert["eps"]
        blocks.append(("table", ["quantity", "value"], [
            ["admissible gamma interval (frozen b grid, at this eps)", gamma_words(g)],
            ["gamma below which no eps works", fmt(g.gamma_lower_bound, "none found")],
            ["paper's bound 1/b_max", fmt(g.paper_bound)],
            ["gamma certified (LMI at this eps)", str(g.certified)],
            *[[f"eps* for {b.covers} b (s): [certified, refuted]"
               + ("  (headline)" if b.covers == e.covers else ""),
               f"[{fmt(b.certified, 'none')}, {fmt(b.refuted, 'none found')}]"]
              for b in e.brackets],
            [f"this eps certified for {e.covers} b", f"{e.certified}: {e.reason}"],
        ]))
        blocks.append(("p", ("What is certified: every plant of the class named here "
                            f"({getattr(e, 'class_description', '') or 'the chain of its b range'})"
                            ": the sampled loop closed by this design's own step, with b and "
                            "the slopes of sigma anywhere in the class's ranges (frozen: each "
                            "constant member; varying: changing along the trajectory). Refuted: "
                            "a member of the class (a frozen corner, or a switching between "
                            "corners) found growing. Not covered: "
                            + ("; ".join(getattr(e, "uncovered", ()) or ()) or "nothing")
                            + ".")))
        if "nonlinear" in cert:
            blocks.append(("p", cert["nonlinear"] + "."))
    elif "skipped" in cert:
        blocks.append(("p", f"Certificates of gamma and eps* skipped: {cert['skipped']}."))
    blocks.append(("p", (f"Linearized nonlinear loop at the equilibrium, this gamma: eps* = "
                        f"{linearized_text(cert['linearized_design'])}.")))
    return blocks


def _sweep(job, figures) -> list:
    smap = job.results.get("sweep")
    if smap is None:
        return [("p", "Not run.")]
    labels = smap.labels
    counts = map_counts(smap)
    cert = job.results.get("certify", {})
    bounded = [bounded_up_to(smap, g) for g in smap.gamma]
    same = len(set(bounded)) == 1
    rows = [[f"{g:.3g}", str(smap.eps_star(g))] + ([] if same else [b])
            for g, b in zip(smap.gamma, bounded)]
    blocks = [("p", (f"{smap.eps.size} x {smap.gamma.size} runs of {smap.duration:g} s "
                    f"(noise-free): {counts}. Empirical eps* at each gamma: the largest grid eps "
                    f"below which every run converges (converging or converged); '> x' means "
                    f"no boundary inside the scanned range, '< x' that even the smallest eps "
                    f"failed."))]
    note = run_length_note(smap, "from the loop")
    if note:
        blocks.append(("p", note))
    if getattr(smap, "n_lost", 0):  # a worker died mid-sweep: the partial map
        from ._brief import lost_line

        blocks.append(("p", (f"PARTIAL MAP: {lost_line(smap)} (marked x in the figure; "
                             "their metrics are NaN, and eps* reads them as not converging, "
                             "so it can only be more cautious than the complete map's). "
                             "Run again for the lost points.")))
    if "stability_map.png" in figures:
        blocks.append(("fig", "stability_map.png", (
            f"Stability map, {job.plant.name}: {smap.duration:g} s noise-free runs to the "
            f"reference {_reference_text(job)}; the star is this design ({design_label(job.design)}), "
            "the dotted line the paper's gamma < 1/b_max")))
    blocks.append(("table", ["gamma", "empirical eps* (s)"]
                   + ([] if same else ["every run bounded up to eps (s)"]), rows))
    if same:
        blocks.append(("p", (f"Every run bounded (not diverged) up to eps: {bounded[0]} s at "
                             "every gamma of the map.")))
    if np.mean(labels == "oscillating") > 0.3:
        blocks.append(("p", ("Most runs are 'oscillating': bounded, but their error does not "
                            "settle inside the band (on the TRMS, a slow limit cycle against the "
                            "Coulomb friction). Those runs count as failures for eps*; the bounded "
                            "column counts them as bounded, the practical stability of Theorem 1.")))
    if np.any(labels == "undecided"):
        blocks.append(("p", ("'undecided' runs are bounded and outside the band, and the last "
                            "half of the run cannot call the trend (an envelope that grows "
                            "without swinging, or swings that decay too little for the fit): a "
                            "mode slower than the run. They count as not converging for eps* "
                            "(the bracket then says 'undecided at', not 'fails at'); longer "
                            "runs decide them. The 'slow' ones were still moving towards the "
                            "reference at the end (envelope shrinking, or the input still "
                            "moving): loops slower than the run, not failures.")))
    if "eps_star.png" in figures:
        blocks.append(("fig", "eps_star.png", ("eps*(gamma): certified, frozen, linearized and "
                       "empirical")))
    if "curve" in cert:
        c = cert["curve"]
        blocks.append(("table", ["gamma", "eps* frozen eigenvalues (s)", "eps* certified, frozen b (s)"],
                       [[f"{g:.3g}", fmt(f, "none"), fmt(x, "not certified")]
                        for g, f, x in zip(c.gamma, c.eps_star_frozen, c.eps_star_certified)]))
    return blocks


def _simulations(job, figures) -> list:
    sim = job.results.get("simulate")
    if not sim:
        return [("p", "Not run.")]
    main = sim["main"]
    tol = main.tol
    window = sim["compare_duration"]
    blocks = [("p", f"This design, {sim['duration']:g} s step: {main.verdict()}."),
              ("p", "The figure of this run is in the summary above.")]
    rows, reasons = [], []
    for (name, std), r in sim["runs"].items():
        lv = sim["levels"][(name, std)]
        over = overshoot_text(r)
        rows.append([name, f"{std:.3g}", over if over[:1].isdigit() else "n/a",
                     window_brief(r, window), fmt(lv["u_noise"], "n/a")])
        reasons.append(f"{name}, noise std {std:.3g}: {r.verdict()}")
    blocks.append(("p", (f"The compared runs measure the transient: each lasts the first "
                         f"{window:g} s ({sim.get('compare_reason', 'given')}), long enough for "
                         "the overshoot and the noise of u, not always for a verdict on the "
                         "slow approach (this design's own run above decides that). The "
                         f"window column says what {window:g} s show.")))
    blocks.append(("table", ["design", "noise std", "overshoot %", f"first {window:g} s show",
                             "u noise"], rows))
    blocks.append(("details", "Each compared run's full verdict", "\n".join(reasons)))
    if "steps.png" in figures:
        ctrl = job.design.controller
        blocks.append(("fig", "steps.png", (
            "Step responses, EHGO and least squares under one controller (gamma = "
            f"{ctrl.gamma:g}, K = {tuple(float(k) for k in ctrl.gains)}), with and without "
            "sensor noise; the legend gives each run's overshoot and what its window shows")))
    if sim["tradeoff"]:
        blocks.append(("table", ["eps (s)", "sigmahat noise", "u noise", "overshoot %"],
                       [[f"{r['eps']:g}", fmt(r["sigmahat_noise"], "n/a"),
                         fmt(r["u_noise"], "n/a"), fmt(r["overshoot_%"], "n/a", 3)]
                        for r in sim["tradeoff"]]))
    if "noise_tradeoff.png" in figures:
        blocks.append(("fig", "noise_tradeoff.png", (
            "Noise of sigmahat and u against eps (std(diff)/sqrt(2) over the tail), gamma = "
            f"{job.design.controller.gamma:g}")))
    blocks.append(("p", (f"Settling band: |e| <= {tol:.3g} (the [classifier] tolerance times "
                        "the step).")))
    return blocks


def _reference_text(job) -> str:
    ref = job.config.scenario.reference
    unit = job.config.plant.output_unit
    sim = job.results.get("simulate")
    if not sim:
        return f"r = {ref:g} {unit}".rstrip()
    main = sim["main"]
    return f"r = {ref:g} {unit} (a step of {main.step:.3g} from y0 = {main.y0:.3g})"


def _codegen(job) -> list:
    cg = job.results.get("codegen")
    if not cg:
        return [("p", "Not run.")]
    if "skipped" in cg:
        return [("p", f"Skipped: {cg['skipped']}.")]
    sil, pkg = cg["sil"], cg["package"]
    lines = cg["costs"].to_markdown().splitlines()
    head = [h.strip() for h in lines[0].strip("|").split("|")]
    rows = [[c.strip() for c in line.strip("|").split("|")] for line in lines[2:]]
    return [("p", (f"C99 package ({pkg.precision}, prefix {pkg.prefix!r}) in {pkg.out_dir}: "
                  f"{', '.join(p.name for p in pkg.files)}.")),
            ("table", head, rows),
            ("p", (f"Software in the loop ({cg['sil_duration']:g} s, noise std "
                  f"{cg['sil_noise_std']:g}): compiled step versus Design.step, max relative "
                  f"error {sil.max_rel_error:.3g} (bound {sil.bound:g}), last tenth "
                  f"{sil.tail_rel_error:.3g}: {'PASSED' if sil.passed else 'FAILED'}."))]


def sections(job, figures, failed=None) -> list:
    """The report's sections from a finished job (see :mod:`fl_design.app._report_write`).

    Parameters
    ----------
    job : Job
        A finished job.
    figures : sequence of str
        The figure files written (sections refer only to those).
    failed : dict, optional
        ``{file: reason}`` of the figures that could not be drawn (said in *Run*).

    Returns
    -------
    list of (str, list)

    Examples
    --------
    >>> from fl_design.app import load_config, run_job
    >>> from fl_design.app._report_sections import sections
    >>> job = run_job(load_config(None), quick=True, stages=("derive",), progress=False)
    >>> [title for title, _ in sections(job, [])][:3]
    ['Summary', "Simulations: this design and the paper's comparison", 'Stability map and eps*']
    """
    timing = ", ".join(f"{k} {v:.1f} s" for k, v in job.timings.items())
    mode = "quick mode (short runs, small grids: not for conclusions)" if job.quick else "full"
    robust = ([(S.ROBUSTNESS, report_blocks(job, figures))]
              if "robustness" in job.results else [])
    return [("Summary", S.summary_blocks(job, figures)),
            (S.SIMULATIONS, _simulations(job, figures)), (S.MAP, _sweep(job, figures)),
            *robust, (S.CERTIFICATES, _certificates(job)), (S.CODE, _codegen(job)),
            (S.DERIVATION, _derivation(job)),
            ("Run", [("p", f"Config {job.config.source}, {mode}; {timing}."),
                     *failed_figures_block(failed or {})])]


def failed_figures_block(failed: dict) -> list:
    """A paragraph naming the figures that could not be drawn, and why (empty if none).

    Examples
    --------
    >>> from fl_design.app._report_sections import failed_figures_block
    >>> failed_figures_block({"steps.png": "ValueError: bad"})
    [('p', 'Figures not drawn: steps.png (ValueError: bad).')]
    """
    if not failed:
        return []
    return [("p", "Figures not drawn: " + "; ".join(f"{k} ({v})" for k, v in failed.items())
             + ".")]


__all__ = ["bounded_up_to", "design_label", "failed_figures_block", "fmt", "linearized_text",
           "overshoot_text", "paper_gamma_bound", "sections"]
