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


def _figures(cls, out: Path) -> dict:
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    ev, L = cls.evidence, cls.evidence.log
    est = ev.windows["local-ls"]
    paths = {}
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 6))
    ok = est.informative(0.1)
    if ok.any():
        i = int(np.argmin(np.where(ok, est.se / np.abs(est.b), np.inf)))
        a, n = int(est.start[i]), est.n_win
        U = chain_response(L.u, L.T, cls.rho, ev.delay)[a:a + n]
        y = L.y[a:a + n]
        Q = _poly_basis(n, cls.rho + 1)
        fit = Q @ (Q.T @ (y - est.b[i] * U)) + est.b[i] * U
        t = L.t[a:a + n]
        ax1.plot(t, y, ".", ms=2, label="y (log)")
        ax1.plot(t, fit, "-", label=f"local fit, b = {est.b[i]:.4g}")
        ax1.set_xlabel("t [s]")
        ax1.legend()
        ax1.set_title("the most informative window")
    for name, e in ev.windows.items():
        m = e.informative(0.1)
        ax2.errorbar(e.y_mid[m], e.b[m], yerr=3 * e.se[m], fmt="o", ms=3, label=name)
    lo, hi = cls.b
    ax2.axhspan(lo, hi, alpha=0.15, label="class b range")
    ax2.set_xlabel("mean y over the window")
    ax2.set_ylabel("b (+-3 se)")
    ax2.legend()
    fig.tight_layout()
    paths["fit"] = out / "identify_fit.png"
    fig.savefig(paths["fit"], dpi=90)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(8, 3))
    ax.plot(L.t[est.start], est.residual, ".", ms=3, label="local-ls residual rms")
    ax.axhline(ev.noise_std, color="k", lw=1, label=f"noise std {ev.noise_std:.3g}")
    ax.set_xlabel("window start [s]")
    ax.legend()
    fig.tight_layout()
    paths["residuals"] = out / "identify_residuals.png"
    fig.savefig(paths["residuals"], dpi=90)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(8, 3))
    f, p = np.asarray(ev.spectrum["f"]), np.asarray(ev.spectrum["psd"])
    if f.size:
        ax.loglog(f[1:], p[1:])
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("PSD of the residual")
    fig.tight_layout()
    paths["noise"] = out / "identify_noise.png"
    fig.savefig(paths["noise"], dpi=90)
    plt.close(fig)
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


__all__ = ["write_page"]
