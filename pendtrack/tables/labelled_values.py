"""Lines of labelled values, as a sketch prints them: ``Angle: 12.3`` or ``t=0.010 theta=0.52``.

A microcontroller's log often names each value on every line instead of once in a header. When
most lines are made of ``name: number`` or ``name = number`` pairs only, with the same names in the
same order, :func:`labelled_lines` writes them as a table: a header of the names (read by
:func:`pendtrack.tables.units.parse_column_name`, units and all: ``Angle (deg): 12.3``) above
comma-separated values. Lines before the first such line stay a preamble; any other line is left
as it is, and the table reader names it if it is not a sample.
"""

from __future__ import annotations

import re
from collections import Counter

_NUM = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|[+-]?(?:nan|inf)"
_PAIR_RE = re.compile(rf"([^\W\d][^:=,;\t]*?)\s*[:=]\s*({_NUM})(?=[\s,;]|$)", re.IGNORECASE)
MIN_LINES = 3


def _pairs(line: str) -> tuple[tuple[str, ...], list[str]] | None:
    """The names and values of a line made of labelled values only, else None."""
    found = _PAIR_RE.findall(line)
    if not found or _PAIR_RE.sub("", line).strip(" ,;\t|"):
        return None
    return tuple(" ".join(name.split()) for name, _ in found), [value for _, value in found]


def labelled_lines(lines: list[tuple[int, str]]) -> list[tuple[int, str]]:
    """``lines`` with labelled values written as a header and rows of values (module docstring).

    Parameters
    ----------
    lines : list of (int, str)
        A text table's numbered lines.

    Returns
    -------
    list of (int, str)
        Unchanged unless at least half of the lines (and :data:`MIN_LINES`) are labelled values.
    """
    parsed = [(n, s, _pairs(s)) for n, s in lines]
    labelled = [p for _, _, p in parsed if p is not None]
    if len(labelled) < max(MIN_LINES, len(lines) // 2):
        return lines
    names = Counter(p[0] for p in labelled).most_common(1)[0][0]
    out: list[tuple[int, str]] = []
    header = False
    for n, s, p in parsed:
        if p is not None and p[0] == names:
            if not header:  # the names once, above the first row
                out.append((n, ",".join(names)))
                header = True
            out.append((n, ",".join(p[1])))
        else:
            out.append((n, s))
    return out
