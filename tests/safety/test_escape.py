"""Escaping of user-named text, checked with independent parsers: markdown-it (CommonMark),
html.parser, the csv module, matplotlib's text layout and a C compiler's preprocessor."""

from __future__ import annotations

import csv
import io
import shutil
import subprocess
from html.parser import HTMLParser

import pytest

from fl_design._escape import (
    ascii_text,
    c_comment,
    csv_field,
    html_text,
    markdown_text,
    plain_text,
)

NASTY = [
    "<img src=x onerror=alert(1)>",
    "pump\n# injected heading\n[link](javascript:alert(1))",
    "a | b |\n|---|---|\n| row | x |",
    "*bold* _it_ `code` ![i](x.png) <script>alert(1)</script>",
    "line\r\nbreak\u2028sep\u0085next\x1b[2J",
    "&amp; &lt; \\ \\\\ */ /* ??= $\\foo{$",
    "=HYPERLINK(\"http://x\")",
    "\u210e \u03b8 m\u00fcde \U0001f600",
]


class _Collect(HTMLParser):
    def __init__(self):
        super().__init__()
        self.tags, self.text = [], []

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)

    def handle_data(self, data):
        self.text.append(data)


def _html(markup: str) -> _Collect:
    parser = _Collect()
    parser.feed(markup)
    parser.close()
    return parser


def _flat(text: str) -> str:
    import re
    return re.sub(r"[\x00-\x1f\x7f-\x9f\u2028\u2029]+", " ", text)


@pytest.mark.parametrize("name", NASTY)
def test_markdown_renders_the_name_literally_in_a_heading_a_paragraph_and_a_table(name):
    from markdown_it import MarkdownIt

    md = MarkdownIt("commonmark").enable("table")
    esc = markdown_text(name)
    assert "\n" not in esc
    doc = f"# Report: {esc}\n\nPlant {esc} here.\n\n| name | v |\n|---|---|\n| {esc} | 1 |\n"
    out = _html(md.render(doc))
    assert out.tags == ["h1", "p", "table", "thead", "tr", "th", "th", "tbody", "tr", "td", "td"]
    text = "".join(out.text)
    assert text.count(_flat(name)) == 3, (text, name)


@pytest.mark.parametrize("name", NASTY)
def test_html_text_is_text(name):
    out = _html(f'<p title="{html_text(name)}">{html_text(name)}</p>')
    assert out.tags == ["p"] and "".join(out.text) == _flat(name)


@pytest.mark.parametrize("name", NASTY)
def test_csv_field_reads_back_as_one_field_and_never_a_formula(name):
    line = ",".join([csv_field(name), "t"]) + "\r\n"
    rows = list(csv.reader(io.StringIO(line)))
    assert len(rows) == 1 and len(rows[0]) == 2 and rows[0][1] == "t"
    assert rows[0][0].lstrip("'") == _flat(name) and rows[0][0][:1] not in "=+-@"


@pytest.mark.parametrize("name", NASTY)
def test_plain_text_is_never_mathtext_and_lays_out(name):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    ax.set_title(plain_text(name))
    ax.set_ylabel(plain_text("$\\foo{$ " + name))
    fig.canvas.draw()  # mathtext would raise on "$\\foo{$"
    assert not ax.title._text.startswith("$") or ax.title._text.startswith("\\$")
    plt.close(fig)


def test_ascii_text_encodes_as_ascii():
    for name in NASTY:
        ascii_text(name).encode("ascii")
    assert ascii_text("m\u00fcde \u03b8") == "mude \\u03b8"


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
@pytest.mark.parametrize("name", NASTY)
def test_c_comment_stays_a_comment(tmp_path, name):
    src = tmp_path / "x.c"
    src.write_text(f"/* plant: {c_comment(name)} */\n// {c_comment(name)}\nint ok = 1;\n")
    proc = subprocess.run(["cc", "-std=c99", "-pedantic", "-Werror", "-Wall", "-trigraphs",
                           "-c", str(src), "-o", str(tmp_path / "x.o")],
                          capture_output=True, text=True, timeout=60, check=False)
    assert proc.returncode == 0, proc.stderr
    c_comment(name).encode("ascii")
