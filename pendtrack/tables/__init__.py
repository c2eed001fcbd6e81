"""One reader of the angle records that `kinematics`, `fit` and `discover` take.

Accepted files
--------------
* pendtrack artifacts: ``angle.parquet``, ``kinematics.parquet`` (its ``omega``, ``alpha`` and
  ``segment`` come along) and ``truth.parquet``; rows with ``ok = false`` are kept, flagged;
* any other Parquet file, read by its column names as a text table's header is, with an
  optional boolean ``ok``;
* text tables (:mod:`pendtrack.tables.text`): CSV, semicolon, tab or white-space separated, a
  decimal comma after a tab, semicolon or space; UTF-8, Windows-1252 or UTF-16 with its byte-order mark; a plain log (``Time,Angle``, a headerless
  encoder log), Tracker's data export (File > Export > Data: the track name, then ``t  x  y …``),
  Vernier Logger Pro and Video Analysis CSV (``"Latest: Time (s)"``, ``"VideoAnalysis: X (m)"``)
  and text exports (``Vernier Format 2``), phyphox CSV (``"Time (s)","Angle (deg)"``);
* Tracker project files ``.trk`` (:mod:`pendtrack.tables.trk`): the point-mass track in the
  project's calibrated world units, timed by its video clip;
* Vernier's own files, Logger Pro ``.cmbl`` and Graphical Analysis ``.gambl``
  (:mod:`pendtrack.tables.vernier`): their data sets read as the text table of their CSV export;
* MATLAB data files ``.mat`` of versions 4 to 7 (:mod:`pendtrack.tables.matlab`): one numeric
  matrix read as a headerless table, or equal-length vectors as columns named by their variables;
* Excel workbooks ``.xlsx``/``.xlsm`` (:mod:`pendtrack.tables.spreadsheet`): the one sheet of data
  read as a text table;
* lines of labelled values, ``Angle (deg): 12.3`` (:mod:`pendtrack.tables.labelled_values`): the
  labels are the header;
* times of day (:mod:`pendtrack.tables.clock_times`): a logger's first column ``14:23:05.123`` (or a
  stopwatch's minutes and seconds, ``01:23.45``) read as seconds since the first row, and the Arduino Serial Monitor's ``14:23:05.123 -> payload``
  lines read as the board's payload (its receive times only for lines of one value).

Columns and units
-----------------
Columns are read **by name** (:mod:`pendtrack.tables.units`): ``t``/``time``/``timestamp`` (and
an Arduino sketch's ``millis``, ``micros``: t in ms, µs),
``theta``/``θ``/``angle``/``ang``/``phi`` (the time's and the angle's names also in the languages lab
software is localised to: ``Zeit``, ``Winkel``, ``tiempo``, ``ángulo``, ...), ``x``, ``y`` (y up), ``y_down``
(y down); indexed names
(``theta1``, ``x 1``) when there is one of a kind; a data-set prefix (``Run 1: Time (s)``) is
read, and several data sets are an error naming the ``--columns`` that picks the first. Units follow
the name in brackets or parentheses or after ``_`` (``t_s``, ``Time [ms]``, ``theta1_rad``,
``Angle (°)``): s, ms, us/µs, ns, min; rad, mrad, deg/°; m, cm, mm, px. ``--columns`` names
every column (``t[us],theta[deg]``, ``_`` to ignore one) and overrides a header. Without a
header, two columns are ``t [s], theta [rad]``; more are refused unless ``--columns`` names them.
A table without a time column (a logger's angles at a fixed rate) is timed by ``--rate``
(:class:`TableSpec` ``rate_hz``): row k at ``t = k / rate_hz``.

A column without a unit is read in s or rad, and checked (:mod:`pendtrack.tables.checks`):
a theta that swings more than a full turn between two turning points is not in rad, and a time
column whose swing period is beyond 100 "s" is not in s. Both are errors that name the
``--columns`` to give (or, for numbers that are no swing in degrees either, say the column is not
an angle); a declared unit is taken as declared, but no free pendulum swings beyond a full turn
between two turning points in any unit.

x, y convention
---------------
``x`` to the right and ``y`` **up** (a lab's or Tracker's world axes); a column named ``y_down``
points down (image pixels). With the pivot ``(px, py)`` in the same units::

    theta = atan2(x - px, py - y)      (y up)        theta = atan2(x - px, y - py)   (y_down)

0 when the bob hangs straight below the pivot, positive at larger x, unwrapped. The pivot is
:class:`TableSpec` ``pivot`` (``--pivot X Y``) or what the caller's ``pivot_fit`` returns (the
stages fit a robust circle to the path). A bob above its pivot in most samples is an error.

Time stamps
-----------
Times must be finite and strictly increasing; every such set of times is used
(:mod:`pendtrack.tables.grid`): times on a uniform grid as they are, jittered or irregular
ones resampled onto one by cubic splines, with the error bound in :attr:`Record.info`
(``"resampled"``). Gaps stay gaps (missing rows).
"""

from pendtrack.tables.checks import theta_warnings, turning_values
from pendtrack.tables.grid import Grid, time_layout, uniform_grid
from pendtrack.tables.record import (
    ARTIFACT_KINDS,
    PARQUET_SUFFIXES,
    PivotFit,
    Record,
    TableSpec,
    is_video,
    read_record,
    theta_from_xy,
)
from pendtrack.tables.units import ColumnName, parse_column_name, parse_columns

__all__ = [
    "ARTIFACT_KINDS", "PARQUET_SUFFIXES", "ColumnName", "Grid", "PivotFit", "Record", "TableSpec", "is_video",
    "parse_column_name", "parse_columns", "read_record", "theta_from_xy", "theta_warnings", "time_layout",
    "turning_values", "uniform_grid",
]
