"""Write the main job's report: ``report.html`` (self-contained), ``report.md`` + PNGs, JSON,
and the runs as CSV.

The sections come from :mod:`fl_design.app._report_sections`, the renderers from
:mod:`fl_design.app._report_render`, the figures from :mod:`fl_design.app._report_figures`
(a figure that fails is named in the report, never a traceback), the CSV files from
:mod:`fl_design.app._report_csv`.

Examples
--------
>>> from pathlib import Path
>>> from fl_design.app import load_config, run_job, write_report
>>> job = run_job(load_config(None), quick=True, stages=("derive",), progress=False)
>>> Path(write_report(job, "report")["markdown"]).read_text().startswith("# ")
True
"""

from __future__ import annotations

import time

from .._json import dumps, jsonable
from .._output import claim_output_folder, record_outputs, write_output
from ._brief import run_brief
from ._report_csv import CSV_MAX_ROWS, BackgroundCsv, run_csv_name, write_runs_csv
from ._report_family import summary as robustness_summary
from ._report_figures import FIGURES, write_figures
from ._report_interactive import live_figures
from ._report_render import md, render_html, render_markdown
from ._report_sections import sections
from ._text import design_label


def summary(job) -> dict:
    """The job's numbers as a strict-JSON-ready dict (what ``summary.json`` holds).

    Parameters
    ----------
    job : Job
        A finished job.

    Returns
    -------
    dict
        The config, the design, the derivation, each stage's results and timings; every
        float finite or None.

    Examples
    --------
    >>> from fl_design.app import load_config, run_job, summary
    >>> job = run_job(load_config(None), quick=True, stages=("derive",), progress=False)
    >>> summary(job)["derivation"]["rho"]
    2
    """
    res = job.results
    out = {"config": job.config.to_dict(), "quick": job.quick, "design": design_label(job.design),
           "derivation": {k: v for k, v in job.derivation.items()
                          if k not in ("text", "a_mathml", "b_mathml")},
           "timings_s": dict(job.timings),
           # a worker died mid-sweep: the counts, so a script never reads it as complete
           "complete": not getattr(job, "lost", None),
           "lost": {stage: line for stage, line in (getattr(job, "lost", None) or {}).items()}}
    if "sweep" in res:  # the machine and instruction set the sweep's kernel ran on
        from ..sim import Kernel

        out["kernel"] = Kernel().describe()
    cert = res.get("certify")
    if cert:
        out["certify"] = {k: (v.to_dict() if hasattr(v, "to_dict") else v)
                          for k, v in cert.items()}
    if "sweep" in res:
        smap = res["sweep"]
        out["sweep"] = smap.to_dict() | {"n_runs": int(smap.status.size),
                                         "n_lost": int(getattr(smap, "n_lost", 0)),
                                         "eps_star": [
            {"gamma": float(g), **smap.eps_star(g).to_dict()} for g in smap.gamma]}
    sim = res.get("simulate")
    if sim:
        out["simulate"] = {"duration_s": sim["duration"],
                           "duration_reason": sim.get("duration_reason", "given"),
                           "main": _run_row(sim["main"]),
                           "compare_duration_s": sim["compare_duration"],
                           "compare_reason": sim.get("compare_reason", "given"),
                           "runs": [{"design": n, "noise_std": s, **_run_row(r),
                                     **sim["levels"][(n, s)]}
                                    for (n, s), r in sim["runs"].items()],
                           "noise_tradeoff": sim["tradeoff"]}
    if "robustness" in res:
        out["robustness"] = robustness_summary(job)
    cg = res.get("codegen")
    if cg and "package" in cg:
        out["codegen"] = {"out_dir": str(cg["package"].out_dir), "sil": cg["sil"].to_dict(),
                          "costs": cg["costs"].to_dict()}
    return jsonable(out)


def _run_row(resp) -> dict:
    m = {k: v for k, v in resp.metrics.items() if k != "estimation_rms"}
    return {"status": resp.status, "verdict": resp.verdict(), "brief": str(run_brief(resp)),
            "duration_s": resp.duration,
            "duration_reason": resp.duration_reason, "metrics": m}


def write_report(job, out_dir, *, force: bool = False, main_csv: bool = False,
                 csv_written: list | None = None, full_csv: bool = False,
                 interactive: bool = True, figures_ahead=None) -> dict:
    """Write ``report.html``, ``report.md``, the PNG figures, ``summary.json`` and the compared
    runs as CSV (:func:`write_runs_csv`).

    The seconds spent on the figures and on the CSV files are added to ``job.timings``
    (``report_figures``, ``report_csv``; ``summary.json`` lists them).

    Parameters
    ----------
    job : Job
        A finished job.
    out_dir : str or pathlib.Path
        The output folder: empty, or holding fl_design's own earlier output unchanged
        (:func:`fl_design._output.claim_output_folder`).
    force : bool, optional
        Write even into a folder holding other files (they may be replaced).
    main_csv : bool, optional
        Also write the main run as CSV (opt-in, ``fl-design run --main-csv``).
    full_csv : bool, optional
        Every sample in the CSV files (default at most
        :data:`~fl_design.app._report_csv.CSV_MAX_ROWS` rows each: ``--full-csv``).
    csv_written : list of str, optional
        The CSV files the caller already wrote into this folder (:func:`write_runs_csv`'s
        result; ``fl-design run`` writes them while the C compilers run): recorded, not
        written again.
    interactive : bool, optional
        Draw the main figures of ``report.html`` with Plotly.js inlined in the page (zoom,
        hover values; :mod:`fl_design.app._report_interactive`), the PNG kept for print
        (default); False: PNG only and no script (``fl-design run --static-report``).
        ``report.md`` links the PNG files either way.
    figures_ahead : FiguresAhead, optional
        Figures the caller drew into this folder while the certify stage ran
        (:class:`~fl_design.app._report_figures.FiguresAhead`): kept, not drawn again; their
        seconds are counted in ``report_figures``.

    Returns
    -------
    dict
        ``{"html": path, "markdown": path, "summary": path, "figures": [names],
        "csv": [relative paths of the runs' CSV files], "failed_figures": {name: reason},
        "live_figures": [names drawn live in report.html]}``.

    Examples
    --------
    >>> from fl_design.app import load_config, run_job, write_report
    >>> job = run_job(load_config(None), quick=True, stages=("derive",), progress=False)
    >>> sorted(write_report(job, "."))
    ['csv', 'failed_figures', 'figures', 'html', 'live_figures', 'markdown', 'summary']
    """
    folder = claim_output_folder(out_dir, force=force, what="report folder")
    start = time.perf_counter()
    ahead = figures_ahead.drawn if figures_ahead is not None else None
    figures, failed = write_figures(job, folder, drawn=ahead)
    job.timings["report_figures"] = time.perf_counter() - start + (
        figures_ahead.seconds if ahead else 0.0)
    if csv_written is None:
        start = time.perf_counter()
        csv = write_runs_csv(job, folder, main=main_csv, full=full_csv)
        job.timings["report_csv"] = time.perf_counter() - start  # before summary.json: in it
    else:
        csv = list(csv_written)
    secs = sections(job, figures, failed)
    if csv:
        secs[-1][1].append(("p", f"{len(csv)} runs as CSV under runs/: " + (
            "every sample." if full_csv else f"at most {CSV_MAX_ROWS} rows each (every k-th "
            "sample and the last; `fl-design run --full-csv` writes every sample).")))
    live, why = live_figures(job, figures) if interactive else (None, "")
    if why:
        secs[-1][1].append(("p", f"Interactive figures: {why}."))
    title = f"fl_design report: {job.plant.name}"
    paths = {"html": folder / "report.html", "markdown": folder / "report.md",
             "summary": folder / "summary.json"}
    # by name, never through a link or into a folder in the way (a temporary file, replaced)
    write_output(folder, "report.html", render_html(secs, folder, title=title, live=live),
                 record=False)
    write_output(folder, "report.md", f"# {md(title)}\n\n" + render_markdown(secs),
                 record=False)
    write_output(folder, "summary.json", dumps(summary(job), indent=2), record=False)
    record_outputs(folder, [*paths.values(), *(folder / name for name in figures),
                            *(folder / name for name in csv)])
    return {**{k: str(v) for k, v in paths.items()}, "figures": figures, "csv": csv,
            "failed_figures": failed, "live_figures": list(live.specs) if live else []}


__all__ = ["FIGURES", "BackgroundCsv", "render_html", "render_markdown", "run_csv_name", "summary",
           "write_report", "write_runs_csv"]
