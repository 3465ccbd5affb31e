"""The tuner page (``fl-design ui``): move eps, gamma, the gains, T, the reference, the noise
and the input limits, and see the response, the verdict and the noise gain redrawn at once;
the stability map, the certificates of the class, the margins and the C step's cost follow
from a background process.

Why this library
----------------
A small server on the standard library (:mod:`http.server`, one thread per connection, kept
alive), Plotly.js served from the ``plotly`` PyPI package (``pip install 'fl_design[ui]'``)
for the stability map, and uPlot (1.6.32, MIT, 50 kB, shipped in ``static/`` with its
licence) for the response charts, rather than Panel/Bokeh:

* the redraw budget (150 ms on 2 cores for a 20 s TRMS run): the server's part is about 15 ms
  of CPU (the compiled kernel's 20 000 samples about 7 ms; the verdict, the noise gain, the
  decimation to at most 2000 points a trace and the JSON the rest), one JSON request per move
  on a kept-alive connection, and the charts' redraw. The response is redrawn at every move:
  uPlot draws its three charts on canvases in 1-2 ms, where Plotly's SVG figure of three
  subplots took 30-40 ms and about 300 DOM nodes that every layout (and every reader of the
  page) walks; the map changes only when a background result arrives, and Plotly's heatmap
  and hover serve it well. ``verify/bench_ui.py`` measures each part. A Bokeh server adds a
  websocket session, document diffs and a Tornado loop beside the kernel;
* the safety rules are a few lines we own and test: bind 127.0.0.1 only, a random token as the
  first path segment of every URL (403 without it), a ``Host`` check against DNS rebinding,
  JSON bodies of bounded size, no file path ever taken from the browser;
* every asset is local: the page's script and style and uPlot are package data, Plotly.js is
  the file the ``plotly`` package installs (nothing fetched at run time, no CDN), and the same
  Plotly.js makes the report's figures interactive offline;
* one small dependency (plotly, pure Python) and one 50 kB file instead of Panel + Bokeh +
  Tornado + their JS.

The computation stays in the library (:func:`fl_design.simulate`, :func:`fl_design.sweep`,
:func:`fl_design.certify_gamma`, :func:`fl_design.certify_eps`,
:func:`fl_design.eps_star_curve`, :func:`fl_design.analysis.loop_margins`,
:func:`fl_design.analysis.noise_gain`, :meth:`fl_design.CPackage.cost`); the page only binds
controls to it. Nothing in the library imports this package; only the command line does, and
this package does not import ``app``: the command line hands it a :class:`TunerSetup` (the
config with its plant and design, the TOML writer, the plant library's table).

Modules: ``_model`` (:class:`Tuner`: controls -> one redraw), ``_background`` (the slow
results in a child process), ``_export`` (the buttons: TOML, C package, snippet, under the
no-overwrite rule), ``_server`` (HTTP, token, :func:`serve`), ``static/`` (the page).

Examples
--------
>>> from fl_design.app._cli import ui_setup
>>> from fl_design.ui import Tuner
>>> tuner = Tuner(ui_setup())  # what `fl-design ui` serves, without the server
>>> [c["name"] for c in tuner.controls()][:2], tuner.defaults()["eps"]
(['gamma', 'eps'], 0.05)
"""

from ._model import Tuner, TunerSetup
from ._server import TunerApp, make_server, serve, url_of

__all__ = ["Tuner", "TunerApp", "TunerSetup", "make_server", "serve", "url_of"]
