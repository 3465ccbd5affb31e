"""Which figures the report draws, from a finished job (the drawing: :mod:`fl_design.plotting`).

:func:`figure_context` gathers the names, units and the design's point the figures print;
:func:`write_figures` draws each figure the job's results allow and writes it as PNG. A figure
that fails to draw (matplotlib raises on text it cannot lay out, a result holds nothing to
draw) is left out with its reason, and the report is still written.

Examples
--------
>>> from fl_design.app._report_figures import FIGURES
>>> list(FIGURES)[:2]
['response.png', 'steps.png']
"""

from __future__ import annotations

import math
import time
from pathlib import Path

from ._brief import run_brief, window_brief
from ._text import overshoot_text, paper_gamma_bound


def figure_context(job):
    """The :class:`~fl_design.plotting.FigureContext` of a job: plant, units, design point.

    Parameters
    ----------
    job : Job
        A job after its derive stage (or any stage: missing parts are left out).

    Returns
    -------
    fl_design.plotting.FigureContext

    Examples
    --------
    >>> from fl_design.app import load_config, run_job
    >>> from fl_design.app._report_figures import figure_context
    >>> job = run_job(load_config(None), quick=True, stages=("derive",), progress=False)
    >>> figure_context(job).gamma_unit
    'V s^2/rad'
    """
    from ..plotting import FigureContext

    d, p = job.design, job.config.plant
    b = (job.derivation or {}).get("b_bounds")
    bound, text = paper_gamma_bound(b) if b is not None else (math.nan, "")
    return FigureContext(
        plant=job.plant.name, y_unit=p.output_unit or "", u_unit=p.input_unit or "",
        rho=job.plant.relative_degree(), design_gamma=float(d.controller.gamma),
        design_eps=float(d.estimator.eps) if d.estimator.has_time_constant else None,
        gamma_bound=bound, gamma_bound_text=text, u_eq=(job.derivation or {}).get("u_eq"))


def map_curves(job) -> dict:
    """Legend label -> ``(gamma, eps_star)`` of the curves the certify stage drew over the
    stability map: certified (LMI) and linearized (none without that stage).

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> from fl_design.app._report_figures import map_curves
    >>> map_curves(SimpleNamespace(results={"certify": {"linearized": {
    ...     "gamma": [1.0], "eps_star": [0.1]}}}))
    {'linearized eps*': ([1.0], [0.1])}
    """
    cert = job.results.get("certify", {})
    curves = {}
    if "curve" in cert:
        curves["certified eps* (LMI)"] = (cert["curve"].gamma, cert["curve"].eps_star_certified)
    if "linearized" in cert:
        curves["linearized eps*"] = (cert["linearized"]["gamma"], cert["linearized"]["eps_star"])
    return curves


def _map(job, ctx):
    from ..plotting._report import stability_map_figure

    return stability_map_figure(job.results["sweep"], ctx, curves=map_curves(job))


def _eps_star(job, ctx):
    from ..plotting._report import eps_star_figure

    cert = job.results.get("certify", {})
    lin = cert.get("linearized")
    return eps_star_figure(ctx, curve=cert.get("curve"),
                           linearized=(lin["gamma"], lin["eps_star"]) if lin else None,
                           smap=job.results.get("sweep"))


def step_labels(sim) -> dict:
    """Legend text of each compared run: its name and its overshoot (or why it has none).

    Examples
    --------
    >>> from fl_design.app._report_figures import step_labels
    >>> step_labels({"runs": {}, "compare_duration": 30.0})
    {}
    """
    out = {}
    for (name, std), r in sim["runs"].items():
        over = overshoot_text(r)
        if over[:1].isdigit():
            text = f"{name}: overshoot {over} %"
        else:
            text = f"{name}: {window_brief(r, sim['compare_duration']).split(' (')[0]}"
        out[(name, std)] = text
    return out


def _steps(job, ctx):
    from ..plotting._report import step_figure

    sim = job.results["simulate"]
    window = f"first {sim['compare_duration']:g} s: the transient ({sim['compare_reason']})"
    return step_figure(sim["runs"], sim["designs"], sim["stds"], ctx, labels=step_labels(sim),
                       window=window if len(window) < 70 else
                       f"first {sim['compare_duration']:g} s: the transient")


def _tradeoff(job, ctx):
    from ..plotting._report import tradeoff_figure

    return tradeoff_figure(job.results["simulate"]["tradeoff"], ctx)


def response_title(job, ctx) -> str:
    """The main run's figure title: ``ctx``'s plant and the run's short verdict, one line.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> from fl_design.plotting import FigureContext
    >>> from fl_design.app._report_figures import response_title
    >>> r = fl.simulate(fl.plants.pendulum(), fl.presets.pendulum_design(), fl.Scenario(0.1, 20.0))
    >>> response_title(SimpleNamespace(results={"simulate": {"main": r}}), FigureContext("p"))
    'p: converged — overshoot 0 %, in the band from 9.08 s'
    """
    resp = job.results["simulate"]["main"]
    return " ".join(f"{ctx.plant}: {run_brief(resp)}".replace(" (beyond the run)", "").split())


def _response(job, ctx):
    from ..plotting._report import response_figure

    resp = job.results["simulate"]["main"]
    title = response_title(job, ctx)
    words = title.split(" ")
    while len(" ".join(words)) > 86 and len(words) > 1:  # one line: whole words
        words.pop()
    cut = " ".join(words)
    return response_figure(resp, ctx, title=cut if cut == title else cut.rstrip(",;") + " …")


def _robust(job, ctx):
    from ..plotting._report import robust_map_figure
    from ._report_family import LEVELS

    return robust_map_figure(job.results["robust_map"], ctx, level=LEVELS[0])


#: File name -> (draws it, the results it needs).
FIGURES = {"response.png": (_response, "simulate"), "steps.png": (_steps, "simulate"),
           "noise_tradeoff.png": (_tradeoff, "tradeoff"), "stability_map.png": (_map, "sweep"),
           "eps_star.png": (_eps_star, "certify"), "robust_map.png": (_robust, "robust_map")}


def _has(job, need: str) -> bool:
    if need == "tradeoff":
        return bool(job.results.get("simulate", {}).get("tradeoff"))
    return need in job.results


def write_figures(job, folder, *, names=None, drawn=None) -> tuple[list, dict]:
    """Draw every figure the job's results allow into ``folder`` (PNG).

    Parameters
    ----------
    job : Job
        A finished job.
    folder : str or pathlib.Path
        The report's folder.
    names : iterable of str, optional
        Only these figures of :data:`FIGURES` (default all).
    drawn : (list, dict), optional
        Figures already written (or failed) into ``folder`` by :class:`FiguresAhead`: kept,
        not drawn again, and part of the result.

    Returns
    -------
    (list of str, dict)
        The files written, and ``{file: reason}`` of the figures that could not be drawn.

    Examples
    --------
    >>> import tempfile
    >>> from fl_design.app import load_config, run_job
    >>> from fl_design.app._report_figures import write_figures
    >>> job = run_job(load_config(None), quick=True, stages=("derive",), progress=False)
    >>> write_figures(job, tempfile.mkdtemp())
    ([], {})
    """
    from ..plotting import close_figure, save_figure

    written, failed = (list(drawn[0]), dict(drawn[1])) if drawn else ([], {})
    wanted = set(FIGURES if names is None else names) - set(written) - set(failed)
    todo = [(name, draw) for name, (draw, need) in FIGURES.items()
            if name in wanted and _has(job, need)]
    if not todo:
        return written, failed
    ctx = figure_context(job)
    for name, draw in todo:
        fig = None
        try:
            fig = draw(job, ctx)
            save_figure(fig, Path(folder) / name)
        except Exception as err:  # noqa: BLE001 - a figure never stops the report
            if fig is not None:
                close_figure(fig)
            first = (str(err).strip().splitlines() or [""])[0][:160]
            failed[name] = f"{type(err).__name__}: {first}" if first else type(err).__name__
            continue
        written.append(name)
    return written, failed


#: The figures drawn from stages of this process alone (the certify stage's results, which the
#: stability map's curves and the eps* figure show, may still be on their way).
AHEAD = ("response.png", "steps.png", "noise_tradeoff.png", "robust_map.png")


class FiguresAhead:
    """Draw the figures of :data:`AHEAD` while the certify stage still runs beside the job.

    ``fl-design run`` passes :meth:`after` to :func:`~fl_design.app.run_job`: when the last
    stage of this process (``codegen``) is done and the certify stage (in its child process)
    is not, this process would only wait; it draws those figures meanwhile, in this thread
    (matplotlib is not thread safe), and :func:`~fl_design.app.write_report` draws the rest.

    Parameters
    ----------
    folder : str or pathlib.Path
        The report's folder (already claimed: :func:`fl_design._output.claim_output_folder`).

    Examples
    --------
    >>> from fl_design.app._report_figures import FiguresAhead
    >>> ahead = FiguresAhead(".")
    >>> ahead.after("sweep", None); ahead.drawn, ahead.seconds
    (None, 0.0)
    """

    def __init__(self, folder):
        self.folder, self.drawn, self.seconds = folder, None, 0.0

    def after(self, stage: str, job) -> None:
        """Draw the figures of :data:`AHEAD` when ``stage`` is ``codegen`` and the certify
        stage's results are not in ``job`` yet (a :func:`run_job` ``after`` hook)."""
        if stage != "codegen" or "certify" in job.results:
            return
        start = time.perf_counter()
        self.drawn = write_figures(job, self.folder, names=AHEAD)
        self.seconds = time.perf_counter() - start


__all__ = ["AHEAD", "FIGURES", "FiguresAhead", "figure_context", "map_curves", "response_title", "step_labels",
           "write_figures"]
