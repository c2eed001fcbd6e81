"""The artifact contract: every file a stage hands to another.

For each Parquet artifact: its columns, dtypes, units and a schema version. Artifacts are
validated on write and on read (a missing or mistyped column is an error that names the
file and the column), written atomically (temp file in the same folder, fsync, rename: a
crash never leaves a half file that a later stage could read as good), and carry their
provenance in the Parquet key-value metadata under the key ``pendtrack``: package version,
stage, schema version, the resolved config the stage depended on, its input files' names
and sha256, and the time. JSON artifacts (fit.json, discovery.json) carry the same
provenance under the key ``"provenance"``.

Units: time in s, angles in rad, angular velocity in rad/s, acceleration in rad/s^2,
image coordinates in px with x to the right and y down.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import re
import json
import os
import tempfile
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from pendtrack.version import __version__
from pendtrack.errors import ArtifactError

METADATA_KEY = b"pendtrack"
# a model's name in the batch summary's column names: a composed model keeps its "+" ("classic+angle_gain")
MODEL_RE = r"[\w+]+?"


@dataclass(frozen=True)
class Column:
    """One column: name, numpy dtype string, unit and meaning."""

    name: str
    dtype: str  # "float64", "int64", "bool"
    unit: str  # "s", "rad", "px", "1" (dimensionless), ...
    description: str
    required: bool = True


@dataclass(frozen=True)
class ColumnPattern:
    """A family of columns named by a regular expression (e.g. one per model parameter)."""

    regex: str  # full-match pattern, e.g. r"classic__(\w+)__value"
    dtype: str
    unit: str  # unit may depend on the name; say so here ("as the parameter")
    description: str


@dataclass(frozen=True)
class ArtifactSchema:
    """A Parquet artifact: file name, schema version and columns (in order).

    ``patterns`` admit extra columns whose names match a regular expression (written after
    the fixed columns, in the order given).
    """

    kind: str
    filename: str
    version: int
    columns: tuple[Column, ...]
    description: str
    patterns: tuple[ColumnPattern, ...] = ()

    def pattern_for(self, name: str) -> ColumnPattern | None:
        for pat in self.patterns:
            if re.fullmatch(pat.regex, name):
                return pat
        return None

    def column(self, name: str) -> Column:
        for c in self.columns:
            if c.name == name:
                return c
        raise KeyError(name)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(c.name for c in self.columns)


def _c(name: str, dtype: str, unit: str, description: str, required: bool = True) -> Column:
    return Column(name, dtype, unit, description, required)


SCHEMAS: dict[str, ArtifactSchema] = {
    s.kind: s
    for s in (
        ArtifactSchema(
            "truth", "truth.parquet", 1,
            (
                _c("t", "float64", "s", "frame time, 0 at the first frame"),
                _c("theta", "float64", "rad", "true angle at the frame's mid-exposure"),
                _c("omega", "float64", "rad/s", "true angular velocity at the frame's mid-exposure"),
            ),
            "Ground truth of a rendered video, one row per frame.",
        ),
        ArtifactSchema(
            "track", "track.parquet", 1,
            (
                _c("frame", "int64", "1", "frame index, 0-based"),
                _c("t", "float64", "s", "presentation time, 0 at the first frame"),
                _c("x_px", "float64", "px", "marker centre in the raw (distorted) frame, x right"),
                _c("y_px", "float64", "px", "marker centre in the raw (distorted) frame, y down"),
                _c("x", "float64", "px", "marker centre after lens correction, x right"),
                _c("y", "float64", "px", "marker centre after lens correction, y down"),
                _c("score", "float64", "1", "normalised template-match score in [-1, 1]"),
                _c("ok", "bool", "1", "score above threshold and position plausible"),
            ),
            "Marker track, one row per decoded frame (lost frames kept with ok = false).",
        ),
        ArtifactSchema(
            "angle", "angle.parquet", 1,
            (
                _c("t", "float64", "s", "time, 0 at the first frame"),
                _c("theta", "float64", "rad", "atan2(dx, dy) of spot minus axle, y down; 0 at rest, + to the right; unwrapped"),
                _c("ok", "bool", "1", "sample usable (tracked frame flagged ok)"),
            ),
            "Pendulum angle theta(t).",
        ),
        ArtifactSchema(
            "kinematics", "kinematics.parquet", 1,
            (
                _c("t", "float64", "s", "time"),
                _c("theta", "float64", "rad", "angle (Savitzky-Golay smoothed)"),
                _c("omega", "float64", "rad/s", "angular velocity d theta/dt (Savitzky-Golay)"),
                _c("alpha", "float64", "rad/s^2", "angular acceleration d2 theta/dt2 (Savitzky-Golay)"),
                _c("ok", "bool", "1", "sample usable"),
                _c("segment", "int64", "1", "index of the gap-free segment the sample belongs to", False),
                _c("A_theta", "float64", "1", "sin(theta/2), eq. amplitudes", False),
                _c("A_omega", "float64", "1", "omega/(2 Omega0), eq. amplitudes", False),
                _c("energy", "float64", "1", "A_theta^2 + A_omega^2, eq. amplitudesobservable", False),
                _c("phase", "float64", "rad", "phi with tan(phi) = A_theta/A_omega, eq. phasephi", False),
                _c("phase_speed", "float64", "rad/s", "d phi/dt, eq. phasespeed", False),
                _c("delta_alpha", "float64", "rad/s^2", "alpha + Omega0^2 sin(theta), eq. lobulosprovados", False),
                _c("negative_damping", "bool", "1", "delta_alpha * omega > 0, eq. negativedampingdefinition", False),
            ),
            "Angle and its derivatives, with the paper's initial analysis.",
        ),
        ArtifactSchema(
            "fit", "fit.parquet", 1,
            (
                _c("t", "float64", "s", "time"),
                _c("theta", "float64", "rad", "measured angle"),
                _c("theta_model", "float64", "rad", "best-fit model angle"),
                _c("omega_model", "float64", "rad/s", "best-fit model angular velocity"),
                _c("residual", "float64", "rad", "theta - theta_model"),
                _c("model", "str", "1", "model name (one file may hold several models)", False),
            ),
            "Best-fit model curves against the data.",
        ),
        ArtifactSchema(
            "joint_fit", "fit_runs.parquet", 1,
            (
                _c("t", "float64", "s", "time"),
                _c("theta", "float64", "rad", "measured angle"),
                _c("theta_model", "float64", "rad", "jointly fitted model angle, from the run's own fitted initial state"),
                _c("omega_model", "float64", "rad/s", "jointly fitted model angular velocity"),
                _c("residual", "float64", "rad", "theta - theta_model"),
                _c("model", "str", "1", "model name"),
                _c("run", "str", "1", "run id (run code, else the record's name)"),
            ),
            "A joint fit's model curves against each run's data, one block per model and run.",
        ),
        ArtifactSchema(
            "summary", "summary.parquet", 1,
            (
                _c("run_id", "str", "1", "run code plus lower-cased file-name suffix (the run's folder); '' if skipped"),
                _c("file", "str", "1", "video file name"),
                _c("status", "str", "1", "ok | failed | skipped"),
                _c("reason", "str", "1", "error (failed), why skipped, or a caveat of an ok run (e.g. discovery failed); '' if none"),
                _c("resumed", "bool", "1", "ok run found complete from an earlier batch, not recomputed (nullable)"),
                _c("code", "str", "1", "canonical run code, e.g. 06na5 (paper's Table kindofrun); '' if skipped"),
                _c("kind", "str", "1", "la | ln | na | nn: launched or not, alley or not"),
                _c("tile_cm", "int64", "cm", "tile length l1 from the run code, 0 = no tile (nullable)"),
                _c("l1_m", "float64", "m", "tile length l1"),
                _c("launched", "bool", "1", "launched with an initial speed (l) or released (n) (nullable)"),
                _c("alley", "bool", "1", "run with the alley (nullable)"),
                _c("trial", "int64", "1", "trial number (nullable)"),
                _c("frames", "int64", "1", "decoded frames, rows of track.parquet (nullable)"),
                _c("fps", "float64", "1/s", "frame rate (track provenance, else 1/median dt)"),
                _c("duration_s", "float64", "s", "frames / fps"),
                _c("ok_fraction", "float64", "1", "fraction of frames tracked ok"),
                _c("runtime_s", "float64", "s", "wall time of the run's pipeline (done.json)"),
                _c("video_sha256", "str", "1", "sha256 of the video the results come from"),
            ),
            "Batch summary, one row per run and per skipped or failed file (pendtrack.batch.summary).",
            (
                ColumnPattern(r"discover__\w+_rms", "float64", "rad",
                              "discovery: baseline_rms, final_rms, baseline_heldout_rms, final_heldout_rms"),
                ColumnPattern(r"discover__\w+", "str", "1", "discovery: baseline, final_model, effects ('+'-joined)"),
                ColumnPattern(MODEL_RE + r"__\w+?__(?:value|stderr|u_paper)", "float64", "as the parameter",
                              "MODEL__PARAM__value|stderr|u_paper: fitted value, statistical and paper's uncertainty"),
                ColumnPattern(MODEL_RE + r"__(?:xi2_min|rms|aic|bic|runtime_s)", "float64", "as in fit.json",
                              "MODEL__xi2_min|rms|aic|bic|runtime_s from the model's fit.json"),
                ColumnPattern(MODEL_RE + r"__converged", "bool", "1", "MODEL__converged (nullable)"),
                ColumnPattern(MODEL_RE + r"__n", "int64", "1", "MODEL__n: samples in the fit (nullable)"),
            ),
        ),
    )
}


def file_sha256(path: str | Path, *, chunk: int = 1 << 20) -> str:
    """Hex sha256 of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        while block := fh.read(chunk):
            h.update(block)
    return h.hexdigest()


@dataclass(frozen=True)
class Provenance:
    """Where an artifact came from; stored in its metadata."""

    stage: str
    config: Mapping[str, Any] = field(default_factory=dict)
    inputs: Mapping[str, str] = field(default_factory=dict)  # file name -> sha256
    extra: Mapping[str, Any] = field(default_factory=dict)  # stage facts (axle, zero reference, ...)
    version: str = __version__
    # Stamped once, when the stage's provenance is made: every file a stage writes, and the result a library
    # call returns beside them, carry the same time.
    created: str = field(default_factory=lambda: _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"))

    def to_dict(self) -> dict[str, Any]:
        return {
            "package": "pendtrack",
            "version": self.version,
            "stage": self.stage,
            "config": dict(self.config),
            "inputs": dict(self.inputs),
            "extra": dict(self.extra),
            "created": self.created,
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> "Provenance":
        return cls(
            stage=d.get("stage", ""),
            config=d.get("config", {}),
            inputs=d.get("inputs", {}),
            extra=d.get("extra", {}),
            version=d.get("version", ""),
            created=d.get("created", ""),
        )


def inputs_for(*paths: str | Path) -> dict[str, str]:
    """Provenance inputs: each file's name mapped to its sha256."""
    return {Path(p).name: file_sha256(p) for p in paths}


def _check_dtype(series: pd.Series, col: Column) -> bool:
    kind = series.dtype.kind
    if col.dtype == "float64":
        return kind == "f"
    if col.dtype == "int64":
        return kind in "iu"
    if col.dtype == "bool":
        return kind == "b"
    if col.dtype == "str":
        return kind in "OUT" or str(series.dtype) in ("string", "str")
    raise ValueError(col.dtype)


def validate_frame(df: pd.DataFrame, schema: ArtifactSchema, path: str | Path) -> pd.DataFrame:
    """Check columns and dtypes against the schema; return the frame with columns in order.

    Raises :class:`ArtifactError` naming the file and the first offending column.
    """
    for col in schema.columns:
        if col.name not in df.columns:
            if col.required:
                raise ArtifactError(f"missing column '{col.name}' ({schema.kind} schema v{schema.version})", path=path)
            continue
        if not _check_dtype(df[col.name], col):
            raise ArtifactError(
                f"column '{col.name}' has dtype {df[col.name].dtype}, expected {col.dtype}", path=path
            )
    extra = [c for c in df.columns if c not in schema.names]
    for name in extra:
        pat = schema.pattern_for(str(name))
        if pat is None:
            raise ArtifactError(f"column '{name}' is not in the {schema.kind} schema", path=path)
        if not _check_dtype(df[name], Column(str(name), pat.dtype, pat.unit, pat.description)):
            raise ArtifactError(f"column '{name}' has dtype {df[name].dtype}, expected {pat.dtype}", path=path)
    ordered = [c.name for c in schema.columns if c.name in df.columns] + extra
    return df[ordered]


def atomic_write(path: str | Path, write: Callable[[Path], None]) -> Path:
    """Call ``write(tmp)`` on a temp file next to ``path``, fsync, then rename over ``path``.

    If ``write`` raises (or the process dies), ``path`` is untouched and the temp file is
    removed (or, after a kill, left with a ``.tmp`` suffix that no stage reads).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        write(tmp)
        with open(tmp, "rb") as fh:
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; an artifact gets the usual mode
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def _umask() -> int:
    current = os.umask(0)
    os.umask(current)
    return current


def write_artifact(df: pd.DataFrame, path: str | Path, kind: str, *, provenance: Provenance) -> Path:
    """Validate ``df`` against the ``kind`` schema and write it atomically with provenance."""
    schema = SCHEMAS[kind]
    df = validate_frame(df, schema, path)
    table = pa.Table.from_pandas(df, preserve_index=False)
    meta = dict(table.schema.metadata or {})
    record = provenance.to_dict() | {"artifact": kind, "schema_version": schema.version}
    meta[METADATA_KEY] = json.dumps(record, default=_json_default).encode()
    table = table.replace_schema_metadata(meta)
    return atomic_write(path, lambda tmp: pq.write_table(table, tmp))


@dataclass(frozen=True)
class Artifact:
    """A validated artifact read back: the data and where it came from."""

    data: pd.DataFrame
    provenance: Provenance
    path: Path


def read_metadata(path: str | Path) -> dict[str, Any] | None:
    """The pendtrack metadata record of a Parquet file, or None if absent or unreadable."""
    try:
        meta = pq.read_schema(path).metadata or {}
    except (OSError, pa.ArrowException):
        return None
    raw = meta.get(METADATA_KEY)
    if raw is None:
        return None
    try:
        return json.loads(raw)
    except ValueError:
        return None


def read_artifact(path: str | Path, kind: str) -> Artifact:
    """Read and validate an artifact of the given kind."""
    path = Path(path)
    schema = SCHEMAS[kind]
    if not path.is_file():
        raise ArtifactError("file not found", path=path)
    try:
        table = pq.read_table(path)
    except (OSError, pa.ArrowException) as exc:
        raise ArtifactError(f"not a readable Parquet file ({exc})", path=path) from None
    record = read_metadata(path) or {}
    found = record.get("schema_version")
    if record.get("artifact") not in (None, kind):
        raise ArtifactError(f"is a {record.get('artifact')} artifact, expected {kind}", path=path)
    if found is not None and found > schema.version:
        raise ArtifactError(f"schema version {found} is newer than this pendtrack reads ({schema.version})", path=path)
    df = validate_frame(table.to_pandas(), schema, path)
    return Artifact(df, Provenance.from_dict(record), path)


def is_up_to_date(path: str | Path, kind: str, *, inputs: Mapping[str, str], config: Mapping[str, Any]) -> bool:
    """True if ``path`` is a complete artifact made from the same inputs and config.

    Used to skip a stage whose output exists (unless --force). A file that cannot be read,
    has no provenance, or was written by another schema version is not up to date.
    """
    path = Path(path)
    if not path.is_file():
        return False
    if path.suffix == ".json":
        try:
            record = json.loads(path.read_text()).get("provenance", {})
        except (OSError, ValueError, AttributeError):
            return False
        schema_ok = True
    else:
        record = read_metadata(path) or {}
        schema_ok = record.get("schema_version") == SCHEMAS[kind].version
    same_config = _normalise(record.get("config")) == _normalise(config)
    return bool(record) and schema_ok and record.get("inputs") == dict(inputs) and same_config


def _normalise(obj: Any) -> Any:
    return json.loads(json.dumps(obj, default=_json_default, sort_keys=True))


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (tuple, set)):
        return list(obj)
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


def write_json_artifact(payload: Mapping[str, Any], path: str | Path, *, required: Iterable[str],
                        provenance: Provenance) -> Path:
    """Write a JSON artifact atomically after checking its required top-level keys."""
    missing = [k for k in required if k not in payload]
    if missing:
        raise ArtifactError(f"missing key '{missing[0]}'", path=path)
    text = _json_text(payload, provenance)
    return atomic_write(path, lambda tmp: tmp.write_text(text + "\n", encoding="utf-8"))


def _json_text(payload: Mapping[str, Any], provenance: Provenance) -> str:
    record = dict(payload) | {"provenance": provenance.to_dict()}
    return json.dumps(record, indent=2, default=_json_default, allow_nan=True)


def as_written(payload: Mapping[str, Any], provenance: Provenance) -> dict[str, Any]:
    """What :func:`write_json_artifact` writes of ``payload``, read back: JSON types, provenance included."""
    return json.loads(_json_text(payload, provenance))


def read_json_artifact(path: str | Path, *, required: Iterable[str]) -> dict[str, Any]:
    """Read a JSON artifact and check its required top-level keys."""
    path = Path(path)
    if not path.is_file():
        raise ArtifactError("file not found", path=path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (ValueError, UnicodeDecodeError) as exc:
        raise ArtifactError(f"not valid JSON ({exc})", path=path) from None
    if not isinstance(data, dict):
        raise ArtifactError("top level is not a JSON object", path=path)
    missing = [k for k in required if k not in data]
    if missing:
        raise ArtifactError(f"missing key '{missing[0]}'", path=path)
    return data


FIT_JSON_KEYS = ("model", "params", "xi2_min", "rms", "aic", "bic", "n", "converged", "runtime_s", "seed")
DISCOVERY_JSON_KEYS = ("baseline", "effects", "steps", "diagnosis", "final_model")


def schemas_markdown() -> str:
    """Markdown tables of every Parquet artifact (the README embeds this text verbatim)."""

    def row(*cells: str) -> str:
        return "| " + " | ".join(cell.replace("|", "\\|") for cell in cells) + " |"

    parts = []
    for s in SCHEMAS.values():
        rows = [f"**{s.filename}** (schema v{s.version}): {s.description}", "",
                "| column | dtype | unit | meaning |", "|---|---|---|---|"]
        rows += [row(f"`{c.name}`", c.dtype, c.unit, c.description + ("" if c.required else " (optional)"))
                 for c in s.columns]
        rows += [row(f"`{p.regex}`", p.dtype, p.unit, p.description) for p in s.patterns]
        parts.append("\n".join(rows))
    return "\n\n".join(parts) + "\n"
