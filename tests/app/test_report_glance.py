"""The report reads at a glance and stays safe with what a user names (issues 37, 36, 31).

* every summary cell of report.md is at most 25 words (the short forms), the HTML page carries
  a stylesheet and a badge per verdict, and at 1280 px in headless Chromium it has no
  horizontal scroll (skipped, saying why, without selenium or Chromium);
* a plant name and units with markup, newlines and mathtext come out literally in report.md,
  report.html and the figures (which are drawn, not dropped);
* a figure that fails to draw is named in the report, which is still written;
* the compared runs' CSV files hold at most CSV_MAX_ROWS rows unless asked for every sample;
* ``[compare] duration = "adaptive"`` sizes the compared runs from this design's rise time.
"""

from __future__ import annotations

import re
import shutil

import numpy as np
import pytest

import fl_design as fl
from fl_design.app import load_config, parse_config, run_job, write_report
from fl_design.app._brief import MAX_WORDS, run_brief
from fl_design.app._report_csv import CSV_MAX_ROWS, csv_rows, csv_text
from fl_design.app._report_summary import summary_rows

STAGES = ("derive", "certify", "sweep", "simulate")


def summary_cells(md: str) -> list[tuple[str, int]]:
    """(question, words of the answer) of the first section's table, as report_glance counts."""
    first = md.split("\n## ")[1]
    out = []
    for line in first.splitlines():
        if line.startswith("|") and not re.match(r"^\|\s*-", line):
            parts = [c.strip() for c in line.strip().strip("|").split("|")]
            if len(parts) >= 2 and parts[0].lower() != "question":
                out.append((parts[0], len(re.findall(r"\S+", " ".join(parts[1:])))))
    return out


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    import matplotlib

    matplotlib.use("Agg")
    out = tmp_path_factory.mktemp("glance")
    job = run_job(load_config(None), quick=True, stages=STAGES, progress=False)
    paths = write_report(job, out)
    return job, out, paths


def test_every_summary_cell_is_at_most_25_words(report):
    job, out, _ = report
    cells = summary_cells((out / "report.md").read_text())
    assert len(cells) >= 7
    assert max(n for _, n in cells) <= MAX_WORDS, cells
    for question, answer, _ in summary_rows(job):
        assert len(str(answer).split()) <= MAX_WORDS, (question, str(answer))


def test_the_page_is_styled_with_badges_that_carry_a_word(report):
    _, out, paths = report
    html = (out / "report.html").read_text()
    css = " ".join(re.findall(r"<style[^>]*>(.*?)</style>", html, re.DOTALL))
    assert len(re.findall(r"\{[^{}]*\}", css)) >= 15
    assert "@media print" in css and "http" not in css
    # no script but the page's own: the figures' JSON, Plotly.js and the drawing script
    scripts = re.findall(r"<script[^>]*>", html)
    assert scripts.count("<script>") <= 2 and len(scripts) <= 2 + len(paths["live_figures"])
    assert all(s == "<script>" or s.startswith('<script type="application/json"')
               for s in scripts)
    badges = re.findall(r'<span class="badge (good|warn|bad|info)">([^<]+)</span>', html)
    assert len(badges) >= 6 and all(word.strip() for _, word in badges)


def test_the_short_form_of_a_run_agrees_with_its_metrics():
    r = fl.simulate(fl.plants.pendulum(), fl.presets.pendulum_design(), fl.Scenario(0.1, 20.0))
    b = run_brief(r)
    assert b.word == r.status == "converged" and b.level == "good"
    assert f"{r.settling_time:.3g} s" in b.detail and f"{r.overshoot:.3g} %" in b.detail
    assert b.long == r.verdict() and b.words() <= MAX_WORDS


def _chromium():
    webdriver = pytest.importorskip("selenium.webdriver", reason="selenium is not installed "
                                    "(pip install -e '.[dev]'): the page's width is not checked")
    if not (shutil.which("chromium") or shutil.which("chromium-browser")) or \
            not shutil.which("chromedriver"):
        pytest.skip("no Chromium and chromedriver on PATH (Debian: apt-get install chromium "
                    "chromium-driver): the page's width is not checked")
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "verify"))
    try:
        from screenshots import driver
    finally:
        sys.path.pop(0)
    del webdriver
    return driver


@pytest.mark.slow
def test_no_horizontal_scroll_at_1280_px_in_chromium(report):
    driver = _chromium()
    _, out, _ = report
    drv = driver(1280, 900)
    try:
        drv.get((out / "report.html").as_uri())
        sw = drv.execute_script("return document.documentElement.scrollWidth")
        cw = drv.execute_script("return document.documentElement.clientWidth")
        widest = drv.execute_script(
            "return Math.max(...Array.from(document.querySelectorAll('table, figure, pre'))"
            ".map(e => e.getBoundingClientRect().right))")
    finally:
        drv.quit()
    assert sw <= cw + 1, f"scrollWidth {sw} > clientWidth {cw}"
    assert widest <= cw + 1


HOSTILE_NAME = "<img src=x onerror=alert(1)>\n# owned | [link](javascript:x) `code`"


def test_what_a_user_names_is_literal_everywhere(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    from fl_design.app._template import config_toml

    text = config_toml(from_ode=True).replace('name = "my_plant"',
                                              f"name = {HOSTILE_NAME!r}".replace("'", '"')
                                              .replace("\n", "\\n"))
    text = re.sub(r'output_unit = "[^"]*"', r'output_unit = "$\\\\foo{$"', text)
    text = re.sub(r'input_unit = "[^"]*"', 'input_unit = "<b>N m</b>"', text)
    # init --from-ode leaves [design] to fl.tune at run time; this test is about names: give one
    text = re.sub(r"^\[design\]\n", "[design]\neps = 0.02\nT = 0.001\ngains = [2.0, 4.0]\n"
                  "gamma = 0.01\n", text, flags=re.MULTILINE)
    text = re.sub(r"^\[scenario\]\n", "[scenario]\nreference = 0.1\n", text, flags=re.MULTILINE)
    cfg = parse_config(text)
    assert cfg.plant.name == HOSTILE_NAME and cfg.plant.output_unit == "$\\foo{$"
    job = run_job(cfg, quick=True, stages=("derive", "simulate"), progress=False)
    paths = write_report(job, tmp_path)
    assert paths["failed_figures"] == {}  # the mathtext unit is drawn literally
    assert {"response.png", "steps.png"} <= set(paths["figures"])
    md = (tmp_path / "report.md").read_text()
    fences = re.findall(r"^(`{3,})$", md, re.MULTILINE)
    assert len(fences) % 2 == 0
    # code blocks show their text literally (a fence longer than any backtick run inside)
    md = re.sub(r"^(`{3,})\n.*?\n\1$", "", md, flags=re.MULTILINE | re.DOTALL)
    assert "<img" not in md.replace("\\<img", "") and "<b>" not in md.replace("\\<b\\>", "")
    assert not any(line.startswith("# owned") for line in md.splitlines())
    assert not re.search(r"(?<!\\)\]\(javascript", md) and not re.search(r"(?<!\\)`code", md)
    assert md.count("\n# ") == 0 and md.startswith("# fl\\_design report: \\<img")
    html = (tmp_path / "report.html").read_text()
    assert "<img src=x" not in html and "&lt;img src=x onerror=alert(1)&gt;" in html
    assert "<b>N m</b>" not in html
    cells = summary_cells(md)
    assert all(n <= MAX_WORDS for _, n in cells)


def test_a_figure_that_fails_is_named_and_the_report_is_still_written(tmp_path, monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    from fl_design.app import _report_figures as F

    def broken(job, ctx):
        raise ValueError("ParseFatalException: Expected end of text")

    monkeypatch.setitem(F.FIGURES, "steps.png", (broken, "simulate"))
    job = run_job(load_config(None), quick=True, stages=("simulate",), progress=False)
    paths = write_report(job, tmp_path)
    assert "steps.png" not in paths["figures"] and "response.png" in paths["figures"]
    assert paths["failed_figures"] == {"steps.png": "ValueError: ParseFatalException: Expected "
                                                    "end of text"}
    assert "Figures not drawn: steps.png (ValueError" in (tmp_path / "report.html").read_text()
    assert "](steps.png)" not in (tmp_path / "report.md").read_text()


def test_csv_files_are_bounded_and_full_on_request():
    r = fl.simulate(fl.plants.pendulum(), fl.presets.pendulum_design(), fl.Scenario(0.1, 25.0))
    n = r.t.size
    assert n > CSV_MAX_ROWS
    idx = csv_rows(n, CSV_MAX_ROWS)
    assert idx.size <= CSV_MAX_ROWS and idx[0] == 0 and idx[-1] == n - 1
    assert np.all(np.diff(idx) > 0) and np.ptp(np.diff(idx)[:-1]) == 0  # evenly spaced
    text = csv_text(r)
    rows = text.splitlines()
    assert len(rows) - 1 == idx.size and rows[0] == r.to_csv().splitlines()[0]
    k = int(idx[1])
    assert rows[2].split(",")[0] == repr(float(r.t[k]))  # the k-th sample, exact
    assert csv_text(r, None) == r.to_csv()


def test_adaptive_compared_runs_last_a_multiple_of_this_designs_rise_time():
    from fl_design.app._build import build_setup
    from fl_design.app._stages import COMPARE_RISE_TIMES, simulate

    cfg = parse_config('[plant]\nlibrary = "pendulum"\n[compare]\nduration = "adaptive"\n'
                       'noise_std = [0.001]\neps_tradeoff = [0.02]\n')
    sim = simulate(build_setup(cfg), False)
    main = fl.simulate(fl.plants.pendulum(), fl.presets.bench_design("pendulum"),
                       fl.Scenario(cfg.scenario.reference, noise=fl.Noise(0.0, seed=1)))
    assert sim["duration"] == pytest.approx(main.duration)
    want = min(COMPARE_RISE_TIMES * main.rise_time, main.duration)
    assert sim["compare_duration"] == pytest.approx(want, rel=1e-9, abs=main.T)
    assert "rise time" in sim["compare_reason"]
    assert all(r.duration == pytest.approx(sim["compare_duration"], abs=2 * main.T)
               for r in sim["runs"].values())


def test_no_cell_says_certified_for_a_non_minimum_phase_plant():
    """w' = w + x1, x1' = x2, x2' = u, y = x1 (issue 31): the zero dynamics w' = w are unstable
    (eigenvalue 1, SymPy's normal form agrees), so the summary says the assumptions fail."""
    cfg = parse_config('[plant]\nname = "nmp"\nstates = ["w", "x1", "x2"]\ninput = "u"\n'
                       'rhs = ["w + x1", "x2", "u"]\noutput = "x1"\n'
                       'region = { w = [-10.0, 10.0], x1 = [-2.0, 2.0], x2 = [-5.0, 5.0] }\n'
                       'input_range = [-20.0, 20.0]\n[design]\neps = 0.02\nT = 0.001\n'
                       'gains = [1.0, 2.0]\ncoeffs = [3.0, 3.0, 1.0]\ngamma = 0.01\n'
                       '[scenario]\nreference = 0.1\n')
    job = run_job(cfg, quick=True, stages=("derive",), progress=False)
    assert job.derivation["minimum_phase"] is False
    assert complex(job.derivation["zero_dynamics_eigenvalues"][0]) == pytest.approx(1.0)
    rows = {q: a for q, a, _ in summary_rows(job)}
    for question in ("Certified for its class", "This step certified?"):
        assert rows[question].word == "assumptions fail" and rows[question].level == "bad"
    assert not any(str(a).startswith("certified") for a in rows.values())
    from fl_design.app._report_summary import summary_blocks

    assert summary_blocks(job, [])[0][1].startswith("The method's assumptions fail")
