"""Delimited text tables: plain logs, Tracker's data export, Vernier Logger Pro / Video Analysis, phyphox.

Layout
------
Blank lines and lines starting with ``#`` or ``%`` are skipped. The first line that starts with a
number starts the data; the lines before it are the preamble. The data's
separator is a tab, a semicolon, a comma or white space (the one that splits the first data
line into the most numbers and fewest other cells), with a decimal comma accepted after a tab,
semicolon or space (phyphox's and European spreadsheets' exports). A cell holding a bracketed
group of numbers, as Python writes a tuple or a numpy array (``"(1392, 685)"``, ``[1392 685]``,
numpy 2's ``(np.float64(1392.0), np.float64(685.0))``), is as many cells, one per number. Empty cells are missing
values: a row whose used cells are all empty is skipped (a shorter run beside a longer one), a
missing theta, x or y makes the row not ok, a missing time with values is an error.

Header
------
The header is the last preamble line that names a time column and another known one (a
Tracker export's first line, the track name ``mass A``, is passed over, as are Logger Pro's
``Vernier Format 2`` lines); a preamble line right after it made of units only (``s  °``:
Logger Pro's text export) gives the units of the columns that have none. Header fields may be
quoted (``"Time (s)"``). Names are read by :func:`pendtrack.tables.units.parse_column_name`.
A Tracker export (subscripted names such as ``v_{x}``, ``θ_{r}``) is read from its ``x``,
``y``: its ``θ`` columns are angles about Tracker's origin, not the pendulum's; a ``θ`` column beside ``x``,
``y`` that is the angle of (x, y) about their origin, in rad or degrees, is such a column too (an export of
``t x y θ`` alone has no subscripted name to tell it by) and is passed over. A header field over
a pair of numbers that names a position (``position``, ``centroid``, ...: :data:`PAIR_NAMES`) is the
bob's x and y, y counting up or down as the path's arc shows (:func:`_arc`).
"""

from __future__ import annotations

import codecs

import csv
import dataclasses
import math
import re
from pathlib import Path
from typing import Any

import numpy as np

from pendtrack.errors import ConfigError
from pendtrack.tables.clock_times import clock_lines
from pendtrack.tables.labelled_values import labelled_lines
from pendtrack.tables.rounded_times import digit_unit
from pendtrack.tables.units import (ALL_UNITS, ANGLE_UNITS, LENGTH_UNITS, RATE_UNITS, SENSOR_UNITS, TIME_UNITS,
                                   ColumnName,
                                    columns_hint, parse_column_name, roles, split_unit)

_HEADER_RE = re.compile(r"[^\s\[(]+(?:\s*[\[(][^\])]*[\])])?")
_NUMBER_RE = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$|^[+-]?(nan|inf)$", re.IGNORECASE)
_LAYOUTS = (("\t", False), ("\t", True), (";", False), (";", True), (",", False), (None, False), (None, True))
_NUM = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
# a tuple or array of numbers in one cell: "(1392, 685)", [1392 685], (0.51; 0.22), optionally quoted
_GROUP_RE = re.compile(rf"\"?[(\[]\s*({_NUM}(?:\s*[,;]?\s*{_NUM})+)\s*[)\]]\"?")
_SCALAR_RE = re.compile(rf"\bnp\.(?:float|u?int)\d*\(({_NUM})\)")  # numpy >= 2's repr of a scalar: np.float64(1.5)
_GROUP_SEP = "\x1f"  # joins a group's numbers until the line is split (str.split() splits at it too)
#: Header names of a cell that holds the bob's (x, y) pair.
PAIR_NAMES = frozenset({"position", "positions", "pos", "point", "points", "centroid", "center", "centre",
                        "coordinates", "coords", "location", "xy", "x,y", "(x, y)", "(x,y)", "bob"})
ROLE_WORDS = {"theta": "an angle", "x": "a position", "y": "a position"}
KIND_WORDS = {"t": "a time", "theta": "an angle", "xy": "a length", "x": "a position", "y": "a position"}
DEFAULT_UNITS = {"t": "s", "theta": "rad", "xy": "px"}  # what a name without a unit is read in
RATE_ADVICE = ("pendtrack reads an angle over time (or the bob's positions), and does not integrate a sensor's rates; "
               "export the angle, or film the swing and run pendtrack on the video")
OTHER_ADVICE = ("pendtrack reads an angle over time (or the bob's positions); export the angle (a rotary motion "
                "sensor's), or film the swing and run pendtrack on the video")
RAGGED_SHARE = 0.9  # rows below a first row of another width that make it a line of settings (a ragged table's
                    # blank cells keep their separators, so its rows keep their count)
FRAME_NAME_RE = re.compile(r"(frames?|frame ?(#|no\.?|number|nr\.?|index|_number|_no|_index))")  # a frame count
MAX_SPELLED = 8  # a --columns hint spelled out in full up to this many columns (one line stays readable)


def _groups_joined(line: str) -> str:
    """``line`` with each bracketed group of numbers (:data:`_GROUP_RE`) written as its numbers joined by
    :data:`_GROUP_SEP`."""
    line = _SCALAR_RE.sub(r"\1", line)
    return _GROUP_RE.sub(lambda m: _GROUP_SEP.join(re.findall(_NUM, m.group(1))), line)


def _split(line: str, sep: str | None) -> list[str]:
    """The cells of ``line`` at ``sep`` (None: white space), a group of numbers still one cell."""
    cells = (line.replace(_GROUP_SEP, "\x00").split() if sep is None
             else [c.strip().strip('"').strip() for c in line.split(sep)])
    if sep is not None and len(cells) > 1 and cells[-1] == "":
        cells = cells[:-1]  # a trailing separator
    return [c.replace("\x00", _GROUP_SEP) for c in cells]


def _cells(line: str, sep: str | None, decimal_comma: bool) -> list[str]:
    cells = [part for c in _split(_groups_joined(line), sep) for part in c.split(_GROUP_SEP)]
    return [c.replace(",", ".") for c in cells] if decimal_comma else cells


def group_sizes(line: str, sep: str | None) -> list[int]:
    """How many numbers each cell of a data line holds: 1, or a bracketed group's count."""
    return [c.count(_GROUP_SEP) + 1 for c in _split(_groups_joined(line), sep)]


def _layout(line: str) -> tuple[str | None, bool] | None:
    """The separator and decimal comma that split a data line into the most numbers (fewest other
    cells), its first cell a number; None if ``line`` is no data line."""
    best, score = None, -1
    for sep, comma in _LAYOUTS:
        if (sep is not None and sep not in line) or (comma and "," not in line):
            continue
        cells = _cells(line, sep, comma)
        if not cells or not _NUMBER_RE.match(cells[0]):
            continue
        numbers = sum(1 for c in cells if c and _NUMBER_RE.match(c))
        value = numbers - sum(1 for c in cells if c and not _NUMBER_RE.match(c))
        if value > score:
            best, score = (sep, comma), value
    return best


def header_fields(line: str) -> list[str]:
    """The fields of a header line: split at tabs, semicolons or commas (quotes allowed), else at
    white space outside brackets (``t (ms)   θ [rad]``)."""
    for sep in ("\t", ";", ","):
        if sep in line:
            return [f.strip() for f in next(csv.reader([line.strip()], delimiter=sep))]
    return _HEADER_RE.findall(line.strip())


def _parse_all(fields: list[str]) -> list[ColumnName | None] | None:
    try:
        return [parse_column_name(f) for f in fields]
    except ConfigError:
        return None


def _names_columns(cols: list[ColumnName | None] | None) -> bool:
    used = [c for c in (cols or []) if c is not None and c.role != "_"]
    return len(used) >= 2 and any(c.role == "t" for c in used)


def _unbracketed(text: str) -> str:
    """``text`` without one pair of enclosing brackets or parentheses (``(s)`` -> ``s``)."""
    if len(text) >= 2 and (text[0], text[-1]) in (("(", ")"), ("[", "]")):
        return text[1:-1].strip()
    return text


def _with_units(fields: list[str], units: list[str]) -> list[str]:
    """``fields`` with the units of a units line (Logger Pro's text export: ``s  °  rad/s``; a spreadsheet's
    ``(s)  (°)`` or ``[s]  [deg]``) added to those that have none; ``fields`` as they are if ``units`` is no
    units line."""
    units = [_unbracketed(u.strip().strip('"').strip()) for u in units]
    if len(units) != len(fields) or not any(u.lower() in ALL_UNITS for u in units):
        return fields
    if any(" " in u or len(u) > 8 or _names_columns(_parse_all([u, "t"])) for u in units):
        return fields
    out = []
    for f, u in zip(fields, units):
        col = (_parse_all([f]) or [None])[0]
        out.append(f"{f} [{u}]" if col is not None and not col.unit and u.lower() in ALL_UNITS else f)
    return out


def _short_first_row(body: list[tuple[int, str]], sep: str | None, comma: bool,
                     preamble: list[tuple[int, str]]) -> str | None:
    """The first row holding every column, where the first row of numbers holds fewer values than the rows
    below and the header names as many columns as they hold: a sample whose last cells are blank (Tracker's
    export leaves a derivative such as omega blank on its first frame, and a space-separated row then has
    fewer values); None otherwise."""
    if len(body) < 3 or not preamble:
        return None
    first = len(_cells(body[0][1], sep, comma))
    widths = np.array([len(_cells(line, sep, comma)) for _, line in body[1:]])
    below = int(np.median(widths))
    if first < below and len(header_fields(preamble[-1][1])) == below:
        return next(line for (_, line), w in zip(body[1:], widths) if w == below)
    return None


def _refuse_ragged_start(body: list[tuple[int, str]], sep: str | None, comma: bool, width: int) -> None:
    """A first row of numbers whose count differs from that of nearly every row below it is a line of
    settings (a logger's ``90, 1000, 5`` for start angle, rate and duration), not a sample: a
    ConfigError naming it, rather than reading the samples below as its columns."""
    if len(body) < 3:
        return
    widths = np.array([len(_cells(line, sep, comma)) for _, line in body[1:]])
    below = int(np.median(widths))
    if below != width and np.count_nonzero(widths == below) >= RAGGED_SHARE * widths.size:
        raise ConfigError(f"line {body[0][0]} ({body[0][1][:40]!r}) has {width} values, but {widths.size} rows "
                          f"below it have {below}: a line of settings above the samples? Remove it (pendtrack "
                          f"reads one sample per row, the same columns in each)")


def _rate_columns(preamble: list[tuple[int, str]]) -> dict[int, tuple[str, str]]:
    """Columns of the header (its last line) whose unit is a rate or another sensor's quantity, not one
    pendtrack reads: index -> (label, what the unit measures). A phone's sensor log (phyphox: ``Gyroscope x
    (rad/s)``, ``Acceleration x (m/s^2)``) or a light sensor's (``Light Intensity (%)``) has no angle column,
    and an angular velocity or a light level read as theta is a meaningless record."""
    if not preamble:
        return {}
    out = {}
    for i, label in enumerate(header_fields(preamble[-1][1])):
        _, unit = split_unit(label.strip().strip('"').strip().lower())
        what = RATE_UNITS.get(unit.replace(" ", "")) or SENSOR_UNITS.get(unit.replace(" ", ""))
        if what:
            out[i] = (label.strip().strip('"').strip(), what)
    return out


def _not_read(what: set[str]) -> tuple[str, str]:
    """What columns of the quantities ``what`` (:func:`_rate_columns`) are, and the advice for them."""
    rates = sorted(w for w in what if w in RATE_UNITS.values())
    others = sorted(what - set(rates))
    kinds = "; ".join([*rates, *others])
    if others:
        return f"{kinds}", OTHER_ADVICE
    return f"rates ({kinds})", RATE_ADVICE


def _unit_columns(preamble: list[tuple[int, str]], width: int) -> dict[int, tuple[str, str, str]]:
    """Columns of the header (its last line, one field per column) whose unit is a time, an angle or a
    length: index -> (label, unit, the role kind it fits: ``"t"``, ``"theta"`` or ``"xy"``)."""
    fields = header_fields(preamble[-1][1]) if preamble else []
    if len(fields) != width:
        return {}
    out = {}
    for i, label in enumerate(fields):
        label = label.strip().strip('"').strip()
        _, unit = split_unit(label.lower())
        kind = ("t" if unit in TIME_UNITS else "theta" if unit in ANGLE_UNITS else
                "xy" if unit in LENGTH_UNITS else None)
        if kind:
            out[i] = (label, unit, kind)
    return out


def _header_units(cols: list[ColumnName | None], columns: tuple[str, ...], preamble: list[tuple[int, str]],
                  width: int) -> list[ColumnName | None]:
    """``--columns`` names without a unit take the unit of the header's column under them; a name over a
    header column of another kind (a distance in cm named theta) is a ConfigError: read in the name's
    default unit it would be a meaningless record."""
    units = _unit_columns(preamble, width)
    out = list(cols)
    for i, c in enumerate(cols):
        if c is None or c.role not in KIND_WORDS or c.declared or i not in units:
            continue
        label, unit, kind = units[i]
        want = "xy" if c.role in ("x", "y") else c.role
        if kind != want:
            raise ConfigError(f"--columns names column {i + 1} {c.role}, but the header gives it as {label!r}, "
                              f"{KIND_WORDS[kind]} ({unit}), not {KIND_WORDS[want]}: name the column that holds "
                              f"{KIND_WORDS[want]}, or declare the unit if the header is wrong "
                              f"(e.g. {columns[i]}[{DEFAULT_UNITS[want]}])")
        out[i] = parse_column_name(f"{columns[i]}[{unit}]")
    return out


def _frame_columns(preamble: list[tuple[int, str]]) -> dict[int, str]:
    """Columns of the header (its last line) that count frames (``frame``, ``Frame #``, ``frame_number``):
    index -> label. A tracker's ``frame,x,y`` numbers its rows; read as t [s], a 30 fps swing of 1.7 s
    becomes one of 50 s, which no unit check can tell from a long pendulum's."""
    if not preamble:
        return {}
    out = {}
    for i, label in enumerate(header_fields(preamble[-1][1])):
        name = label.strip().strip('"').strip()
        if FRAME_NAME_RE.fullmatch(name.lower()):
            out[i] = name
    return out


def _header_time_names(preamble: list[tuple[int, str]], shape_line: str, sep: str | None, frames: dict[int, str], *,
                       y_down: bool) -> tuple[int, str] | None:
    """The header's own time column (not a frame count) and ``--columns`` names after the header's roles
    (``y_down`` for its y when the user's names point y down), or None when the header names no time."""
    cols = _header(preamble, group_sizes(shape_line, sep)) or []
    where = [i for i, c in enumerate(cols) if c is not None and c.role == "t" and i not in frames]
    if not where:
        return None
    names = ["_" if c is None or c.role == "_" or i in frames else
             ("y_down" if c.role == "y" and (y_down or c.y_down) else c.role) for i, c in enumerate(cols)]
    return where[0], ",".join(names)


def _header(preamble: list[tuple[int, str]], sizes: list[int]) -> list[ColumnName | None] | None:
    """The columns named by the preamble (see the module docstring); None without a preamble.

    ``sizes``: the numbers each cell of the first data line holds (:func:`group_sizes`). A header
    line with one field per cell names a pair cell's two columns by :func:`_pair_names`.
    """
    if not preamble:
        return None
    pairs = len(sizes) != sum(sizes)

    def names(line: str) -> list[ColumnName | None] | None:
        fields = header_fields(line)
        cols = _parse_all(fields)
        if not _names_columns(cols):
            fields = _unit_only_names(fields) or fields
            cols = _parse_all(fields)
        if cols is not None and pairs and len(fields) == len(sizes):
            cols = [c for f, col, k in zip(fields, cols, sizes)
                    for c in (_pair_names(f) if k == 2 else [col if k == 1 else None] * k)]
        return cols

    chosen = None
    for k in range(len(preamble) - 1, -1, -1):
        if _names_columns(names(preamble[k][1])):
            chosen = k
            break
    if chosen is None:  # the last line, for its error
        return [parse_column_name(f) for f in header_fields(preamble[-1][1])]
    fields = header_fields(preamble[chosen][1])
    if not _names_columns(_parse_all(fields)):
        fields = _unit_only_names(fields) or fields
    if chosen + 1 < len(preamble):
        fields = _with_units(fields, header_fields(preamble[chosen + 1][1]))
    cols = [parse_column_name(f) for f in fields]
    if pairs and len(fields) == len(sizes):
        cols = [c for f, col, k in zip(fields, cols, sizes)
                for c in (_pair_names(f) if k == 2 else [col if k == 1 else None] * k)]
    if any("_{" in f for f in fields) and {"x", "y"} <= {c.role for c in cols if c is not None}:
        cols = [None if c is not None and c.role == "theta" else c for c in cols]  # Tracker's θ: about its origin
    return cols


def _unit_only_names(fields: list[str]) -> list[str] | None:
    """Column names for a header whose columns are named by their units (``s, rad``; ``(ms)  [deg]``; ``s  px  px``;
    ``t  rad  xerr  yerr``): a field that is a time unit alone is t, an angle unit alone theta, two lengths x and y,
    where no field names that column; a rate (``rad/s``), an empty field and, beside them, a word pendtrack does
    not know are passed over. None when the units do not say which column is which."""
    out: list[str] = []
    roles: list[str] = []
    xy = iter(("x", "y"))
    lengths = sum(_unbracketed(f.strip().strip('"').strip()).lower() in LENGTH_UNITS for f in fields)
    for field in fields:
        unit = _unbracketed(field.strip().strip('"').strip()).lower()
        col = (_parse_all([field]) or [None])[0] if unit not in ALL_UNITS else None
        if col is not None and col.role != "_":
            out.append(field)
            roles.append("xy" if col.role in ("x", "y") else col.role)
        elif unit in TIME_UNITS:
            out.append(f"t[{unit}]")
            roles.append("t")
        elif unit in ANGLE_UNITS:
            out.append(f"theta[{unit}]")
            roles.append("theta")
        elif unit in LENGTH_UNITS and lengths == 2:
            out.append(f"{next(xy)}[{unit}]")
            roles.append("xy")
        else:
            out.append("_")
    if roles.count("t") != 1 or (roles.count("theta"), roles.count("xy")) not in ((1, 0), (0, 2)):
        return None
    if all(_unbracketed(f.strip().strip('"').strip()).lower() not in ALL_UNITS for f in fields):
        return None  # no unit named a column: the header's own names did not make t and theta
    return out


def _pair_names(field: str) -> list[ColumnName | None]:
    """The two columns of a header field over a pair of numbers: x and y if it names a position
    (:data:`PAIR_NAMES`, a unit allowed: ``position (px)``), else two ignored columns. y counts
    upwards here; :func:`read_text` turns it downwards when the path's arc says so."""
    name, unit = split_unit(field.strip().strip('"').strip().lower())
    if name not in PAIR_NAMES:
        return [None, None]
    x, y = parse_column_name(f"x [{unit}]" if unit else "x"), parse_column_name(f"y [{unit}]" if unit else "y")
    label = field.strip().strip('"').strip()
    return [dataclasses.replace(x, label=f"{label} (x)", from_pair=True),
            dataclasses.replace(y, label=f"{label} (y)", from_pair=True)]


def read_lines(path: Path) -> list[tuple[int, str]]:
    """Numbered non-blank, non-comment lines (UTF-8, UTF-16 with its byte-order mark, else Windows-1252 as
    Logger Pro writes)."""
    data = path.read_bytes()
    if data.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)):  # Windows' "Unicode text" (Excel, Notepad)
        try:
            data = data.decode("utf-16").encode("utf-8")
        except UnicodeDecodeError:
            pass  # not text after all: refused as binary below
    if b"\x00" in data[:4096]:
        raise ConfigError("not a text table (binary data): expected columns t [s], theta [rad]")
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = data.decode("cp1252", errors="replace")
    lines = [(n, raw.strip()) for n, raw in enumerate(text.splitlines(), start=1)]
    lines = [(n, s) for n, s in lines if s and not s.startswith(("#", "%"))]
    if lines and lines[0][1].lower().startswith(("<!doctype html", "<html")):
        # a repository's file page saved from the browser in place of the file
        raise ConfigError("a web page (HTML), not a table: download the file itself (on GitHub: its Raw button)")
    if lines and lines[0][1].lower().startswith("<?xml") and "<phyphox" in text[:2000].lower():
        # the app's saved experiment (its buffers as XML), not its data export
        raise ConfigError("a saved phyphox experiment (.phyphox, XML), not a table: export its data from the app "
                          "(the menu's Export Data, as CSV) and give pendtrack that file")
    return lines


def _without_leading_empty_cells(lines: list[tuple[int, str]]) -> list[tuple[int, str]]:
    """The lines without the empty cells every one of them starts with (``,,,t,theta``: a table that starts in a
    spreadsheet's fourth column, saved as CSV); ``--columns`` then names the table's own columns."""
    for sep in (",", ";"):
        k = min((len(s) - len(s.lstrip(sep)) for _, s in lines), default=0)
        if k > 0 and all(s[k:].strip() for _, s in lines):
            return [(n, s[k:].lstrip()) for n, s in lines]
    return lines


def read_text(path: Path, columns: tuple[str, ...] | None, *, rate_hz: float | None = None,
              lines: list[tuple[int, str]] | None = None) -> dict[str, Any]:
    """The raw record of a text table (module docstring), in SI units (t [s], theta [rad]).

    Parameters
    ----------
    path : Path
    columns : tuple of str, optional
        ``--columns`` names, one per column, overriding the header.
    rate_hz : float, optional
        ``--rate``: the table has no time column; row k is at ``t = k / rate_hz`` [Hz].
    lines : list of (int, str), optional
        The table's numbered lines, when they come from another file format
        (:func:`pendtrack.tables.vernier.vernier_lines`); default: the file's own (:func:`read_lines`).

    Returns
    -------
    dict
        ``t``, ``theta`` (or None), ``x``, ``y``, ``y_down``, ``ok``, ``cols`` (each column's
        :class:`ColumnName`), ``roles`` (role -> column index), ``kind`` ("table").
    """
    lines = _without_leading_empty_cells(read_lines(path) if lines is None else lines)
    lines, clock = clock_lines(lines, rate_hz=rate_hz)
    if clock is None or clock.kind != "serial_monitor":  # a monitor's payload is read so already
        lines = labelled_lines(lines)
    start = next((i for i, (_, s) in enumerate(lines) if _layout(s) is not None), len(lines))
    preamble, body = lines[:start], lines[start:]
    body, footer = _without_summary_footer(body)
    if not body:
        raise ConfigError("no row of numbers: expected one sample per row (t, theta, ... in columns)"
                          + (f" below the header {preamble[-1][1][:60]!r}" if preamble else ""))
    sep, comma = _layout(body[0][1]) if body else (None, False)  # type: ignore[misc]
    full = _short_first_row(body, sep, comma, preamble)
    shape_line = body[0][1] if full is None else full  # the row whose values set the columns
    width = len(_cells(shape_line, sep, comma)) if body else 2
    if full is None:
        _refuse_ragged_start(body, sep, comma, width)
    if width == 1 and rate_hz is None:
        raise ConfigError("one column of numbers: pendtrack reads a sample per row with its time (t, theta in "
                          "columns); for a log of angles written at a fixed rate, give it with --rate HZ "
                          "(row k at t = k / rate), and the angle's unit with --columns (e.g. theta[deg])")
    rates = _rate_columns(preamble)
    short_header = 0  # the number of columns a header shorter than the rows names, else 0
    if columns is not None:
        if body and len(columns) != width:
            sizes = group_sizes(shape_line, sep)
            groups = "" if width == len(sizes) else (
                f"; a bracketed group such as {_GROUP_RE.search(shape_line).group(0)} is one column per number")  # type: ignore[union-attr]
            raise ConfigError(f"--columns names {len(columns)} columns, the table has {width} (first data line "
                              f"{body[0][0]}{groups}): add _ for each column to ignore")
        cols = [parse_column_name(n) for n in columns]
        where = "--columns"
        frames = _frame_columns(preamble)
        for i, c in enumerate(cols):
            if c is not None and c.role == "t" and not c.unit and i in frames:
                rest = ",".join("_" if j == i else columns[j] for j in range(width))
                timed = _header_time_names(preamble, shape_line, sep, frames, y_down=any(
                    n is not None and n.y_down for n in cols))
                instead = (f"the header's column {timed[0] + 1} holds the times: name the columns after it "
                           f"(e.g. --columns {timed[1]}) or give the frame rate: --columns {rest} --rate FPS"
                           if timed else f"give the frame rate instead: --columns {rest} --rate FPS")
                raise ConfigError(f"--columns names column {i + 1} t [s], but the header gives it as "
                                  f"{frames[i]!r}: frame numbers, not seconds; {instead}")
        for i, c in enumerate(cols):
            if c is not None and c.role in ("theta", "x", "y") and i in rates:
                kind, advice = _not_read({rates[i][1]})
                kind = f"a rate ({rates[i][1]})" if kind.startswith("rates") else rates[i][1]
                raise ConfigError(f"--columns names column {i + 1} {c.role}, but the header gives it as "
                                  f"{rates[i][0]!r}, {kind}, not {ROLE_WORDS[c.role]}: {advice}")
        cols = _header_units(cols, columns, preamble, width)
    else:
        cols_or_none = _header(preamble, group_sizes(shape_line, sep))
        where = "header"
        if cols_or_none is not None:
            cols_or_none = _pair_direction(cols_or_none, body, sep, comma)
        if cols_or_none is None:
            if width > 2 and len(body) < width:
                # a logger that writes one row per quantity (times, then angles): a record along the rows
                raise ConfigError(f"{len(body)} rows of {width} values and no header: pendtrack reads one "
                                  f"sample per row (t, theta, ... in columns); transpose the table")
            if rate_hz is not None and width > 1:
                raise ConfigError(f"{width} columns, no header and --rate: say which column is the angle with "
                                  f"--columns (e.g. theta{',_' * (width - 1)})")
            if width > 2:
                arc = _arc(body, sep, comma, 1, 2)
                clock = _time_column(body, sep, comma, width)
                if width <= MAX_SPELLED and clock not in (None, 0):
                    names = ["_"] * width
                    names[clock] = "t"
                    names[0] = "theta"
                    hint = (f"column {clock + 1} increases like a time, column 1 does not: add --columns "
                            f"{','.join(names)} if column 1 is theta [rad] (theta[deg] if in degrees), or name "
                            f"the columns that hold theta or x, y")
                elif width <= MAX_SPELLED and arc:
                    hint = (f"columns 2 and 3 trace a pendulum's arc: add --columns t,{arc}{',_' * (width - 3)} if "
                            f"they are t [s] and the bob's positions ({arc}: {ARC_WORDS[arc]}), or --columns "
                            f"t,theta{',_' * (width - 2)} if they are t [s], theta [rad] and {width - 2} to ignore")
                elif width <= MAX_SPELLED:
                    hint = (f"add --columns t,theta{',_' * (width - 2)} if they are t [s], theta [rad] and "
                            f"{width - 2} to ignore (or --columns t,x,y{',_' * (width - 3)} for positions)")
                else:
                    hint = (f"e.g. --columns t,theta,_,... with one name per column, _ for each of the "
                            f"{width - 2} to ignore")
                raise ConfigError(f"{width} columns and no header: say what they are with --columns; {hint}")
            cols_or_none = ([ColumnName("theta", label="theta", assumed=True)] if rate_hz is not None else
                            [ColumnName("t", label="t", assumed=True), ColumnName("theta", label="theta", assumed=True)])
        elif len(cols_or_none) < width:  # a header shorter than its rows: the rows' columns it does not name
            short_header = len(cols_or_none)
            cols_or_none = [*cols_or_none, *[None] * (width - len(cols_or_none))]
        cols = cols_or_none
    if where == "header":
        cols = _without_polar_angle(cols, body, sep, comma)
    if rate_hz is not None:
        cols = _rate_times(cols, rate_hz)
    try:
        found = roles(cols, where)
    except ConfigError as exc:
        frames = _frame_columns(preamble) if where == "header" and rate_hz is None else {}
        if frames and not any(c is not None and c.role == "t" for c in cols):
            names = ",".join("_" if j in frames or cols[j] is None else cols[j].label  # type: ignore[union-attr]
                             for j in range(len(cols)))
            first = min(frames)
            raise ConfigError(f"header: column {first + 1} {frames[first]!r} numbers the frames and no column "
                              f"holds times: give the frame rate, --columns {names} --rate FPS") from None
        if where == "header" and rates and not any(c is not None and c.role in ("theta", "x", "y") for c in cols):
            names = ", ".join(repr(label) for label, _ in rates.values())
            kind, advice = _not_read({u for _, u in rates.values()})
            verb = "are" if len(rates) > 1 or kind.startswith("rates") else "is"
            raise ConfigError(f"header: the column{'s' if len(rates) > 1 else ''} {names} {verb} {kind}, "
                              f"not an angle or positions: {advice}") from None
        if short_header:
            raise ConfigError(f"{exc}; the header names {short_header} columns, the rows hold {width}") from None
        if (where == "header" and rate_hz is None and len(cols) > width >= 2
                and "missing column" in str(exc)):  # the hint counts the rows' columns, not the header's names
            rest = ",_" * (width - 2)
            xy = f" or --columns t,x,y{rest[2:]}" if width >= 3 else ""
            raise ConfigError(f"header: names {len(cols)} columns, the rows hold {width}, and the names do not say "
                              f"which is t and which theta: name the rows' columns, e.g. --columns t,theta{rest}{xy}"
                              ) from None
        raise
    order = sorted(found.items(), key=lambda kv: kv[1])
    data = np.full((len(body), len(order)), np.nan)
    expected = ", ".join(cols[i].describe() for _, i in order)  # type: ignore[union-attr]
    t_unit = np.full(len(body), np.nan)  # each written time's last-digit unit (rounded_times)
    for row, (lineno, line) in enumerate(body):
        cells = _cells(line, sep, comma)
        if rate_hz is not None:  # the times column that _rate_times added after the table's own
            cells = [*cells[:width], f"{row / rate_hz!r}"]
        try:
            data[row] = [float(cells[i]) if i < len(cells) and cells[i] else np.nan for _, i in order]
        except ValueError:
            raise ConfigError(f"line {lineno}: expected numbers {expected}, got {line[:60]!r}") from None
        if rate_hz is None and found["t"] < len(cells):
            t_unit[row] = digit_unit(cells[found["t"]])
    present = ~np.all(np.isnan(data), axis=1)
    k_t = [role for role, _ in order].index("t")
    no_time = present & np.isnan(data[:, k_t])
    if np.any(no_time):
        raise ConfigError(f"line {body[int(np.argmax(no_time))][0]}: values without a time")
    data = data[present]
    t_unit = t_unit[present] * cols[found["t"]].scale  # type: ignore[union-attr]
    # t and theta in s and rad; x and y as written (the pivot is in their units)
    values = {role: data[:, k] * (cols[i].scale if role in ("t", "theta") else 1.0)  # type: ignore[union-attr]
              for k, (role, i) in enumerate(order)}
    if where == "header" and "theta" in found:
        _refuse_placeholder_theta(values["theta"], cols, found, body, sep, comma)
    record = raw_record(values, found, cols, "table")
    if rate_hz is None:
        record["t_unit"] = t_unit
    if clock is not None:
        record["clock"] = clock
    if footer:
        record["footer"] = footer
    return record


FOOTER_MAX = 10  # summary lines below a spreadsheet's table: mean, std, min, max, a fit's results


def _without_summary_footer(body: list[tuple[int, str]]) -> tuple[list[tuple[int, str]], list[tuple[int, str]]]:
    """``(body, footer)``: the lines below the last row of numbers that start with a word (a spreadsheet's
    ``mean,0.0012`` or ``Period (s):;1.07`` under its table, a logger's ``Stopped``), at most :data:`FOOTER_MAX` of
    them; ``footer`` is empty when the table has none. A word within the rows stays an error naming its line."""
    last = len(body)
    while last > 0 and _NUMBER_RE.match(_first_cell(body[last - 1][1])) is None:
        last -= 1
    footer = body[last:]
    if (not footer or last == 0 or len(footer) > FOOTER_MAX
            or not all(re.match(r"[^\W\d_]", _first_cell(line)) for _, line in footer)):
        return body, []
    return body[:last], footer


def _first_cell(line: str) -> str:
    """The first cell of a line, whatever the separator (tab, semicolon, comma, white space), without quotes."""
    cell = re.split(r"[\t;,]|\s+", line.strip(), maxsplit=1)[0]
    return cell.strip().strip('"').strip()


POLAR_TOL = (0.02, 1.0)  # [rad], [deg]: Tracker writes its θ to 0.1 degree, and x, y to 4 digits (~1e-3 rad)


def _without_polar_angle(cols: list[ColumnName | None], body: list[tuple[int, str]], sep: str | None,
                         comma: bool) -> list[ColumnName | None]:
    """``cols`` with a theta column passed over where it is the angle of the x, y columns about their origin:
    Tracker's θ, written without the subscripted names that mark its export (``t x y θ``)."""
    where = {c.role: i for i, c in reversed(list(enumerate(cols))) if c is not None}
    if not {"theta", "x", "y"} <= set(where):
        return cols
    theta, x, y = (np.array([_number_or_nan(_cells(line, sep, comma), where[r]) for _, line in body])
                   for r in ("theta", "x", "y"))
    if not _polar_angle(theta * cols[where["theta"]].scale, x, y):  # type: ignore[union-attr]
        return cols
    return [None if i == where["theta"] else c for i, c in enumerate(cols)]


def _number_or_nan(cells: list[str], i: int) -> float:
    try:
        return float(cells[i])
    except (IndexError, ValueError):
        return math.nan


def _polar_angle(theta: np.ndarray, x: np.ndarray, y: np.ndarray) -> bool:
    """``theta`` is the angle of (x, y) about their origin (Tracker's polar θ, with y up or down), in rad or
    in degrees: the median wrapped difference within :data:`POLAR_TOL` over at least 10 rows."""
    for sign in (1.0, -1.0):
        polar = np.arctan2(sign * y, x)
        for ref, tol, turn in ((polar, POLAR_TOL[0], 2 * np.pi), (np.degrees(polar), POLAR_TOL[1], 360.0)):
            d = (theta - ref + turn / 2) % turn - turn / 2
            d = d[np.isfinite(d)]
            if d.size >= 10 and float(np.median(np.abs(d))) < tol:
                return True
    return False


def _rate_times(cols: list[ColumnName | None], rate_hz: float) -> list[ColumnName | None]:
    """``cols`` with the times ``k / rate_hz`` [s] after them (:func:`roles` refuses a time among them)."""
    return [*cols, ColumnName("t", unit="s", label=f"t = row / {rate_hz:g} Hz", from_rate=True)]


def _refuse_placeholder_theta(theta: np.ndarray, cols: list[ColumnName | None], found: dict[str, int],
                              body: list[tuple[int, str]], sep: str | None, comma: bool) -> None:
    """A theta column with one value in every row beside x, y columns that move is a placeholder, not an
    angle (a tracker that wrote theta = 0 and left the angle for later): a ConfigError naming the
    ``--columns`` that reads the positions instead."""
    th = theta[np.isfinite(theta)]
    xy = {c.role: i for i, c in reversed(list(enumerate(cols))) if c is not None and c.role in ("x", "y")}
    if th.size < 2 or np.ptp(th) > 0 or set(xy) != {"x", "y"}:
        return
    moves = False
    cells = [_cells(line, sep, comma) for _, line in body]
    for role in ("x", "y"):
        col = np.array([_number(c[xy[role]]) if xy[role] < len(c) else np.nan for c in cells])
        col = col[np.isfinite(col)]
        moves = moves or (col.size > 1 and np.ptp(col) > 0)
    if not moves:
        return
    hint = columns_hint(cols, {"t": found["t"], **xy})
    raise ConfigError(f"theta is {th[0]:g} in every row (no angle recorded) while x and y move: read the positions "
                      f"with --columns {hint} (y_down if y counts image rows downwards)")


ARC_R2 = 0.8  # columns 2 and 3 are an arc when a parabola y(x) explains this share of y's variance ...
ARC_LINE_R2 = 0.5  # ... and a straight line at most this share (the curvature is what explains it)
ARC_SHARE = 0.25  # ... over the record's first quarter, where the swing is widest (later, a damped swing's sag sinks
# into the positions' rounding: a Tracker export in whole mm: 0.89 over its first quarter, 0.76 over all of it)
ARC_WORDS = {"x,y": "y upwards", "x,y_down": "y counting downwards, as image rows do"}


TIME_ROWS = 0.99  # a column is time-like when it increases from row to row in this share of the rows


def _time_column(body: list[tuple[int, str]], sep: str | None, comma: bool, width: int) -> int | None:
    """The first column whose numbers increase from row to row (a clock), None if none does; only looked
    for to name the time column in a headerless table's hint."""
    cells = [_cells(line, sep, comma) for _, line in body]
    for j in range(width):
        col = np.array([_number(c[j]) if j < len(c) else math.nan for c in cells])
        col = col[np.isfinite(col)]
        if col.size >= 10 and np.count_nonzero(np.diff(col) > 0) >= TIME_ROWS * (col.size - 1):
            return j
    return None


def _pair_direction(cols: list[ColumnName | None], body: list[tuple[int, str]], sep: str | None,
                    comma: bool) -> list[ColumnName | None]:
    """``cols`` with the y of a header's pair cell (:func:`_pair_names`) counting downwards if the path's arc
    curves that way (image rows); a ConfigError if the path shows no arc to tell."""
    pair = [i for i, c in enumerate(cols) if c is not None and c.from_pair]
    if len(pair) != 2:
        return cols
    arc = _arc(body, sep, comma, *pair)
    if arc is None:
        label = cols[pair[0]].label.removesuffix(" (x)")  # type: ignore[union-attr]
        raise ConfigError(f"column {label!r} holds (x, y) pairs, but their path shows no pendulum's arc to tell "
                          f"which way y counts: name the columns with --columns: {cols_hint_pair(cols, pair)}")
    if arc == "x,y_down":
        y = cols[pair[1]]
        cols = [*cols]
        cols[pair[1]] = dataclasses.replace(y, y_down=True)  # type: ignore[arg-type]
    return cols


def cols_hint_pair(cols: list[ColumnName | None], pair: list[int]) -> str:
    """``--columns`` spellings for a table whose pair cell is columns ``pair``: y up, then y down."""
    def spell(y_name: str) -> str:
        names = []
        for i, c in enumerate(cols):
            if i == pair[0]:
                names.append("x")
            elif i == pair[1]:
                names.append(y_name)
            else:
                names.append(c.describe() if c is not None and c.role in ("t", "theta") else "_")
        return ",".join(names)
    return f"{spell('y')} if y counts upwards, {spell('y_down')} if it counts image rows downwards"


def _arc(body: list[tuple[int, str]], sep: str | None, comma: bool, ix: int, iy: int) -> str | None:
    """``"x,y"`` or ``"x,y_down"`` when columns ``ix`` and ``iy`` (0-based) look like the bob's positions.

    A bob swinging on a circle about a pivot above it has ``y = y_bottom + x^2 / 2L + ...`` near the
    bottom: y is a parabola in x, curving up when y counts upwards and down when it counts image rows
    downwards. An angle beside another quantity (omega, an uncertainty, a fit residual) is not.
    """
    cells = [_cells(line, sep, comma) for _, line in body]
    xy = np.array([[_number(c[ix]), _number(c[iy])] if len(c) > max(ix, iy) else [math.nan, math.nan]
                   for c in cells])
    xy = xy[np.all(np.isfinite(xy), axis=1)]
    xy = xy[: max(int(ARC_SHARE * xy.shape[0]), 10)]
    if xy.shape[0] < 10:
        return None
    x, y = xy[:, 0] - xy[:, 0].mean(), xy[:, 1] - xy[:, 1].mean()
    var = float(y @ y)
    if var <= 0.0 or float(x @ x) <= 0.0:
        return None
    quad, res2 = np.polyfit(x, y, 2, full=True)[:2]
    _, res1 = np.polyfit(x, y, 1, full=True)[:2]
    r2 = 1.0 - float(res2[0]) / var if res2.size else 1.0
    r2_line = 1.0 - float(res1[0]) / var if res1.size else 1.0
    if r2 < ARC_R2 or r2_line > ARC_LINE_R2:
        return None
    return "x,y" if quad[0] > 0 else "x,y_down"


def _number(cell: str) -> float:
    try:
        return float(cell)
    except ValueError:
        return math.nan


def raw_record(values: dict[str, np.ndarray], found: dict[str, int], cols: list[ColumnName | None],
               kind: str) -> dict[str, Any]:
    """The raw record of named columns (``values`` per role, already scaled)."""
    y_down = "y" in found and cols[found["y"]].y_down  # type: ignore[union-attr]
    if "x" in found and "y" in found:
        x, y = cols[found["x"]], cols[found["y"]]
        assert x is not None and y is not None
        if x.unit and y.unit and x.unit != y.unit:  # two lengths (cm and m; roles() refused px with m): in m
            values["x"], values["y"] = values["x"] * x.scale, values["y"] * y.scale
    n = values["t"].size
    ok = np.ones(n, dtype=bool)
    for role in ("theta", "x", "y"):
        if role in values:
            ok &= np.isfinite(values[role])
    used = set(found.values())
    labels = [c.describe() if i in used and c is not None else "_" for i, c in enumerate(cols)]
    return {"t": values["t"], "theta": values.get("theta"), "x": values.get("x"), "y": values.get("y"),
            "y_down": bool(y_down), "ok": ok, "kind": kind, "labels": labels, "columns": {}, "cols": cols,
            "roles": found}
