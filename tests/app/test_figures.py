"""The report's figures read at a glance: short titles, legends outside the data, tick labels
that do not overlap, units on the axes (checked on the rendered figures' text boxes)."""

from __future__ import annotations

import itertools

import pytest

from fl_design.app import load_config, run_job
from fl_design.app._report_write import FIGURES


@pytest.fixture(scope="module")
def figures():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    job = run_job(load_config(None), quick=True, stages=("certify", "sweep", "simulate"),
                  progress=False)
    made = {name: make(job) for name, make in FIGURES.items()}
    for fig in made.values():
        fig.canvas.draw()
    yield made
    for fig in made.values():
        plt.close(fig)


def _overlap(a, b) -> bool:
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


@pytest.mark.parametrize("name", list(FIGURES))
def test_legends_stay_off_the_data_and_ticks_do_not_overlap(figures, name):
    fig = figures[name]
    renderer = fig.canvas.get_renderer()
    for ax in fig.axes:
        legend = ax.get_legend()
        if legend is not None:
            assert not _overlap(legend.get_window_extent(renderer),
                                ax.get_window_extent(renderer)), f"{name}: legend on the data"
        for axis in (ax.xaxis, ax.yaxis):
            boxes = [t.get_window_extent(renderer) for t in axis.get_ticklabels()
                     if t.get_visible() and t.get_text()]
            for a, b in itertools.combinations(boxes, 2):
                assert not _overlap(a, b), f"{name}: tick labels overlap"
        title = ax.get_title()
        assert len(title) <= 60 and "\n" not in title, f"{name}: title {title!r}"
        for label in (ax.get_xlabel(), ax.get_ylabel()):
            if label and label not in ("controller gain gamma",):
                assert "(" in label, f"{name}: no unit in {label!r}"
    if fig._suptitle is not None:
        assert len(fig._suptitle.get_text()) <= 60
