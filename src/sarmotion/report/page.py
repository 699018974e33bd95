"""The page every HTML report of sarmotion shares: stylesheet, header, sections, tables.

The analysis report (:mod:`sarmotion.report.html`) and the tracks report
(:mod:`sarmotion.report.tracks`) are written with :func:`page`: one stylesheet
(:data:`CSS`), the same header (the title, then one line: the package version, the time
written and what was found) and the body as white sections in a column at most 1400 px
wide, with the same tables (:func:`table`) and figures (:func:`figure`: as wide as the
column at most, their caption under them).
"""

from __future__ import annotations

import datetime as _dt
import html
from collections.abc import Sequence

from .._version import __version__

__all__ = ["CSS", "figure", "header_line", "page", "section", "table"]

#: The reports' stylesheet. ``main`` is 1400 px wide at most with 32 px of padding each
#: side and a section has 20 px of padding and a 1-px border each side: a figure wider
#: than the column left (1294 CSS px in a 1400-px window) is shown scaled down to it.
CSS = """
body{font-family:-apple-system,'Segoe UI',Helvetica,Arial,sans-serif;margin:0;color:#222;
background:#f5f6f8}
header{background:#1f3a5f;color:#fff;padding:18px 32px}
header h1{margin:0;font-size:22px} header p{margin:4px 0 0;opacity:.85;font-size:13px}
main{max-width:1400px;margin:0 auto;padding:16px 32px}
section{background:#fff;border:1px solid #dde1e6;border-radius:6px;margin:16px 0;
padding:12px 20px}
h2{font-size:17px;border-bottom:1px solid #e5e7eb;padding-bottom:6px;color:#1f3a5f}
table{border-collapse:collapse;font-size:13px;margin:8px 0}
th,td{border:1px solid #d0d5dc;padding:4px 8px;text-align:right}
th{background:#eef1f5} td.l,th.l{text-align:left}
.kv td:first-child{text-align:left;color:#555}
img{max-width:100%;height:auto;display:block;margin:6px 0}
.note{font-size:12px;color:#555}
.bad{color:#b42318;font-weight:600} .ok{color:#067647} .info{color:#1f3a5f;font-style:italic}
"""


def header_line(*items: str) -> str:
    """The header's line: ``sarmotion VERSION · TIME UTC · items...`` (items as HTML)."""
    now = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    return " &middot; ".join([f"sarmotion {__version__}", now, *items])


def section(title: str, body: str) -> str:
    """A section of the page: its heading (plain text) and its body (HTML)."""
    return f"<section><h2>{html.escape(title)}</h2>{body}</section>"


def figure(b64_png: str, caption: str) -> str:
    """A PNG (base64) embedded in the page with its caption (plain text) under it."""
    text = html.escape(caption)
    return f'<img alt="{text}" src="data:image/png;base64,{b64_png}"><p class="note">{text}</p>'


def table(head: Sequence[str], rows: Sequence[Sequence[str]], *, escape_head: bool = True) -> str:
    """A table: ``head`` (plain text, or HTML with ``escape_head=False``), cells as HTML."""
    h = "".join(f"<th>{html.escape(c) if escape_head else c}</th>" for c in head)
    body = "".join("<tr>" + "".join(f"<td>{c}</td>" for c in r) + "</tr>" for r in rows)
    return f"<table><tr>{h}</tr>{body}</table>"


def page(title: str, line: str, parts: Sequence[str]) -> str:
    """The whole page: the stylesheet, the header (``title``, ``line``), then ``parts``.

    Parameters
    ----------
    title : str
        Title of the page and of its header (plain text).
    line : str
        The header's line (HTML; :func:`header_line`).
    parts : sequence of str
        The sections (HTML; :func:`section`).
    """
    head = [
        "<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>",
        f"<title>{html.escape(title)}</title><style>{CSS}</style></head><body>",
        f"<header><h1>{html.escape(title)}</h1><p>{line}</p></header><main>",
    ]
    return "\n".join([*head, *parts, "</main></body></html>"])
