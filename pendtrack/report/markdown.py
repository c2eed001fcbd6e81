"""A small, safe Markdown-to-HTML converter for discovery.md (no dependency, no raw HTML).

Supported: ATX headings (``#``..``######``, shifted down so they sit under the page's own
``<h2>``), paragraphs, ``-``/``*``/``1.`` lists, pipe tables, fenced code blocks, and inline
``**bold**``, ``*em*``/``_em_``, ```code```. Everything is HTML-escaped first, so the
text cannot inject markup; links are shown as text (the page stays offline).
"""

from __future__ import annotations

import html
import re

_INLINE = (
    (re.compile(r"`([^`]+)`"), r"<code>\1</code>"),
    (re.compile(r"\*\*(.+?)\*\*"), r"<b>\1</b>"),
    (re.compile(r"(?<![\w*])\*(?!\s)(.+?)(?<!\s)\*(?![\w*])"), r"<em>\1</em>"),
    (re.compile(r"(?<!\w)_(?!\s)(.+?)(?<!\s)_(?!\w)"), r"<em>\1</em>"),
    (re.compile(r"\[([^\]]+)\]\([^)]*\)"), r"\1"),
)
_TABLE_RULE = re.compile(r"^\|?\s*:?-{2,}:?\s*(\|\s*:?-{2,}:?\s*)*\|?$")


def _inline(text: str) -> str:
    out = _INLINE[0][0].sub(_INLINE[0][1], html.escape(text, quote=False))
    pieces = re.split(r"(<code>.*?</code>)", out)  # no emphasis inside code spans
    for i, piece in enumerate(pieces):
        if not piece.startswith("<code>"):
            for pattern, repl in _INLINE[1:]:
                piece = pattern.sub(repl, piece)
            pieces[i] = piece
    return "".join(pieces)


def _cells(line: str) -> list[str]:
    line = line.strip()
    if line.startswith("|"):
        line = line[1:]
    if line.endswith("|"):
        line = line[:-1]
    return [c.strip() for c in line.split("|")]


def to_html(text: str, *, heading_offset: int = 2) -> str:
    """Markdown ``text`` as an HTML fragment; headings ``#`` become ``<h{1 + heading_offset}>``."""
    lines = text.replace("\r\n", "\n").split("\n")
    out: list[str] = []
    para: list[str] = []
    i = 0

    def flush() -> None:
        if para:
            out.append(f"<p>{_inline(' '.join(para))}</p>")
            para.clear()

    while i < len(lines):
        line = lines[i]
        stripped = line.strip()
        if stripped.startswith("```"):
            flush()
            block = []
            i += 1
            while i < len(lines) and not lines[i].strip().startswith("```"):
                block.append(lines[i])
                i += 1
            out.append(f"<pre>{html.escape(chr(10).join(block))}</pre>")
            i += 1
            continue
        m = re.match(r"^(#{1,6})\s+(.*)$", stripped)
        if m:
            flush()
            level = min(6, len(m.group(1)) + heading_offset)
            out.append(f"<h{level}>{_inline(m.group(2).strip().rstrip('#').strip())}</h{level}>")
            i += 1
            continue
        if stripped.startswith("|") and i + 1 < len(lines) and _TABLE_RULE.match(lines[i + 1].strip()):
            flush()
            head = "".join(f'<th class="text">{_inline(c)}</th>' for c in _cells(stripped))
            i += 2
            rows = []
            while i < len(lines) and lines[i].strip().startswith("|"):
                rows.append("<tr>" + "".join(f'<td class="text">{_inline(c)}</td>' for c in _cells(lines[i])) + "</tr>")
                i += 1
            out.append(f'<div class="table"><div class="scroll"><table><thead><tr>{head}</tr></thead>'
                       f"<tbody>{''.join(rows)}</tbody></table></div></div>")
            continue
        m = re.match(r"^(\s*)([-*+]|\d+[.)])\s+(.*)$", line)
        if m:
            flush()
            ordered = m.group(2)[0].isdigit()
            tag = "ol" if ordered else "ul"
            items = []
            while i < len(lines):
                m = re.match(r"^\s*([-*+]|\d+[.)])\s+(.*)$", lines[i])
                if m and (m.group(1)[0].isdigit()) == ordered:
                    items.append(m.group(2))
                elif lines[i].startswith(("  ", "\t")) and lines[i].strip() and items:
                    items[-1] += " " + lines[i].strip()  # continuation line
                else:
                    break
                i += 1
            out.append(f"<{tag}>" + "".join(f"<li>{_inline(it)}</li>" for it in items) + f"</{tag}>")
            continue
        if not stripped:
            flush()
        else:
            para.append(stripped)
        i += 1
    flush()
    return "\n".join(out)
