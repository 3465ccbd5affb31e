"""The report's main figures as Plotly figure specs: plain dicts (``{"data", "layout"}``), no
Plotly import here, drawn by Plotly.js in the page (zoom, hover values).

Same colours and labels as the PNG figures of :mod:`fl_design.plotting._report`: the
configured design ``C0`` and a gold star, the compared designs ``C0``, ``C1``, ..., the
reference black dashed, the paper's gamma bound black dotted, the map's statuses
:data:`~fl_design.plotting._base.STATUS_COLORS`. Every line is thinned by
:func:`~fl_design.plotting._base.thin_line` to at most ``5 * INTERACTIVE_BUCKETS`` points
(plus fewer than one bucket's samples), values rounded to 6 significant digits (times to 8).
Every name a user chose is escaped for Plotly's text (``<``, ``>``, ``&`` as entities: Plotly
reads a small HTML subset in titles, legends and hover text, and shows entities literally).

Examples
--------
>>> from fl_design.plotting._plotly import plotly_text
>>> plotly_text("<b>x</b> & y")
'&lt;b&gt;x&lt;/b&gt; &amp; y'
"""

from __future__ import annotations

import math

import numpy as np

from ._base import (
    OUTSIDE_RANGE,
    STATUS_COLORS,
    bracket_points,
    edges,
    is_bracket,
    status_legend,
    thin_line,
)
from ._maps import LOST_LABEL, MAP_EPS_STAR, lost_points

#: Time buckets per line (:func:`thin_line`): at most 5 points each, 2500 per trace.
INTERACTIVE_BUCKETS = 500

#: matplotlib's default cycle ``C0`` .. ``C9`` (the PNG figures' colours).
CYCLE = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
         "#7f7f7f", "#bcbd22", "#17becf")

_FONT = {"family": "system-ui, -apple-system, Segoe UI, Roboto, Arial, sans-serif", "size": 12}


def plotly_text(text) -> str:
    """``text`` on one line, shown literally by Plotly (``&``, ``<``, ``>`` as entities).

    Parameters
    ----------
    text : object
        ``str()`` of it is used.

    Examples
    --------
    >>> from fl_design.plotting._plotly import plotly_text
    >>> plotly_text("</script>\\nx")
    '&lt;/script&gt; x'
    """
    one = " ".join(str(text).split())
    return one.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def _num(values, digits: int = 6) -> list:
    """Floats rounded to ``digits`` significant digits; NaN and inf as None (a gap)."""
    out = []
    for v in np.asarray(values, dtype=float).ravel().tolist():
        out.append(float(f"{v:.{digits}g}") if math.isfinite(v) else None)
    return out


def _line(t, y, *, name: str, color: str, dash: str = "solid", width: float = 1.4,
          axis: int = 1, shape: str = "linear", legend: str = "legend", show: bool = True):
    tt, yy = thin_line(np.asarray(t, dtype=float), np.asarray(y, dtype=float),
                       INTERACTIVE_BUCKETS)
    return {"type": "scatter", "mode": "lines", "x": _num(tt, 8), "y": _num(yy),
            "name": name, "line": {"color": color, "dash": dash, "width": width,
                                   "shape": shape},
            "xaxis": "x", "yaxis": "y" if axis == 1 else f"y{axis}", "legend": legend,
            "showlegend": show, "hovertemplate": "%{y:.4g}"}


def _label(what: str, unit: str) -> str:
    """``what (unit)`` for Plotly (the unit as the user wrote it, escaped)."""
    return f"{what} ({plotly_text(unit)})" if unit else what


def _gamma_unit(ctx) -> str:
    return plotly_text(f"{ctx.u_unit} s^{ctx.rho}/{ctx.y_unit}")


def _layout(title: str, height: int, **more) -> dict:
    return {"title": {"text": title, "x": 0.01, "xanchor": "left", "font": {"size": 14}},
            "height": height, "font": _FONT, "margin": {"l": 70, "r": 20, "t": 40, "b": 50},
            "paper_bgcolor": "#ffffff", "plot_bgcolor": "#ffffff", **more}


def _axis(title: str, **more) -> dict:
    return {"title": {"text": title}, "showline": True, "linecolor": "#444", "mirror": True,
            "ticks": "outside", "gridcolor": "#eeeeee", "zeroline": False, **more}


def _log_axis(lo: float, hi: float) -> dict:
    """A log axis over ``[lo, hi]`` (log10 of the ends) labelled like the PNG figures: plain
    numbers (``0.0001``), the decades only over more than 2.5 decades, else 1, 2, 5."""
    return {"type": "log", "range": [lo, hi], "tickformat": "~g",
            "dtick": 1 if hi - lo > 2.5 else "D2"}


def _legend_inside(y: float) -> dict:
    return {"x": 0.995, "xanchor": "right", "y": y, "yanchor": "top",
            "bgcolor": "rgba(255,255,255,0.85)", "bordercolor": "#cccccc", "borderwidth": 1,
            "font": {"size": 11}}


def response_spec(resp, ctx, *, title: str) -> dict:
    """The configured design's run: output and reference, input (``u_eq`` dotted), sigma.

    Parameters
    ----------
    resp : fl_design.Response
        The run.
    ctx : fl_design.plotting.FigureContext
        Names, units, ``u_eq``.
    title : str
        One line (the short verdict).

    Returns
    -------
    dict
        ``{"data": [...], "layout": {...}}`` (strict JSON once NaN is None).

    Examples
    --------
    >>> from fl_design.plotting import FigureContext
    >>> from fl_design.plotting._plotly import response_spec
    >>> r = fl.simulate(fl.plants.pendulum(), fl.presets.pendulum_design(), fl.Scenario(0.1, 1.0))
    >>> [d["name"] for d in response_spec(r, FigureContext("p"), title="t")["data"]][:3]
    ['reference', 'y', 'estimate']
    """
    t = resp.t
    data = []
    if np.any(resp.ym != resp.y):
        data.append(_line(t, resp.ym, name="measured", color="#bfbfbf", width=0.6))
    data += [_line(t, resp.r, name="reference", color="#000000", dash="dash", width=1.0),
             _line(t, resp.y, name="y", color=CYCLE[0]),
             _line(t, resp.xhat[:, 0], name="estimate", color=CYCLE[1], dash="dot", width=0.9),
             _line(t, resp.u, name="u", color=CYCLE[2], width=1.0, axis=2, shape="hv",
                   legend="legend2", show=False)]
    if ctx.u_eq is not None and math.isfinite(ctx.u_eq):
        data.append({"type": "scatter", "mode": "lines", "x": _num([t[0], t[-1]], 8),
                     "y": _num([ctx.u_eq] * 2), "name": f"u_eq = {ctx.u_eq:.3g}",
                     "line": {"color": "#000000", "dash": "dot", "width": 1.0},
                     "xaxis": "x", "yaxis": "y2", "legend": "legend2"})
    data += [_line(t, resp.sigma, name="sigma (true)", color=CYCLE[0], width=1.2, axis=3,
                   legend="legend3"),
             _line(t, resp.sigmahat, name="sigma estimate", color=CYCLE[1], width=0.8, axis=3,
                   legend="legend3")]
    shapes = []
    if resp.diverged:
        shapes = [{"type": "line", "xref": "x", "yref": "paper", "x0": resp.divergence_time,
                   "x1": resp.divergence_time, "y0": 0, "y1": 1,
                   "line": {"color": STATUS_COLORS[1], "width": 1}}]
    unit = plotly_text(ctx.y_unit) or "1"
    layout = _layout(plotly_text(title), 620, hovermode="x unified", hoversubplots="axis",
                     shapes=shapes,
                     xaxis=_axis("time (s)", anchor="y3"),
                     yaxis=_axis(_label("output y", ctx.y_unit), domain=[0.70, 1.0]),
                     yaxis2=_axis(_label("input u", ctx.u_unit), domain=[0.36, 0.64]),
                     yaxis3=_axis(f"sigma ({unit}/s^{ctx.rho})", domain=[0.0, 0.30]),
                     legend=_legend_inside(1.0), legend2=_legend_inside(0.64),
                     legend3=_legend_inside(0.30))
    for k in ("yaxis", "yaxis2"):
        layout[k]["anchor"] = "x"
    layout["yaxis3"]["anchor"] = "x"
    return {"data": data, "layout": layout}


def step_spec(runs, designs, stds, ctx, *, labels=None, window: str = "") -> dict:
    """Step responses of the compared designs, one panel per noise level, its legend below.

    Parameters
    ----------
    runs : dict
        ``{(design name, noise std): Response}``.
    designs : sequence of str
        Names in order (the first, the configured design, is ``C0``).
    stds : sequence of float
        Noise levels (one panel each).
    ctx : fl_design.plotting.FigureContext
        Names and units.
    labels : dict, optional
        ``{(name, std): legend text}`` (default the name and the status).
    window : str, optional
        Which window the runs show (the title's second half).

    Returns
    -------
    dict
        ``{"data", "layout"}``: a panel per noise level, each with its legend below it.

    Examples
    --------
    >>> from fl_design.plotting import FigureContext
    >>> from fl_design.plotting._plotly import step_spec
    >>> r = fl.simulate(fl.plants.pendulum(), fl.presets.pendulum_design(), fl.Scenario(0.1, 1.0))
    >>> spec = step_spec({("a", 0.0): r}, ["a"], [0.0], FigureContext("p"))
    >>> spec["data"][0]["name"] == f"a: {r.status}", spec["data"][1]["name"]
    (True, 'reference')
    """
    n = len(stds)
    rows = math.ceil((len(designs) + 1) / 3)  # legend rows (the designs and the reference)
    panel, below = 220, 34 + 20 * rows + 26   # ticks, the legend, the next panel's name
    last = 22  # the time axis' title under the last panel
    height = 50 + n * (panel + below) + last
    inner = height - 60  # the plotting area (margins t 50, b 10)
    top = 1.0
    data, layout = [], _layout("", height, hovermode="x unified")
    head = f"{ctx.plant}: compared estimators under one controller"
    layout["title"]["text"] = plotly_text(head + (f", {window}" if window else ""))
    layout["margin"] = {"l": 70, "r": 20, "t": 50, "b": 10}
    for k, std in enumerate(stds):
        sfx = "" if k == 0 else str(k + 1)
        lo = top - panel / inner
        legend = f"legend{sfx}"
        r = None
        for i, name in enumerate(designs):
            r = runs[(name, std)]
            text = (labels or {}).get((name, std), f"{name}: {r.status}")
            data.append(_line(r.t, r.y, name=plotly_text(text), color=CYCLE[i % 10], width=1.1,
                              legend=legend) | {"xaxis": f"x{sfx}", "yaxis": f"y{sfx}"})
        if r is not None:
            data.append(_line(r.t, r.r, name="reference", color="#000000", dash="dash",
                              width=0.9, legend=legend)
                        | {"xaxis": f"x{sfx}", "yaxis": f"y{sfx}"})
        noise = (f"sensor noise std {std:.3g} {plotly_text(ctx.y_unit)}".rstrip() if std
                 else "noise-free")
        final = k == n - 1
        layout[f"xaxis{sfx}"] = _axis("time (s)" if final else "", anchor=f"y{sfx}",
                                      **({"matches": "x"} if k else {}))
        layout[f"yaxis{sfx}"] = _axis(_label("y", ctx.y_unit), anchor=f"x{sfx}",
                                      domain=[max(lo, 0.0), top])
        layout[legend] = {"orientation": "h", "x": 0.5, "xanchor": "center",
                          "y": lo - (34 + (last if final else 0)) / inner, "yanchor": "top",
                          "font": {"size": 11}}
        layout.setdefault("annotations", []).append(
            {"text": noise, "xref": "paper", "yref": "paper", "x": 0, "y": top,
             "xanchor": "left", "yanchor": "bottom", "showarrow": False, "font": {"size": 11}})
        top = lo - below / inner
    return {"data": data, "layout": layout}


def _bracket_traces(gamma, stars, *, label: str, color: str) -> list:
    """eps*(gamma) brackets as :func:`~fl_design.plotting.plot_eps_star` draws them."""
    points = bracket_points(gamma, stars)
    out = []
    if "value" in points:
        xs, ys = zip(*points["value"])
        out.append({"type": "scatter", "mode": "lines+markers", "x": _num(xs), "y": _num(ys),
                    "name": label, "line": {"color": color, "width": 1.8},
                    "marker": {"symbol": "square", "size": 6, "color": color}})
    for kind, (words, _, symbol) in OUTSIDE_RANGE.items():
        if kind in points:
            xs, ys = zip(*points[kind])
            out.append({"type": "scatter", "mode": "markers", "x": _num(xs), "y": _num(ys),
                        "name": f"{label}: {words}",
                        "marker": {"symbol": symbol, "size": 10, "color": color,
                                   "line": {"width": 1.5, "color": color}}})
    return out


def stability_map_spec(smap, ctx, *, curves=None) -> dict:
    """The stability map (status per cell, hover: status, |gamma|, eps), its eps*, the curves,
    the paper's bound and the design's star.

    Parameters
    ----------
    smap : fl_design.StabilityMap
        The sweep.
    ctx : fl_design.plotting.FigureContext
        Names, units, the design's point.
    curves : dict, optional
        ``{label: (gamma, eps values or EpsStar brackets)}``.

    Returns
    -------
    dict
        ``{"data", "layout"}``: the heat map first, then one trace per legend entry.

    Examples
    --------
    A map with a linearized eps* curve whose second bracket lies above the range:

    >>> from fl_design.plotting import FigureContext
    >>> from fl_design.plotting._plotly import stability_map_spec
    >>> m = fl.StabilityMap(np.array([0.1, 0.2]), np.array([1.0, 2.0]),
    ...                     np.array([[1, 2], [-1, 2]]), {}, 1e-3, 1.0, 0.1)
    >>> lin = ([1.0, 2.0], [fl.EpsStar(0.1, 0.2), fl.EpsStar(0.2, float("inf"))])
    >>> spec = stability_map_spec(m, FigureContext("p", design_gamma=1.0, design_eps=0.1),
    ...                           curves={"lin": lin})
    >>> [d["name"] for d in spec["data"]][1:]  # doctest: +NORMALIZE_WHITESPACE
    ['diverged', 'converging', 'converged', 'eps* (this map)', 'eps* > largest eps scanned',
     'lin', 'lin: eps* above the range (> top)', 'this design']
    """
    gx = np.abs(np.asarray(smap.gamma, dtype=float))
    status = np.asarray(smap.status, dtype=int)
    labels = np.asarray(smap.labels)
    z = (status + 2).astype(float)
    text = [[f"{labels[i, j]}<br>|gamma| {gx[j]:.4g}<br>eps {smap.eps[i]:.4g}"
             for j in range(gx.size)] for i in range(len(smap.eps))]
    n = len(STATUS_COLORS)
    scale = []
    for k, color in enumerate(STATUS_COLORS):
        scale += [[k / n, color], [(k + 1) / n, color]]
    data = [{"type": "heatmap", "x": _num(edges(gx)), "y": _num(edges(smap.eps)),
             "z": z.tolist(), "zmin": -0.5, "zmax": n - 0.5, "colorscale": scale,
             "showscale": False, "text": text, "hovertemplate": "%{text}<extra></extra>",
             "name": "runs", "showlegend": False}]
    for _, color, name in status_legend(status):
        data.append({"type": "scatter", "mode": "markers", "x": [None], "y": [None],
                     "name": name, "marker": {"symbol": "square", "size": 12, "color": color},
                     "hoverinfo": "skip"})
    lost = lost_points(smap)
    if lost:  # a partial map (a worker died): its lost cells crossed
        xs, ys = zip(*lost)
        data.append({"type": "scatter", "mode": "markers", "x": _num(xs), "y": _num(ys),
                     "name": LOST_LABEL.format(n=len(lost)),
                     "marker": {"symbol": "x", "size": 9, "color": "#000000"},
                     "hoverinfo": "skip"})
    points = bracket_points(smap.gamma, [smap.eps_star(g) for g in smap.gamma])
    for kind, name, opacity in MAP_EPS_STAR:
        if kind in points:
            xs, ys = zip(*points[kind])
            data.append({"type": "scatter", "mode": "markers", "x": _num(xs), "y": _num(ys),
                         "name": name, "opacity": opacity,
                         "marker": {"symbol": "triangle-up", "size": 9, "color": "#ffffff",
                                    "line": {"color": "#000000", "width": 1}}})
    for i, (label, (g, e)) in enumerate((curves or {}).items()):
        color = CYCLE[i % 10]
        if len(e) and all(is_bracket(s) for s in e):
            data += _bracket_traces(g, list(e), label=plotly_text(label), color=color)
        else:
            data.append({"type": "scatter", "mode": "lines", "x": _num(np.abs(np.asarray(g))),
                         "y": _num(e), "name": plotly_text(label),
                         "line": {"color": color, "width": 1.8}})
    xr = [float(v) for v in np.log10(np.sort(edges(gx)[[0, -1]]))]
    yr = [float(v) for v in np.log10(np.sort(edges(smap.eps)[[0, -1]]))]
    right = float(np.max(gx)) * 1.5
    if math.isfinite(ctx.gamma_bound) and ctx.gamma_bound > 0:
        where = "" if ctx.gamma_bound <= right else " (off the map)"
        data.append({"type": "scatter", "mode": "lines", "x": [ctx.gamma_bound] * 2,
                     "y": _num(10.0 ** np.array(yr)),
                     "name": f"paper's bound |gamma| < {ctx.gamma_bound:.3g}{where}",
                     "line": {"color": "#000000", "dash": "dot", "width": 1.2}})
    if ctx.design_eps is not None and math.isfinite(ctx.design_gamma):
        data.append({"type": "scatter", "mode": "markers", "x": _num([abs(ctx.design_gamma)]),
                     "y": _num([ctx.design_eps]), "name": "this design",
                     "marker": {"symbol": "star", "size": 16, "color": "#ffd700",
                                "line": {"color": "#000000", "width": 1}}})
    part = f" (PARTIAL: {len(lost)} of {status.size} runs lost, x)" if lost else ""
    layout = _layout(plotly_text(f"{ctx.plant}: stability map, noise-free runs of "
                                 f"{smap.duration:g} s{part}"), 600, hovermode="closest",
                     xaxis=_axis(f"controller gain |gamma| ({_gamma_unit(ctx)})",
                                 **_log_axis(*xr)),
                     yaxis=_axis("observer time constant eps (s)", **_log_axis(*yr)),
                     legend={"orientation": "h", "x": 0.5, "xanchor": "center", "y": -0.14,
                             "yanchor": "top", "font": {"size": 11}})
    layout["margin"]["b"] = 20
    return {"data": data, "layout": layout}


__all__ = ["CYCLE", "INTERACTIVE_BUCKETS", "plotly_text", "response_spec", "stability_map_spec",
           "step_spec"]
