"""Page assembly: sections of figures, tables and notes, written as one self-contained HTML file.

The page needs nothing but itself: images are PNG data URIs, the CSS is inline, there is no
executable script (only a ``<script type="application/json">`` holding the provenance, which
browsers never run), no web font and no external link apart from relative links to other
reports. A ``Content-Security-Policy`` meta tag forbids the browser any fetch except ``data:``
images, so even a mistake cannot make the page reach the network.

Text from the data (run codes, parameter names, discovery diagnoses) is always escaped;
captions and intros are written by pendtrack itself and may hold simple inline markup
(``<em>``, ``<sub>``, ``<sup>``, ``<code>``). Use :class:`Markup` for a table cell that is
trusted HTML (a link).
"""

from __future__ import annotations

import base64
import html
import json
import re
from dataclasses import dataclass, field
from typing import Any, Union

CSP = "default-src 'none'; img-src data:; style-src 'unsafe-inline'; base-uri 'none'; form-action 'none'"
PROVENANCE_ID = "pendtrack-provenance"

_CSS = """
:root { color-scheme: light; }
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, "DejaVu Sans", sans-serif;
       margin: 0; color: #222; background: #fafafa; line-height: 1.45; }
header { background: #263238; color: #fff; padding: 1.2em 2em; }
header h1 { margin: 0 0 .2em 0; font-size: 1.6em; }
header p { margin: .2em 0; color: #cfd8dc; }
main { max-width: 1100px; margin: 0 auto; padding: 1em 2em 3em 2em; }
nav { background: #fff; border: 1px solid #ddd; border-radius: 6px; padding: .6em 1.2em; margin: 1em 0; }
nav ol { margin: .3em 0; padding-left: 1.4em; columns: 2; }
section { background: #fff; border: 1px solid #ddd; border-radius: 6px; padding: .4em 1.4em 1em 1.4em;
          margin: 1.2em 0; }
h2 { border-bottom: 2px solid #eceff1; padding-bottom: .2em; }
figure { margin: 1.2em 0; }
figure img { max-width: 100%; height: auto; display: block; border: 1px solid #eee; }
figcaption { font-size: .92em; color: #444; margin-top: .4em; }
figcaption b { color: #222; }
table { border-collapse: collapse; margin: .8em 0; font-size: .9em; }
th, td { border: 1px solid #ddd; padding: .25em .6em; text-align: right; }
th { background: #eceff1; }
td.text, th.text { text-align: left; }
td.text { max-width: 32em; overflow-wrap: anywhere; }
td:first-child { white-space: nowrap; }
.table { margin: 1em 0; } .table .scroll { overflow-x: auto; }
.table-caption { font-size: .92em; color: #444; margin: .3em 0; }
.table table { margin: 0; }
.facts { display: grid; grid-template-columns: max-content auto; gap: .15em 1.2em; margin: .6em 0; }
.facts dt { color: #555; } .facts dd { margin: 0; font-variant-numeric: tabular-nums; }
.note { border-left: 4px solid #90a4ae; background: #f5f7f8; padding: .5em .9em; margin: .8em 0; }
.note.missing { border-color: #ffb300; background: #fff8e1; }
.note.error { border-color: #e53935; background: #ffebee; }
.prose { white-space: pre-wrap; margin: .6em 0; }
pre { background: #f5f5f5; padding: .8em; overflow-x: auto; font-size: .85em; }
footer { color: #777; font-size: .8em; margin-top: 2em; }
code { font-size: .92em; }
h3 { margin: 1.2em 0 .4em 0; font-size: 1.1em; }
.markdown { border-left: 3px solid #eceff1; padding-left: 1em; }
"""


class Markup(str):
    """A string that is already HTML (trusted, written by pendtrack): not escaped again."""


Cell = Union[str, int, float, None, Markup]


@dataclass(frozen=True)
class FigureBlock:
    """An embedded figure: PNG bytes (or the reason it could not be drawn) and its caption.

    ``key`` names the figure in the page (``data-figure`` attribute), so tests and readers can
    find it; ``caption`` is trusted HTML saying what to look at.
    """

    key: str
    caption: str
    png: bytes | None = None
    alt: str = ""
    error: str | None = None


@dataclass(frozen=True)
class Table:
    """A table: header cells, rows of cells and a caption (trusted HTML).

    Numbers are formatted by :func:`fmt`; ``text_columns`` are left-aligned.
    """

    header: tuple[str, ...]
    rows: tuple[tuple[Cell, ...], ...]
    caption: str = ""
    text_columns: tuple[int, ...] = (0,)
    key: str = ""


@dataclass(frozen=True)
class Note:
    """A paragraph; ``kind`` is ``"info"``, ``"missing"`` (an input is absent) or ``"error"``."""

    text: str
    kind: str = "info"
    trusted: bool = False  # True: ``text`` is HTML written by pendtrack


@dataclass(frozen=True)
class Facts:
    """A definition list of label -> value (values escaped)."""

    items: tuple[tuple[str, str], ...]


@dataclass(frozen=True)
class Preformatted:
    """Text shown as is (escaped): monospace, optionally folded behind a summary line, or as prose
    (normal font, line breaks kept)."""

    text: str
    summary: str = ""
    prose: bool = False


@dataclass(frozen=True)
class Html:
    """A trusted HTML fragment made by pendtrack (e.g. :func:`pendtrack.report.markdown.to_html`)."""

    html: str


@dataclass(frozen=True)
class Heading:
    """A sub-heading inside a section (``<h3>``)."""

    text: str


Block = Union[FigureBlock, Table, Note, Facts, Preformatted, Html, Heading]


@dataclass(frozen=True)
class Section:
    """A titled part of the page; ``intro`` is trusted HTML."""

    key: str
    title: str
    blocks: tuple[Block, ...] = ()
    intro: str = ""


@dataclass(frozen=True)
class Page:
    """A whole report page."""

    title: str
    subtitle: str
    sections: tuple[Section, ...]
    provenance: dict[str, Any] = field(default_factory=dict)
    kind: str = "run"  # "run" | "batch"

    @property
    def figures(self) -> tuple[FigureBlock, ...]:
        """Every figure block of the page, in order."""
        return tuple(b for s in self.sections for b in s.blocks if isinstance(b, FigureBlock))


def fmt(value: Cell, digits: int = 4) -> str:
    """A table cell as text: numbers with ``digits`` significant digits, None/NaN as an en dash."""
    if value is None:
        return "–"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if value != value:  # NaN
            return "–"
        if value == 0:
            return "0"
        mag = abs(value)
        if 1e-3 <= mag < 1e5:
            return f"{value:.{digits}g}"
        return f"{value:.{max(digits - 1, 1)}e}"
    return str(value)


def _cell(value: Cell) -> str:
    if isinstance(value, Markup):
        return str(value)
    return html.escape(fmt(value))


def _render_block(block: Block) -> str:
    if isinstance(block, FigureBlock):
        if block.png is None:
            reason = html.escape(block.error or "not drawn")
            return (f'<div class="note error" data-figure-error="{html.escape(block.key)}">'
                    f"Figure <code>{html.escape(block.key)}</code> could not be drawn: {reason}</div>")
        data = base64.b64encode(block.png).decode("ascii")
        alt = html.escape(block.alt or re.sub(r"<[^>]+>", "", block.caption)[:160], quote=True)
        return (f'<figure data-figure="{html.escape(block.key)}" id="fig-{html.escape(block.key)}">'
                f'<img src="data:image/png;base64,{data}" alt="{alt}">'
                f"<figcaption>{block.caption}</figcaption></figure>")
    if isinstance(block, Table):
        head = "".join(
            f'<th class="text">{html.escape(h)}</th>' if i in block.text_columns else f"<th>{html.escape(h)}</th>"
            for i, h in enumerate(block.header)
        )
        body = []
        for row in block.rows:
            cells = "".join(
                f'<td class="text">{_cell(c)}</td>' if i in block.text_columns else f"<td>{_cell(c)}</td>"
                for i, c in enumerate(row)
            )
            body.append(f"<tr>{cells}</tr>")
        key = f' data-table="{html.escape(block.key)}"' if block.key else ""
        caption = f'<p class="table-caption">{block.caption}</p>' if block.caption else ""
        return (f'<div class="table">{caption}<div class="scroll"><table{key}><thead><tr>{head}</tr></thead>'
                f"<tbody>{''.join(body)}</tbody></table></div></div>")
    if isinstance(block, Note):
        text = block.text if block.trusted else html.escape(block.text)
        return f'<div class="note {html.escape(block.kind)}">{text}</div>'
    if isinstance(block, Facts):
        items = "".join(f"<dt>{html.escape(k)}</dt><dd>{html.escape(v)}</dd>" for k, v in block.items)
        return f'<dl class="facts">{items}</dl>'
    if isinstance(block, Preformatted):
        if block.prose:
            return f'<div class="prose">{html.escape(block.text)}</div>'
        pre = f"<pre>{html.escape(block.text)}</pre>"
        if block.summary:
            return f"<details><summary>{html.escape(block.summary)}</summary>{pre}</details>"
        return pre
    if isinstance(block, Html):
        return f'<div class="markdown">{block.html}</div>'
    if isinstance(block, Heading):
        return f"<h3>{html.escape(block.text)}</h3>"
    raise TypeError(f"unknown block {type(block).__name__}")  # programming error


def _json_for_script(obj: Any) -> str:
    text = json.dumps(obj, sort_keys=True, default=str)
    return text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")


def render_page(page: Page) -> str:
    """The page as one HTML document (a string)."""
    nav = "".join(f'<li><a href="#{html.escape(s.key)}">{html.escape(s.title)}</a></li>' for s in page.sections)
    sections = []
    for s in page.sections:
        intro = f"<p>{s.intro}</p>" if s.intro else ""
        blocks = "\n".join(_render_block(b) for b in s.blocks)
        sections.append(f'<section id="{html.escape(s.key)}"><h2>{html.escape(s.title)}</h2>{intro}\n'
                        f"{blocks}</section>")
    prov = page.provenance
    footer = html.escape(
        f"pendtrack {prov.get('version', '')} · report written {prov.get('created', '')}"
    )
    return (
        "<!DOCTYPE html>\n"
        '<html lang="en"><head><meta charset="utf-8">\n'
        f'<meta http-equiv="Content-Security-Policy" content="{CSP}">\n'
        '<meta name="viewport" content="width=device-width, initial-scale=1">\n'
        f'<meta name="generator" content="pendtrack">\n'
        f"<title>{html.escape(page.title)}</title>\n<style>{_CSS}</style>\n"
        f'<script type="application/json" id="{PROVENANCE_ID}">{_json_for_script(prov)}</script>\n'
        f'</head><body data-report="{html.escape(page.kind)}">\n'
        f"<header><h1>{html.escape(page.title)}</h1><p>{html.escape(page.subtitle)}</p></header>\n"
        f"<main><nav><b>Contents</b><ol>{nav}</ol></nav>\n"
        + "\n".join(sections)
        + f"\n<footer>{footer}</footer></main></body></html>\n"
    )


def read_provenance(text: str) -> dict[str, Any] | None:
    """The provenance record embedded by :func:`render_page`, or None if absent or unreadable."""
    m = re.search(rf'<script type="application/json" id="{PROVENANCE_ID}">(.*?)</script>', text, re.S)
    if not m:
        return None
    try:
        record = json.loads(m.group(1))
    except ValueError:
        return None
    return record if isinstance(record, dict) else None


def link(href: str, text: str) -> Markup:
    """An escaped ``<a>`` element as trusted markup (for table cells)."""
    return Markup(f'<a href="{html.escape(href, quote=True)}">{html.escape(text)}</a>')
