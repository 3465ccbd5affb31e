"""Write the main job's report: ``report.html`` (self-contained), ``report.md`` + PNGs, JSON.

One list of sections, two renderers: a block is ``("p", text)``, ``("pre", text)``,
``("table", header, rows)`` or ``("fig", file name, caption)``.

Examples
--------
>>> from fl_design.app import render_markdown
>>> print(render_markdown([("Title", [("p", "text"), ("table", ["a"], [[1]])])]))
## Title
<BLANKLINE>
text
<BLANKLINE>
| a |
| --- |
| 1 |
<BLANKLINE>
"""

from __future__ import annotations

import base64
import html
import time
from pathlib import Path

from .._json import dumps, jsonable
from .._output import claim_output_folder, record_outputs
from ._report_figures import (
    design_label,
    eps_star_figure,
    main_response_figure,
    stability_map_figure,
    step_figure,
    tradeoff_figure,
)
from ._report_sections import sections
from ._robust_map import save_figure as save_robust_map_figure
from ._uncertainty import summary as robustness_summary

FIGURES = {"stability_map.png": stability_map_figure, "eps_star.png": eps_star_figure,
           "steps.png": step_figure, "noise_tradeoff.png": tradeoff_figure,
           "response.png": main_response_figure}


def _cell(value) -> str:
    """A Markdown table cell: ``|`` escaped (``|e|`` would split the row)."""
    return str(value).replace("|", "\\|")


def render_markdown(secs) -> str:
    """Render sections as Markdown (figures as linked PNG files).

    Parameters
    ----------
    secs : list of (str, list)
        Sections: a title and its blocks.

    Returns
    -------
    str

    Examples
    --------
    >>> from fl_design.app import render_markdown
    >>> render_markdown([("A", [("pre", "x")])]).splitlines()[2]
    '```'
    """
    from ._report_summary import anchor

    out = []
    for title, blocks in secs:
        out += [f"## {title}", ""]
        for block in blocks:
            kind = block[0]
            if kind == "p":
                out += [block[1], ""]
            elif kind == "math":
                out += [f"{block[1]} $${block[3]}$$", ""]
            elif kind == "details":
                out += [f"<details><summary>{block[1]}</summary>", "", "```", block[2], "```",
                        "", "</details>", ""]
            elif kind == "list":
                out += [f"- {item}" for item in block[1]] + [""]
            elif kind == "links":
                out += ["| question | answer |", "| --- | --- |"]
                out += [f"| [{q}](#{anchor(sec)}) | {_cell(a)} |" for q, a, sec in block[1]]
                out.append("")
            elif kind == "pre":
                out += ["```", block[1], "```", ""]
            elif kind == "table":
                out.append("| " + " | ".join(map(_cell, block[1])) + " |")
                out.append("|" + " --- |" * len(block[1]))
                out += ["| " + " | ".join(map(_cell, row)) + " |" for row in block[2]]
                out.append("")
            elif kind == "fig":
                out += [f"![{block[2]}]({block[1]})", "", f"*{block[2]}*", ""]
    return "\n".join(out)


def render_html(secs, folder: Path, *, title: str) -> str:
    """Render sections as one self-contained HTML page (PNG figures embedded as base64).

    Parameters
    ----------
    secs : list of (str, list)
        Sections.
    folder : pathlib.Path
        Where the figures' PNG files are.
    title : str
        Page title.

    Returns
    -------
    str

    Examples
    --------
    >>> from pathlib import Path
    >>> from fl_design.app import render_html
    >>> '<h2 id="a">A</h2>' in render_html([("A", [("p", "x < y")])], Path("."), title="t")
    True
    """
    from ._report_summary import anchor

    e = html.escape
    body = [f"<h1>{e(title)}</h1>"]
    for name, blocks in secs:
        body.append(f'<h2 id="{anchor(name)}">{e(name)}</h2>')
        for block in blocks:
            kind = block[0]
            if kind == "p":
                body.append(f"<p>{e(block[1])}</p>")
            elif kind == "math":  # MathML from SymPy's printer (our own output, not user text)
                body.append(f"<p>{e(block[1])} <math>{block[2]}</math></p>")
            elif kind == "details":
                body.append(f"<details><summary>{e(block[1])}</summary><pre>{e(block[2])}"
                            "</pre></details>")
            elif kind == "list":
                body.append("<ul>" + "".join(f"<li>{e(i)}</li>" for i in block[1]) + "</ul>")
            elif kind == "links":
                rows = "".join(f'<tr><th><a href="#{anchor(sec)}">{e(q)}</a></th>'
                               f'<td class="answer">{e(a)}</td></tr>' for q, a, sec in block[1])
                body.append(f'<table class="summary">{rows}</table>')
            elif kind == "pre":
                body.append(f"<pre>{e(block[1])}</pre>")
            elif kind == "table":
                head = "".join(f"<th>{e(str(h))}</th>" for h in block[1])
                rows = "".join("<tr>" + "".join(f"<td>{e(str(c))}</td>" for c in row) + "</tr>"
                               for row in block[2])
                body.append(f"<table><tr>{head}</tr>{rows}</table>")
            elif kind == "fig":
                data = base64.b64encode((folder / block[1]).read_bytes()).decode("ascii")
                body.append(f'<figure><img alt="{e(block[2])}" src="data:image/png;base64,'
                            f'{data}"><figcaption>{e(block[2])}</figcaption></figure>')
    style = ("body{font-family:sans-serif;max-width:60em;margin:2em auto;line-height:1.4}"
             "table{border-collapse:collapse}td,th{border:1px solid #aaa;padding:2px 6px;"
             "text-align:right}pre{background:#f4f4f4;padding:.5em;overflow-x:auto}"
             "img{max-width:100%}table.summary th{text-align:left;vertical-align:top}"
             "td.answer{text-align:left}")
    return (f"<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>{e(title)}</title>"
            f"<style>{style}</style></head><body>\n" + "\n".join(body) + "\n</body></html>\n")


def _figures(job, folder: Path) -> list[str]:
    import matplotlib.pyplot as plt

    written = []
    for name, make in FIGURES.items():
        if name == "stability_map.png" and "sweep" not in job.results:
            continue
        if name in ("steps.png", "response.png") and "simulate" not in job.results:
            continue
        if name == "noise_tradeoff.png" and not job.results.get("simulate", {}).get("tradeoff"):
            continue
        if name == "eps_star.png" and "certify" not in job.results:
            continue
        fig = make(job)
        fig.savefig(folder / name, dpi=100)
        plt.close(fig)
        written.append(name)
    return written


def summary(job) -> dict:
    """The job's numbers as a strict-JSON-ready dict (what ``summary.json`` holds).

    Parameters
    ----------
    job : Job
        A finished job.

    Returns
    -------
    dict

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
           "timings_s": dict(job.timings)}
    if "sweep" in res:  # the machine and instruction set the sweep's kernel ran on
        from ..sim import Kernel

        out["kernel"] = Kernel().describe()
    cert = res.get("certify")
    if cert:
        out["certify"] = {k: (v.to_dict() if hasattr(v, "to_dict") else v)
                          for k, v in cert.items()}
    if "sweep" in res:
        smap = res["sweep"]
        out["sweep"] = smap.to_dict() | {"eps_star": [
            {"gamma": float(g), **smap.eps_star(g).to_dict()} for g in smap.gamma]}
    sim = res.get("simulate")
    if sim:
        from ._job import noise_levels

        out["simulate"] = {"duration_s": sim["duration"],
                           "duration_reason": sim.get("duration_reason", "given"),
                           "main": _run_row(sim["main"]),
                           "runs": [{"design": n, "noise_std": s, **_run_row(r),
                                     **noise_levels(r)} for (n, s), r in sim["runs"].items()],
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
    return {"status": resp.status, "verdict": resp.verdict(), "duration_s": resp.duration,
            "duration_reason": resp.duration_reason, "metrics": m}


def write_report(job, out_dir, *, force: bool = False, main_csv: bool = False,
                 csv_written: list | None = None) -> dict:
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
        Also write the main run as CSV (the default 300 s run is 300 000 rows, ~73 MB and
        ~3 s of float formatting: opt-in, ``fl-design run --main-csv``).
    csv_written : list of str, optional
        The CSV files the caller already wrote into this folder (:func:`write_runs_csv`'s
        result; ``fl-design run`` writes them while the C compilers run): recorded, not
        written again.

    Returns
    -------
    dict
        ``{"html": path, "markdown": path, "summary": path, "figures": [names],
        "csv": [relative paths of the runs' CSV files]}``.

    Examples
    --------
    >>> from fl_design.app import load_config, run_job, write_report
    >>> job = run_job(load_config(None), quick=True, stages=("derive",), progress=False)
    >>> sorted(write_report(job, "."))
    ['csv', 'figures', 'html', 'markdown', 'summary']
    """
    folder = claim_output_folder(out_dir, force=force, what="report folder")
    start = time.perf_counter()
    figures = _figures(job, folder) + save_robust_map_figure(job, folder)
    job.timings["report_figures"] = time.perf_counter() - start
    if csv_written is None:
        start = time.perf_counter()
        csv = write_runs_csv(job, folder, main=main_csv)
        job.timings["report_csv"] = time.perf_counter() - start  # before summary.json: in it
    else:
        csv = list(csv_written)
    secs = sections(job, figures)
    title = f"fl_design report: {job.plant.name}, {design_label(job.design)}"
    paths = {"html": folder / "report.html", "markdown": folder / "report.md",
             "summary": folder / "summary.json"}
    paths["html"].write_text(render_html(secs, folder, title=title), encoding="utf-8")
    paths["markdown"].write_text(f"# {title}\n\n" + render_markdown(secs), encoding="utf-8")
    paths["summary"].write_text(dumps(summary(job), indent=2), encoding="utf-8")
    record_outputs(folder, [*paths.values(), *(folder / name for name in figures),
                            *(folder / name for name in csv)])
    return {**{k: str(v) for k, v in paths.items()}, "figures": figures, "csv": csv}


def run_csv_name(design: str, std: float) -> str:
    """File name of a compared run's CSV: ``runs/<design>_noise<std>.csv`` (safe characters).

    Parameters
    ----------
    design : str
        The design's label (``"EHGO eps=0.05"``, ``"LS(9)"``, or ``"main"``).
    std : float
        Noise standard deviation of the run.

    Returns
    -------
    str

    Examples
    --------
    >>> from fl_design.app._report_write import run_csv_name
    >>> run_csv_name("LS(9)", 0.001), run_csv_name("EHGO eps=0.05", 0.0)
    ('runs/LS9_noise0.001.csv', 'runs/EHGO_eps0.05_noise0.csv')
    """
    import re

    safe = re.sub(r"[^A-Za-z0-9.]+", "_", design.replace("(", "").replace(")", "")).strip("_")
    safe = safe.replace("_eps_", "_eps").replace("eps_", "eps")
    return f"runs/{safe}_noise{std:g}.csv"


def write_runs_csv(job, folder, *, main: bool = False) -> list:
    """Write the compared runs (and, with ``main``, the main run) as CSV under
    ``folder/runs`` (:meth:`fl_design.Response.to_csv`: every sample, exact); return the
    relative paths.

    Without ``main``, a main-run CSV this folder holds from fl_design's own earlier run
    (recorded in its marker, unchanged) is removed, so the folder never pairs this report with
    an older main run; a file fl_design did not write is left alone.

    Parameters
    ----------
    job : Job
        A job (nothing is written without its simulate stage).
    folder : str or pathlib.Path
        The report's folder.
    main : bool, optional
        Also write the main run (``runs/main_noise<std>.csv``; 300 000 rows for the default
        300 s run, so opt-in).

    Returns
    -------
    list of str

    Examples
    --------
    >>> from fl_design.app import load_config, run_job
    >>> from fl_design.app._report_write import write_runs_csv
    >>> write_runs_csv(run_job(load_config(None), quick=True, stages=("derive",),
    ...                        progress=False), ".")
    []
    """
    sim = job.results.get("simulate")
    if not sim:
        return []
    runs = dict(sim["runs"])
    main_key = ("main", job.config.scenario.noise_std)
    if main:
        runs[main_key] = sim["main"]
    else:
        _remove_own(Path(folder), run_csv_name(*main_key))
    out = Path(folder) / "runs"
    out.mkdir(exist_ok=True)
    names = []
    for (design, std), resp in runs.items():
        name = run_csv_name(design, std)
        resp.to_csv(Path(folder) / name, overwrite=True)  # the report's own folder
        names.append(name)
    return names


def _remove_own(folder: Path, name: str) -> None:
    """Delete ``folder/name`` only if the folder's marker records it with this content."""
    from .._output import _digest, _recorded

    sha = (_recorded(folder) or {}).get(name)
    target = folder / name
    if sha is not None and _digest(target) == sha:
        target.unlink()


_CSV_TIMEOUT = 900.0  # seconds: a 300 s main run's CSV takes about 3 s


class BackgroundCsv:
    """Write the runs' CSV files (:func:`write_runs_csv`) in a thread started when the
    ``simulate`` stage is done: the float formatting (seconds for the full job) runs while the
    C stage waits for its compilers. ``fl-design run`` passes :meth:`after` to
    :func:`~fl_design.app.run_job` and :meth:`result` to :func:`write_report`.

    Parameters
    ----------
    out : str or pathlib.Path
        The report's folder (already claimed: :func:`fl_design._output.claim_output_folder`).
    main : bool
        Also write the main run.

    Examples
    --------
    >>> from fl_design.app import load_config, run_job
    >>> import tempfile
    >>> from fl_design.app._report_write import BackgroundCsv
    >>> w = BackgroundCsv(tempfile.mkdtemp(), main=False)  # a new, empty folder
    >>> job = run_job(load_config(None), quick=True, stages=("derive", "simulate"),
    ...               progress=False, after=w.after)
    >>> len(w.result()) == len(job.results["simulate"]["runs"])
    True
    """

    def __init__(self, out, *, main: bool):
        self.out, self.main = out, main
        self.thread = self.names = self.error = None
        self.cpu = 0.0  # seconds of CPU the thread used

    def after(self, stage: str, job) -> None:
        """Start the thread when ``stage`` is ``simulate`` (a :func:`run_job` ``after`` hook).

        Examples
        --------
        >>> from fl_design.app._report_write import BackgroundCsv
        >>> w = BackgroundCsv(".", main=False)
        >>> w.after("sweep", None); w.thread is None
        True
        """
        if stage != "simulate":
            return
        import threading

        def work():
            start, cpu = time.perf_counter(), time.thread_time()
            try:
                self.names = write_runs_csv(job, self.out, main=self.main)
            except BaseException as exc:  # noqa: BLE001 - re-raised in the main thread
                self.error = exc
            job.timings["report_csv"] = time.perf_counter() - start
            self.cpu = time.thread_time() - cpu  # also in the stages' process CPU times

        self.thread = threading.Thread(target=work, name="fl-design-csv", daemon=True)
        self.thread.start()

    def wait(self) -> None:
        """Wait for the thread (at most 900 s; errors stay for :meth:`result`).

        Examples
        --------
        >>> from fl_design.app._report_write import BackgroundCsv
        >>> BackgroundCsv(".", main=False).wait()
        """
        if self.thread is not None:
            self.thread.join(timeout=_CSV_TIMEOUT)

    def result(self) -> list | None:
        """The files written (None: never started); the thread's error is raised here.

        Examples
        --------
        >>> from fl_design.app._report_write import BackgroundCsv
        >>> BackgroundCsv(".", main=False).result() is None
        True
        """
        from ..errors import ComputationError

        if self.thread is None:
            return None
        self.wait()
        if self.thread.is_alive():
            raise ComputationError(f"writing the runs' CSV files into {str(self.out)!r} took "
                                   f"over {_CSV_TIMEOUT:.0f} s; is the folder on a slow disk?")
        if self.error is not None:
            raise self.error
        return self.names


__all__ = ["FIGURES", "BackgroundCsv", "render_html", "render_markdown", "run_csv_name", "summary",
           "write_report", "write_runs_csv"]
