"""The batch summary: one row per run (and per skipped or failed file), from the run artifacts.

Columns are the ``summary`` schema of :mod:`pendtrack.artifacts`. Fixed columns: the run
code's fields (tile length in **cm** ``tile_cm`` and in **m** ``l1_m``, ``launched``,
``alley``, ``kind``, ``trial``), the status (``ok`` | ``failed`` | ``skipped``) and
reason, and the video facts from ``track.parquet`` (frames, fps, duration, fraction of
frames tracked ok). Per fitted model ``M`` (pattern-named columns): ``M__P__value``,
``M__P__stderr``, ``M__P__u_paper`` for every parameter ``P`` (units as the parameter),
``M__xi2_min``, ``M__rms``, ``M__aic``, ``M__bic``, ``M__n``, ``M__converged``,
``M__runtime_s``; with discovery, ``discover__baseline``, ``discover__final_model``,
``discover__effects`` (``+``-joined) and ``discover__{baseline,final}[_heldout]_rms``.
Columns a row does not have are null (nullable integer and boolean dtypes).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pendtrack.artifacts import (
    DISCOVERY_JSON_KEYS,
    FIT_JSON_KEYS,
    SCHEMAS,
    Provenance,
    atomic_write,
    read_artifact,
    read_json_artifact,
    write_artifact,
)
from pendtrack.batch.runcode import RunCode
from pendtrack.errors import ArtifactError

FIT_SCALARS = ("xi2_min", "rms", "aic", "bic", "runtime_s")
PARAM_FIELDS = ("value", "stderr", "u_paper")


def code_fields(code: RunCode | None) -> dict[str, Any]:
    """The run-code columns of a row (nulls for a file without a run code)."""
    if code is None:
        return {"code": "", "kind": "", "tile_cm": None, "l1_m": np.nan, "launched": None, "alley": None,
                "trial": None}
    return {"code": code.code, "kind": code.kind, "tile_cm": code.tile_cm, "l1_m": code.l1_m,
            "launched": code.launched, "alley": code.alley, "trial": code.trial}


def video_facts(run_dir: str | Path) -> dict[str, Any]:
    """Frames, fps, duration and fraction of frames tracked ok, from ``track.parquet``.

    fps is the ``[video] fps`` override or the container's rate recorded in the track's
    provenance, else ``1/median(dt)``.
    Empty dict when the run folder has no readable track.
    """
    path = Path(run_dir) / SCHEMAS["track"].filename
    try:
        art = read_artifact(path, "track")
    except ArtifactError:
        return {}
    t = art.data["t"].to_numpy(float)
    n = len(t)
    fps = _provenance_fps(art.provenance)
    if not np.isfinite(fps) and n > 1:
        dt = float(np.median(np.diff(t)))
        fps = 1.0 / dt if dt > 0 else np.nan
    return {"frames": n, "fps": fps, "duration_s": n / fps if fps and np.isfinite(fps) else np.nan,
            "ok_fraction": float(art.data["ok"].mean()) if n else np.nan}


def _provenance_fps(prov: Provenance) -> float:
    """The frame rate the track used: the ``[video] fps`` override, else the container's rate."""
    override = (prov.config.get("video") or {}).get("fps")
    video = prov.extra.get("video")
    candidates = [override, video.get("fps") if isinstance(video, dict) else None, prov.extra.get("fps")]
    for value in candidates:
        if isinstance(value, (int, float)) and not isinstance(value, bool) and value > 0:
            return float(value)
    return float("nan")


def fit_records(run_dir: str | Path) -> dict[str, dict[str, Any]]:
    """The fit stage's per-model records of a run folder (``fit_<model>.json``, else a
    single-model ``fit.json``), by model name."""
    run_dir = Path(run_dir)
    out: dict[str, dict[str, Any]] = {}
    for path in sorted(run_dir.glob("fit_*.json")) or [run_dir / "fit.json"]:
        try:
            record = read_json_artifact(path, required=FIT_JSON_KEYS)
        except ArtifactError:
            continue
        out.setdefault(str(record["model"]), record)
    return out


def fit_columns(records: Mapping[str, Mapping[str, Any]]) -> dict[str, Any]:
    """The per-model columns of a row from fit.json records."""
    row: dict[str, Any] = {}
    for model, rec in records.items():
        for key in FIT_SCALARS:
            row[f"{model}__{key}"] = _float(rec.get(key))
        row[f"{model}__n"] = rec.get("n")
        row[f"{model}__converged"] = bool(rec.get("converged"))
        for name, est in (rec.get("params") or {}).items():
            for fld in PARAM_FIELDS:
                row[f"{model}__{name}__{fld}"] = _float((est or {}).get(fld))
    return row


def discovery_columns(run_dir: str | Path) -> dict[str, Any]:
    """Discovery's outcome from the run's ``discovery.json``, if any.

    ``discover__baseline``, ``discover__final_model`` (model name), ``discover__effects``
    (effects kept, ``+``-joined, "" if none) and the baseline's and final model's rms and
    held-out rms [rad].
    """
    path = Path(run_dir) / "discovery.json"
    try:
        rec = read_json_artifact(path, required=DISCOVERY_JSON_KEYS)
    except ArtifactError:
        return {}
    final = rec.get("final_model") if isinstance(rec.get("final_model"), dict) else {}
    base = rec.get("baseline_fit") if isinstance(rec.get("baseline_fit"), dict) else {}
    effects = rec.get("effects") if isinstance(rec.get("effects"), list) else []
    return {"discover__baseline": str(rec.get("baseline", "")), "discover__final_model": str(final.get("model", "")),
            "discover__effects": "+".join(map(str, effects)),
            "discover__baseline_rms": _float(base.get("rms")), "discover__final_rms": _float(final.get("rms")),
            "discover__baseline_heldout_rms": _float(base.get("heldout_rms")),
            "discover__final_heldout_rms": _float(final.get("heldout_rms"))}


def _float(x: Any) -> float:
    try:
        return float(x) if x is not None else np.nan
    except (TypeError, ValueError):
        return np.nan


def run_row(run_dir: str | Path, *, video: Path, code: RunCode, resumed: bool,
            runtime_s: float | None, video_sha256: str = "", note: str = "") -> dict[str, Any]:
    """The row of a run that finished (now or in an earlier batch), read from its artifacts."""
    run_dir = Path(run_dir)
    return {"run_id": code.run_id, "file": video.name, "status": "ok", "reason": note, "resumed": resumed,
            **code_fields(code), **video_facts(run_dir), "runtime_s": _float(runtime_s),
            "video_sha256": video_sha256, **fit_columns(fit_records(run_dir)), **discovery_columns(run_dir)}


def failed_row(*, video: Path, code: RunCode, reason: str, runtime_s: float | None = None) -> dict[str, Any]:
    """The row of a run that failed: code fields and the error message."""
    return {"run_id": code.run_id, "file": video.name, "status": "failed", "reason": reason, "resumed": False,
            **code_fields(code), "runtime_s": _float(runtime_s), "video_sha256": ""}


def skipped_row(*, video: Path, reason: str) -> dict[str, Any]:
    """The row of a file that was not processed (no run code, duplicate)."""
    return {"run_id": "", "file": video.name, "status": "skipped", "reason": reason, "resumed": None,
            **code_fields(None), "runtime_s": np.nan, "video_sha256": ""}


_FIXED_DTYPES = {"str": "str", "float64": "float64", "int64": "Int64", "bool": "boolean"}


def summary_frame(rows: Sequence[Mapping[str, Any]]) -> pd.DataFrame:
    """Rows -> a frame with the summary schema's dtypes, fixed columns first, then per-model columns.

    Per-model columns are grouped by model (models in first-seen order): the fit scalars,
    then each parameter's value, stderr, u_paper.
    """
    schema = SCHEMAS["summary"]
    df = pd.DataFrame(list(rows))
    for col in schema.columns:
        if col.name not in df.columns:
            df[col.name] = None
    extra = [c for c in df.columns if c not in schema.names]
    for name in list(schema.names) + extra:
        dtype = schema.column(name).dtype if name in schema.names else _pattern_dtype(name)
        df[name] = _as_dtype(df[name], dtype)
    return df[list(schema.names) + _order_extra(extra)].reset_index(drop=True)


def _pattern_dtype(name: str) -> str:
    pat = SCHEMAS["summary"].pattern_for(name)
    if pat is None:
        raise ArtifactError(f"column '{name}' is not in the summary schema")
    return pat.dtype


def _as_dtype(series: pd.Series, dtype: str) -> pd.Series:
    if dtype == "str":
        return series.map(lambda v: "" if v is None or (isinstance(v, float) and np.isnan(v)) else str(v)).astype(str)
    if dtype == "float64":
        return pd.to_numeric(series, errors="coerce").astype("float64")
    if dtype == "int64":
        return pd.array([None if _missing(v) else int(v) for v in series], dtype="Int64")
    if dtype == "bool":
        return pd.array([None if _missing(v) else bool(v) for v in series], dtype="boolean")
    raise ValueError(dtype)


def _missing(v: Any) -> bool:
    return v is None or v is pd.NA or (isinstance(v, float) and np.isnan(v))


def _order_extra(extra: Sequence[str]) -> list[str]:
    """Model columns grouped by model (first-seen order), scalars before parameters; discovery last."""
    models: list[str] = []
    for name in extra:
        model = name.split("__")[0]
        if not name.startswith("discover__") and model not in models:
            models.append(model)

    def key(name: str) -> tuple[int, int]:
        if name.startswith("discover__"):
            return (len(models), 0)
        parts = name.split("__")
        return (models.index(parts[0]), 0 if len(parts) == 2 else 1)

    return sorted(extra, key=key)  # stable: first-seen order within a group


def write_summary(df: pd.DataFrame, out_dir: str | Path, *, provenance: Provenance) -> tuple[Path, Path]:
    """Write ``summary.parquet`` (validated, with provenance) and ``summary.csv``, both atomically."""
    out_dir = Path(out_dir)
    parquet = write_artifact(df, out_dir / SCHEMAS["summary"].filename, "summary", provenance=provenance)
    csv = atomic_write(out_dir / "summary.csv", lambda tmp: df.to_csv(tmp, index=False, float_format="%.10g"))
    return parquet, csv
