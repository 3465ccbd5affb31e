"""The report as a browser shows it: headless Chromium renders ``report.html`` (skips without one).

A copy of the report gets a measuring script (the report itself has none); Chromium loads it
with a 1280 x 1080 window and prints the DOM after the load event, which carries the numbers:
where the summary section (its table and the design's own figure) ends, whether every image
decoded, whether anything is wider than the window. A screenshot of the first screen is also
taken and must show the summary (not a blank page).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
SCREEN = (1280, 1080)
BROWSERS = ("chromium-headless-shell", "chromium", "chromium-browser", "google-chrome")

_MEASURE = """
window.addEventListener("load", () => {
  const h2 = Array.from(document.querySelectorAll("h2"));
  const s = h2.findIndex(h => h.textContent.trim() === "Summary");
  let end = null, figures = 0;
  if (s >= 0) {
    let el = h2[s].nextElementSibling, last = h2[s];
    while (el && el.tagName !== "H2") {
      if (el.tagName === "FIGURE") figures += 1;
      last = el; el = el.nextElementSibling;
    }
    end = last.getBoundingClientRect().bottom + window.scrollY;
  }
  const out = document.createElement("pre");
  out.id = "fl-measure";
  out.textContent = JSON.stringify({
    summary_end: end, summary_figures: figures,
    viewport: [window.innerWidth, window.innerHeight],
    page_height: document.documentElement.scrollHeight,
    page_width: document.documentElement.scrollWidth,
    images: Array.from(document.images).map(i => [i.complete, i.naturalWidth, i.naturalHeight])
  });
  document.body.appendChild(out);
});
"""


def _browser() -> str | None:
    for name in BROWSERS:
        path = shutil.which(name)
        if path:
            return path
    return None


def _chromium(browser: str, profile: Path, *args) -> subprocess.CompletedProcess:
    flags = [f"--user-data-dir={profile}", "--disable-gpu", "--hide-scrollbars",
             f"--window-size={SCREEN[0]},{SCREEN[1]}", "--virtual-time-budget=10000"]
    if Path(browser).name != "chromium-headless-shell":
        flags.insert(0, "--headless")
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        flags.append("--no-sandbox")  # Chromium refuses to run as root with its sandbox
    return subprocess.run([browser, *flags, *args], capture_output=True, text=True,
                          timeout=120, check=False)


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    browser = _browser()
    if browser is None:
        pytest.skip("no Chromium on PATH (Debian: apt-get install chromium-headless-shell); "
                    "the report's rendering is not checked")
    out = tmp_path_factory.mktemp("report")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    # the static page (its PNG figures; the interactive one: test_report_interactive.py)
    proc = subprocess.run([sys.executable, "-m", "fl_design", "run", "--quick", "--static-report",
                           "--out", str(out)], capture_output=True, text=True, env=env,
                          timeout=300, check=False)
    assert proc.returncode == 0, proc.stderr
    html = (out / "report.html").read_text(encoding="utf-8")
    assert "<script" not in html  # the report runs no scripts; only the copy below measures
    probe = out / "measure.html"
    probe.write_text(html.replace("</body>", f"<script>{_MEASURE}</script></body>"),
                     encoding="utf-8")
    profile = tmp_path_factory.mktemp("chromium-profile")
    dom = _chromium(browser, profile, "--dump-dom", probe.as_uri())
    found = re.search(r'<pre id="fl-measure">([^<]*)</pre>', dom.stdout)
    assert found, f"Chromium printed no measurement (exit {dom.returncode}): {dom.stderr[-500:]}"
    shot = out / "first_screen.png"
    _chromium(browser, profile, f"--screenshot={shot}", (out / "report.html").as_uri())
    return json.loads(found.group(1).replace("&quot;", '"')), shot


def test_summary_and_its_figure_within_three_screens(rendered):
    m, _ = rendered
    assert m["viewport"] == list(SCREEN)
    assert m["summary_end"] is not None, "no Summary section"
    assert m["summary_figures"] >= 1  # the design's own run is shown in the summary
    assert m["summary_end"] <= 3 * SCREEN[1], f"summary ends at {m['summary_end']:.0f} px"
    assert m["page_height"] > m["summary_end"]  # the details follow


def test_every_image_decodes_and_nothing_is_wider_than_the_window(rendered):
    m, _ = rendered
    assert len(m["images"]) == 5
    for complete, width, height in m["images"]:
        assert complete and width > 100 and height > 100, "a broken image"
    assert m["page_width"] <= SCREEN[0], f"page {m['page_width']} px wide"


def test_first_screen_shows_text_not_a_blank_page(rendered):
    import matplotlib.image

    _, shot = rendered
    assert shot.exists(), "Chromium wrote no screenshot"
    pixels = matplotlib.image.imread(str(shot))
    assert pixels.shape[:2] == (SCREEN[1], SCREEN[0])
    gray = pixels[..., :3].mean(axis=2)
    dark_rows = np.flatnonzero((gray < 0.5).any(axis=1))  # rows with text or lines on them
    assert dark_rows.size > 0.2 * SCREEN[1], "the first screen is nearly blank"
