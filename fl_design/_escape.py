"""Escaping of user-named text (plant, state and design names, units) for every output format.

A name comes from a config someone else may have written: ``<img src=x onerror=...>`` or a
newline followed by ``# heading`` must show as those characters, never act as markup. One
pure function per format, each returning one line:

* :func:`markdown_text`: Markdown paragraphs, headings and table cells (HTML special
  characters as entities, Markdown punctuation backslash-escaped, ``|`` too);
* :func:`html_text`: HTML text and attribute values;
* :func:`c_comment`: inside a C ``/* ... */`` or ``//`` comment (ASCII only, no comment end,
  no line splice, no trigraph);
* :func:`csv_field`: a CSV header or cell (RFC 4180 quoting; a leading ``= + - @`` cannot start
  a spreadsheet formula);
* :func:`plain_text`: matplotlib figure text (``$`` escaped: never mathtext) and terminals.

Line breaks and other control characters (``\\n``, ``\\r``, ``\\t``, U+2028, U+0085...) become
one space in every format: a name never adds a line, heading, table row or CSV record.

Examples
--------
>>> from fl_design._escape import markdown_text, plain_text
>>> markdown_text("pump <img src=x onerror=alert(1)>\\n# owned")
'pump &lt;img src=x onerror=alert\\\\(1\\\\)&gt; \\\\# owned'
>>> plain_text("$\\\\foo{$ m/s")
'\\\\$\\\\foo{\\\\$ m/s'
"""

from __future__ import annotations

import html
import re
import unicodedata

_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f\u2028\u2029]+")
_MARKDOWN = re.compile(r"([\\`*_{}\[\]()#+\-.!|~>:])")


def _one_line(text) -> str:
    """``str(text)`` with every run of control characters (line breaks...) as one space."""
    return _CONTROL.sub(" ", str(text))


def markdown_text(text) -> str:
    """``text`` as literal Markdown inline text, on one line (safe in a heading or table cell).

    Parameters
    ----------
    text : object
        Converted with ``str``.

    Returns
    -------
    str
        The escaped text, without line breaks.

    Examples
    --------
    >>> from fl_design._escape import markdown_text
    >>> markdown_text("a|b [x](javascript:1)")
    'a\\\\|b \\\\[x\\\\]\\\\(javascript\\\\:1\\\\)'
    """
    return _MARKDOWN.sub(r"\\\1", html.escape(_one_line(text), quote=True))


def html_text(text) -> str:
    """``text`` escaped for HTML text or a quoted attribute value, on one line.

    Examples
    --------
    >>> from fl_design._escape import html_text
    >>> html_text('<b onclick="x">&')
    '&lt;b onclick=&quot;x&quot;&gt;&amp;'
    """
    return html.escape(_one_line(text), quote=True)


def c_comment(text) -> str:
    """``text`` safe inside a C comment: ASCII (others as ``\\uXXXX``), no ``*/`` or ``/*``,
    no trailing backslash (a ``//`` line splice), no trigraph ``??``, on one line.

    Examples
    --------
    >>> from fl_design._escape import c_comment
    >>> c_comment("x */ system(1); /* \\u03b8??=\\\\")
    'x * / system(1); / * \\\\u03b8? ?=\\\\ '
    """
    out = "".join(ch if ord(ch) < 128 else f"\\u{ord(ch):04x}" if ord(ch) < 0x10000
                  else f"\\U{ord(ch):08x}" for ch in _one_line(text))
    while "*/" in out or "/*" in out or "??" in out:
        out = out.replace("*/", "* /").replace("/*", "/ *").replace("??", "? ?")
    return out + " " if out.endswith("\\") else out


def csv_field(text) -> str:
    """``text`` as one CSV field (RFC 4180): quoted when it holds ``, " ;`` or spaces at its
    ends, quotes doubled, and prefixed by ``'`` when it would start a spreadsheet formula.

    Examples
    --------
    >>> from fl_design._escape import csv_field
    >>> csv_field("theta"), csv_field('=HYPERLINK("x")'), csv_field("a,b")
    ('theta', '"\\'=HYPERLINK(""x"")"', '"a,b"')
    """
    out = _one_line(text)
    if out[:1] in ("=", "+", "-", "@"):
        out = "'" + out
    if any(c in out for c in ',";') or out != out.strip():
        out = '"' + out.replace('"', '""') + '"'
    return out


def plain_text(text) -> str:
    """``text`` shown literally by matplotlib (``$`` escaped, so never parsed as mathtext) and
    by terminals (no control characters: no escape sequences), on one line.

    Examples
    --------
    >>> from fl_design._escape import plain_text
    >>> plain_text("rad/s\\x1b[2J")
    'rad/s [2J'
    """
    return _one_line(text).replace("$", r"\$")


def ascii_text(text) -> str:
    """``text`` for a stream that cannot encode it (an ASCII-only terminal): NFKD letters
    without their accents, anything else as ``\\uXXXX``.

    Examples
    --------
    >>> from fl_design._escape import ascii_text
    >>> ascii_text("Pendel \\u03b8 m\\u00fcde")
    'Pendel \\\\u03b8 mude'
    """
    out = []
    for ch in str(text):
        if ord(ch) < 128:
            out.append(ch)
            continue
        base = unicodedata.normalize("NFKD", ch).encode("ascii", "ignore").decode()
        out.append(base if base else f"\\u{ord(ch):04x}" if ord(ch) < 0x10000
                   else f"\\U{ord(ch):08x}")
    return "".join(out)


__all__ = ["ascii_text", "c_comment", "csv_field", "html_text", "markdown_text", "plain_text"]
