"""The report's two renderers: one self-contained HTML page and the same content in Markdown.

A section is ``(title, blocks)``; a block is ``("p", text)``, ``("pre", text)``, ``("list",
items)``, ``("table", header, rows)``, ``("links", [(question, answer, section)])`` (the
summary: an answer is a :class:`~fl_design.app._brief.Brief` or text), ``("math", label,
mathml, latex)``, ``("details", summary, text)`` or ``("fig", file name, caption)``.

Everything that is text is escaped for its format: HTML entities in the page, backslash
escapes in Markdown (markup, links, images, table pipes; newlines become spaces), so a name a
user chose (``<img src=x onerror=...>``, a line break, ``|``) shows as written and never turns
into markup. The page carries its stylesheet and its figures (base64; the main ones also
drawn live by Plotly.js inlined once, :mod:`fl_design.app._report_interactive`), works offline
and prints: the summary first, a badge per verdict whose colour carries the meaning and whose
word and border say it again in greyscale, tables that wrap inside the width.

Examples
--------
>>> from fl_design.app._report_render import md
>>> md("<img src=x onerror=alert(1)>\\n# heading")
'\\\\<img src=x onerror=alert(1)\\\\> \\\\# heading'
"""

from __future__ import annotations

import base64
import html
import re
from pathlib import Path

from ._brief import Brief

_MD_SPECIAL = re.compile(r"([\\`*_\[\]{}<>#|!~&$])")


def md(text) -> str:
    """``text`` as one line of literal Markdown: markup characters backslash-escaped.

    Parameters
    ----------
    text : object
        Written as ``str(text)``, white space folded.

    Returns
    -------
    str
        Also a leading ``1.``, ``-``, ``+`` or ``=`` escaped (no list, no heading).

    Examples
    --------
    >>> from fl_design.app._report_render import md
    >>> print(md("a|b *c* [l](u)"))
    a\\|b \\*c\\* \\[l\\](u)
    """
    one = " ".join(str(text).split())
    out = _MD_SPECIAL.sub(r"\\\1", one)
    if re.match(r"^(\d+[.)]|[-+=])(\s|$)", out):  # a list item or a heading underline
        out = "\\" + out
    return out


def _fence(text: str) -> str:
    """A code fence longer than any run of backticks in ``text`` (it cannot be closed early)."""
    longest = max((len(m) for m in re.findall(r"`+", text)), default=0)
    return "`" * max(3, longest + 1)


def _md_answer(answer) -> str:
    if isinstance(answer, Brief):
        text = str(answer)
        word = answer.word
        rest = text[len(word):]
        return f"**{md(word)}** {md(rest)}".rstrip() if text.startswith(word) else md(text)
    return md(answer)


def render_markdown(secs) -> str:
    """Render sections as Markdown (figures as linked PNG files), every text escaped.

    Parameters
    ----------
    secs : list of (str, list)
        Sections: a title and its blocks.

    Returns
    -------
    str

    Examples
    --------
    >>> from fl_design.app._report_render import render_markdown
    >>> print(render_markdown([("Title", [("p", "text"), ("table", ["a"], [[1]])])]))
    ## Title
    <BLANKLINE>
    text
    <BLANKLINE>
    | a |
    | --- |
    | 1 |
    <BLANKLINE>
    """
    from ._report_summary import anchor

    out = []
    for title, blocks in secs:
        out += [f"## {md(title)}", ""]
        for block in blocks:
            kind = block[0]
            if kind == "p":
                out += [md(block[1]), ""]
            elif kind == "math":  # SymPy's LaTeX of the plant's own expressions
                out += [f"{md(block[1])} $${block[3]}$$", ""]
            elif kind in ("details", "pre"):
                text = block[-1]
                fence = _fence(text)
                if kind == "details":
                    out += [f"<details><summary>{html.escape(block[1])}</summary>", ""]
                out += [fence, text, fence, ""]
                if kind == "details":
                    out += ["</details>", ""]
            elif kind == "list":
                out += [f"- {md(item)}" for item in block[1]] + [""]
            elif kind == "links":
                out += ["| question | answer |", "| --- | --- |"]
                out += [f"| [{md(q)}](#{anchor(sec)}) | {_md_answer(a)} |" for q, a, sec in block[1]]
                out.append("")
            elif kind == "table":
                out.append("| " + " | ".join(md(h) for h in block[1]) + " |")
                out.append("|" + " --- |" * len(block[1]))
                out += ["| " + " | ".join(md(c) for c in row) + " |" for row in block[2]]
                out.append("")
            elif kind == "fig":
                out += [f"![{md(block[2])}]({block[1]})", "", f"*{md(block[2])}*", ""]
    return "\n".join(out)


#: The page's stylesheet: layout, badges (colour + symbol + border: readable in greyscale),
#: tables that wrap inside the width, print rules.
CSS = """
:root{--good:#1a7f37;--warn:#9a6700;--bad:#cf222e;--info:#57606a;--line:#d0d7de;--bg2:#f6f8fa;
--ink:#1f2328;--link:#0969da}
*{box-sizing:border-box}
html{-webkit-text-size-adjust:100%}
body{font:15px/1.5 system-ui,-apple-system,"Segoe UI",Roboto,"Helvetica Neue",Arial,sans-serif;
color:var(--ink);max-width:1120px;margin:0 auto;padding:1.2rem 2rem 3rem;overflow-wrap:anywhere}
h1{font-size:1.55rem;line-height:1.25;margin:.3rem 0 .8rem;padding-bottom:.35rem;
border-bottom:3px solid var(--ink)}
h2{font-size:1.2rem;margin:2.2rem 0 .6rem;padding-bottom:.2rem;border-bottom:1px solid var(--line)}
a{color:var(--link);text-decoration:none}
a:hover{text-decoration:underline}
p{margin:.5rem 0}
nav.toc{font-size:.88rem;color:var(--info);margin:0 0 1rem}
nav.toc a{margin-right:.9rem;white-space:nowrap}
table{border-collapse:collapse;width:100%;margin:.6rem 0 1rem;font-size:.9rem}
th,td{border:1px solid var(--line);padding:.3rem .55rem;text-align:left;vertical-align:top}
thead th,tr.head th{background:var(--bg2);font-weight:600}
td.num{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}
table.summary{font-size:.95rem}
table.summary th{width:15rem;background:var(--bg2);font-weight:600}
table.summary td{line-height:1.6}
.badge{display:inline-block;padding:0 .55rem;margin-right:.35rem;border-radius:.8rem;
font-weight:700;font-size:.85rem;border:2px solid;white-space:nowrap}
.badge.good{color:#fff;background:var(--good);border-color:var(--good)}
.badge.good::before{content:"\\2713\\00a0"}
.badge.warn{color:var(--ink);background:#fff8c5;border-color:var(--warn);border-style:dashed}
.badge.warn::before{content:"!\\00a0"}
.badge.bad{color:#fff;background:var(--bad);border-color:#82071e;border-style:double;border-width:3px}
.badge.bad::before{content:"\\2717\\00a0"}
.badge.info{color:var(--info);background:#fff;border-color:var(--line)}
details{margin:.3rem 0}
details>summary{cursor:pointer;color:var(--link);font-size:.88rem}
details.why{display:inline}
details.why[open]{display:block}
details.why>div{font-size:.88rem;color:var(--info);margin:.25rem 0 .1rem}
pre{background:var(--bg2);padding:.6rem .8rem;overflow-x:auto;white-space:pre-wrap;
font-size:.82rem;border-radius:4px}
div.math{overflow-x:auto;margin:.4rem 0}
math{font-size:1.35em}
figure{margin:1.2rem 0;text-align:center}
img{max-width:100%;height:auto;border:1px solid var(--line)}
figcaption{font-size:.86rem;color:var(--info);margin-top:.3rem}
ul{padding-left:1.3rem}
@media (max-width:700px){body{padding:.8rem}table.summary th{width:auto}}
@media print{body{max-width:none;padding:0;font-size:10.5pt}nav.toc{display:none}
a{color:inherit}h2{break-after:avoid}figure,tr{break-inside:avoid}
.badge{-webkit-print-color-adjust:exact;print-color-adjust:exact}
details>summary{display:none}details>*{display:block}}
"""


def _html_answer(answer) -> str:
    e = html.escape
    if not isinstance(answer, Brief):
        return e(str(answer))
    detail = e(str(answer)[len(answer.word):].lstrip(" —")) if str(answer).startswith(
        answer.word) else e(str(answer))
    sep = " — " if detail else ""
    why = (f'<details class="why"><summary>why</summary><div>{e(answer.long)}</div></details>'
           if answer.long and answer.long != str(answer) else "")
    return (f'<span class="badge {e(answer.level)}">{e(answer.word)}</span>{sep}{detail} {why}'
            .rstrip())


def _is_number(text: str) -> bool:
    return bool(re.fullmatch(r"[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?", text.strip()))


def render_html(secs, folder: Path, *, title: str, live=None) -> str:
    """Render sections as one self-contained HTML page (PNG figures embedded as base64).

    With ``live`` (:class:`~fl_design.app._report_interactive.LiveFigures`), the figures it
    holds are drawn by Plotly.js inlined in the page (zoom, hover values), their PNG kept for
    print and for a browser without JavaScript; the page then carries a Content-Security-Policy
    that allows only its own scripts and no connection.

    Parameters
    ----------
    secs : list of (str, list)
        Sections.
    folder : pathlib.Path
        Where the figures' PNG files are.
    title : str
        Page title.
    live : LiveFigures, optional
        Interactive figures (default none: a page without scripts).

    Returns
    -------
    str

    Examples
    --------
    >>> from pathlib import Path
    >>> from fl_design.app._report_render import render_html
    >>> '<h2 id="a">A</h2>' in render_html([("A", [("p", "x < y")])], Path("."), title="t")
    True
    """
    from ._report_summary import anchor

    e = html.escape
    toc = " ".join(f'<a href="#{anchor(name)}">{e(name)}</a>' for name, _ in secs)
    body = [f"<h1>{e(title)}</h1>", f'<nav class="toc">{toc}</nav>']
    for name, blocks in secs:
        body.append(f'<h2 id="{anchor(name)}">{e(name)}</h2>')
        for block in blocks:
            kind = block[0]
            if kind == "p":
                body.append(f"<p>{e(str(block[1]))}</p>")
            elif kind == "math":  # MathML from SymPy's printer (our own output, not user text)
                body.append(f'<div class="math">{e(block[1])} <math>{block[2]}</math></div>')
            elif kind == "details":
                body.append(f"<details><summary>{e(block[1])}</summary><pre>{e(block[2])}"
                            "</pre></details>")
            elif kind == "list":
                body.append("<ul>" + "".join(f"<li>{e(str(i))}</li>" for i in block[1])
                            + "</ul>")
            elif kind == "links":
                rows = "".join(f'<tr><th><a href="#{anchor(sec)}">{e(q)}</a></th>'
                               f"<td>{_html_answer(a)}</td></tr>" for q, a, sec in block[1])
                body.append(f'<table class="summary">{rows}</table>')
            elif kind == "pre":
                body.append(f"<pre>{e(block[1])}</pre>")
            elif kind == "table":
                head = "".join(f"<th>{e(str(h))}</th>" for h in block[1])
                rows = "".join("<tr>" + "".join(
                    f'<td class="num">{e(str(c))}</td>' if _is_number(str(c)) else
                    f"<td>{e(str(c))}</td>" for c in row) + "</tr>" for row in block[2])
                body.append(f"<table><thead><tr>{head}</tr></thead><tbody>{rows}</tbody>"
                            "</table>")
            elif kind == "fig":
                data = base64.b64encode((Path(folder) / block[1]).read_bytes()).decode("ascii")
                img = f'<img alt="{e(block[2])}" src="data:image/png;base64,{data}">'
                cap = f"<figcaption>{e(block[2])}</figcaption>"
                body.append(live.figure(block[1], img, cap) if live and block[1] in live.specs
                            else f"<figure>{img}{cap}</figure>")
    head, css, tail = "", CSS, ""
    if live:
        from ._report_interactive import CSS as LIVE_CSS

        head, css, tail = live.head(), CSS + LIVE_CSS, "\n" + live.scripts()
    return (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">{head}'
            f'<meta name="viewport" content="width=device-width, initial-scale=1">'
            f"<title>{e(title)}</title><style>{css}</style></head><body>\n"
            + "\n".join(body) + tail + "\n</body></html>\n")


__all__ = ["CSS", "md", "render_html", "render_markdown"]
