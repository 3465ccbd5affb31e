"""Screenshots of the report for the docs, taken in headless Chromium at 1280 px.

Runs ``fl-design run`` (``--quick`` by default; ``--full`` for the whole job) into a temporary
folder, or uses ``--report DIR`` (a folder holding ``report.html``), then writes
``docs/img/report.png`` (the first screen: the summary) and ``docs/img/report_page.png`` (the
whole page, at most 12 000 px tall) and prints the page's measurements (scroll width against
the window, height). Needs selenium (``pip install -e '.[dev]'``) and Chromium with its driver
(Debian: ``apt-get install chromium chromium-driver``); exits 2 naming what is missing.

Usage::

    python verify/screenshots.py [--report DIR] [--full] [--out docs/img] [--width 1280]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def driver(width: int, height: int):
    """A headless Chromium driven by selenium, ``width`` x ``height`` CSS pixels.

    Raises
    ------
    RuntimeError
        selenium, Chromium or chromedriver missing (the message says which).
    """
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.options import Options
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        raise RuntimeError("selenium is not installed: pip install -e '.[dev]'") from None
    browser = shutil.which("chromium") or shutil.which("chromium-browser") or \
        shutil.which("google-chrome")
    chromedriver = shutil.which("chromedriver")
    if not browser or not chromedriver:
        raise RuntimeError("Chromium and chromedriver are needed (Debian: apt-get install "
                           "chromium chromium-driver)")
    opts = Options()
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
                f"--window-size={width},{height}", "--force-device-scale-factor=1"):
        opts.add_argument(arg)
    opts.binary_location = browser
    drv = webdriver.Chrome(service=Service(chromedriver), options=opts)
    drv.set_page_load_timeout(60)
    drv.set_script_timeout(30)
    return drv


def wait_for(drv, script: str, timeout: float):
    """The first truthy value of ``script`` run in the page (polled every 20 ms), or None after
    ``timeout`` seconds."""
    end = time.time() + timeout
    while time.time() < end:
        value = drv.execute_script(script)
        if value:
            return value
        time.sleep(0.02)
    return None


def measure(drv) -> dict:
    """Scroll width, client width and page height of the loaded page."""
    return drv.execute_script(
        "const d = document.documentElement;"
        "return {scroll_width: d.scrollWidth, client_width: d.clientWidth,"
        " page_height: d.scrollHeight, images: document.images.length,"
        " stylesheet_rules: Array.from(document.styleSheets)"
        "   .reduce((n, s) => n + s.cssRules.length, 0)};")


def shoot(html: Path, out: Path, width: int = 1280, height: int = 900) -> dict:
    """Write ``report.png`` (first screen) and ``report_page.png`` (whole page) of ``html``.

    Returns the page's measurements (:func:`measure`).
    """
    out.mkdir(parents=True, exist_ok=True)
    drv = driver(width, height)
    try:
        drv.get(html.resolve().as_uri())
        m = measure(drv)
        drv.save_screenshot(str(out / "report.png"))
        drv.set_window_size(width, min(int(m["page_height"]) + 120, 12_000))
        drv.save_screenshot(str(out / "report_page.png"))
    finally:
        drv.quit()
    return m


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--report", type=Path, default=None, help="a folder holding report.html")
    p.add_argument("--full", action="store_true", help="run the whole job (default --quick)")
    p.add_argument("--out", type=Path, default=ROOT / "docs" / "img")
    p.add_argument("--width", type=int, default=1280)
    args = p.parse_args(argv)
    folder = args.report
    if folder is None:
        folder = Path(tempfile.mkdtemp(prefix="fl_screens_")) / "out"
        cmd = [sys.executable, "-m", "fl_design", "run", "--no-progress", "--out", str(folder)]
        if not args.full:
            cmd.insert(4, "--quick")
        env = dict(os.environ, MPLBACKEND="Agg")
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=1800, env=env,
                              check=False)
        if proc.returncode != 0:
            print(proc.stderr[-2000:], file=sys.stderr)
            return proc.returncode
    html = folder / "report.html"
    if not html.is_file():
        print(f"screenshots: no report.html in {folder}", file=sys.stderr)
        return 2
    try:
        m = shoot(html, args.out, args.width)
    except RuntimeError as err:
        print(f"screenshots: {err}", file=sys.stderr)
        return 2
    print(json.dumps(m))
    print(f"wrote {args.out / 'report.png'} and {args.out / 'report_page.png'}")
    return 0 if m["scroll_width"] <= m["client_width"] + 1 else 1


if __name__ == "__main__":
    raise SystemExit(main())
