"""Excel workbooks (``.xlsx``, ``.xlsm``), read as the text table their one sheet of data holds.

Tracker exports its data table to Excel, and a lab's numbers are often kept in a workbook. A
workbook is read with openpyxl (values as last computed, not formulas); the sheet whose rows start
with numbers is written as the lines of a tab-separated table, a line per spreadsheet row (so
``line 5`` in an error is row 5), of the columns that hold a number in some row of data (a column of
notes beside the samples is left out), each number with every digit of its double (``repr``), so that
:func:`pendtrack.tables.text.read_text` reads it as it reads any table: its header row by name
and unit, title rows above it as a preamble. A time of day (a logger's clock) is written as
``HH:MM:SS.ffffff`` and read by :mod:`pendtrack.tables.clock_times`; a duration as seconds.

Several sheets of data are an error naming them (pendtrack does not guess which one is the
record); the older binary ``.xls`` and OpenDocument ``.ods`` are refused with the way to save them.
"""

from __future__ import annotations

import datetime as _dt
import math
import zipfile
from pathlib import Path

from pendtrack.errors import ConfigError

SPREADSHEET_SUFFIXES = frozenset({".xlsx", ".xlsm"})
UNREAD_SUFFIXES = {".xls": "an Excel 97-2003 workbook (.xls)", ".ods": "an OpenDocument spreadsheet (.ods)",
                   ".numbers": "a Numbers document"}
SAVE_ADVICE = "save it as .xlsx, or the sheet with the record as CSV"
MIN_DATA_ROWS = 3  # rows starting with a number that make a sheet one of data (a sheet of a few results is not)


def _cell(value: object) -> str:
    """A cell as the text table writes it."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return str(value)
    if isinstance(value, (int, float)):
        return repr(float(value)) if math.isfinite(value) else ""
    if isinstance(value, _dt.datetime):
        value = value.time()
    if isinstance(value, _dt.time):
        return f"{value.hour:02d}:{value.minute:02d}:{value.second:02d}.{value.microsecond:06d}"
    if isinstance(value, _dt.timedelta):
        return repr(value.total_seconds())
    return " ".join(str(value).split())  # a cell's own tabs and line breaks are no separators


def _starts_with_number(row: tuple[object, ...]) -> bool:
    return _is_number(next((v for v in row if v is not None and v != ""), None))


def spreadsheet_lines(path: Path) -> list[tuple[int, str]]:
    """The rows of a workbook's sheet of data as numbered lines of a tab-separated table.

    Parameters
    ----------
    path : Path
        An ``.xlsx`` or ``.xlsm`` workbook.

    Returns
    -------
    list of (int, str)
        ``(row number, cells joined by tabs)`` for every non-empty row of the one sheet of data.

    Raises
    ------
    ConfigError
        A file openpyxl cannot read, a workbook with no sheet of data or with several (naming them).
    """
    try:
        import openpyxl  # only a workbook needs it
    except ImportError:  # pragma: no cover - a dependency of the package
        raise ConfigError("reading a workbook needs openpyxl (pip install openpyxl), or save the sheet as CSV") from None
    try:
        book = openpyxl.load_workbook(path, read_only=True, data_only=True)
    except (zipfile.BadZipFile, KeyError, ValueError, OSError) as exc:
        raise ConfigError(f"not an Excel workbook openpyxl can read ({type(exc).__name__}: {exc}): "
                          f"{SAVE_ADVICE}") from None
    try:
        sheets = []
        for sheet in book.worksheets:
            rows = [(k, row) for k, row in enumerate(sheet.iter_rows(values_only=True), start=1)
                    if any(v is not None and v != "" for v in row)]
            if sum(_starts_with_number(row) for _, row in rows) >= MIN_DATA_ROWS:
                sheets.append((sheet.title, rows))
    finally:
        book.close()
    if not sheets:
        raise ConfigError(f"no sheet holds rows of numbers (at least {MIN_DATA_ROWS} rows starting with a number): "
                          "expected one sample per row (t, theta, ... in columns)")
    if len(sheets) > 1:
        names = ", ".join(repr(name) for name, _ in sheets)
        raise ConfigError(f"{len(sheets)} sheets hold rows of numbers ({names}); pendtrack reads one record: keep "
                          "the sheet with it alone in the workbook, or save that sheet as CSV")
    _, rows = sheets[0]
    # the columns that hold a number in some row of data; a column of words beside the samples (a note by the
    # release) and the padding of a sheet's rows to its widest used column are no data
    numeric = sorted({i for _, row in rows if _starts_with_number(row) for i, v in enumerate(row) if _is_number(v)})
    return [(k, "\t".join(_cell(row[i]) if i < len(row) else "" for i in numeric)) for k, row in rows]


def _is_number(value: object) -> bool:
    return isinstance(value, (int, float, _dt.time, _dt.datetime, _dt.timedelta)) and not isinstance(value, bool)
