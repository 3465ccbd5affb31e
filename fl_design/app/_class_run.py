"""``fl-design run CLASS.toml`` and ``fl-design identify LOG.csv``: the model-free route.

``run`` on a ``[class]`` config: :func:`fl_design.tune` for the class (certificate, margins at
the class's extremes, noise gain, member runs), a map over class members (the surrogate loop's
spectral radius over ``b`` and ``eps`` around the design), the comparison runs (linear ADRC
with a ``b0`` guess on the same members, :mod:`fl_design.design._adrc`), the C package, and
the report (``report.md``, ``report.html``, ``summary.json``, figures).

``identify`` reads a log, writes the page (:func:`fl_design.identification.write_page`) and
``class.toml``, and prints the command that designs from it.

Examples
--------
>>> from fl_design.app._class_run import class_report_lines
>>> class_report_lines.__name__
'class_report_lines'
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np

from .._json import jsonable


def _adrc_runs(tuned, quick: bool) -> list:
    """The baseline on the same members: linear ADRC, b0 the geometric mean of the range."""
    from ..design._adrc import LinearADRC
    from ..tuning._class_checks import MAX_RUN, MAX_SAMPLES, _metrics, member_rig

    cls, design = tuned.plant_class, tuned.design
    lo, hi = cls.b
    b0 = math.copysign(math.sqrt(lo * hi), lo)
    wc = tuned.time_scale
    adrc = LinearADRC(rho=cls.rho, T=design.T, b0=b0, wc=wc, wo=10.0 * wc,
                      u_limits=cls.u_limits)
    y0 = 0.0 if cls.operating_point is None else cls.operating_point
    u_eq = 0.0 if cls.u_eq is None else float(cls.u_eq)
    dur = min(max(MAX_RUN, MAX_SAMPLES * design.T), max(12.0 / wc, 2000 * design.T)) / (
        2.0 if quick else 1.0)
    out = []
    for b in (lo, b0, hi):
        rig = member_rig(cls.rho, b=b, T=design.T, noise_std=cls.noise_std, delay=cls.delay,
                         y0=y0, u_eq=u_eq)  # held at the operating point by u_eq, as the class says
        m = _metrics(rig.run(adrc, tuned.reference, dur, seed=0, u0=u_eq), tuned.reference, y0,
                     cls.noise_std, f"ADRC on the chain at b = {b:.4g}", b, b)
        out.append(m)
    return [adrc.describe()] + out


def _map(tuned) -> dict:
    """Spectral radius of the surrogate loop over b (log grid) at eps/2, eps, 2 eps."""
    from ..analysis._surrogate import SurrogateLoop

    design, cls = tuned.design, tuned.plant_class
    loop = SurrogateLoop(design)
    lo, hi = cls.b
    bs = np.geomspace(abs(lo), abs(hi), 25) * cls.sign if lo != hi else np.array([lo])
    eps = design.estimator.eps
    rows = {}
    for f in (0.5, 1.0, 2.0):
        M0, M1 = loop.parts(eps=eps * f)
        rows[f"{eps * f:.4g}"] = [float(max(abs(np.linalg.eigvals(M0 + b * M1)))) for b in bs]
    return {"b": [float(b) for b in bs], "radius": rows}


def class_sections(tuned, adrc, cmap, pkg_dir, fig_name: str | None = None) -> list:
    """The report as sections for the shared renderers (:mod:`._report_render`): summary first.

    Parameters
    ----------
    tuned : ClassTuning
        The design for the class.
    adrc : list
        The baseline's description, then its member runs.
    cmap : dict
        The class map (:func:`_map`).
    pkg_dir : str or pathlib.Path
        The C package's folder.
    fig_name : str, optional
        The class map's PNG file name.

    Returns
    -------
    list of (str, list)
    """
    from ._brief import Brief

    cls, d = tuned.plant_class, tuned.design
    ctrl, est = d.controller, d.estimator
    cert = tuned.eps_certificate
    n_ok = sum(m.converged for m in tuned.members)
    a_ok = sum(m.converged for m in adrc[1:])
    star = cert.eps_star_certified
    which = ("every plant of the class" if not cls.delay else
             f"every plant of the class without its {cls.delay}-sample input delay (not covered: "
             "the member runs include it)")
    cert_brief = (Brief("certified", "good", f"eps = {est.eps:.4g} s for {which}; certified "
                        f"eps* {star:.4g} s" if star else
                        f"eps = {est.eps:.4g} s for {which}", cert.reason)
                  if tuned.certified else
                  Brief("NOT certified", "bad", f"eps = {est.eps:.4g} s: no certificate "
                        "for the class", cert.reason))
    runs = Brief("converging" if n_ok == len(tuned.members) else "failing",
                 "good" if n_ok == len(tuned.members) else "bad",
                 f"{n_ok}/{len(tuned.members)} member runs converge")
    base = Brief("baseline", "info", f"{a_ok}/{len(adrc) - 1} ADRC runs converge (b0 guessed)")
    design_text = (f"EHGO eps = {est.eps:.4g} s, T = {est.T:g} s; gamma = {ctrl.gamma:.4g}, "
                   f"gains {tuple(round(k, 4) for k in ctrl.gains)}")
    summary = [("Is it certified?", cert_brief, "Certificate"),
               ("For which plants?", Brief("class", "info", cls.describe(), cls.describe()),
                "Certificate"),
               ("Which design?", design_text, "How it was chosen"),
               ("Does it work on members?", runs, "Member runs"),
               ("Against ADRC?", base, "Comparison with ADRC"),
               ("Not covered", ", ".join(tuned.uncovered) or "nothing", "Certificate"),
               ("C package", str(pkg_dir), "Certificate")]
    secs = [("Summary", [("links", summary)]),
            ("Certificate", [("p", f"Class: {cls.describe()}"), ("p", cert.reason),
                             ("p", "Not covered by the certificate: "
                              + (", ".join(tuned.uncovered) or "nothing"))]),
            ("How it was chosen", [("list", list(tuned.reasons)
                                    + [f"tried: {t}" for t in tuned.tried])]),
            ("Margins at the class's extremes", [("table", [
                "b", "gain margins", "phase margin [deg]", "delay margin [s]"], [
                [f"{m.b:.4g}", f"({m.gain_margins[0]:.3g}, {m.gain_margins[1]:.3g})",
                 f"{m.phase_margin:.3g}", f"{m.delay_margin:.3g}"] for m in tuned.margins])]),
            ("Noise gain", [("list", [f"b = {b}: rms u {g['u']:.4g}, rms y {g['y']:.4g} per "
                                      "rms sensor noise" for b, g in tuned.noise_gain.items()])]),
            ("Map over class members", [("table", ["b"] + [f"eps {e}" for e in cmap["radius"]],
                                         [[f"{b:.4g}"] + [f"{v[i]:.6f}" for v in
                                                          cmap["radius"].values()]
                                          for i, b in enumerate(cmap["b"])])]
             + ([("fig", fig_name, ("stability margin of the surrogate loop over the class's "
                  "b range (frozen members) at eps/2, eps and 2 eps"))] if fig_name else [])),
            ("Member runs", [("list", [m.line() for m in tuned.members])]),
            ("Comparison with ADRC", [
                ("p", (f"{adrc[0]} (b0 the geometric mean of the class's range, w_c the "
                 "design's loop decay, w_o = 10 w_c); verify/adrc_b0_sweep.py measures what "
                 "not needing b0 buys over a b0-error sweep.")),
                ("list", [m.line() for m in adrc[1:]])])]
    return secs


def class_report_lines(tuned, adrc, cmap, pkg_dir) -> list:
    """The report as Markdown lines (the summary first), for the console and tests.

    Parameters
    ----------
    tuned, adrc, cmap, pkg_dir
        As :func:`class_sections`.

    Returns
    -------
    list of str
    """
    from ._report_render import render_markdown

    return ["# fl-design: a design for a plant class", ""] + render_markdown(
        class_sections(tuned, adrc, cmap, pkg_dir)).splitlines()


def _figure(tuned, out: Path) -> Path:
    from ..plotting import save_figure
    from ..plotting._identify import plot_class_map

    path = out / "class_map.png"
    save_figure(plot_class_map(_map(tuned)), path, dpi=90)
    return path


def cls_name(plant_class) -> str:
    """A short name of the class for titles."""
    return plant_class.name or f"{plant_class.source} class, rho = {plant_class.rho}"


def run_class(args, config_path) -> int:
    """``fl-design run CLASS.toml``."""
    from .._output import record_outputs
    from ..codegen import generate_c
    from ..tuning._tune_class import tune_class
    from ._class_table import load_class_config
    from ._job import note
    from ._outdir import check_out_dir
    from ._report_render import md, render_html, render_markdown

    cfg = load_class_config(config_path)
    out = check_out_dir(args.out, force=args.force)
    start = time.perf_counter()
    show = not args.no_progress

    def stage(k: int, text: str) -> None:
        note(f"{k}/4 {text} ({time.perf_counter() - start:.1f} s)", enabled=show)

    stage(1, f"tune for the {cfg.plant_class.describe()} ...")
    tuned = tune_class(cfg.plant_class, objective=cfg.tune.objective,
                       reference=cfg.tune.reference,
                       progress=((lambda line: note(f"tune: {line} "
                                                    f"({time.perf_counter() - start:.1f} s)"))
                                 if show else None))
    stage(2, "the ADRC baseline on the class's members ...")
    adrc = _adrc_runs(tuned, args.quick)
    stage(3, "the class's (eps, gamma) map ...")
    cmap = _map(tuned)
    stage(4, f"the C package ({cfg.codegen.precision}) ...")
    pkg = generate_c(tuned.design, out / "c", precision=cfg.codegen.precision,
                     prefix=cfg.codegen.prefix, force=args.force)
    note(f"report (figure, HTML, Markdown, JSON) ({time.perf_counter() - start:.1f} s)",
         enabled=show)
    fig = _figure(tuned, out)
    secs = class_sections(tuned, adrc, cmap, pkg.out_dir, fig.name)
    title = f"fl_design report: {cls_name(cfg.plant_class)}"
    paths = [out / "report.md", out / "report.html", out / "summary.json"]
    paths[0].write_text(f"# {md(title)}\n\n" + render_markdown(secs) + "\n", encoding="utf-8")
    paths[1].write_text(render_html(secs, out, title=title), encoding="utf-8")
    summary = {"route": "class", "tuning": tuned.to_dict(), "map": cmap,
               "baseline": [adrc[0]] + [m.to_dict() for m in adrc[1:]],
               "c_package": str(pkg.out_dir), "seconds": time.perf_counter() - start}
    paths[2].write_text(json.dumps(jsonable(summary), allow_nan=False, indent=1),
                        encoding="utf-8")
    record_outputs(out, [*paths, fig])
    lines = render_markdown(secs[:1]).splitlines()
    print("\n".join(lines))
    print(f"\nwrote {out / 'report.html'}, {out / 'report.md'}, {out / 'summary.json'}, "
          f"{fig.name}; C package in {pkg.out_dir}")
    return 0


def add_identify_parser(sub) -> None:
    """The ``identify`` subcommand."""
    p = sub.add_parser("identify", help="a plant class from a rig's log (CSV: t, y, u, r)")
    p.add_argument("log", help="CSV file with a header: t [s], y, u (applied), r optional")
    p.add_argument("--rho", type=int, required=True, help="relative degree you know")
    p.add_argument("--T", type=float, default=None, help="expected sampling time [s]")
    p.add_argument("--u-limits", type=float, nargs=2, default=None, metavar=("LO", "HI"))
    p.add_argument("--b-sign", type=int, choices=(1, -1), default=None)
    p.add_argument("--skip-bad-rows", action="store_true",
                   help="skip unusable rows (counted, with the reason) instead of an error")
    p.add_argument("--out", default="identify_out", help="folder for the page and class.toml")
    p.add_argument("--force", action="store_true")
    p.set_defaults(func=cmd_identify)


def cmd_identify(args) -> int:
    """``fl-design identify LOG.csv --rho R``."""
    from ..identification import identify, write_page
    from ._class_table import class_toml
    from ._outdir import check_out_dir

    cls = identify(args.log, rho=args.rho, T=args.T, u_limits=args.u_limits,
                   b_sign=args.b_sign, bad_rows="skip" if args.skip_bad_rows else "error")
    out = check_out_dir(args.out, force=args.force)
    paths = write_page(cls, out)
    toml = out / "class.toml"
    toml.write_text(class_toml(cls, comment=f"identified by fl-design from {args.log}\n"
                               + "\n".join(cls.evidence.lines()[:-1])), encoding="utf-8")
    print(cls.describe())
    print("\n".join(f"  {x}" for x in cls.evidence.lines()[:-1]))
    print(f"\nwrote {paths['html']}, {toml}")
    print(f"design from it:  fl-design run {toml}")
    return 0


__all__ = ["add_identify_parser", "class_report_lines", "cmd_identify", "run_class"]
