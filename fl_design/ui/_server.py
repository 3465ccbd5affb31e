"""The tuner's local web server: 127.0.0.1 only, a random token in every URL, no paths taken.

Routes, all under ``/<token>/`` (anything else, or a wrong token: 403):

* ``GET /<token>/`` the page; ``GET /<token>/static/<name>`` one of :data:`ASSETS` (the page's
  script and style and uPlot from this package, Plotly.js from the installed ``plotly``
  package);
* ``GET /<token>/api/init`` the controls and the plant's description;
* ``POST /<token>/api/redraw`` (JSON controls) the response, verdict and noise gain
  (:meth:`fl_design.ui._model.Tuner.redraw`); it also tells the background what to compute;
* ``GET /<token>/api/background`` the slow results so far (:mod:`fl_design.ui._background`);
* ``POST /<token>/api/save`` ``{"what": "toml" | "c" | "snippet", "values": {...}}``: writes
  into the output folder chosen on the command line (:mod:`fl_design.ui._export`).

Requests whose ``Host`` is not this server's loopback address are refused too (a page from
elsewhere cannot reach the tuner through DNS rebinding); bodies are JSON of at most
:data:`MAX_BODY` bytes.

Examples
--------
>>> from fl_design.ui._server import token_ok
>>> token_ok("/abc/api/init", "abc"), token_ok("/api/init", "abc"), token_ok("/abcd/", "abc")
(True, False, False)
"""

from __future__ import annotations

import hmac
import json
import secrets
import sys
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from pathlib import Path

from ..errors import FlDesignError, MissingDependencyError, ParameterError

#: Largest request body (bytes).
MAX_BODY = 65536
#: Files the page may load: name -> content type. Plotly.js comes from the installed ``plotly``
#: package, the others from ``static/`` of this package (uPlot 1.6.32, MIT: ``uPlot.LICENSE``).
ASSETS = {
    "tuner.js": "text/javascript; charset=utf-8",
    "tuner.css": "text/css; charset=utf-8",
    "plotly.min.js": "text/javascript; charset=utf-8",
    "uPlot.iife.min.js": "text/javascript; charset=utf-8",
    "uPlot.min.css": "text/css; charset=utf-8",
}


def token_ok(path: str, token: str) -> bool:
    """Whether ``path`` starts with ``/<token>/`` (compared in constant time).

    Parameters
    ----------
    path : str
        The request path (query removed).
    token : str
        The server's token.

    Returns
    -------
    bool
    """
    parts = path.split("/", 2)
    if len(parts) < 3 or parts[0] != "":
        return False
    return hmac.compare_digest(parts[1].encode(), token.encode())


def plotly_js() -> bytes:
    """Plotly.js as shipped inside the ``plotly`` Python package (nothing fetched).

    Raises
    ------
    MissingDependencyError
        ``plotly`` is not installed (``pip install 'fl_design[ui]'``).
    """
    try:
        import plotly
    except ImportError:
        raise MissingDependencyError("fl-design ui needs plotly (its Plotly.js is served to the "
                                     "page): pip install 'fl_design[ui]'") from None
    path = Path(plotly.__file__).parent / "package_data" / "plotly.min.js"
    try:
        return path.read_bytes()
    except OSError as err:
        raise MissingDependencyError(f"the plotly package has no {path} ({err.strerror}): "
                                     "reinstall it (pip install --force-reinstall plotly)") \
            from None


class TunerApp:
    """What the server serves: a tuner, its background, a token and an output folder.

    Parameters
    ----------
    tuner : fl_design.ui._model.Tuner
        The model.
    out : path-like
        Where the buttons write (claimed at each write, never replaced).
    background : bool, optional
        Compute the slow results (False: the page alone, for tests).
    token : str, optional
        Default: 32 random URL-safe characters (:func:`secrets.token_urlsafe`).

    Examples
    --------
    >>> from fl_design.app._cli import ui_setup
    >>> from fl_design.ui import Tuner, TunerApp
    >>> app = TunerApp(Tuner(ui_setup()), "ui_out", background=False)
    >>> len(app.token) >= 32, app.init()["plant"]
    (True, 'trms_yaw')
    >>> app.close()
    """

    def __init__(self, tuner, out, *, background: bool = True, token: str | None = None):
        from ._background import Background

        self.tuner, self.out = tuner, Path(out)
        self.token = token or secrets.token_urlsafe(24)
        self.background = Background(tuner.setup, enabled=background)
        self._lock = threading.Lock()  # one simulation at a time (the kernel's buffers)
        self.assets = {name: plotly_js() if name == "plotly.min.js" else _static(name)
                       for name in ASSETS}
        self.page = _static("index.html")

    def init(self) -> dict:
        t = self.tuner
        return {"controls": t.controls(), "plant": t.plant.name, "source": t.config.source,
                "rho": t.rho, "b_bounds": t.b_bounds,
                "plant_class": None if t.plant_class is None else t.plant_class.describe(),
                "out": str(self.out), "defaults": t.defaults()}

    def redraw(self, values) -> dict:
        self.background.pause()  # before the simulation: the redraw gets the cores
        with self._lock:
            view = self.tuner.redraw(values)
        if "error" not in view:
            self.background.submit(view["values"])
        return view

    def save(self, body) -> dict:
        from . import _export

        if not isinstance(body, dict) or body.get("what") not in ("toml", "c", "snippet") \
                or set(body) - {"what", "values"}:
            raise ParameterError('save takes {"what": "toml" | "c" | "snippet", "values": '
                                 "{...}}; no path: files go to the folder given with --out")
        values = body.get("values", {})
        what = body["what"]
        if what == "toml":
            return {"written": str(_export.save_toml(self.tuner, values, self.out))}
        if what == "c":
            with self._lock:
                pkg = _export.write_c(self.tuner, values, self.out)
            return {"written": str(pkg.out_dir), "files": [p.name for p in pkg.files]}
        path, text = _export.save_snippet(self.tuner, values, self.out)
        return {"written": str(path), "text": text}

    def close(self) -> None:
        self.background.close()
        self.tuner.loops.close()


def _static(name: str) -> bytes:
    return resources.files("fl_design.ui").joinpath("static", name).read_bytes()


class _Handler(BaseHTTPRequestHandler):
    server_version = "fl-design-ui"
    # TCP_NODELAY: the headers and the body are two writes; with Nagle's algorithm the body
    # waits for the client's delayed ACK of the headers (about 40 ms on Linux) on every redraw
    disable_nagle_algorithm = True
    # keep-alive: the page's redraws reuse one connection (no new socket and thread per move);
    # every answer has its Content-Length
    protocol_version = "HTTP/1.1"
    app: TunerApp = None  # set per server (a subclass)
    hosts: tuple = ()

    def log_message(self, format, *args):
        pass  # quiet: the terminal shows the URL and errors only

    def _send(self, code: int, body: bytes, ctype: str) -> None:
        self.send_response(code)
        if code >= 400:  # a refused request's body may be unread: never parse it as a request
            self.close_connection = True
            self.send_header("Connection", "close")
        self.send_header("Content-Type", ctype)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.send_header("X-Content-Type-Options", "nosniff")
        self.send_header("Referrer-Policy", "no-referrer")
        if getattr(self, "_timing", None):
            self.send_header("Server-Timing", self._timing)
        # Plotly sets inline styles (style-src 'unsafe-inline'); no script but ours and Plotly.js
        self.send_header("Content-Security-Policy", "default-src 'self'; script-src 'self'; "
                         "style-src 'self' 'unsafe-inline'; img-src 'self' data:; "
                         "connect-src 'self'; frame-ancestors 'none'")
        self.end_headers()
        self.wfile.write(body)

    def _json(self, code: int, data, started: float | None = None) -> None:
        body = json.dumps(data, allow_nan=False).encode()
        if started is not None:  # the server's whole part, for the page's timing line
            self._timing = f"server;dur={1e3 * (time.perf_counter() - started):.1f}"
        self._send(code, body, "application/json")

    def _refuse(self, code: int, why: str) -> None:
        self._send(code, (why + "\n").encode(), "text/plain; charset=utf-8")

    def _route(self) -> str | None:
        """The path after the token, or None (already refused)."""
        if self.headers.get("Host", "") not in self.hosts:
            self._refuse(403, "forbidden: wrong Host")
            return None
        path = self.path.split("?", 1)[0]
        if not token_ok(path, self.app.token):
            self._refuse(403, "forbidden: the URL's token is missing or wrong (use the URL "
                         "that `fl-design ui` printed)")
            return None
        return "/" + path.split("/", 2)[2]

    def do_GET(self):
        route = self._route()
        if route is None:
            return
        if route == "/":
            self._send(200, self.app.page, "text/html; charset=utf-8")
        elif route.startswith("/static/") and route[8:] in ASSETS:
            self._send(200, self.app.assets[route[8:]], ASSETS[route[8:]])
        elif route == "/api/init":
            self._json(200, self.app.init())
        elif route == "/api/background":
            self._json(200, self.app.background.snapshot())
        else:
            self._refuse(404, "not found")

    def do_POST(self):
        started = time.perf_counter()
        route = self._route()
        if route is None:
            return
        if route not in ("/api/redraw", "/api/save"):
            self._refuse(404, "not found")
            return
        try:
            n = int(self.headers.get("Content-Length", "0"))
        except ValueError:
            n = -1
        if not 0 <= n <= MAX_BODY:
            self._refuse(413, f"the body must be JSON of at most {MAX_BODY} bytes")
            return
        if not self.headers.get("Content-Type", "").startswith("application/json"):
            self._refuse(415, "the body must be application/json")
            return
        try:
            body = json.loads(self.rfile.read(n) or b"{}")
        except ValueError:
            self._refuse(400, "the body is not JSON")
            return
        try:
            data = self.app.redraw(body) if route == "/api/redraw" else self.app.save(body)
        except FlDesignError as err:
            self._json(400, {"error": str(err)})
            return
        except Exception as err:  # noqa: BLE001 (one line to the page and the terminal)
            msg = f"{type(err).__name__}: {err}"
            print(f"fl-design ui: {route} failed: {msg}", file=sys.stderr, flush=True)
            self._json(500, {"error": f"the tuner failed on this request ({msg}); the "
                             "terminal says the same"})
            return
        self._json(200, data, started)


def make_server(app: TunerApp, port: int = 0) -> ThreadingHTTPServer:
    """A threading HTTP server for ``app`` on 127.0.0.1 (``port`` 0: a free one).

    Parameters
    ----------
    app : TunerApp
        What to serve.
    port : int, optional
        TCP port (0: the system picks a free one).

    Returns
    -------
    http.server.ThreadingHTTPServer
        Not yet serving; its URL is :func:`url_of`.

    Raises
    ------
    ParameterError
        A port outside 0..65535, or one that is taken.

    Examples
    --------
    >>> import threading, urllib.request, urllib.error
    >>> from fl_design.app._cli import ui_setup
    >>> from fl_design.ui import Tuner, TunerApp, make_server, url_of
    >>> app = TunerApp(Tuner(ui_setup()), "ui_out", background=False)
    >>> httpd = make_server(app, 0)
    >>> _ = threading.Thread(target=httpd.serve_forever, daemon=True).start()
    >>> urllib.request.urlopen(url_of(httpd, app), timeout=30).status
    200
    >>> try:
    ...     urllib.request.urlopen(url_of(httpd, app).replace(app.token, "guess"), timeout=30)
    ... except urllib.error.HTTPError as err:
    ...     print(err.code)
    403
    >>> httpd.shutdown(); httpd.server_close(); app.close()
    """
    if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
        raise ParameterError(f"--port must be an integer in 0..65535 (0: a free port), got "
                             f"{port!r}")
    try:
        httpd = ThreadingHTTPServer(("127.0.0.1", port), _Handler, bind_and_activate=True)
    except OSError as err:
        raise ParameterError(f"cannot listen on 127.0.0.1:{port} ({err.strerror or err}): "
                             "choose another --port, or leave it out for a free one") from None
    bound = httpd.server_address[1]
    httpd.daemon_threads = True
    httpd.RequestHandlerClass = type("Handler", (_Handler,), {
        "app": app, "hosts": (f"127.0.0.1:{bound}", f"localhost:{bound}")})
    return httpd


def url_of(httpd, app: TunerApp) -> str:
    """The page's URL (with the token).

    Parameters
    ----------
    httpd : http.server.ThreadingHTTPServer
        A server of :func:`make_server`.
    app : TunerApp
        Its app.

    Returns
    -------
    str
        ``http://127.0.0.1:PORT/TOKEN/``.
    """
    return f"http://127.0.0.1:{httpd.server_address[1]}/{app.token}/"


def serve(setup, *, port: int = 0, out="ui_out", open_browser: bool = False,
          background: bool = True) -> int:
    """Serve the tuner of ``config`` until Ctrl-C (or SIGTERM); print its URL first.

    Parameters
    ----------
    setup : fl_design.ui.TunerSetup
        A configuration with its plant and design (``fl_design.app._cli.ui_setup``).
    port : int, optional
        TCP port on 127.0.0.1 (0: a free one).
    out : path-like, optional
        The buttons' output folder (default ``ui_out``; created at the first write, and only
        if empty or holding fl_design's own output).
    open_browser : bool, optional
        Open the page in the default browser.
    background : bool, optional
        Compute the map, certificates, margins and C cost in a background process.

    Returns
    -------
    int
        0 after a clean stop.

    Raises
    ------
    ParameterError
        A config the tuner cannot use, or a port that cannot be had.
    MissingDependencyError
        ``plotly`` is not installed.

    Examples
    --------
    From the command line (it serves until Ctrl-C)::

        fl-design ui --plant trms            # prints http://127.0.0.1:PORT/TOKEN/
        fl-design ui my_rig.toml --port 8765 --out tuned --open
        fl-design ui --class rho=2,T=1e-3,b=1:50,noise_std=1e-3
    """
    import signal

    from ._model import Tuner

    start = time.perf_counter()
    tuner = Tuner(setup, compile_aside=True)
    config = setup.config
    app = TunerApp(tuner, out, background=background)
    httpd = make_server(app, port)
    tuner.warm_up()  # the defaults' kernel compiled before the page asks: the first page is fast
    app.background.submit(tuner.check({}))
    url = url_of(httpd, app)
    print(f"fl-design ui: {tuner.plant.name} from {config.source}, ready in "
          f"{time.perf_counter() - start:.1f} s\n  {url}\n(Ctrl-C stops it; only this "
          "machine can reach it, and only with the token in the URL)", flush=True)
    if open_browser:
        import webbrowser

        webbrowser.open(url)

    def _term(signum, frame):
        raise KeyboardInterrupt

    old = signal.signal(signal.SIGTERM, _term) if threading.current_thread() is \
        threading.main_thread() else None
    try:
        httpd.serve_forever(poll_interval=0.2)
    except KeyboardInterrupt:
        print("fl-design ui: stopped", file=sys.stderr, flush=True)
    finally:
        if old is not None:
            signal.signal(signal.SIGTERM, old)
        httpd.server_close()
        app.close()
    return 0


__all__ = ["ASSETS", "MAX_BODY", "TunerApp", "make_server", "plotly_js", "serve", "token_ok",
           "url_of"]
