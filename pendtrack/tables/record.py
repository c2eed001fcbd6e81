"""The record: read a file (artifact, Parquet, text table, Tracker project), check its units and
times, compute theta of x, y, and put it on a uniform grid. See :mod:`pendtrack.tables`."""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pendtrack.artifacts import Provenance, read_artifact, read_metadata
from pendtrack.config import VIDEO_SUFFIXES
from pendtrack.errors import ArtifactError, ConfigError
from pendtrack.gitlfs import is_lfs_pointer, lfs_message
from pendtrack.tables.checks import (
    angle_impossible, theta_not_radians, theta_warnings, time_not_seconds, turning_values,
)
from pendtrack.tables.rounded_times import retime_rounded
from pendtrack.tables.grid import (CHANGE_GAP_COUNTS, at_count_edges, change_count, dwell_gaps, resample_irregular,
                                   resample_jittered, time_layout)
from pendtrack.tables.text import raw_record, read_text
from pendtrack.tables.trk import read_trk
from pendtrack.tables.units import ColumnName, columns_hint, parse_column_name, parse_columns, roles
from pendtrack.tables.clock_times import MONITOR_ADVICE
from pendtrack.tables.matlab import MATLAB_SUFFIXES, matlab_lines
from pendtrack.tables.spreadsheet import SAVE_ADVICE, SPREADSHEET_SUFFIXES, UNREAD_SUFFIXES, spreadsheet_lines
from pendtrack.tables.vernier import VERNIER_SUFFIXES, vernier_lines

log = logging.getLogger(__name__)

PARQUET_SUFFIXES = frozenset({".parquet", ".pq"})
TRACKER_SUFFIXES = frozenset({".trk"})
ARTIFACT_KINDS = ("angle", "kinematics", "truth")  # pendtrack artifacts that hold theta(t)
CARRIED = ("omega", "alpha")  # float columns of a kinematics artifact resampled with theta


@dataclass(frozen=True)
class TableSpec:
    """How to read a table: what its columns are, the pivot of x, y columns, a Tracker track.

    Attributes
    ----------
    columns : tuple of str, optional
        One name per column of a text table (``("t", "theta[deg]", "_")``), overriding its header;
        see :func:`pendtrack.tables.units.parse_columns`.
    pivot : (float, float), optional
        Pivot of x, y columns, in their units. None: the caller's ``pivot_fit`` decides.
    track : str, optional
        The point-mass track of a Tracker project with several.
    rate_hz : float, optional
        Sampling rate of a text table whose rows carry no time (a logger's angles written at a
        fixed rate): row k of the table is at ``t = k / rate_hz`` [Hz].
    """

    columns: tuple[str, ...] | None = None
    pivot: tuple[float, float] | None = None
    track: str | None = None
    rate_hz: float | None = None

    def __post_init__(self) -> None:
        if self.columns is not None:
            parse_columns(",".join(self.columns), timed_by_rate=self.rate_hz is not None)
        if self.rate_hz is not None and not (math.isfinite(self.rate_hz) and self.rate_hz > 0.0):
            raise ConfigError(f"--rate must be a sampling rate > 0 [Hz], got {self.rate_hz:g}")

    @property
    def default(self) -> bool:
        """True when nothing is specified (the file alone decides)."""
        return self.columns is None and self.pivot is None and self.track is None and self.rate_hz is None

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"columns": None if self.columns is None else list(self.columns),
                               "pivot": None if self.pivot is None else list(self.pivot)}
        if self.track is not None:
            out["track"] = self.track
        if self.rate_hz is not None:
            out["rate_hz"] = self.rate_hz
        return out


PivotFit = Callable[[np.ndarray, np.ndarray], tuple[tuple[float, float], dict[str, Any]]]


@dataclass(frozen=True, eq=False)
class Record:
    """theta(t) as read, on a uniform grid (with possible gaps) when its times were not.

    Attributes
    ----------
    t : ndarray
        Times [s], strictly increasing.
    theta : ndarray
        Angle [rad] (see the package's conventions).
    ok : ndarray of bool
        Usable rows (an artifact's ``ok`` and a finite theta).
    source : Path
        The file read.
    kind : str
        ``"angle"``, ``"kinematics"``, ``"truth"``, ``"parquet"`` (no pendtrack metadata), ``"table"``
        or ``"tracker"`` (a ``.trk`` project).
    columns : dict of str to ndarray
        Further columns of a kinematics artifact (``omega``, ``alpha``, ``segment``).
    provenance : Provenance or None
        The artifact's provenance (pendtrack artifacts only).
    info : dict
        How it was read, for the provenance: ``kind``, ``columns`` (as understood),
        ``pivot`` (x, y tables), ``resampled`` (None, or the grid, method and error bound),
        ``times_rounded`` (None, or the grid step [s] and the largest offset [steps] of times written
        with too few decimals, now on it),
        ``tracker`` (a .trk project's track, frames and clip), ``warnings``.
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

    @property
    def zero_reference(self) -> str:
        """Where theta's zero comes from: an artifact's ``zero_reference`` (angle.parquet, passed on by
        kinematics.parquet: a measured rest ``"rest"``, the image vertical ``"vertical"``),
        ``"truth"`` for truth.parquet, ``"table"`` for a plain table or Parquet file (its own
        convention), ``"unknown"`` if an artifact does not say. The fit reads it
        (:data:`pendtrack.fitting.models_fit.ZERO_NOT_MEASURED`)."""
        if self.kind == "truth":
            return "truth"
        if self.kind in ("angle", "kinematics"):
            value = ((self.provenance.extra or {}) if self.provenance is not None else {}).get("zero_reference")
            return value if isinstance(value, str) and value else "unknown"
        return "table"

    def axle_share(self, key: str) -> float | None:
        """A share of the axle's uncertainty in theta: ``"zero_sigma_rad"`` (of its zero [rad]) or
        ``"theta_scale_rel"`` (of its scale [1]); angle.parquet's ``axle_uncertainty`` holds them,
        kinematics.parquet passes them on. None when the record does not carry it (a given axle, a
        table, the truth)."""
        prov = self.provenance
        extra = (prov.extra or {}) if prov is not None and self.kind in ("angle", "kinematics") else {}
        value = extra.get(key) if self.kind == "kinematics" else (extra.get("axle_uncertainty") or {}).get(key)
        return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) else None

    @property
    def marker_radius_px(self) -> float | None:
        """The marker's distance from the fitted axle [px] (angle.parquet's ``circle``, passed on by
        kinematics.parquet as ``marker_radius_px``); None without a fitted circle (a given axle, a table)."""
        prov = self.provenance
        extra = (prov.extra or {}) if prov is not None and self.kind in ("angle", "kinematics") else {}
        if self.kind == "kinematics":
            value = extra.get("marker_radius_px")
        else:
            circle = extra.get("circle")
            value = circle.get("radius") if isinstance(circle, dict) else None
        ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) and value > 0
        return float(value) if ok else None

    @property
    def zero_sigma_rad(self) -> float | None:
        """The standard uncertainty [rad] of theta's zero from the axle's sideways uncertainty (:meth:`axle_share`)."""
        return self.axle_share("zero_sigma_rad")

    @property
    def theta_scale_rel(self) -> float | None:
        """The relative uncertainty [1] of theta's scale from the axle's radius uncertainty (:meth:`axle_share`)."""
        return self.axle_share("theta_scale_rel")


def is_video(path: str | Path) -> bool:
    """True if ``path`` looks like a video file (by its suffix)."""
    return Path(path).suffix.lower() in VIDEO_SUFFIXES


def read_record(path: str | Path, *, spec: TableSpec | None = None, pivot_fit: PivotFit | None = None,
                min_samples: int = 0, purpose: str = "this stage") -> Record:
    """Read theta(t) from an artifact, a Parquet file, a text table, a Tracker project, a Vernier, MATLAB or Excel file.

    Parameters
    ----------
    path : path
        The file.
    spec : TableSpec, optional
        Column names, pivot and track (``--columns``, ``--pivot``, ``--track``).
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
        Missing, unreadable or malformed file, unknown columns, a unit that cannot be right,
        unusable times; one line naming the file.
    """
    path = Path(path)
    spec = spec or TableSpec()
    if not path.is_file():
        raise ArtifactError("file not found", path=path)
    if is_lfs_pointer(path):
        raise ArtifactError(lfs_message("the data"), path=path)
    if is_video(path):
        raise ArtifactError("is a video: run the video stages first (`pendtrack run` or `pendtrack discover` do)",
                            path=path)
    suffix = path.suffix.lower()
    try:
        if spec.track is not None and suffix not in TRACKER_SUFFIXES:
            raise ConfigError("--track applies to Tracker projects (.trk)")
        if spec.rate_hz is not None and suffix in PARQUET_SUFFIXES | TRACKER_SUFFIXES:
            raise ConfigError("--rate applies to text tables without a time column; this file carries its times")
        if suffix in PARQUET_SUFFIXES:
            raw = _read_parquet(path, spec)
        elif suffix in TRACKER_SUFFIXES:
            if spec.columns is not None:
                raise ConfigError("--columns applies to tables; a Tracker project's track is read as t, x, y")
            raw = read_trk(path, spec.track)
        elif suffix in VERNIER_SUFFIXES:
            raw = read_text(path, spec.columns, rate_hz=spec.rate_hz, lines=vernier_lines(path))
        elif suffix in MATLAB_SUFFIXES:
            raw = read_text(path, spec.columns, rate_hz=spec.rate_hz, lines=matlab_lines(path))
        elif suffix in SPREADSHEET_SUFFIXES:
            raw = read_text(path, spec.columns, rate_hz=spec.rate_hz, lines=spreadsheet_lines(path))
        elif suffix in UNREAD_SUFFIXES:
            raise ConfigError(f"{UNREAD_SUFFIXES[suffix]}, which pendtrack does not read: {SAVE_ADVICE}")
        else:
            raw = read_text(path, spec.columns, rate_hz=spec.rate_hz)
    except ConfigError as exc:
        raise ArtifactError(str(exc), path=path) from None
    retimed = retime_rounded(raw["t"], raw["t_unit"]) if raw.get("t_unit") is not None else None
    if retimed is not None:  # rows a frame apart, their times written too coarsely to tell them apart
        raw["t"] = retimed.t
    repeated = _drop_repeated_rows(raw)
    t, ok = raw["t"], raw["ok"]
    _check_times(t, path, unit=raw.get("t_unit"))
    _check_units(raw, path)
    info: dict[str, Any] = {"kind": raw["kind"], "columns": raw["labels"], "pivot": None, "resampled": None,
                            "times_rounded": None,
                            "warnings": []}
    if retimed is not None:
        info["retimed"] = retimed.describe()
        text = (f"the times are written to {retimed.coarsest:g} s at their coarsest, more coarsely than the rows are "
                f"spaced ({retimed.n_repeated} rows repeat the time before them): each row is read as the next "
                f"sample of a uniform grid of {1e3 * retimed.step:.6g} ms, within every "
                "written time's rounding; if the rate is known, --rate HZ with the time column named _ in --columns "
                "times the rows exactly")
        log.warning("%s: %s", path, text)
        info["warnings"].append(text)
    if repeated:
        text = (f"{repeated} rows repeat the row before them exactly (a logger writing one sample twice): "
                "each is read once")
        log.warning("%s: %s", path, text)
        info["warnings"].append(text)
    if raw.get("footer"):
        lines = raw["footer"]
        text = (f"lines {lines[0][0]}-{lines[-1][0]} below the table ({lines[0][1][:30]!r}, ...) are a summary, "
                "not samples: passed over" if len(lines) > 1 else
                f"line {lines[0][0]} below the table ({lines[0][1][:30]!r}) is a summary, not a sample: passed over")
        log.warning("%s: %s", path, text)
        info["warnings"].append(text)
    if "tracker" in raw:
        info["tracker"] = raw["tracker"]
    if raw.get("clock") is not None:
        info["clock"] = raw["clock"].describe()
        if raw["clock"].receive_times:
            text = (f"the times are the Arduino Serial Monitor's, when the computer received each line (t = 0 at "
                    f"{raw['clock'].first}), not when the board measured it: {MONITOR_ADVICE}")
            log.warning("%s: %s", path, text)
            info["warnings"].append(text)
    theta = _theta_from_xy(raw, ok, spec, pivot_fit, info, path) if raw.get("theta") is None else raw["theta"]
    ok = ok & np.isfinite(theta)
    columns: dict[str, np.ndarray] = raw["columns"]
    layout, grid = time_layout(t)
    if layout == "rounded":  # times written with too few decimals: each row at its grid point
        assert grid is not None
        t = grid.origin + grid.step * grid.index.astype(np.float64)
        info["times_rounded"] = {"step_s": grid.step, "max_offset_steps": grid.max_offset}
        log.info("%s: time stamps rounded off a uniform grid of %.9g s (by up to %.2g of a step): taken at the "
                 "grid's times", path, grid.step, grid.max_offset)
    elif layout == "jittered":
        assert grid is not None
        theta, columns, t, info["resampled"] = resample_jittered(t, theta, ok, columns, grid)
    elif layout == "irregular":
        count = change_count(theta, ok)
        gap_after = None
        dwell: tuple[np.ndarray, float] | None = None
        if count is not None:  # an encoder logging each change of its count: rows at the edges crossed
            dwell = dwell_gaps(t, theta)
            theta, ok, gap_after = at_count_edges(theta, ok, count)
            gap_after = gap_after | dwell[0]
        n_rows = t.size
        t_rows = t
        theta, columns, t, info["resampled"] = resample_irregular(t, theta, ok, columns, path=path,
                                                                  gap_after=gap_after)
        if count is not None:
            assert dwell is not None
            info["resampled"].update(change_driven=True, count_rad=count, gap_counts=CHANGE_GAP_COUNTS,
                                     dwell_limit_s=dwell[1] if math.isfinite(dwell[1]) else None)
            if np.any(dwell[0]):
                k = int(np.argmax(np.diff(t_rows)))
                text = (f"{int(np.count_nonzero(dwell[0]))} spacing(s) without a row longer than a period "
                        f"({dwell[1]:.3g} s), the longest {t_rows[k + 1] - t_rows[k]:.3g} s after t = {t_rows[k]:.6g} "
                        f"s: no swinging bob stays so long within one count (at rest, or the logger paused), so "
                        f"each is a gap; {info['resampled']['n_samples_unused']} of {n_rows} rows in runs too short "
                        "to use")
                log.warning("%s: %s", path, text)
                info["warnings"].append(text)
            log.info("%s: a row per change of a %.4g-rad count: rows taken at the count edges crossed, spacings "
                     "within %d counts are no gaps", path, count, CHANGE_GAP_COUNTS)
        ok = np.ones(t.size, dtype=bool)
    if np.count_nonzero(ok) < min_samples:
        raise ArtifactError(f"only {np.count_nonzero(ok)} usable samples; {purpose} needs at least {min_samples}",
                            path=path)
    for text in theta_warnings(theta[ok]):
        log.warning("%s: %s", path, text)
        info["warnings"].append(text)
    if info["resampled"] is not None:
        r = info["resampled"]
        bound = r.get("error_bound_rad")
        log.info("%s: %s time stamps resampled onto a uniform grid of %.6g s (cubic spline, error %s)", path,
                 "irregular" if r.get("irregular") else "jittered", r["step_s"],
                 "not estimated" if bound is None else f"<= {bound:.2g} rad")
    return Record(t=t, theta=theta, ok=ok, source=path, kind=raw["kind"], columns=columns,
                  provenance=raw.get("provenance"), info=info)


def _drop_repeated_rows(raw: dict[str, Any]) -> int:
    """Drop, in place, every row whose time and values (theta or x, y, and ``ok``) equal the row before's.

    Such a row is one sample written twice: reading it once loses nothing. Returns how many were dropped.
    """
    t = np.asarray(raw["t"])
    if t.size < 2:
        return 0
    same = (t[1:] == t[:-1]) & (np.asarray(raw["ok"])[1:] == np.asarray(raw["ok"])[:-1])
    for key in ("theta", "x", "y"):
        v = raw.get(key)
        if v is not None:
            v = np.asarray(v, dtype=np.float64)
            same &= (v[1:] == v[:-1]) | (np.isnan(v[1:]) & np.isnan(v[:-1]))
    if not same.any():
        return 0
    keep = np.concatenate([[True], ~same])
    for key in ("t", "ok", "theta", "x", "y", "t_unit"):
        if raw.get(key) is not None:
            raw[key] = np.asarray(raw[key])[keep]
    raw["columns"] = {name: np.asarray(v)[keep] for name, v in raw["columns"].items()}
    return int(same.sum())


def _check_times(t: np.ndarray, path: Path, *, unit: np.ndarray | None = None) -> None:
    """Finite, strictly increasing times: the only times that are refused are unusable ones.

    ``unit``: each written time's last-digit unit [s] (a text table's); a repeated time written more
    coarsely than the rows are spaced is named as such, with the ways out.
    """
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        raise ArtifactError(f"row {bad[0]} has a non-finite time", path=path)
    steps = np.diff(t)
    if np.any(steps <= 0):
        i = int(np.argmax(steps <= 0))
        n_same = int(np.count_nonzero(steps == 0))
        what = ("time going back" if steps[i] < 0 else "a repeated time" if n_same == 1 else
                f"a repeated time (one of {n_same})")
        why = ""
        if unit is not None and steps[i] == 0 and np.any(steps > 0) and unit.size == t.size:
            # the rows' spacing: the mean step (where times repeat, the steps that are not 0 are the rounding's)
            spacing = min(float(np.median(steps[steps > 0])), float(t[-1] - t[0]) / (t.size - 1))
            if unit[i + 1] > spacing:
                why = (f"; the times are written to {unit[i + 1]:g} s there, more coarsely than the rows' "
                       f"{1e3 * spacing:.3g}-ms spacing, and the rows do not fit one uniform grid within that "
                       "rounding: write the times with more digits, or time the rows with --rate HZ (naming the "
                       "time column _ in --columns)")
        raise ArtifactError(f"times must increase strictly: {what}, t[{i + 1}] = "
                            f"{t[i + 1]:g} s after t[{i}] = {t[i]:g} s{why}", path=path)


def _check_units(raw: dict[str, Any], path: Path) -> None:
    """An undeclared time or angle column that cannot be in s or rad is an error naming the fix."""
    cols: list[ColumnName | None] | None = raw.get("cols")
    found: dict[str, int] | None = raw.get("roles")
    if cols is None or found is None:
        return  # a pendtrack artifact: its units are pendtrack's
    problems: list[str] = []
    fix: dict[str, str] = {}
    note = ""
    t_col = cols[found["t"]]
    if t_col is not None and not t_col.declared:
        signal = raw["theta"] if raw.get("theta") is not None else raw["x"]
        wrong = time_not_seconds(raw["t"], signal)
        if wrong is not None:
            why, unit = wrong
            problems.append(f"{why}: it looks like {'µs' if unit == 'us' else unit}")
            fix["t"] = unit
    if "theta" in found:
        th_col = cols[found["theta"]]
        if th_col is not None and not th_col.declared:
            wrong_theta = theta_not_radians(raw["theta"])
            if wrong_theta is not None:
                why_theta, in_degrees = wrong_theta
                if not in_degrees:  # no unit to declare: the column is not an angle
                    raise ArtifactError(why_theta, path=path)
                if th_col.assumed:  # no header said it is an angle: the bob's position in px or mm looks alike
                    note = ("; with no header to say what the column is, it may be the bob's position (px, mm) "
                            "instead: pendtrack then reads its x and y (--columns t,x,y)")
                problems.append(why_theta)
                fix["theta"] = "deg"
        elif th_col is not None:  # declared: the numbers must still make a free swing in that unit
            why_theta = angle_impossible(raw["theta"], from_rest=False)
            if why_theta is not None:
                unit = "deg" if th_col.unit == "°" else (th_col.unit or "rad")
                raise ArtifactError(f"{why_theta}: column {found['theta'] + 1} is not an angle in {unit} (a position "
                                    "in pixels or mm? then name the columns x and y)", path=path)
    if problems:
        header = ", ".join(f"'{r} [{u}]'" for r, u in fix.items())
        units = f"unit{'s' if len(fix) > 1 else ''}"
        how = (f"name the Parquet column{'s' if len(fix) > 1 else ''} {header}" if raw["kind"] == "parquet" else
               f"declare the {units} with --columns {columns_hint(cols, found, **fix)} (or in the header: {header})")
        raise ArtifactError(f"{'; '.join(problems)}: {how}{note}", path=path)


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
    found = roles(cols, "columns")
    values: dict[str, Any] = {}
    for role, i in found.items():
        series = df[df.columns[i]]
        if series.dtype.kind not in "fiu":
            raise ConfigError(f"column {df.columns[i]!r} has dtype {series.dtype}, expected a number")
        scale = cols[i].scale if role in ("t", "theta") else 1.0  # type: ignore[union-attr]
        values[role] = series.to_numpy(dtype=float) * scale
    raw = raw_record(values, found, cols, "parquet")
    if "ok" in df.columns:
        if df["ok"].dtype.kind != "b":
            raise ConfigError(f"column 'ok' has dtype {df['ok'].dtype}, expected bool")
        raw["ok"] = df["ok"].to_numpy(dtype=bool)
    return raw


# --- x, y -> theta ------------------------------------------------------------------------

def theta_from_xy(x: np.ndarray, y: np.ndarray, *, pivot: tuple[float, float], y_down: bool) -> np.ndarray:
    """theta [rad] of positions about a pivot (the package's x, y convention), unwrapped.

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


SIDEWAYS_RAD = math.pi / 4  # positions whose swing is centred this far from straight down and from straight up (y's sign
# the other way, refused below) have gravity along x
FASTEST_SHARE = 0.1  # the fastest tenth of the samples: where a swing passes its bottom (_below_where_fastest)


def _column_names(raw: dict[str, Any], spec: TableSpec) -> tuple[str, ...] | None:
    """The table's columns as ``--columns`` names: the user's, else the header's roles (with their units);
    None for a table without them (a Tracker project)."""
    if spec.columns:
        return tuple(spec.columns)
    cols = [c for c in raw.get("cols") or [] if c is None or not c.from_rate]
    if not cols:
        return None
    names = []
    for c in cols:
        role = "_" if c is None else "y_down" if c.role == "y" and c.y_down else c.role
        names.append(role + (f"[{c.unit}]" if c is not None and c.unit and role != "_" else ""))
    return tuple(names)


def _swap_y(columns: tuple[str, ...], vertical: str) -> str:
    """``columns`` with the y column named ``vertical`` (y or y_down), units and the other columns kept."""
    out = []
    for name in columns:
        base, bracket, unit = name.partition("[")
        out.append((vertical if base.strip() in ("y", "y_down") else base) + bracket + unit)
    return ",".join(out)


def _swap_xy(columns: tuple[str, ...], vertical: str) -> str:
    """``columns`` (--columns' names) with x and y's roles swapped, the old x named ``vertical`` (y or y_down);
    units and the other columns kept."""
    out = []
    for name in columns:
        base, bracket, unit = name.partition("[")
        role = {"x": vertical, "y": "x", "y_down": "x"}.get(base.strip(), base)
        out.append(role + bracket + unit)
    return ",".join(out)


def _below_where_fastest(t: np.ndarray, theta: np.ndarray, below: np.ndarray) -> bool:
    """Whether the bob moves fastest below the pivot, as every pendulum does: its speed peaks at the bottom,
    where its potential energy is least. A swing over or near the top lingers above the pivot (most of its
    samples) and still passes it fastest below; a y axis read the wrong way, or a pivot off the path, puts
    the fastest samples above. Fewer than 10 samples: most of them below."""
    if theta.size < 10:
        return bool(np.median(below) >= 0)
    speed = np.abs(np.gradient(theta, t))
    fastest = speed >= np.quantile(speed, 1.0 - FASTEST_SHARE)
    return bool(np.median(below[fastest]) > 0)


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
    plane = facts.get("swing_plane")
    if plane is not None:  # a swing filmed obliquely: its positions as seen square to its plane (fitted_pivot)
        log.warning("%s: %s", path, plane["note"])
        (s00, s01), (s10, s11) = plane["stretch"]
        dx, dy = x - pivot[0], y - pivot[1]
        x, y = pivot[0] + s00 * dx + s01 * dy, pivot[1] + s10 * dx + s11 * dy
    theta = theta_from_xy(x, y, pivot=pivot, y_down=y_down)
    ext = turning_values(theta[usable])
    centre = float(np.median(0.5 * (ext[1:] + ext[:-1]))) if ext.size >= 3 else 0.0
    if SIDEWAYS_RAD < abs(centre) < math.pi - SIDEWAYS_RAD:  # gravity along x: the angle's zero would mean nothing
        names = _column_names(raw, spec)
        up, down = (_swap_xy(names, v) for v in ("y", "y_down")) if names else ("t,y,x", "t,y_down,x")
        raise ArtifactError(f"the bob swings about a direction {math.degrees(centre):.0f} degrees from straight down "
                            f"(y {'down' if y_down else 'up'}, pivot ({pivot[0]:.6g}, {pivot[1]:.6g}) from the "
                            "positions): the vertical is not the y column; if the camera was turned or the columns are "
                            f"swapped, name them so that y is the vertical (e.g. --columns {up} or {down}"
                            + ("" if names else " for the file's second and third columns") + ")", path=path)
    below = (y[usable] - pivot[1]) * (1.0 if y_down else -1.0)
    if below.size and not _below_where_fastest(raw["t"][usable], theta[usable], below):
        axis, other = ("down", "y") if y_down else ("up", "y_down")
        where = (f"above the pivot ({pivot[0]:.6g}, {pivot[1]:.6g}) where it moves fastest (a swing's bottom) and in "
                 f"{np.mean(below < 0):.0%} of its samples")
        if path.suffix.lower() == ".trk":  # a Tracker track's y points up, and no --columns applies to it
            raise ArtifactError(f"the bob is {where} (a Tracker track's y points up): give the pivot with --pivot X Y "
                                "in the track's units, or choose the bob's track with --track", path=path)
        names = _column_names(raw, spec)
        example = _swap_y(names, other) if names else f"t,x,{other}"
        raise ArtifactError(f"the bob is {where} with y {axis}: if the y axis points the other way, name the column "
                            f"{other} (e.g. --columns {example})", path=path)
    info["pivot"] = {"x": pivot[0], "y": pivot[1], "y_axis": "down" if y_down else "up", **facts}
    return theta
