"""The identification page: what was read, the class, and three plots (fit, residuals, noise).

``identify.html`` and ``identify.md`` beside ``identify_fit.png`` (the output and the local fit
over the most informative window; ``b`` per window against the visited output, both
estimators), ``identify_residuals.png`` (the local fit's residual per window against the noise
level) and ``identify_noise.png`` (the residual's Welch spectrum).

Examples
--------
>>> import tempfile, fl_design as fl
>>> from fl_design.sim._rig import chain_rig
>>> from fl_design.identification import write_page
>>> d = fl.tune(fl.PlantClass(rho=2, T=1e-3, b=(2, 10)), reference=1.0).design
>>> log = chain_rig(2, b=4.0, T=1e-3, noise_std=1e-3).run(d, lambda t: (t // 2) % 2, 12.0)
>>> paths = write_page(fl.identify(log.columns(), rho=2), tempfile.mkdtemp())
>>> sorted(p.suffix for p in paths.values())
['.html', '.md', '.png', '.png', '.png']
"""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np

from ._estimators import _poly_basis, chain_response


def best_window_fit(cls):
    """The local fit over the most informative window: ``(t, y, y_fit, b)``, or None.

    Parameters
    ----------
    cls : IdentifiedClass
        What :func:`fl_design.identify` returned.

    Returns
    -------
    tuple of (numpy.ndarray, numpy.ndarray, numpy.ndarray, float) or None
        None when no window is informative.
    """
    ev, L = cls.evidence, cls.evidence.log
    est = ev.windows["local-ls"]
    ok = est.informative(0.1)
    if not ok.any():
        return None
    i = int(np.argmin(np.where(ok, est.se / np.abs(est.b), np.inf)))
    a, n = int(est.start[i]), est.n_win
    U = chain_response(L.u, L.T, cls.rho, ev.delay)[a:a + n]
    y = L.y[a:a + n]
    Q = _poly_basis(n, cls.rho + 1)
    fit = Q @ (Q.T @ (y - est.b[i] * U)) + est.b[i] * U
    return L.t[a:a + n], y, fit, float(est.b[i])


def _figures(cls, out: Path) -> dict:
    from ..plotting import save_figure
    from ..plotting._identify import plot_identification

    paths = {}
    for key, fig in plot_identification(cls, best_window_fit(cls)).items():
        paths[key] = out / f"identify_{key}.png"
        save_figure(fig, paths[key], dpi=90)
    return paths


def write_page(cls, out_dir) -> dict:
    """Write the page and its plots into ``out_dir`` (created); returns their paths.

    Parameters
    ----------
    cls : IdentifiedClass
        The result of :func:`fl_design.identify`.
    out_dir : str or pathlib.Path
        Folder.

    Returns
    -------
    dict
        ``html``, ``markdown``, ``fit``, ``residuals``, ``noise`` paths.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = _figures(cls, out)
    lines = cls.evidence.lines()
    md = ["# Identified class", "", f"**{cls.describe()}**", "", "## Evidence", ""]
    md += [f"- {x}" for x in lines]
    md += ["", "## Plots", ""] + [f"![{k}]({p.name})" for k, p in paths.items()]
    paths["markdown"] = out / "identify.md"
    paths["markdown"].write_text("\n".join(md) + "\n", encoding="utf-8")
    body = [f"<h1>Identified class</h1><p><b>{html.escape(cls.describe())}</b></p>",
            "<h2>Evidence</h2><ul>"] + [f"<li>{html.escape(x)}</li>" for x in lines] + \
        ["</ul><h2>Plots</h2>"] + [f'<p><img src="{p.name}" alt="{k}"></p>'
                                   for k, p in paths.items() if p.suffix == ".png"]
    paths["html"] = out / "identify.html"
    paths["html"].write_text("<!doctype html><meta charset='utf-8'><title>identify</title>"
                             + "\n".join(body), encoding="utf-8")
    return paths


__all__ = ["best_window_fit", "write_page"]
