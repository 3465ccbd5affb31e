"""The report's interactive figures: Plotly.js inlined once, figure specs as JSON, a strict CSP.

``report.html`` stays one file that opens offline from ``file://``: Plotly.js is read from the
installed ``plotly`` Python package (its full ``plotly.min.js``, about 4.8 MB: the only bundle
that package ships; Plotly's partial bundles come from npm only, a second, unpinned, fetched
dependency) and inlined in one ``<script>``. Each main figure (this design's run, the stability
map, the compared runs) is a ``{"data", "layout"}`` spec from
:mod:`fl_design.plotting._plotly`, embedded as ``<script type="application/json">`` with every
``<``, ``>``, ``&`` and line separator written as a ``\\uXXXX`` escape (no ``</script>`` nor
``<!--`` can appear inside). The page's Content-Security-Policy allows only these two scripts
(by their SHA-256), inline styles, ``data:`` and ``blob:`` images (the plots' PNG export
builds one in the page) and no connection at all (``default-src 'none'``). The PNG stays in the figure: shown without JavaScript (or if a plot
fails), and in print (a print rule hides the live plot).

Examples
--------
>>> from fl_design.app._report_interactive import script_json
>>> script_json({"name": "</script><!--"})
'{"name":"\\\\u003c/script\\\\u003e\\\\u003c!--"}'
"""

from __future__ import annotations

import base64
import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path

from .._json import jsonable
from ..errors import MissingDependencyError

#: The figures drawn live (file name of their PNG fallback).
LIVE = ("response.png", "stability_map.png", "steps.png")

#: The page's script: draw each spec, then mark its figure live (its PNG then hides on screen).
INIT_JS = """(function () {
  if (!window.Plotly) { return; }
  var config = {displaylogo: false, responsive: true, typesetMath: false,
                scrollZoom: false, toImageButtonOptions: {format: 'png'}};
  var figures = document.querySelectorAll('figure.live-figure');
  Array.prototype.forEach.call(figures, function (fig) {
    var source = document.getElementById(fig.getAttribute('data-spec'));
    var target = fig.querySelector('div.plot');
    try {
      var spec = JSON.parse(source.textContent);
      Plotly.newPlot(target, spec.data, spec.layout, config).then(function () {
        fig.classList.add('live');
      }, function () {});
    } catch (err) { /* the PNG stays */ }
  });
})();"""

#: Rules for live figures: the plot on screen, the PNG in print and without JavaScript.
CSS = """
figure.live-figure div.plot{width:100%;text-align:left}
figure.live-figure.live img{display:none}
@media print{figure.live-figure div.plot{display:none}figure.live-figure.live img{display:inline}}
"""


def plotly_bundle() -> str:
    """Plotly.js as the installed ``plotly`` package ships it (read, never fetched).

    Raises
    ------
    MissingDependencyError
        ``plotly`` is not installed, or its bundle is missing.

    Examples
    --------
    >>> from fl_design.app._report_interactive import plotly_bundle
    >>> plotly_bundle()[:3]
    '/**'
    """
    import importlib.util

    spec = importlib.util.find_spec("plotly")  # its location only: nothing of it is imported
    if spec is None or not spec.origin:
        raise MissingDependencyError("interactive report figures need plotly (its Plotly.js is "
                                     "inlined): pip install 'fl_design[ui]', or write a static "
                                     "report (fl-design run --static-report)")
    path = Path(spec.origin).parent / "package_data" / "plotly.min.js"
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as err:
        raise MissingDependencyError(f"the plotly package has no {path} ({err.strerror}): "
                                     "reinstall it (pip install --force-reinstall plotly)") \
            from None
    if "</script" in text.lower() or "<!--" in text:
        raise MissingDependencyError(f"{path} holds '</script' or '<!--' and cannot be inlined "
                                     "in a page; write a static report (--static-report)")
    return text


def script_json(value) -> str:
    """``value`` as strict JSON safe inside ``<script type="application/json">``.

    ``<``, ``>``, ``&``, U+2028 and U+2029 become ``\\uXXXX`` escapes: the text cannot close
    the script element (``</script>``), open a comment (``<!--``), nor break a JavaScript
    parser; ``JSON.parse`` gives the same strings back. Non-finite floats are ``null``.

    Parameters
    ----------
    value : object
        Plain data (:func:`fl_design._json.jsonable` is applied).

    Examples
    --------
    >>> import json
    >>> from fl_design.app._report_interactive import script_json
    >>> s = script_json({"a": "<!-- x & y -->", "b": float("nan")})
    >>> "<" in s, json.loads(s)
    (False, {'a': '<!-- x & y -->', 'b': None})
    """
    text = json.dumps(jsonable(value), allow_nan=False, separators=(",", ":"),
                      ensure_ascii=False)
    for char, code in (("<", "\\u003c"), (">", "\\u003e"), ("&", "\\u0026"),
                       ("\u2028", "\\u2028"), ("\u2029", "\\u2029")):
        text = text.replace(char, code)
    return text


def _sha256(text: str) -> str:
    return "'sha256-" + base64.b64encode(hashlib.sha256(text.encode("utf-8")).digest()).decode(
        "ascii") + "'"


@dataclass(frozen=True)
class LiveFigures:
    """The interactive figures of one page: their specs and the Plotly.js to inline.

    Parameters
    ----------
    specs : dict
        ``{PNG file name: {"data", "layout"}}``.
    bundle : str
        Plotly.js (:func:`plotly_bundle`).

    Examples
    --------
    >>> from fl_design.app._report_interactive import LiveFigures
    >>> live = LiveFigures({"a.png": {"data": [], "layout": {}}}, "var Plotly = {};")
    >>> "script-src 'sha256-" in live.head()
    True
    """

    specs: dict
    bundle: str
    ids: dict = field(init=False, repr=False)

    def __post_init__(self):
        object.__setattr__(self, "ids", {name: f"fl-spec-{k}"
                                         for k, name in enumerate(self.specs)})

    def head(self) -> str:
        """The Content-Security-Policy ``<meta>``: only these scripts, no connection."""
        policy = (f"default-src 'none'; script-src {_sha256(self.bundle)} {_sha256(INIT_JS)}; "
                  "style-src 'unsafe-inline'; img-src data: blob:; font-src 'none'; "
                  "connect-src 'none'; base-uri 'none'; form-action 'none'")
        return f'<meta http-equiv="Content-Security-Policy" content="{policy}">'

    def figure(self, name: str, img: str, caption: str) -> str:
        """A live figure: the plot's box, the PNG ``<img>`` (fallback), the caption (HTML)."""
        return (f'<figure class="live-figure" data-spec="{self.ids[name]}"><div class="plot">'
                f"</div>{img}{caption}</figure>")

    def scripts(self) -> str:
        """The specs (JSON), Plotly.js and the drawing script, for the end of ``<body>``."""
        blocks = [f'<script type="application/json" id="{self.ids[name]}">{script_json(spec)}'
                  "</script>" for name, spec in self.specs.items()]
        return "\n".join([*blocks, f"<script>{self.bundle}</script>",
                          f"<script>{INIT_JS}</script>"])


def _response(job, ctx):
    from ..plotting._plotly import response_spec
    from ._report_figures import response_title

    return response_spec(job.results["simulate"]["main"], ctx, title=response_title(job, ctx))


def _map(job, ctx):
    from ..plotting._plotly import stability_map_spec
    from ._report_figures import map_curves

    return stability_map_spec(job.results["sweep"], ctx, curves=map_curves(job))


def _steps(job, ctx):
    from ..plotting._plotly import step_spec
    from ._report_figures import step_labels

    sim = job.results["simulate"]
    return step_spec(sim["runs"], sim["designs"], sim["stds"], ctx, labels=step_labels(sim),
                     window=f"first {sim['compare_duration']:g} s: the transient")


_BUILD = {"response.png": _response, "stability_map.png": _map, "steps.png": _steps}


def live_figures(job, figures) -> tuple[LiveFigures | None, str]:
    """The job's interactive figures (those of :data:`LIVE` whose PNG was written).

    A figure whose spec fails stays a PNG; without ``plotly`` every figure does, and the
    reason is returned.

    Parameters
    ----------
    job : Job
        A finished job.
    figures : list of str
        The PNG files written.

    Returns
    -------
    (LiveFigures or None, str)
        The figures (None: none live) and why some or all stayed static ("" if none did).

    Examples
    --------
    >>> from fl_design.app import load_config, run_job
    >>> from fl_design.app._report_interactive import live_figures
    >>> job = run_job(load_config(None), quick=True, stages=("derive",), progress=False)
    >>> live_figures(job, [])
    (None, '')
    """
    from ._report_figures import figure_context

    todo = [name for name in LIVE if name in figures]
    if not todo:
        return None, ""
    try:
        bundle = plotly_bundle()
    except MissingDependencyError as err:
        return None, str(err)
    ctx = figure_context(job)
    specs, failed = {}, []
    for name in todo:
        try:
            specs[name] = _BUILD[name](job, ctx)
        except Exception as err:  # noqa: BLE001 - a figure never stops the report
            failed.append(f"{name} ({type(err).__name__}: {str(err)[:120]})")
    why = ("static only: " + "; ".join(failed)) if failed else ""
    return (LiveFigures(specs, bundle) if specs else None), why


def points(spec) -> int:
    """The largest number of points of any trace of a spec (the thinning's effect).

    Examples
    --------
    >>> from fl_design.app._report_interactive import points
    >>> points({"data": [{"x": [1, 2, 3]}, {"x": [1]}]})
    3
    """
    return max((len(d.get("x") or []) for d in spec["data"]), default=0)


__all__ = ["CSS", "INIT_JS", "LIVE", "LiveFigures", "live_figures", "plotly_bundle", "points",
           "script_json"]
