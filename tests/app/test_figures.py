"""The report's figures read at a glance: one-line titles, legends below the axes or inside
them without hiding the data, tick labels that do not overlap, units on the axes, the same
colour for the same design in every panel (checked on the rendered figures)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from fl_design.app import load_config, run_job
from fl_design.app._report_figures import FIGURES, figure_context

NAMES = [n for n in FIGURES if n != "robust_map.png"]  # tests/app/test_uncertainty.py


@pytest.fixture(scope="module")
def figures():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    job = run_job(load_config(None), quick=True, stages=("certify", "sweep", "simulate"),
                  progress=False)
    ctx = figure_context(job)
    made = {name: FIGURES[name][0](job, ctx) for name in NAMES}
    for fig in made.values():
        fig.canvas.draw()
    yield made
    for fig in made.values():
        plt.close(fig)


def _overlap(a, b) -> bool:
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


def _hidden_fraction(ax, box) -> float:
    """Fraction of the axes' line points (display coordinates) under the legend's box."""
    pts = [line.get_transform().transform(np.column_stack(line.get_data()))
           for line in ax.get_lines() if len(line.get_xdata()) > 1]
    if not pts:
        return 0.0
    xy = np.vstack(pts)
    xy = xy[np.all(np.isfinite(xy), axis=1)]
    inside = ((xy[:, 0] > box.x0) & (xy[:, 0] < box.x1) & (xy[:, 1] > box.y0)
              & (xy[:, 1] < box.y1))
    return float(inside.mean()) if xy.size else 0.0


@pytest.mark.parametrize("name", NAMES)
def test_legends_hide_no_data_and_ticks_do_not_overlap(figures, name):
    fig = figures[name]
    renderer = fig.canvas.get_renderer()
    for ax in fig.axes:
        legend = ax.get_legend()
        if legend is not None:
            box = legend.get_window_extent(renderer)
            assert box.x0 >= -1 and box.x1 <= fig.bbox.x1 + 1, f"{name}: legend cut off"
            if _overlap(box, ax.get_window_extent(renderer)):  # inside: over no data
                assert _hidden_fraction(ax, box) < 0.03, f"{name}: legend on the data"
        for axis in (ax.xaxis, ax.yaxis):
            boxes = [t.get_window_extent(renderer) for t in axis.get_ticklabels()
                     if t.get_visible() and t.get_text()]
            for a, b in itertools.combinations(boxes, 2):
                assert not _overlap(a, b), f"{name}: tick labels overlap"
        for where in ("center", "left"):
            title = ax.get_title(loc=where)
            assert len(title) <= 90 and "\n" not in title, f"{name}: title {title!r}"
        for label in (ax.get_xlabel(), ax.get_ylabel()):
            if label:
                assert "(" in label, f"{name}: no unit in {label!r}"
    if fig._suptitle is not None:
        assert len(fig._suptitle.get_text()) <= 100 and "\n" not in fig._suptitle.get_text()


def test_a_design_has_one_colour_in_every_panel(figures):
    fig = figures["steps.png"]
    colours = [{line.get_label().split(":")[0]: line.get_color() for line in ax.get_lines()
                if not line.get_label().startswith("_")} for ax in fig.axes]
    assert all(c == colours[0] for c in colours) and len(colours[0]) == 3


def test_the_comparison_figure_says_its_window(figures):
    sup = figures["steps.png"]._suptitle.get_text()
    assert "first 4 s" in sup and "transient" in sup
