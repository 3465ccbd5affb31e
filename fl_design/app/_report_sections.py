"""The report's sections: what a control engineer reads, in order, with honest verdicts.

Examples
--------
>>> from fl_design.app._report_sections import fmt
>>> fmt(float("nan"), "no boundary"), fmt(0.123456)
('no boundary', '0.1235')
"""

from __future__ import annotations

import math

import numpy as np

from ._report_map import map_counts


def paper_gamma_bound(b_bounds) -> tuple[float, str]:
    """The paper's gain condition ``gamma < 1/b_max`` for a ``b`` range of either sign.

    ``gamma`` takes the sign of ``b``, so the bound is on ``|gamma|``: ``1 / max|b|``.

    Parameters
    ----------
    b_bounds : (float, float)
        ``b`` over the plant's region.

    Returns
    -------
    (float, str)
        The bound on ``|gamma|`` (NaN when ``b`` changes sign) and the condition in words.

    Examples
    --------
    >>> from fl_design.app._report_sections import paper_gamma_bound
    >>> paper_gamma_bound((3.6, 6.8))[1], paper_gamma_bound((-174.6, -18.19))[1]
    ('gamma < 1/b_max = 0.1471', '|gamma| < 1/max|b| = 0.005727 (gamma < 0, as b)')
    """
    lo, hi = (float(v) for v in b_bounds)
    if lo > 0:
        return 1.0 / hi, f"gamma < 1/b_max = {1.0 / hi:.4g}"
    if hi < 0:
        return 1.0 / abs(lo), f"|gamma| < 1/max|b| = {1.0 / abs(lo):.4g} (gamma < 0, as b)"
    return math.nan, "b changes sign over the region: the paper's gamma bound does not apply"


def fmt(value, missing: str = "-", digits: int = 4) -> str:
    """A number with ``digits`` significant digits, or ``missing`` (with its reason) for None/NaN.

    Parameters
    ----------
    value : float or None
        The number.
    missing : str, optional
        What to print instead of None or NaN (say why).
    digits : int, optional
        Significant digits.

    Returns
    -------
    str

    Examples
    --------
    >>> from fl_design.app._report_sections import fmt
    >>> fmt(None, "not certified")
    'not certified'
    """
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return missing
    return f"{value:.{digits}g}"


def _derivation(job) -> list:
    d = job.derivation
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
            ["admissible gamma interval (frozen b grid, at this eps)",
             f"({fmt(g.gamma_min, 'none')}, {fmt(g.gamma_max, 'none')})"],
            ["gamma below which no eps works", fmt(g.gamma_lower_bound, "none found")],
            ["paper's bound 1/b_max", fmt(g.paper_bound)],
            ["gamma certified (LMI at this eps)", str(g.certified)],
            *[[f"eps* for {b.covers} b (s): [certified, refuted]"
               + ("  (headline)" if b.covers == e.covers else ""),
               f"[{fmt(b.certified, 'none')}, {fmt(b.refuted, 'none found')}]"]
              for b in e.brackets],
            [f"this eps certified for {e.covers} b", f"{e.certified}: {e.reason}"],
        ]))
        blocks.append(("p", ("What is certified: the sampled linear surrogate loop (chain of "
                            "integrators, sigma = b u) closed by this design's own step, for b "
                            "constant (frozen) or changing arbitrarily in its interval along "
                            "the trajectory (varying, the paper's b(w(k), x(k))); not the "
                            "nonlinear plant. Refuted: a constant or periodically switched b "
                            "found that makes the surrogate grow.")))
        if "nonlinear" in cert:
            blocks.append(("p", cert["nonlinear"] + "."))
    elif "skipped" in cert:
        blocks.append(("p", f"Certificates of gamma and eps* skipped: {cert['skipped']}."))
    blocks.append(("p", (f"Linearized nonlinear loop at the equilibrium, this gamma: eps* = "
                        f"{linearized_text(cert['linearized_design'])}.")))
    return blocks


def linearized_text(star) -> str:
    """A linearized eps* bracket in words, saying when the boundary lies outside the range.

    Parameters
    ----------
    star : fl_design.sim.EpsStar
        The result of :func:`fl_design.linearized_eps_star`.

    Returns
    -------
    str

    Examples
    --------
    >>> from fl_design.sim import EpsStar
    >>> from fl_design.app._report_sections import linearized_text
    >>> linearized_text(EpsStar(1.0, float("inf")))
    '> 1 s (stable on the whole scanned range: no boundary found up to 1 s)'
    >>> linearized_text(EpsStar(0.0417, 0.0418))
    '0.0417 s (unstable at 0.0418 s)'
    """
    if star.above_range:
        return (f"> {star.lower:g} s (stable on the whole scanned range: no boundary found up "
                f"to {star.lower:g} s)")
    if star.below_range:
        return f"< {star.upper:g} s (unstable already at the smallest eps scanned)"
    lower, upper = str(star).removesuffix(")").split(" (fails at ")  # the digits it needs
    return f"{lower} s (unstable at {upper} s)"


def bounded_up_to(smap, gamma: float) -> str:
    """Largest grid eps below which every run at ``gamma`` stays bounded (not diverged).

    Parameters
    ----------
    smap : fl_design.StabilityMap
        A sweep.
    gamma : float
        A grid gamma.

    Returns
    -------
    str
        ``"> eps_max"`` when no run diverged, ``"< eps_min"`` when the first did.

    Examples
    --------
    >>> import numpy as np
    >>> from fl_design.sim import StabilityMap
    >>> from fl_design.app._report_sections import bounded_up_to
    >>> m = StabilityMap(np.array([0.1, 0.2]), np.array([1.0]), np.array([[0], [-1]]), {},
    ...                  1e-3, 1.0, 0.1)
    >>> bounded_up_to(m, 1.0)
    '0.1 (diverges at 0.2)'
    """
    j = int(np.argmin(np.abs(np.log(smap.gamma / gamma))))
    ok = np.asarray(smap.status)[:, j] >= 0
    if ok.all():
        return f"> {smap.eps[-1]:g}"
    first = int(np.argmin(ok))
    if first == 0:
        return f"< {smap.eps[0]:g}"
    return f"{smap.eps[first - 1]:g} (diverges at {smap.eps[first]:g})"


def _sweep(job, figures) -> list:
    smap = job.results.get("sweep")
    if smap is None:
        return [("p", "Not run.")]
    labels = smap.labels
    counts = map_counts(smap)
    cert = job.results.get("certify", {})
    rows = [[f"{g:.3g}", str(smap.eps_star(g)), bounded_up_to(smap, g)] for g in smap.gamma]
    blocks = [("p", (f"{smap.eps.size} x {smap.gamma.size} runs of {smap.duration:g} s "
                    f"(noise-free): {counts}. Empirical eps* at each gamma: the largest grid eps "
                    f"below which every run converges (converging or converged); '> x' means "
                    f"no boundary inside the scanned range, '< x' that even the smallest eps "
                    f"failed."))]
    if smap.duration_reason != "given":
        blocks.append(("p", f"Run length chosen from the loop: {smap.duration_reason}."))
    if "stability_map.png" in figures:
        blocks.append(("fig", "stability_map.png", (
            f"Stability map, {job.plant.name}: {smap.duration:g} s noise-free runs to the "
            f"reference {_reference_text(job)}; the star is this design ({design_label(job.design)}), "
            "the dotted line the paper's gamma < 1/b_max")))
    blocks.append(("table", ["gamma", "empirical eps* (s)", "every run bounded up to eps (s)"],
                   rows))
    if np.mean(labels == "oscillating") > 0.3:
        blocks.append(("p", ("Most runs are 'oscillating': bounded, but their error does not "
                            "settle inside the band (on the TRMS, a slow limit cycle against the "
                            "Coulomb friction). Those runs count as failures for eps*; the last "
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
    from ._job import noise_levels

    sim = job.results.get("simulate")
    if not sim:
        return [("p", "Not run.")]
    main = sim["main"]
    tol = main.tol
    blocks = [("p", f"This design, {sim['duration']:g} s step: {main.verdict()}."),
              ("p", "The figure of this run is in the summary above.")]
    rows, reasons = [], []
    for (name, std), r in sim["runs"].items():
        lv = noise_levels(r)
        rows.append([name, f"{std:.3g}", r.status, overshoot_text(r), fmt(r.tail_error),
                     fmt(lv["u_noise"], "n/a")])
        reasons.append(f"{name}, noise std {std:.3g}: {r.verdict()}")
    blocks.append(("p", (f"The compared runs, {sim['compare_duration']:g} s each "
                         "(the transient: overshoot and noise):")))
    blocks.append(("table", ["design", "noise std", "verdict", "overshoot %", "tail max |e|",
                             "u noise"], rows))
    blocks.append(("list", reasons))
    if "steps.png" in figures:
        ctrl = job.design.controller
        blocks.append(("fig", "steps.png", (
            "Step responses, EHGO and least squares under one controller (gamma = "
            f"{ctrl.gamma:g}, K = {tuple(float(k) for k in ctrl.gains)}), with and without "
            "sensor noise; the legend gives each run's verdict and overshoot")))
    if sim["tradeoff"]:
        blocks.append(("table", ["eps (s)", "sigmahat noise", "u noise", "verdict",
                                 "overshoot %"],
                       [[f"{r['eps']:g}", fmt(r["sigmahat_noise"], "n/a"),
                         fmt(r["u_noise"], "n/a"), r["status"], fmt(r["overshoot_%"], "n/a",
                                                                    3)]
                        for r in sim["tradeoff"]]))
    if "noise_tradeoff.png" in figures:
        blocks.append(("fig", "noise_tradeoff.png", (
            "Noise of sigmahat and u against eps (std(diff)/sqrt(2) over the tail), gamma = "
            f"{job.design.controller.gamma:g}")))
    blocks.append(("p", (f"Settling band: |e| <= {tol:.3g} (the [scenario] tolerance times the "
                        "step).")))
    return blocks


def _reference_text(job) -> str:
    ref = job.config.scenario.reference
    unit = job.config.plant.output_unit
    sim = job.results.get("simulate")
    if not sim:
        return f"r = {ref:g} {unit}".rstrip()
    main = sim["main"]
    return f"r = {ref:g} {unit} (a step of {main.step:.3g} from y0 = {main.y0:.3g})"


def design_label(design) -> str:
    from ._report_figures import design_label as label

    return label(design)


def overshoot_text(resp) -> str:
    """Overshoot in %, or why it is not one (diverged; does not track).

    Parameters
    ----------
    resp : fl_design.Response
        A run.

    Returns
    -------
    str

    Examples
    --------
    >>> import fl_design as fl
    >>> from fl_design.app._report_sections import overshoot_text
    >>> r = fl.simulate(fl.plants.pendulum(), fl.presets.pendulum_design(), fl.Scenario(0.1, 20.0))
    >>> overshoot_text(r)
    '0'
    """
    if resp.status == "diverged":
        return "n/a (diverged)"
    reach = np.nanmax(np.abs(resp.y - resp.y0)) / max(abs(resp.step), 1e-300)
    if reach < 0.9:
        return f"none: never reaches the reference (peak {100 * reach:.0f} % of the step)"
    return f"{resp.overshoot:.3g}"


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


def sections(job, figures) -> list:
    """The report's sections from a finished job (see :mod:`fl_design.app._report_write`).

    Parameters
    ----------
    job : Job
        A finished job.
    figures : sequence of str
        The figure files written (sections refer only to those).

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
    from . import _report_summary as S

    timing = ", ".join(f"{k} {v:.1f} s" for k, v in job.timings.items())
    mode = "quick mode (short runs, small grids: not for conclusions)" if job.quick else "full"
    from ._uncertainty import report_blocks

    robust = ([("Robustness: a family of plants", report_blocks(job, figures))]
              if "robustness" in job.results else [])
    return [("Summary", S.summary_blocks(job, figures)),
            (S.SIMULATIONS, _simulations(job, figures)), (S.MAP, _sweep(job, figures)),
            *robust, (S.CERTIFICATES, _certificates(job)), (S.CODE, _codegen(job)),
            (S.DERIVATION, _derivation(job)),
            ("Run", [("p", f"Config {job.config.source}, {mode}; {timing}.")])]


__all__ = ["bounded_up_to", "fmt", "overshoot_text", "sections"]
