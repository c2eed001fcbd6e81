"""Vernier's own files: Logger Pro (``.cmbl``) and Graphical Analysis (``.gambl``), read as the text table they hold.

A ``.cmbl`` file is XML: ``<Document>`` holds ``<DataSet>`` elements (a run: ``<DataSetName>`` such as
``Latest`` or ``Run 1``), each with ``<DataColumn>`` elements: ``<DataObjectName>`` (``Time``, ``Angle``),
``<ColumnUnits>`` (``s``, ``°``, ``rad``) and ``<ColumnCells>``, one value per line. A ``.gambl`` file is a tar
archive whose ``vstudm/data.udm`` is the same XML. A data set without columns (Logger Pro keeps its curve fits in
one) is left out; a cell that is no number (a sensor's missed sample) is blank.

:func:`vernier_lines` writes the columns as the lines of a tab-separated table with Logger Pro's own CSV header,
``Run 1: Time (s)``, so that :func:`pendtrack.tables.text.read_text` reads them by name and unit, as it reads
Logger Pro's exports: several runs side by side are an error naming the ``--columns`` that picks one.
"""

from __future__ import annotations

import math
import tarfile
import xml.etree.ElementTree as ET
from pathlib import Path

from pendtrack.errors import ConfigError

VERNIER_SUFFIXES = frozenset({".cmbl", ".gambl"})
GAMBL_MEMBER = "vstudm/data.udm"  # the XML inside a Graphical Analysis file


def _xml(path: Path) -> bytes:
    """The XML text of a ``.cmbl`` file, or of a ``.gambl`` archive's data."""
    if path.suffix.lower() != ".gambl":
        return path.read_bytes()
    try:
        with tarfile.open(path) as archive:
            member = archive.extractfile(GAMBL_MEMBER)
            if member is None:
                raise KeyError(GAMBL_MEMBER)
            return member.read()
    except (tarfile.TarError, KeyError):
        raise ConfigError(f"not a Graphical Analysis file: no {GAMBL_MEMBER} in a tar archive") from None


def _cell(text: str) -> str:
    """A value as written, or '' where it is no finite number."""
    text = text.strip()
    try:
        value = float(text)
    except ValueError:
        return ""
    return text if math.isfinite(value) else ""


def vernier_lines(path: Path) -> list[tuple[int, str]]:
    """The data sets of a Logger Pro or Graphical Analysis file as numbered lines of a tab-separated table.

    Parameters
    ----------
    path : Path
        A ``.cmbl`` or ``.gambl`` file.

    Returns
    -------
    list of (int, str)
        ``(1, header)`` with a ``Set: Name (unit)`` field per column, then ``(k + 1, row k)``: row k holds each
        column's k-th value ('' past a column's end).

    Raises
    ------
    ConfigError
        Not such a file, or one without a column of values.
    """
    kind = "Graphical Analysis" if path.suffix.lower() == ".gambl" else "Logger Pro"
    try:
        root = ET.fromstring(_xml(path))
    except ET.ParseError as exc:
        raise ConfigError(f"not a {kind} file (its XML does not parse: {exc})") from None
    fields: list[str] = []
    columns: list[list[str]] = []
    for data_set in root.iter("DataSet"):
        name = (data_set.findtext("DataSetName") or "Data Set").replace(":", " ").strip() or "Data Set"
        for column in data_set.findall("DataColumn"):
            label = (column.findtext("DataObjectName") or "").strip()
            unit = (column.findtext("ColumnUnits") or "").strip()
            cells = [_cell(v) for v in (column.findtext("ColumnCells") or "").splitlines()]
            while cells and not cells[-1]:
                cells.pop()
            if not label or not cells:
                continue
            fields.append(f"{name}: {label}" + (f" ({unit})" if unit else ""))
            columns.append(cells)
    if not columns:
        raise ConfigError(f"a {kind} file without a column of values")
    rows = max(len(c) for c in columns)
    lines = [(1, "\t".join(fields))]
    for k in range(rows):
        cells = [c[k] if k < len(c) else "" for c in columns]
        if any(cells):
            lines.append((k + 2, "\t".join(cells)))
    return lines
