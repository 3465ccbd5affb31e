"""The report's interactive figures: escaping, thinning, the page's structure, and the page in
a real browser (headless Chromium driven by Selenium from ``file://``; skips, saying why, where
no browser, driver or selenium is installed).

The browser checks: the three main figures drawn by Plotly.js (with data), hover values and a
zoom by the mouse, no request leaving the page (resource timing entries; the CSP's
``default-src 'none'``; no CSP violation in the console, the PNG export included), the
summary first, no horizontal
scroll at 1280 px, the PNG shown in print and the plot hidden, and a plant name with markup
shown literally by Plotly.
"""

from __future__ import annotations

import base64
import hashlib
import json
import re
import shutil
import time
from html.parser import HTMLParser

import numpy as np
import pytest

from fl_design.app._report_interactive import (
    INIT_JS,
    LiveFigures,
    live_figures,
    plotly_bundle,
    script_json,
)
from fl_design.app._report_render import render_html, render_markdown
from fl_design.plotting import FigureContext, thin_line
from fl_design.plotting._plotly import INTERACTIVE_BUCKETS, plotly_text, stability_map_spec
from fl_design.sim import EpsStar, StabilityMap

HOSTILE = "</script><script>alert(1)</script><!-- & \u2028"
PNG = base64.b64decode("iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mNk+M9QDwAD"
                       "hgGAWjR9awAAAABJRU5ErkJggg==")


class _Scripts(HTMLParser):
    """Every <script> element of a page: its attributes and its text (as a browser splits it)."""

    def __init__(self):
        super().__init__()
        self.scripts, self.meta, self._open = [], [], None

    def handle_starttag(self, tag, attrs):
        if tag == "script":
            self._open = [dict(attrs), ""]
        elif tag == "meta":
            self.meta.append(dict(attrs))

    def handle_data(self, data):
        if self._open is not None:
            self._open[1] += data

    def handle_endtag(self, tag):
        if tag == "script" and self._open is not None:
            self.scripts.append(tuple(self._open))
            self._open = None


def _small_map():
    return StabilityMap(np.array([0.01, 0.1]), np.array([1e-4, 1e-3]),
                        np.array([[2, 1], [-1, 3]]), {}, 1e-3, 2.0, 0.02)


def _page(tmp_path, name=HOSTILE, bundle="window.flBundle = 1;"):
    (tmp_path / "stability_map.png").write_bytes(PNG)
    ctx = FigureContext(name, y_unit="<b>rad</b>", u_unit="V", rho=2, design_gamma=5e-4,
                        design_eps=0.05, gamma_bound=0.02, gamma_bound_text="b")
    curves = {"linearized eps*": (np.array([1e-4, 1e-3]),
                                  [EpsStar(0.01, 0.02), EpsStar(1.0, float("inf"))])}
    live = LiveFigures({"stability_map.png": stability_map_spec(_small_map(), ctx,
                                                                curves=curves)}, bundle)
    secs = [("Summary", [("p", name), ("fig", "stability_map.png", f"map of {name}")]),
            ("Details", [("p", "more")])]
    return render_html(secs, tmp_path, title=f"report: {name}", live=live), live


def test_script_json_cannot_close_its_script_and_round_trips():
    value = {"name": HOSTILE, "x": [1.0, float("nan"), float("inf")]}
    text = script_json(value)
    for bad in ("<", ">", "</script", "<!--", "\u2028", "\u2029"):
        assert bad not in text
    assert json.loads(text) == {"name": HOSTILE, "x": [1.0, None, None]}


def test_a_hostile_plant_name_cannot_break_out_of_the_page(tmp_path):
    page, live = _page(tmp_path)
    parsed = _Scripts()
    parsed.feed(page)
    kinds = [attrs.get("type", "text/javascript") for attrs, _ in parsed.scripts]
    assert kinds == ["application/json", "text/javascript", "text/javascript"]
    assert page.count("<script") == 3 and "alert(1)</script>" not in page
    spec = json.loads(parsed.scripts[0][1])
    assert spec["layout"]["title"]["text"].startswith(plotly_text(HOSTILE))
    assert plotly_text(HOSTILE).startswith("&lt;/script&gt;&lt;script&gt;")
    assert parsed.scripts[1][1] == live.bundle and parsed.scripts[2][1] == INIT_JS
    # the CSP allows exactly the page's two scripts (their SHA-256, computed here) and no fetch
    (csp,) = [m["content"] for m in parsed.meta if m.get("http-equiv") == "Content-Security-Policy"]
    hashes = sorted(re.findall(r"'sha256-([^']+)'", csp))
    own = sorted(base64.b64encode(hashlib.sha256(s.encode()).digest()).decode()
                 for _, s in parsed.scripts[1:])
    assert hashes == own
    assert "default-src 'none'" in csp and "connect-src 'none'" in csp
    assert "unsafe-inline" not in csp.split("script-src")[1].split(";")[0]


def test_without_live_figures_the_page_has_no_script(tmp_path):
    (tmp_path / "a.png").write_bytes(PNG)
    secs = [("Summary", [("fig", "a.png", HOSTILE)])]
    page = render_html(secs, tmp_path, title="t")
    assert "<script" not in page and "Content-Security-Policy" not in page
    assert "![" in render_markdown(secs)  # report.md keeps its PNG either way


def test_lines_are_thinned_to_a_few_thousand_points_keeping_the_extremes():
    from fl_design.plotting._plotly import _line

    t = np.arange(300_000) * 1e-4
    y = np.sin(7 * t) + 1e-3 * np.cos(500 * t)
    trace = _line(t, y, name="y", color="#000")
    k = -(-t.size // INTERACTIVE_BUCKETS)
    assert len(trace["x"]) <= 5 * INTERACTIVE_BUCKETS + k
    assert max(trace["y"]) == pytest.approx(y.max(), rel=1e-5)
    assert min(trace["y"]) == pytest.approx(y.min(), rel=1e-5)
    tt, _ = thin_line(t, y, INTERACTIVE_BUCKETS)  # the same samples as the PNG's thinning
    np.testing.assert_allclose(trace["x"], tt, rtol=1e-7)


def test_the_map_spec_matches_the_map():
    m = _small_map()
    spec = stability_map_spec(m, FigureContext("p", design_gamma=5e-4, design_eps=0.05))
    heat = spec["data"][0]
    assert heat["type"] == "heatmap"
    np.testing.assert_array_equal(np.array(heat["z"]) - 2, m.status)  # code -2 -> colour 0
    assert len(heat["x"]) == m.gamma.size + 1 and len(heat["y"]) == m.eps.size + 1
    assert heat["text"][1][0].startswith(str(m.labels[1, 0]))
    star = [d for d in spec["data"] if d["name"] == "this design"]
    assert star[0]["x"] == [5e-4] and star[0]["y"] == [0.05]


def test_without_plotly_the_report_stays_static_and_says_why(monkeypatch):
    from fl_design.app import _report_interactive as ri
    from fl_design.errors import MissingDependencyError

    def missing():
        raise MissingDependencyError("interactive report figures need plotly")

    monkeypatch.setattr(ri, "plotly_bundle", missing)

    live, why = live_figures(None, ["response.png"])  # the bundle is checked before the job
    assert live is None and "need plotly" in why


def test_the_cli_flag_exists():
    from fl_design.app._cli import build_parser

    assert build_parser().parse_args(["run", "--static-report"]).static_report is True
    assert build_parser().parse_args(["run"]).static_report is False


# --- in a real browser ------------------------------------------------------------------------

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
DRIVER = shutil.which("chromedriver")


@pytest.fixture(scope="module")
def driver():
    webdriver = pytest.importorskip("selenium.webdriver", reason="selenium is not installed "
                                    "(pip install 'fl_design[dev]')")
    if CHROMIUM is None or DRIVER is None:
        pytest.skip("no chromium / chromedriver on PATH (apt-get install chromium "
                    "chromium-driver): the interactive report is not checked in a browser")
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    opts = Options()
    for a in ("--headless=new", "--no-sandbox", "--disable-gpu", "--window-size=1280,1000"):
        opts.add_argument(a)
    opts.binary_location = CHROMIUM
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    drv = webdriver.Chrome(service=Service(DRIVER), options=opts)
    drv.set_page_load_timeout(120)
    drv.set_script_timeout(60)
    try:
        yield drv
    finally:
        drv.quit()


def _wait(drv, script, timeout=60.0, *args):
    end = time.time() + timeout
    while time.time() < end:
        value = drv.execute_script(script, *args)
        if value:
            return value
        time.sleep(0.05)
    raise AssertionError(f"the page did not reach `{script}` within {timeout} s")


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    from fl_design.app import load_config, run_job, write_report

    job = run_job(load_config(None), quick=True, stages=("sweep", "simulate"), progress=False)
    out = tmp_path_factory.mktemp("report")
    paths = write_report(job, out)
    return out, paths


_LIVE = "return Array.from(document.querySelectorAll('figure.live-figure.live'))"


@pytest.mark.slow
def test_the_report_draws_its_figures_live_offline(driver, report):
    out, paths = report
    assert paths["live_figures"] == ["response.png", "stability_map.png", "steps.png"]
    driver.get((out / "report.html").as_uri())
    _wait(driver, _LIVE + ".length === 3")
    plots = driver.execute_script("return Array.from(document.querySelectorAll("
                                  "'.js-plotly-plot')).map(d => [d.data.length, "
                                  "Math.max(...d.data.map(t => (t.x || []).length))])")
    assert len(plots) == 3 and all(n >= 2 and most > 1 for n, most in plots), plots
    assert max(most for _, most in plots) <= 5 * INTERACTIVE_BUCKETS + 50
    hidden = driver.execute_script(_LIVE + ".map(f => getComputedStyle(f.querySelector('img'))"
                                   ".display)")
    assert hidden == ["none"] * 3  # the PNG hides on screen once the plot is drawn
    # nothing leaves the page: no resource fetched, and no CSP violation reported
    assert driver.execute_script("return performance.getEntriesByType('resource').length") == 0
    logs = [e["message"] for e in driver.get_log("browser")]
    assert not [m for m in logs if "Content Security Policy" in m or "Refused" in m], logs
    # the summary first, its figure the response; no horizontal scroll at 1280 px
    first = driver.execute_script("return document.querySelector('h2').textContent")
    assert first == "Summary"
    where = driver.execute_script("const f = document.querySelector('figure.live-figure'); "
                                  "let e = f; while (e && e.tagName !== 'H2') "
                                  "e = e.previousElementSibling; return e && e.textContent")
    assert where == "Summary"
    sw, cw = driver.execute_script("return [document.documentElement.scrollWidth, "
                                   "document.documentElement.clientWidth]")
    assert sw <= cw + 1, f"scrollWidth {sw} > clientWidth {cw}"


@pytest.mark.slow
def test_hover_shows_values_and_the_mouse_zooms(driver, report):
    from selenium.webdriver.common.action_chains import ActionChains

    out, _ = report
    driver.get((out / "report.html").as_uri())
    _wait(driver, _LIVE + ".length === 3")
    drag = driver.find_element("css selector", "figure.live-figure .nsewdrag")
    driver.execute_script("arguments[0].scrollIntoView({block: 'center'})", drag)
    ActionChains(driver).move_to_element(drag).pause(0.3).perform()
    text = _wait(driver, "const h = document.querySelector('figure.live-figure .hoverlayer'); "
                 "return h && h.textContent", 10)
    assert re.search(r"\d", text), text  # a value under the mouse
    before = driver.execute_script("return document.querySelector('.js-plotly-plot')"
                                   "._fullLayout.xaxis.range.slice()")
    w = drag.size["width"]
    (ActionChains(driver).move_to_element_with_offset(drag, -w // 4, 0).click_and_hold()
     .move_by_offset(w // 8, 0).move_by_offset(w // 8, 0).release().perform())
    after = _wait(driver, "const r = document.querySelector('.js-plotly-plot')"
                  "._fullLayout.xaxis.range; return r[1] - r[0] < arguments[0] && r", 10,
                  0.5 * (before[1] - before[0]))
    assert after[1] - after[0] < 0.5 * (before[1] - before[0])  # a quarter of the width shown
    # the camera button's export (a PNG built in the page) passes the CSP
    png = driver.execute_async_script(
        "const done = arguments[0]; Plotly.toImage(document.querySelector('.js-plotly-plot'), "
        "{format: 'png'}).then(u => done(u.slice(0, 22)), e => done('failed: ' + e));")
    assert png == "data:image/png;base64,", png
    logs = [e["message"] for e in driver.get_log("browser")]
    assert not [m for m in logs if "Content Security Policy" in m], logs


@pytest.mark.slow
def test_print_shows_the_png_and_a_hostile_name_shows_literally(driver, tmp_path):
    page, _ = _page(tmp_path, bundle=plotly_bundle())
    path = tmp_path / "report.html"
    path.write_text(page, encoding="utf-8")
    driver.get(path.as_uri())
    _wait(driver, _LIVE + ".length === 1")
    title = driver.execute_script("return document.querySelector('.gtitle').textContent")
    assert title.startswith(" ".join(HOSTILE.split())), title
    assert driver.execute_script("return document.querySelectorAll('script').length") == 3
    driver.execute_cdp_cmd("Emulation.setEmulatedMedia", {"media": "print"})
    try:
        shown = driver.execute_script(
            "const f = document.querySelector('figure.live-figure'); return "
            "[getComputedStyle(f.querySelector('img')).display, "
            "getComputedStyle(f.querySelector('div.plot')).display]")
    finally:
        driver.execute_cdp_cmd("Emulation.setEmulatedMedia", {"media": ""})
    assert shown == ["inline", "none"]
    # scripts that do not run (JavaScript off, or blocked: here a changed script whose hash no
    # longer matches the CSP) leave the PNG on screen
    path.write_text(page.replace("if (!window.Plotly) { return; }", "/* changed */"),
                    encoding="utf-8")
    driver.get(path.as_uri())
    time.sleep(0.5)
    assert driver.execute_script(
        "const f = document.querySelector('figure.live-figure'); return [f.classList.contains("
        "'live'), getComputedStyle(f.querySelector('img')).display, "
        "f.querySelectorAll('.js-plotly-plot').length]") == [False, "inline", 0]
