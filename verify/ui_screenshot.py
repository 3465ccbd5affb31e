"""The tuner page's screenshot for the README, and its redraw time against the 150 ms target.

Serves ``fl-design ui`` for a plant (default the TRMS bench design) in this process, drives
headless Chromium (Selenium + Debian's chromium-driver) to move gamma from 3e-4 to 3e-3 in
log steps (each waiting for its redraw), prints each redraw's time as the page measures it
(input event to drawn, the server's part beside it) with the machine's load, waits for the
background results (map, certificates, margins, C cost) and saves a screenshot.

Usage::

    python verify/ui_screenshot.py                 # docs/img/ui.png, waits for every result
    python verify/ui_screenshot.py --quick         # 4 moves, no waiting, a temporary PNG

Exit status 1 when the median redraw exceeds 150 ms (the issue's target on 2 cores; a loaded
machine can miss it: the load is printed) or when the page does not draw.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path

from screenshots import driver, wait_for

TARGET_MS = 150.0
ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="4 moves, no wait, a temporary PNG")
    ap.add_argument("--plant", default="trms", help="library plant (default trms)")
    ap.add_argument("--png", default=None, help="where the screenshot goes (default "
                    "docs/img/ui.png; --quick: a temporary file)")
    ap.add_argument("--wait", type=float, default=240.0,
                    help="seconds to wait for the background results (default 240)")
    args = ap.parse_args(argv)
    try:
        drv = driver(1400, 1000)
    except RuntimeError as exc:  # selenium, Chromium or chromedriver missing
        print(f"skipped: {exc}")
        return 0
    try:
        return _drive(drv, args)
    finally:
        drv.quit()


def _drive(drv, args) -> int:
    """Serve the tuner, move gamma in ``drv``, time the redraws, save the screenshot."""
    from fl_design.app import parse_config
    from fl_design.app._cli import ui_setup
    from fl_design.ui import Tuner, TunerApp, make_server, url_of

    png = Path(args.png) if args.png else (
        Path(tempfile.mkdtemp(prefix="fl-ui-")) / "ui.png" if args.quick
        else ROOT / "docs" / "img" / "ui.png")
    cfg = parse_config(f'[plant]\nlibrary = "{args.plant}"', source=f"--plant {args.plant}")
    app = TunerApp(Tuner(ui_setup(cfg)), "ui_out",  # shown on the page; nothing is written
                   background=not args.quick)
    httpd = make_server(app, 0)
    thread = threading.Thread(target=httpd.serve_forever, kwargs={"poll_interval": 0.1},
                              daemon=True)
    thread.start()
    try:
        drv.get(url_of(httpd, app))
        if not wait_for(drv, "return window.flTuner && window.flTuner.redraws >= 1", 60):
            print("FAILS: the page did not draw within 60 s")
            return 1
        steps = 4 if args.quick else 9
        gammas = [3e-4 * 10 ** (i / (steps - 1)) for i in range(steps)]
        times, server = [], []
        for g in gammas:
            n = drv.execute_script("""
                const c = window.flTuner.controls.find((x) => x.name === 'gamma');
                const lo = Math.log10(c.min), hi = Math.log10(c.max);
                c.input.value = String(Math.round(1000 * (Math.log10(arguments[0]) - lo) / (hi - lo)));
                c.input.dispatchEvent(new Event('input', {bubbles: true}));
                return window.flTuner.redraws;""", g)
            if not wait_for(drv, f"return window.flTuner.redraws > {n} && "
                         "!window.flTuner.inflight", 60):
                print(f"FAILS: no redraw for gamma = {g:.3g} within 60 s")
                return 1
            times.append(drv.execute_script("return window.flTuner.lastRedrawMs"))
            server.append(drv.execute_script("return window.flTuner.lastServerMs"))
            status = drv.find_element("id", "status").text
            over = drv.find_element("id", "overshoot").text
            print(f"gamma = {g:.3g}: {status}, overshoot {over}; redrawn in {times[-1]:.0f} ms "
                  f"(server {server[-1]:.0f} ms)")
            time.sleep(0.3)  # a user's pace: the background is paused while the slider moves
        if not args.quick:
            end = time.time() + args.wait
            while time.time() < end:
                states = drv.execute_script("return window.flTuner.bg && Object.values("
                                            "window.flTuner.bg).map((s) => s.state)")
                if states and all(s == "ready" for s in states):
                    break
                time.sleep(1.0)
            print(f"background results: {states}")
            time.sleep(1.0)
        png.parent.mkdir(parents=True, exist_ok=True)
        drv.save_screenshot(str(png))
        med = statistics.median(times)
        load = os.getloadavg()[0]
        ok = med <= TARGET_MS
        print(f"{'holds' if ok else 'FAILS'}: median redraw {med:.0f} ms (max {max(times):.0f} ms"
              f", server median {statistics.median(server):.0f} ms) against {TARGET_MS:.0f} ms; "
              f"load {load:.1f} on {os.cpu_count()} cores")
        print(f"wrote {png}")
        return 0 if ok else 1
    finally:
        httpd.shutdown()
        httpd.server_close()
        app.close()


if __name__ == "__main__":
    sys.exit(main())
