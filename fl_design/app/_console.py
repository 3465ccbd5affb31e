"""What the CLI prints on stdout (progress goes to stderr).

``fl-design run`` prints :func:`print_job`: by default one screen (the summary's short answers
and the compared runs, under 60 lines); ``--verbose`` adds every stage's detail (the
``print_<stage>`` functions, which the single-stage subcommands print). Each printer takes the
job after its stage: ``print_derive(job)`` after ``derive``, ... ``print_codegen(job)`` after
``codegen``; :func:`print_summary` and :func:`print_job` any job.

Examples
--------
One quick job, then every printer (each output cut after its first words):

>>> from fl_design.app import load_config, run_job
>>> from fl_design.app import _console
>>> job = run_job(load_config(None), quick=True, progress=False)
>>> _console.print_derive(job)  # doctest: +ELLIPSIS
Plant: trms_yaw...
>>> _console.print_certificates(job)  # doctest: +ELLIPSIS
Design: EHGO eps = 0.05 s...
>>> _console.print_sweep(job)  # doctest: +ELLIPSIS
Stability map 5 x 5...
>>> _console.print_simulate(job)  # doctest: +ELLIPSIS
This design (EHGO eps = 0.05 s...
>>> _console.print_codegen(job)  # doctest: +ELLIPSIS
C package...
>>> _console.print_summary(job)  # doctest: +ELLIPSIS
trms_yaw: EHGO eps = 0.05 s, gamma = 0.0003, ... (quick mode)
...
>>> _console.print_job(job, verbose=True)  # doctest: +ELLIPSIS
Plant: trms_yaw...
"""

from __future__ import annotations

import sys

from ._brief import DASH, Brief, window_brief
from ._report_map import map_counts
from ._report_summary import summary_rows
from ._text import (
    bounded_up_to,
    design_label,
    fmt,
    linearized_text,
    overshoot_text,
    run_length_note,
)


def print_derive(job) -> None:
    """Print the derivation report of the job's plant (after the derive stage)."""
    print(job.derivation["text"])


def print_certificates(job) -> None:
    """Print the certificates: Lyapunov, gamma interval, eps*, linearized eps*."""
    cert = job.results["certify"]
    print(f"Design: {design_label(job.design)} on {job.plant.name}")
    for key in ("lyapunov", "gamma", "eps"):
        if key in cert:
            print(cert[key])
    if "skipped" in cert:
        print(f"gamma/eps certificates skipped: {cert['skipped']}")
    if "eps" in cert:
        e = cert["eps"]
        star = "none" if e.eps_star_certified is None else f"{e.eps_star_certified:.4g} s"
        print(f"eps* to use: {star}, certified for {e.covers} b (the strongest coverage these "
              "data support; the brackets above say how tight)")
        for m in cert.get("margins", ()):
            print(f"margins at the plant input (surrogate, b frozen): {m['text']}")
        if "nonlinear" in cert:
            print(cert["nonlinear"])
    print("linearized eps* at this gamma (eigenvalues of the nonlinear loop's Jacobian at rest, "
          f"not a certificate): {linearized_text(cert['linearized_design'])}")


print_certify = print_certificates


def print_sweep(job) -> None:
    """Print the stability map's counts and its empirical eps* per gamma."""
    smap = job.results["sweep"]
    counts = map_counts(smap)
    print(f"Stability map {smap.eps.size} x {smap.gamma.size} (eps x gamma), {smap.duration:g} "
          f"s runs: {counts}")
    note = run_length_note(smap, "from the loop")
    if note:
        print(f"  {note}")
    brackets = [str(smap.eps_star(g)) for g in smap.gamma]
    bounded = [bounded_up_to(smap, g) for g in smap.gamma]
    width = max([18, *map(len, brackets)])
    same = len(set(bounded)) == 1  # a column that says the same on every row: one line
    print(f"  {'gamma':<10} {'empirical eps* (s)':<{width}}"
          + ("" if same else " every run bounded up to eps (s)"))
    for g, text, b in zip(smap.gamma, brackets, bounded):
        print(f"  {g:<10.3g} {text:<{width}}" + ("" if same else f" {b}"))
    if same:
        print(f"  every run bounded (not diverged) up to eps {bounded[0]} s at every gamma")


def print_simulate(job) -> None:
    """Print every run's verdict and overshoot (the paper's comparison)."""
    sim = job.results["simulate"]
    main = sim["main"]
    print(f"This design ({design_label(job.design)}), {sim['duration']:g} s: {main.verdict()}")
    print(f"\n  compared runs, the first {sim['compare_duration']:g} s (the transient; "
          f"{sim.get('compare_reason', 'given')}):")
    print(f"  {'design':<16}{'noise std':>10}  {'verdict':<12}{'overshoot %':>14}  "
          f"{'tail |e|':>9}")
    for (name, std), r in sim["runs"].items():
        print(f"  {name:<16}{std:>10.3g}  {r.status:<12}{overshoot_text(r):>14}  "
              f"{r.tail_error:>9.3g}")
    if sim["tradeoff"]:
        print(f"\n  noise std {sim['tradeoff'][0]['noise_std']:.3g}: eps -> sigmahat noise, "
              "u noise")
        for r in sim["tradeoff"]:
            print(f"  {r['eps']:<8g} {fmt(r['sigmahat_noise'], 'n/a'):>10} "
                  f"{fmt(r['u_noise'], 'n/a'):>10}")


def print_codegen(job) -> None:
    """Print the C package, its SIL result and the cost table."""
    cg = job.results["codegen"]
    if "skipped" in cg:
        print(f"C package skipped: {cg['skipped']}")
        return
    pkg, sil = cg["package"], cg["sil"]
    print(f"C package ({pkg.precision}) in {pkg.out_dir}: {len(pkg.files)} files")
    print(f"SIL {cg['sil_duration']:g} s: max relative error {sil.max_rel_error:.3g} "
          f"(bound {sil.bound:g}): {'passed' if sil.passed else 'FAILED'}" +
          (f" (the loop is {sil.c_status} in C as in Python: the design fails the scenario)"
           if sil.c_failed and sil.verdicts_agree else ""))
    print(cg["costs"].to_markdown())


#: Most compared runs listed by the default console output (more: the noisiest level only).
MAX_COMPARED_LINES = 18


def _dash() -> str:
    """The short forms' dash, or ``-`` on a terminal that cannot print it."""
    try:
        DASH.encode(getattr(sys.stdout, "encoding", None) or "ascii")
    except (UnicodeEncodeError, LookupError):
        return "-"
    return DASH


def _line(answer) -> str:
    text = str(answer)
    if isinstance(answer, Brief):
        text = text.replace(f" {DASH} ", f" {_dash()} ", 1)
    return text


def print_summary(job) -> None:
    """Print the summary's short answers and the compared runs (one screen)."""
    mode = " (quick mode)" if job.quick else ""
    print(f"{job.plant.name}: {design_label(job.design)}{mode}")
    rows = summary_rows(job)
    width = max(len(q) for q, _, _ in rows)
    for question, answer, _ in rows:
        print(f"  {question:<{width}}  {_line(answer)}")
    sim = job.results.get("simulate")
    if sim:
        window = sim["compare_duration"]
        print(f"\nCompared runs, the first {window:g} s (the transient: overshoot, noise):")
        names = max(len(n) for n in sim["designs"])
        print(f"  {'design':<{names}}  {'noise std':>9}  {'overshoot %':>11}  "
              f"first {window:g} s show")
        runs = list(sim["runs"].items())
        if len(runs) > MAX_COMPARED_LINES:  # one screen: the noisiest level only
            top = max(sim["stds"])
            runs = [(k, r) for k, r in runs if k[1] == top]
        for (name, std), r in runs:
            over = overshoot_text(r)
            print(f"  {name:<{names}}  {std:>9.3g}  {over if over[:1].isdigit() else 'n/a':>11}"
                  f"  {window_brief(r, window)}")
        if len(runs) < len(sim["runs"]):
            print(f"  ({len(sim['runs']) - len(runs)} quieter runs: the report, or --verbose)")


def print_job(job, *, verbose: bool = False) -> None:
    """Print what ``fl-design run`` shows: the summary; with ``verbose`` every stage's detail.

    Parameters
    ----------
    job : Job
        A finished job.
    verbose : bool, optional
        Also every stage's tables (the derivation, the certificates, the map, the runs, C).
    """
    if verbose:
        printers = (("derive", print_derive), ("certify", print_certificates),
                    ("sweep", print_sweep), ("simulate", print_simulate),
                    ("codegen", print_codegen))
        for stage, printer in printers:
            if stage == "derive" and job.derivation or stage in job.results:
                printer(job)
                print()
    print_summary(job)


__all__ = ["print_certificates", "print_certify", "print_codegen", "print_derive", "print_job",
           "print_simulate", "print_summary", "print_sweep"]
