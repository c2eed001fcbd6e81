"""One reader of the angle records that `kinematics`, `fit` and `discover` take.

Accepted files
--------------
* pendtrack artifacts: ``angle.parquet``, ``kinematics.parquet`` (its ``omega``, ``alpha`` and
  ``segment`` come along) and ``truth.parquet``; rows with ``ok = false`` are kept, flagged;
* any other Parquet file, read by its column names as a text table's header is (below), with an
  optional boolean ``ok``;
* a CSV or whitespace-separated text table. Blank lines and lines starting with ``#`` or ``%``
  are skipped; fields are split at commas, semicolons, tabs and spaces.

Columns
-------
A first line that is not numeric is a header, and columns are read **by name** (case
insensitive; other names are ignored):

==========  ================================================  ====================================
role        names                                             units (``name [unit]``, ``name (unit)``,
                                                              ``name_unit``)
==========  ================================================  ====================================
``t``       ``t``, ``time``, ``timestamp``                    ``s`` (default), ``ms``
``theta``   ``theta``, ``θ``, ``angle``, ``ang``              ``rad`` (default), ``deg``, ``°``
``x, y``    ``x``, ``y`` (y up), ``y_down`` (y down)          any length, the same for both
==========  ================================================  ====================================

A table gives ``t`` and either ``theta`` or ``x`` and ``y`` (``theta`` wins if both are there).
Without a header, two columns are ``t [s], theta [rad]``; a table of more columns is refused
unless :class:`TableSpec` ``columns`` (``--columns t,theta,_``) names every column, ``_`` for one
to ignore (``--columns`` also overrides a header). A Parquet file's columns are named already,
with the canonical names only (``t``, ``theta``, ``x``, ``y``, ``y_down``; units allowed).

x, y convention
---------------
``x`` to the right and ``y`` **up** (a lab's or Tracker's axes, e.g. metres); a column named
``y_down`` points down (image pixels, as in track.parquet). With the pivot ``(px, py)`` in the
same units::

    theta = atan2(x - px, py - y)      (y up)        theta = atan2(x - px, y - py)   (y_down)

0 when the bob hangs straight below the pivot, positive when it is at larger x (to the right),
unwrapped: the angle stage's convention (docs/architecture.md), with the table's vertical as
zero. The pivot is :class:`TableSpec` ``pivot`` (``--pivot X Y``) or, when not given, what the
caller's ``pivot_fit`` returns (the stages fit a robust circle to the path, which this module
cannot import: it sits in the artifacts layer). A bob above its pivot in most samples is an
error (inverted pendulum or a y axis pointing down).

Checks and warnings
-------------------
Times must be finite and strictly increasing; a non-finite theta makes its row not ok.
Warnings (logged, and listed in :attr:`Record.info` for the provenance, never fatal):

* a swing between two turning points of more than a full turn (2 pi): a pendulum that turns
  back cannot have swept that far, so the column is degrees (or a position);
* an oscillation about a centre more than :data:`CENTRE_WARN_RAD` from 0 (modulo full
  turns): a position (x in metres, say), not an angle whose zero is the rest.

Time stamps (:func:`uniform_grid`)
----------------------------------
Times within :data:`GRID_RTOL` of a step of a uniform grid are kept. Slightly uneven ones
(every sample within :data:`JITTER_MAX_STEPS` of a step of the least-squares grid, e.g. a
phone's timestamps) are resampled onto that grid by a **cubic spline** through each run of
usable samples, and the resampling is recorded in :attr:`Record.info` (``"resampled"``).
Cubic rather than linear: a pendulum record has tens of samples per period, where a cubic's
error (order h^4) is far below the tracking noise while linear interpolation flattens every
turning point by order h^2 (a bias in amplitude and damping); near a knot the spline's
weights are ~1 on that sample, so the noise is not amplified. The kinematics core resamples
jittered records the same way. A step longer than :data:`GAP_STEPS` steps is a gap: the
grid points in it are missing rows (the stages' gap handling: ok flags, segments), not
invented. Anything else (samples closer than half a step, off the grid by more than the
jitter limit) is an error.
"""

from __future__ import annotations

import logging
import math
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pendtrack.artifacts import Provenance, read_artifact, read_metadata
from pendtrack.config import VIDEO_SUFFIXES
from pendtrack.errors import ArtifactError, ConfigError

log = logging.getLogger(__name__)

PARQUET_SUFFIXES = frozenset({".parquet", ".pq"})
GRID_RTOL = 1e-3  # times within this fraction of a step of the grid are on it (the fitter's tolerance)
JITTER_MAX_STEPS = 0.25  # slightly uneven: every time within this many steps of the grid (well below one)
GAP_STEPS = 1.5  # a step longer than this many grid steps is a gap: its grid points are missing rows
TURN = 2.0 * math.pi  # no swing between two turning points exceeds a full turn (the degrees test)
CENTRE_WARN_RAD = 0.5  # an oscillation centred further than this from 0 (mod 2 pi) looks like a position
ZIGZAG_FRACTION = 0.1  # a turning point is confirmed after a retreat of this share of theta's range
ZIGZAG_MAX_SAMPLES = 20000  # the turning-point search runs on at most this many samples (decimated)

TIME_NAMES = frozenset({"t", "time", "timestamp", "times"})
THETA_NAMES = frozenset({"theta", "θ", "angle", "ang"})
TIME_UNITS = {"": 1.0, "s": 1.0, "sec": 1.0, "secs": 1.0, "second": 1.0, "seconds": 1.0, "ms": 1e-3}
ANGLE_UNITS = {"": 1.0, "rad": 1.0, "rads": 1.0, "radian": 1.0, "radians": 1.0,
               "deg": math.pi / 180, "degree": math.pi / 180, "degrees": math.pi / 180, "°": math.pi / 180}
LENGTH_UNITS = frozenset({"", "m", "cm", "mm", "px", "pixel", "pixels", "in", "ft"})
IGNORED = frozenset({"_", "-"})
ARTIFACT_KINDS = ("angle", "kinematics", "truth")  # pendtrack artifacts that hold theta(t)
CARRIED = ("omega", "alpha")  # float columns of a kinematics artifact resampled with theta
_UNIT_RE = re.compile(r"^(?P<name>.*?)\s*[\[(](?P<unit>[^\])]*)[\])]\s*$")
_HEADER_RE = re.compile(r"[^\s\[(]+(?:\s*[\[(][^\])]*[\])])?")


@dataclass(frozen=True)
class ColumnName:
    """One column's meaning, parsed from a header or ``--columns`` name.

    Attributes
    ----------
    role : str
        ``"t"``, ``"theta"``, ``"x"``, ``"y"`` or ``"_"`` (ignored).
    scale : float
        Factor to s (t) or rad (theta); 1 for x, y.
    unit : str
        The unit as written ('' if none).
    y_down : bool
        A ``y_down`` column (y points down).
    label : str
        The name as written.
    """

    role: str
    scale: float = 1.0
    unit: str = ""
    y_down: bool = False
    label: str = ""


def parse_column_name(label: str, *, aliases: bool = True) -> ColumnName | None:
    """The meaning of a column name (``theta [deg]``, ``time_ms``, ``θ``, ``y_down``, ``_``), None if unknown.

    ``aliases=False`` (Parquet files, whose names a program wrote) knows only the names
    ``t``, ``theta``, ``x``, ``y``, ``y_down``, units still allowed.

    Raises
    ------
    ConfigError
        A known name with a unit that does not fit it (``theta [m]``).
    """
    text = label.strip().lower()
    if text in IGNORED or not text:
        return ColumnName("_", label=label)
    unit = ""
    m = _UNIT_RE.match(text)
    if m:
        text, unit = m.group("name").strip(), m.group("unit").strip()
    else:
        for sep in ("_", " "):
            head, _, tail = text.rpartition(sep)
            if head and tail and (tail in TIME_UNITS or tail in ANGLE_UNITS or tail in LENGTH_UNITS):
                text, unit = head, tail
                break
    if text.endswith("°"):
        text, unit = text[:-1].strip(), "°"
    if not aliases and text not in ("t", "theta", "x", "y", "y_down"):
        return None
    if text in TIME_NAMES:
        return ColumnName("t", _unit(TIME_UNITS, unit, label, "s or ms"), unit, label=label)
    if text in THETA_NAMES:
        return ColumnName("theta", _unit(ANGLE_UNITS, unit, label, "rad or deg"), unit, label=label)
    if text in ("x", "y", "y_down", "ydown"):
        if unit not in LENGTH_UNITS:
            raise ConfigError(f"column {label!r}: unit {unit!r} is not a length ({', '.join(sorted(LENGTH_UNITS - {''}))})")
        return ColumnName("x" if text == "x" else "y", 1.0, unit, y_down=text in ("y_down", "ydown"), label=label)
    return None


def _unit(table: Mapping[str, float], unit: str, label: str, expected: str) -> float:
    if unit not in table:
        raise ConfigError(f"column {label!r}: unknown unit {unit!r} (expected {expected})")
    return table[unit]


def parse_columns(text: str) -> tuple[str, ...]:
    """Split and check a ``--columns`` value (``t,theta,_``, ``t,x,y``, ``time_ms,theta_deg``).

    Raises
    ------
    ConfigError
        An unknown name, or not exactly one ``t`` and one ``theta`` or one ``x`` and one ``y``.
    """
    names = tuple(n.strip() for n in text.split(","))
    parsed = []
    for n in names:
        c = parse_column_name(n)
        if c is None:
            raise ConfigError(f"--columns: unknown column name {n!r} (t, theta, x, y, y_down, or _ to ignore one; "
                              "a unit may follow: theta_deg, 'theta [deg]', t_ms)")
        parsed.append(c)
    _roles(parsed, "--columns")
    return names


def _roles(cols: list[ColumnName | None], where: str) -> dict[str, int]:
    """Index of each used role; raises ConfigError if the names do not make t + theta or t + x + y."""
    found: dict[str, int] = {}
    for i, c in enumerate(cols):
        if c is None or c.role == "_":
            continue
        if c.role in found:
            raise ConfigError(f"{where}: two columns are {c.role} ({cols[found[c.role]].label!r} and "  # type: ignore[union-attr]
                              f"{c.label!r})")
        found[c.role] = i
    if "t" not in found or not ("theta" in found or {"x", "y"} <= set(found)):
        missing = "t" if "t" not in found else "theta"
        names = ", ".join(repr(c.label) for c in cols if c is not None and c.role != "_") or "none"
        hint = "" if where == "columns" else "; name them, e.g. --columns t,theta,_ or --columns t,x,y"
        raise ConfigError(f"{where}: missing column '{missing}' (needs t and theta, or t, x and y; recognised: "
                          f"{names}){hint}")
    if "theta" in found:
        found.pop("x", None)
        found.pop("y", None)
    x, y = cols[found["x"]] if "x" in found else None, cols[found["y"]] if "y" in found else None
    if x is not None and y is not None and x.unit and y.unit and x.unit != y.unit:
        raise ConfigError(f"{where}: x is in {x.unit} and y in {y.unit}: give them in one unit")
    return found


@dataclass(frozen=True)
class TableSpec:
    """How to read a table: what its columns are, and the pivot of x, y columns.

    Attributes
    ----------
    columns : tuple of str, optional
        One name per column of a text table (``("t", "theta", "_")``), overriding its header;
        see :func:`parse_columns`.
    pivot : (float, float), optional
        Pivot of x, y columns, in their units. None: the caller's ``pivot_fit`` decides.
    """

    columns: tuple[str, ...] | None = None
    pivot: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        if self.columns is not None:
            parse_columns(",".join(self.columns))

    @property
    def default(self) -> bool:
        """True when nothing is specified (the file alone decides)."""
        return self.columns is None and self.pivot is None

    def to_dict(self) -> dict[str, Any]:
        return {"columns": None if self.columns is None else list(self.columns),
                "pivot": None if self.pivot is None else list(self.pivot)}


PivotFit = Callable[[np.ndarray, np.ndarray], tuple[tuple[float, float], dict[str, Any]]]


@dataclass(frozen=True, eq=False)
class Record:
    """theta(t) as read, on a uniform grid when it was slightly uneven.

    Attributes
    ----------
    t : ndarray
        Times [s], strictly increasing.
    theta : ndarray
        Angle [rad] (see the module's conventions).
    ok : ndarray of bool
        Usable rows (an artifact's ``ok`` and a finite theta).
    source : Path
        The file read.
    kind : str
        ``"angle"``, ``"kinematics"``, ``"truth"``, ``"parquet"`` (no pendtrack metadata) or ``"table"``.
    columns : dict of str to ndarray
        Further columns of a kinematics artifact (``omega``, ``alpha``, ``segment``).
    provenance : Provenance or None
        The artifact's provenance (pendtrack artifacts only).
    info : dict
        How it was read, for the provenance: ``kind``, ``columns`` (as understood),
        ``pivot`` (x, y tables), ``resampled`` (None, or the grid and method), ``warnings``.
    """

    t: np.ndarray
    theta: np.ndarray
    ok: np.ndarray
    source: Path
    kind: str
    columns: dict[str, np.ndarray] = field(default_factory=dict)
    provenance: Provenance | None = None
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def n_usable(self) -> int:
        """Number of usable rows."""
        return int(np.count_nonzero(self.ok))

    @property
    def warnings(self) -> tuple[str, ...]:
        """The warnings raised while reading (also logged)."""
        return tuple(self.info.get("warnings", ()))


def is_video(path: str | Path) -> bool:
    """True if ``path`` looks like a video file (by its suffix)."""
    return Path(path).suffix.lower() in VIDEO_SUFFIXES


def read_record(path: str | Path, *, spec: TableSpec | None = None, pivot_fit: PivotFit | None = None,
                min_samples: int = 0, purpose: str = "this stage") -> Record:
    """Read theta(t) from an artifact, a Parquet file or a text table (see the module docstring).

    Parameters
    ----------
    path : path
        The file.
    spec : TableSpec, optional
        Column names and pivot (``--columns``, ``--pivot``).
    pivot_fit : callable, optional
        ``pivot_fit(x, y) -> ((px, py), facts)`` for x, y columns without ``spec.pivot``;
        without it such a table needs the pivot.
    min_samples : int
        Fewer usable rows are an error.
    purpose : str
        Who needs them, for that error ("discovery").

    Returns
    -------
    Record

    Raises
    ------
    ArtifactError
        Missing, unreadable or malformed file, unknown columns, bad times; one line naming the file.
    """
    path = Path(path)
    spec = spec or TableSpec()
    if not path.is_file():
        raise ArtifactError("file not found", path=path)
    if is_video(path):
        raise ArtifactError("is a video: run the video stages first (`pendtrack run` or `pendtrack discover` do)",
                            path=path)
    try:
        if path.suffix.lower() in PARQUET_SUFFIXES:
            raw = _read_parquet(path, spec)
        else:
            raw = _read_text(path, spec)
    except ConfigError as exc:
        raise ArtifactError(str(exc), path=path) from None
    t, ok = raw["t"], raw["ok"]
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        raise ArtifactError(f"row {bad[0]} has a non-finite time", path=path)
    steps = np.diff(t)
    if np.any(steps <= 0):
        i = int(np.argmax(steps <= 0))
        raise ArtifactError(f"time must be strictly increasing (times must increase strictly): t[{i + 1}] = "
                            f"{t[i + 1]:g} s after t[{i}] = {t[i]:g} s", path=path)
    info: dict[str, Any] = {"kind": raw["kind"], "columns": raw["labels"], "pivot": None, "resampled": None,
                            "warnings": []}
    if raw.get("theta") is None:
        theta = _theta_from_xy(raw, ok, spec, pivot_fit, info, path)
    else:
        theta = raw["theta"]
    ok = ok & np.isfinite(theta)
    columns: dict[str, np.ndarray] = raw["columns"]
    grid = uniform_grid(t, path=path)
    if grid is not None:
        theta, columns, t, info["resampled"] = _resample(t, theta, ok, columns, grid)
    if np.count_nonzero(ok) < min_samples:
        raise ArtifactError(f"only {np.count_nonzero(ok)} usable samples; {purpose} needs at least {min_samples}",
                            path=path)
    for text in theta_warnings(theta[ok]):
        log.warning("%s: %s", path, text)
        info["warnings"].append(text)
    if info["resampled"] is not None:
        r = info["resampled"]
        log.info("%s: time stamps resampled onto a uniform grid of %.6g s (off by up to %.3g step)", path,
                 r["step_s"], r["max_offset_steps"])
    return Record(t=t, theta=theta, ok=ok, source=path, kind=raw["kind"], columns=columns,
                  provenance=raw.get("provenance"), info=info)


# --- reading ------------------------------------------------------------------------------

def _read_parquet(path: Path, spec: TableSpec) -> dict[str, Any]:
    import pyarrow as pa
    import pyarrow.parquet as pq

    if spec.columns is not None:
        raise ConfigError("--columns applies to text tables; a Parquet file's columns are named already")
    meta = read_metadata(path) or {}
    kind = meta.get("artifact")
    if kind is not None and kind not in ARTIFACT_KINDS:
        raise ConfigError(f"is a {kind} artifact, which holds no angle series (expected angle, kinematics, "
                          "a Parquet file or a text table of t, theta)")
    if kind is not None:
        art = read_artifact(path, kind)
        df = art.data
        ok = df["ok"].to_numpy(dtype=bool) if "ok" in df.columns else np.ones(len(df), bool)
        columns = {c: df[c].to_numpy() for c in (*CARRIED, "segment") if c in df.columns}
        return {"t": df["t"].to_numpy(float), "theta": df["theta"].to_numpy(float), "ok": ok, "kind": kind,
                "labels": ["t", "theta"], "columns": columns, "provenance": art.provenance}
    try:
        df = pq.read_table(path).to_pandas()
    except (OSError, pa.ArrowException) as exc:
        raise ConfigError(f"not a readable Parquet file ({exc})") from None
    cols = [parse_column_name(str(c), aliases=False) for c in df.columns]
    roles = _roles(cols, "columns")
    values: dict[str, Any] = {}
    for role, i in roles.items():
        series = df[df.columns[i]]
        if series.dtype.kind not in "fiu":
            raise ConfigError(f"column {df.columns[i]!r} has dtype {series.dtype}, expected a number")
        values[role] = series.to_numpy(dtype=float) * cols[i].scale  # type: ignore[union-attr]
    ok = np.ones(len(df), dtype=bool)
    if "ok" in df.columns:
        if df["ok"].dtype.kind != "b":
            raise ConfigError(f"column 'ok' has dtype {df['ok'].dtype}, expected bool")
        ok = df["ok"].to_numpy(dtype=bool)
    return _raw(values, ok, roles, cols, "parquet")


def _raw(values: dict[str, Any], ok: np.ndarray, roles: dict[str, int], cols: list[ColumnName | None],
         kind: str) -> dict[str, Any]:
    used = {i for i in roles.values()}
    labels = [_describe(c) if i in used else "_" for i, c in enumerate(cols)]
    y_down = "y" in roles and cols[roles["y"]].y_down  # type: ignore[union-attr]
    return {"t": values["t"], "theta": values.get("theta"), "x": values.get("x"), "y": values.get("y"),
            "y_down": bool(y_down), "ok": ok, "kind": kind, "labels": labels, "columns": {}}


def _describe(c: ColumnName | None) -> str:
    if c is None or c.role == "_":
        return "_"
    name = "y_down" if c.y_down else c.role
    unit = c.unit or {"t": "s", "theta": "rad"}.get(c.role, "")
    return f"{name} [{unit}]" if unit else name


def _split(line: str) -> list[str]:
    return [f for f in re.split(r"[,;\s]+", line.strip()) if f]


def _header_fields(line: str) -> list[str]:
    if any(sep in line for sep in ",;\t"):
        return [f.strip() for f in re.split(r"[,;\t]", line.strip()) if f.strip()]
    return _HEADER_RE.findall(line.strip())


def _numeric(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _read_text(path: Path, spec: TableSpec) -> dict[str, Any]:
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise ConfigError("not a text table (not UTF-8): expected columns t [s], theta [rad]") from None
    lines = [(n, raw.strip()) for n, raw in enumerate(text.splitlines(), start=1)]
    lines = [(n, s) for n, s in lines if s and not s.startswith(("#", "%"))]
    header: list[str] | None = None
    if lines and not _numeric(_split(lines[0][1])[0]):
        header = _header_fields(lines[0][1])
        lines = lines[1:]
    width = len(_split(lines[0][1])) if lines else 2
    if spec.columns is not None:
        names = list(spec.columns)
        if lines and len(names) != width:
            raise ConfigError(f"--columns names {len(names)} columns, the table has {width} (first data line "
                              f"{lines[0][0]}): add _ for each column to ignore")
        cols = [parse_column_name(n) for n in names]
    elif header is not None:
        cols = [parse_column_name(n) for n in header]
    elif width > 2:
        hint = "t,theta" + ",_" * (width - 2)
        raise ConfigError(f"{width} columns and no header: say what they are with --columns; add "
                          f"--columns {hint} if they are t [s], theta [rad] and {width - 2} to ignore "
                          f"(or --columns t,x,y{',_' * (width - 3)} for positions)")
    else:
        cols = [ColumnName("t", label="t"), ColumnName("theta", label="theta")]
    roles = _roles(cols, "header" if spec.columns is None else "--columns")
    order = sorted(roles.items(), key=lambda kv: kv[1])
    need = order[-1][1] + 1
    data = np.empty((len(lines), len(order)))
    expected = ", ".join(_describe(cols[i]) for _, i in order)
    for row, (lineno, line) in enumerate(lines):
        fields = _split(line)
        try:
            if len(fields) < need:
                raise ValueError
            data[row] = [float(fields[i]) for _, i in order]
        except ValueError:
            raise ConfigError(f"line {lineno}: expected numbers {expected}, got {line[:60]!r}") from None
    values = {role: data[:, k] * cols[i].scale for k, (role, i) in enumerate(order)}  # type: ignore[union-attr]
    return _raw(values, np.ones(len(lines), dtype=bool), roles, cols, "table")


# --- x, y -> theta ------------------------------------------------------------------------

def theta_from_xy(x: np.ndarray, y: np.ndarray, *, pivot: tuple[float, float], y_down: bool) -> np.ndarray:
    """theta [rad] of positions about a pivot (the module's x, y convention), unwrapped.

    Parameters
    ----------
    x, y : ndarray
        Positions, any length unit; y up unless ``y_down``.
    pivot : (float, float)
        Pivot in the same units.
    y_down : bool
        y points down (image pixels).
    """
    dx = np.asarray(x, float) - pivot[0]
    below = np.asarray(y, float) - pivot[1]
    if not y_down:
        below = -below
    theta = np.arctan2(dx, below)
    good = np.isfinite(theta)
    theta[good] = np.unwrap(theta[good])
    return theta


def _theta_from_xy(raw: dict[str, Any], ok: np.ndarray, spec: TableSpec, pivot_fit: PivotFit | None,
                   info: dict[str, Any], path: Path) -> np.ndarray:
    x, y, y_down = raw["x"], raw["y"], raw["y_down"]
    usable = ok & np.isfinite(x) & np.isfinite(y)
    facts: dict[str, Any] = {"source": "--pivot"}
    if spec.pivot is not None:
        pivot = (float(spec.pivot[0]), float(spec.pivot[1]))
    elif pivot_fit is not None:
        pivot, fitted = pivot_fit(x[usable], y[usable])
        facts = {"source": "circle fit", **fitted}
    else:
        raise ArtifactError("x, y columns need the pivot: give --pivot X Y (in the table's units)", path=path)
    theta = theta_from_xy(x, y, pivot=pivot, y_down=y_down)
    below = (y[usable] - pivot[1]) * (1.0 if y_down else -1.0)
    if below.size and np.median(below) < 0:
        axis, other = ("down", "y") if y_down else ("up", "y_down")
        raise ArtifactError(f"the bob is above the pivot ({pivot[0]:.6g}, {pivot[1]:.6g}) in most samples with y "
                            f"{axis}: if the y axis points the other way, name the column {other} (e.g. "
                            f"--columns t,x,{other})", path=path)
    info["pivot"] = {"x": pivot[0], "y": pivot[1], "y_axis": "down" if y_down else "up", **facts}
    return theta


# --- warnings -----------------------------------------------------------------------------

def turning_values(theta: np.ndarray) -> np.ndarray:
    """Values of theta at its turning points, by a zigzag: an extreme counts once theta has
    retreated from it by :data:`ZIGZAG_FRACTION` of theta's 1-99 % range (noise does not)."""
    x = np.asarray(theta, float)
    x = x[np.isfinite(x)]
    if x.size < 3:
        return np.empty(0)
    x = x[:: max(1, x.size // ZIGZAG_MAX_SAMPLES)]
    lo, hi = np.percentile(x, [1, 99])
    delta = ZIGZAG_FRACTION * (hi - lo)
    if delta <= 0:
        return np.empty(0)
    out: list[float] = []
    start = ext = x[0]
    direction = 0  # +1 rising, -1 falling, 0 not yet known
    for v in x[1:]:
        if direction == 0:
            if abs(v - start) >= delta:
                direction, ext = (1 if v > start else -1), v
        elif direction * (v - ext) > 0:
            ext = v
        elif direction * (ext - v) >= delta:
            out.append(ext)
            direction, ext = -direction, v
    return np.asarray(out)


def theta_warnings(theta: np.ndarray) -> list[str]:
    """Warnings on an angle series that looks like degrees or a position (see the module docstring)."""
    ext = turning_values(theta)
    out: list[str] = []
    if ext.size < 2:
        return out
    swing = float(np.max(np.abs(np.diff(ext))))
    if swing > TURN:
        out.append(f"theta swings by up to {swing:.4g} between two turning points, more than a full turn "
                   f"(2 pi rad): it looks like degrees (name the column theta_deg or 'theta [deg]') or a position, "
                   "not an angle in rad")
        return out
    centre = float(np.median(0.5 * (ext[1:] + ext[:-1])))
    off = (centre + math.pi) % TURN - math.pi
    if abs(off) > CENTRE_WARN_RAD:
        out.append(f"theta oscillates about {centre:.4g} rad, not about 0 (hanging straight down): it looks like "
                   "a position (x or y, e.g. in metres), not the angle; give positions as columns t, x, y (header or "
                   "--columns), with --pivot X Y or a fitted pivot")
    return out


# --- time stamps --------------------------------------------------------------------------

@dataclass(frozen=True)
class Grid:
    """The uniform grid of a slightly uneven record: ``t_k = origin + step * index_k``."""

    origin: float
    step: float
    index: np.ndarray  # grid index of each row (strictly increasing; jumps > 1 at gaps)
    max_offset: float  # largest |t - grid| [steps]
    rms_offset: float  # [steps]


def uniform_grid(t: np.ndarray, *, path: str | Path | None = None) -> Grid | None:
    """The least-squares uniform grid of slightly uneven times, or None if they are on one already.

    Parameters
    ----------
    t : ndarray
        Strictly increasing times [s].
    path : path, optional
        For the error message.

    Raises
    ------
    ArtifactError
        Times too uneven to resample (see the module docstring).
    """
    t = np.asarray(t, float)
    if t.size < 3:
        return None
    steps = np.diff(t)
    h0 = float(np.median(steps))
    k0 = np.rint((t - t[0]) / h0)
    if float(np.max(np.abs(t - t[0] - k0 * h0))) <= GRID_RTOL * h0 and np.all(np.diff(k0) > 0):
        return None
    m = np.rint(steps / h0)  # grid steps between rows: 1, or >= 2 at a gap (a step >= GAP_STEPS h)
    small = np.flatnonzero(m < 1)
    if small.size:
        i = int(small[0])
        raise ArtifactError(f"time stamps too uneven for a uniform grid: t[{i + 1}] - t[{i}] = {steps[i]:.4g} s is "
                            f"less than half the median step {h0:.4g} s", path=path)
    index = np.concatenate(([0], np.cumsum(m))).astype(np.int64)
    step, origin = np.polyfit(index.astype(float), t, 1)
    offset = (t - origin - step * index) / step
    worst = float(np.max(np.abs(offset)))
    if worst <= GRID_RTOL:
        return None
    if worst > JITTER_MAX_STEPS:
        i = int(np.argmax(np.abs(offset)))
        raise ArtifactError(f"time stamps too uneven for a uniform grid: t[{i}] = {t[i]:.6g} s is {worst:.2g} of a "
                            f"step ({step:.4g} s) off it; up to {JITTER_MAX_STEPS} step is resampled", path=path)
    return Grid(origin=float(origin), step=float(step), index=index, max_offset=worst,
                rms_offset=float(np.sqrt(np.mean(offset ** 2))))


def _resample(t: np.ndarray, theta: np.ndarray, ok: np.ndarray, columns: dict[str, np.ndarray], grid: Grid
              ) -> tuple[np.ndarray, dict[str, np.ndarray], np.ndarray, dict[str, Any]]:
    """theta and the carried float columns at the grid times, by a cubic spline per run of usable rows."""
    from scipy.interpolate import CubicSpline

    new_t = grid.origin + grid.step * grid.index
    floats = {"theta": theta, **{c: columns[c] for c in CARRIED if c in columns}}
    out = {name: np.array(v, dtype=float) for name, v in floats.items()}
    # runs: consecutive usable rows without a gap between them
    brk = np.flatnonzero(~ok[1:] | ~ok[:-1] | (np.diff(grid.index) > 1)) + 1
    for run in np.split(np.arange(t.size), brk):
        run = run[ok[run]]
        if run.size < 2:
            continue
        for name, v in floats.items():
            out[name][run] = CubicSpline(t[run], v[run])(new_t[run])
    carried = {**columns, **{c: out[c] for c in CARRIED if c in columns}}
    record = {"method": "cubic spline (not-a-knot) through each run of usable samples", "step_s": grid.step,
              "origin_s": grid.origin, "max_offset_steps": grid.max_offset, "rms_offset_steps": grid.rms_offset,
              "n": int(t.size)}
    return out["theta"], carried, new_t, record
