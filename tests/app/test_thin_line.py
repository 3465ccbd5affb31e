"""The report's figures draw thinned lines (:func:`fl_design.plotting.thin_line`, M4): the
picture must be the one the full line gives, checked on rendered pixels."""

from __future__ import annotations

import numpy as np
import pytest

from fl_design.errors import ParameterError
from fl_design.plotting import thin_line


def _pixels(t, y, *, step=False):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.0, 2.0), dpi=100)
    (ax.step if step else ax.plot)(t, y, color="k", lw=1.0, antialiased=False,
                                   **({"where": "post"} if step else {}))
    ax.set_xlim(t[0], t[-1])
    ax.set_ylim(np.nanmin(y) - 0.1, np.nanmax(y) + 0.1)
    fig.canvas.draw()
    img = np.asarray(fig.canvas.buffer_rgba())[..., 0].copy()
    plt.close(fig)
    return img


@pytest.mark.parametrize("step", [False, True])
def test_thinned_line_covers_the_same_pixels(step):
    rng = np.random.default_rng(3)
    t = np.arange(300_000) * 1e-3
    y = np.sin(t / 7.0) * np.exp(-t / 200.0) + 0.05 * rng.standard_normal(t.size)
    tt, yy = thin_line(t, y)
    assert len(tt) < 0.05 * len(t)
    full, thin = _pixels(t, y, step=step), _pixels(tt, yy, step=step)
    differ, drawn = np.count_nonzero(full != thin), np.count_nonzero(full < 128)
    # sub-pixel joins at bucket edges only (every 75th sample instead: ~7000 pixels differ)
    assert differ <= 0.01 * drawn, (differ, drawn)


def test_extremes_ends_and_nan_breaks_are_kept():
    t = np.arange(50_000, dtype=float)
    y = np.cos(t / 500.0)
    y[12_345] = 7.0  # a single-sample spike
    y[40_000:] = np.nan  # diverged: the line stops here
    tt, yy = thin_line(t, y, buckets=100)
    assert np.all(np.diff(tt) >= 0) and tt[0] == 0 and tt[-1] == t[-1]
    assert 12_345 in tt and np.nanmax(yy) == 7.0 and np.nanmin(yy) == np.nanmin(y)
    assert tt[np.isnan(yy)][0] == 40_000  # the first NaN: where the drawn line breaks
    assert np.all(np.isnan(yy[tt >= 40_000]))


def test_short_lines_and_none_are_unchanged_and_bad_input_named():
    t = np.arange(1000.0)
    assert thin_line(t, t, buckets=2000)[0] is not None
    assert len(thin_line(t, t, buckets=2000)[0]) == 1000
    assert len(thin_line(t, t, buckets=None)[0]) == 1000
    with pytest.raises(ParameterError, match="buckets must be a positive integer"):
        thin_line(t, t, buckets=0)
    with pytest.raises(ParameterError, match="one length"):
        thin_line(t, t[:-1])
