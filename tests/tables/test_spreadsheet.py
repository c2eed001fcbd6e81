"""Excel workbooks (pendtrack.tables.spreadsheet), on small workbooks written with openpyxl in the layouts users
have: Tracker's data table exported to Excel, a lab's sheet with a title above its header, a logger's clock.

hyp0515/EXPERIMENTAL_PHYSICS_III@2d81d29 keeps each Tracker project beside its Excel export (`tracker_file/*.xlsx`:
one sheet, `t x y r θ`, x and y in metres about the pivot, θ Tracker's angle of (x, y) in degrees); pendtrack
answered "not a text table (binary data)" to the workbook and read the .trk beside it.
"""

from __future__ import annotations

import datetime as dt

import numpy as np
import pytest
from test_tables import _one_line_error, invoke

from pendtrack.errors import ArtifactError
from pendtrack.models import get_model, simulate
from pendtrack.tables import TableSpec, read_record

openpyxl = pytest.importorskip("openpyxl")

RATE = 30.0
T = np.arange(int(10.0 * RATE)) / RATE
THETA = simulate(get_model("standard"), {"Omega0": 4.7, "C1": 0.05, "C0": 0.01, "C2": 0.02}, T,
                 theta0=0.4, omega0=0.0).theta
L = 0.45  # [m]
X, Y = L * np.sin(THETA), -L * np.cos(THETA)  # about the pivot, y up (Tracker's axes)


def _book(path, sheets: dict[str, list[tuple]]) -> None:
    book = openpyxl.Workbook()
    book.remove(book.active)
    for name, rows in sheets.items():
        sheet = book.create_sheet(name)
        for row in rows:
            sheet.append(list(row))
    book.save(path)


def _tracker_rows() -> list[tuple]:
    polar = np.degrees(np.arctan2(Y, X))
    return [("t", "x", "y", "r", "θ")] + [(float(t), float(x), float(y), L, float(p))
                                           for t, x, y, p in zip(T, X, Y, polar)]


def test_tracker_table_exported_to_excel(tmp_path):
    src = tmp_path / "163008.xlsx"
    _book(src, {"工作表1": _tracker_rows()})
    rec = read_record(src, spec=TableSpec(pivot=(0.0, 0.0)))
    # θ is the angle of (x, y) about Tracker's origin, passed over; theta from x, y about the pivot, exact to
    # float rounding of the stored doubles
    np.testing.assert_allclose(rec.t, T, rtol=0, atol=1e-12)
    np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=1e-9)


def test_a_title_above_the_header_and_a_sheet_of_notes(tmp_path):
    src = tmp_path / "lab.xlsx"
    rows = [("Pendulum, 24 Nov", None, None), (None, None, None), ("Time (s)", "Angle (deg)", "note")]
    rows += [(float(t), float(np.degrees(th)), "release" if k == 0 else None) for k, (t, th) in enumerate(zip(T, THETA))]
    _book(src, {"data": rows, "notes": [("length", "0.45 m"), ("mass", "50 g")]})
    rec = read_record(src)
    np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=1e-9)


def test_a_loggers_clock_in_time_cells(tmp_path):
    src = tmp_path / "clock.xlsx"
    start = dt.datetime(2023, 11, 24, 16, 5, 52)
    rows = [("Time", "Angle (rad)")] + [((start + dt.timedelta(seconds=float(t))).time(), float(th))
                                       for t, th in zip(T, THETA)]
    _book(src, {"Sheet1": rows})
    rec = read_record(src)
    # Excel keeps a time of day to the millisecond: the 33.3-ms rows come back on their grid within that rounding
    np.testing.assert_allclose(rec.t - rec.t[0], T, rtol=0, atol=1e-3)
    assert rec.info["clock"]["kind"] == "logger"


@pytest.mark.integration
def test_two_sheets_of_data_and_old_formats_are_refused_naming_the_way_out(tmp_path):
    src = tmp_path / "two.xlsx"
    _book(src, {"run 1": _tracker_rows(), "run 2": _tracker_rows()})
    with pytest.raises(ArtifactError, match="2 sheets hold rows of numbers \\('run 1', 'run 2'\\)"):
        read_record(src, spec=TableSpec(pivot=(0.0, 0.0)))
    old = tmp_path / "old.xls"
    old.write_bytes(b"\xd0\xcf\x11\xe0\xa1\xb1\x1a\xe1" + bytes(504))
    out = tmp_path / "out"
    res = invoke("fit", str(old), "--model", "standard", "--out", str(out))
    _one_line_error(res, "old.xls", "Excel 97-2003 workbook", "save it as .xlsx")
    assert not out.exists()
    broken = tmp_path / "broken.xlsx"
    broken.write_text("t,theta\n0,1\n")
    with pytest.raises(ArtifactError, match="not an Excel workbook"):
        read_record(broken)
