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

import html
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from .._json import jsonable


def _adrc_runs(tuned, quick: bool) -> list:
    """The baseline on the same members: linear ADRC, b0 the geometric mean of the range."""
    from ..design._adrc import LinearADRC
    from ..sim._rig import chain_rig
    from ..tuning._class_checks import _metrics

    cls, design = tuned.plant_class, tuned.design
    lo, hi = cls.b
    b0 = math.copysign(math.sqrt(lo * hi), lo)
    wc = tuned.time_scale
    adrc = LinearADRC(rho=cls.rho, T=design.T, b0=b0, wc=wc, wo=10.0 * wc,
                      u_limits=cls.u_limits)
    y0 = 0.0 if cls.operating_point is None else cls.operating_point
    dur = min(60.0, max(12.0 / wc, 2000 * design.T)) / (2.0 if quick else 1.0)
    out = []
    for b in (lo, b0, hi):
        rig = chain_rig(cls.rho, b=b, T=design.T, noise_std=cls.noise_std, delay=cls.delay,
                        x0=(y0,) + (0.0,) * (cls.rho - 1))
        m = _metrics(rig.run(adrc, tuned.reference, dur, seed=0), tuned.reference, y0,
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


def class_report_lines(tuned, adrc, cmap, pkg_dir) -> list:
    """The report as Markdown lines (the summary first)."""
    cls, d = tuned.plant_class, tuned.design
    ctrl, est = d.controller, d.estimator
    n_ok = sum(m.converged for m in tuned.members)
    verdict = ("certified for every plant of the class" if tuned.certified else
               "NOT certified for the class (see the certificate)")
    a_ok = sum(m.converged for m in adrc[1:])
    out = ["# fl-design: a design for a plant class", "", "## Summary", "",
           f"- **{verdict}**: {tuned.eps_certificate.reason}",
           f"- class: {cls.describe()}",
           (f"- design: EHGO eps = {est.eps:.4g} s, T = {est.T:g} s; gains "
            f"{tuple(round(k, 6) for k in ctrl.gains)}, gamma = {ctrl.gamma:.4g}, u limits "
            f"{ctrl.u_limits}"),
           f"- member runs: {n_ok}/{len(tuned.members)} converge",
           f"- baseline {adrc[0]}: {a_ok}/{len(adrc) - 1} member runs converge",
           f"- outside the certificate: {', '.join(tuned.uncovered) or 'nothing'}",
           f"- C package: {pkg_dir}", "", "## How it was chosen", ""]
    out += [f"- {r}" for r in tuned.reasons] + [f"- tried: {t}" for t in tuned.tried]
    out += ["", "## Margins at the class's extremes", "",
            "| b | gain margins | phase margin [deg] | delay margin [s] |", "|---|---|---|---|"]
    out += [f"| {m.b:.4g} | ({m.gain_margins[0]:.3g}, {m.gain_margins[1]:.3g}) | "
            f"{m.phase_margin:.3g} | {m.delay_margin:.3g} |" for m in tuned.margins]
    out += ["", "## Noise gain", ""] + [f"- b = {b}: rms u {g['u']:.4g}, rms y {g['y']:.4g} "
                                        "per rms sensor noise" for b, g in
                                        tuned.noise_gain.items()]
    out += ["", "## Map over class members (surrogate spectral radius)", "",
            "| b | " + " | ".join(f"eps {e}" for e in cmap["radius"]) + " |",
            "|---|" + "---|" * len(cmap["radius"])]
    for i, b in enumerate(cmap["b"]):
        out.append(f"| {b:.4g} | " + " | ".join(f"{v[i]:.6f}" for v in cmap["radius"].values())
                   + " |")
    out += ["", "## Member runs", ""] + [f"- {m.line()}" for m in tuned.members]
    out += ["", "## Comparison: the practitioner's baseline", "", (f"- {adrc[0]} (b0 the "
            "geometric mean of the class's range, w_c the design's loop decay, w_o = 10 w_c)")]
    out += [f"- {m.line()}" for m in adrc[1:]]
    out += ["", ("`verify/adrc_b0_sweep.py` measures what not needing b0 buys over a b0-error "
            "sweep."), ""]
    return out


def _figure(tuned, out: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    cmap = _map(tuned)
    fig, ax = plt.subplots(figsize=(7, 3))
    for e, v in cmap["radius"].items():
        ax.semilogx(np.abs(cmap["b"]), 1.0 - np.asarray(v), label=f"eps {e}")
    ax.set_xlabel("|b|")
    ax.set_ylabel("1 - spectral radius")
    ax.legend()
    fig.tight_layout()
    path = out / "class_map.png"
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def run_class(args, config_path) -> int:
    """``fl-design run CLASS.toml``."""
    from ..codegen import generate_c
    from ..tuning._tune_class import tune_class
    from ._class_table import load_class_config
    from ._cli import check_out_dir

    cfg = load_class_config(config_path)
    out = check_out_dir(args.out, force=args.force)
    start = time.perf_counter()
    if not args.no_progress:
        print(f"fl-design: tuning for {cfg.plant_class.describe()} ...", file=sys.stderr)
    tuned = tune_class(cfg.plant_class, objective=cfg.tune.objective,
                       reference=cfg.tune.reference)
    adrc = _adrc_runs(tuned, args.quick)
    cmap = _map(tuned)
    pkg = generate_c(tuned.design, out / "c", precision=cfg.codegen.precision,
                     prefix=cfg.codegen.prefix, force=args.force)
    fig = _figure(tuned, out)
    lines = class_report_lines(tuned, adrc, cmap, pkg.out_dir)
    lines += ["## Figures", "", f"![map]({fig.name})", ""]
    (out / "report.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    body = "\n".join(f"<p>{html.escape(x)}</p>" if x else "" for x in lines)
    (out / "report.html").write_text("<!doctype html><meta charset='utf-8'><title>fl-design "
                                     f"class</title>{body}<img src='{fig.name}'>",
                                     encoding="utf-8")
    summary = {"route": "class", "tuning": tuned.to_dict(), "map": cmap,
               "baseline": [adrc[0]] + [m.to_dict() for m in adrc[1:]],
               "c_package": str(pkg.out_dir), "seconds": time.perf_counter() - start}
    (out / "summary.json").write_text(json.dumps(jsonable(summary), allow_nan=False,
                                                 indent=1), encoding="utf-8")
    print("\n".join(lines[:11]))
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
    from ._cli import check_out_dir

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
