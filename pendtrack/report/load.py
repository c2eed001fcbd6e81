"""Read what a run folder holds, tolerating absences: a report shows what exists.

A missing artifact is simply ``None`` (its sections then say so); an artifact that exists but
cannot be read (truncated, wrong schema, ...) is ``None`` too and its error message is kept in
:attr:`RunData.problems`, which the page shows. Only a folder with nothing to report at all is
an error, raised by the stage.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

from pendtrack.artifacts import (
    DISCOVERY_JSON_KEYS,
    FIT_JSON_KEYS,
    SCHEMAS,
    Artifact,
    read_artifact,
    read_json_artifact,
)
from pendtrack.errors import PendtrackError

log = logging.getLogger(__name__)

RUN_ARTIFACTS = ("track", "angle", "kinematics", "fit", "joint_fit")  # Parquet kinds a run folder may hold
FIT_JSON_GLOB = "fit_*.json"
COMBINED_FIT_JSON = "fit.json"
DISCOVERY_JSON = "discovery.json"
DISCOVERY_MD = "discovery.md"


@dataclass(frozen=True)
class RunData:
    """Everything readable in one run folder.

    Attributes
    ----------
    run_dir : Path
        The folder.
    name : str
        Run id (the folder's name, e.g. ``24la1``).
    artifacts : mapping
        Parquet kind (``track``, ``angle``, ``kinematics``, ``fit``; ``joint_fit`` in a joint fit's
        folder) -> :class:`Artifact`, for those present and valid.
    fits : mapping
        Model name -> that model's fit.json content (FIT_JSON_KEYS plus extras), in file order.
    combined : dict or None
        The combined fit.json when it is not itself a single model's fit (cross-model relations...).
    discovery : dict or None
        discovery.json content.
    discovery_md : str or None
        discovery.md text.
    problems : tuple of str
        One message per artifact that exists but could not be read.
    inputs : tuple of Path
        Every file the report was made from (for provenance).
    provenances : mapping
        File name -> the provenance record that file carries (Parquet metadata or JSON key).
    """

    run_dir: Path
    name: str
    artifacts: Mapping[str, Artifact] = field(default_factory=dict)
    fits: Mapping[str, dict[str, Any]] = field(default_factory=dict)
    combined: dict[str, Any] | None = None
    discovery: dict[str, Any] | None = None
    discovery_md: str | None = None
    problems: tuple[str, ...] = ()
    inputs: tuple[Path, ...] = ()
    provenances: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)

    def get(self, kind: str) -> pd.DataFrame | None:
        """The data of a Parquet artifact, or None."""
        art = self.artifacts.get(kind)
        return None if art is None else art.data

    def extra(self, kind: str) -> Mapping[str, Any]:
        """The provenance ``extra`` facts of a Parquet artifact ({} if absent)."""
        art = self.artifacts.get(kind)
        return {} if art is None else dict(art.provenance.extra)

    def stage_config(self, kind: str) -> Mapping[str, Any]:
        """The config sections recorded by the stage that wrote ``kind`` ({} if absent)."""
        art = self.artifacts.get(kind)
        return {} if art is None else dict(art.provenance.config)

    @property
    def empty(self) -> bool:
        """True if nothing at all could be read."""
        return not (self.artifacts or self.fits or self.discovery)


def run_files(run_dir: Path) -> list[Path]:
    """The artifact files of a run folder that a report reads (existing ones, sorted)."""
    names = [SCHEMAS[k].filename for k in RUN_ARTIFACTS]
    names += [COMBINED_FIT_JSON, DISCOVERY_JSON, DISCOVERY_MD]
    files = [run_dir / n for n in names if (run_dir / n).is_file()]
    files += sorted(p for p in run_dir.glob(FIT_JSON_GLOB) if p.is_file())
    return sorted(set(files))


def _fit_entries(data: Mapping[str, Any]) -> list[dict[str, Any]]:
    """Single-model fit dicts found in a (per-model or combined) fit.json."""
    if "model" in data and "params" in data:
        return [dict(data)]
    models = data.get("models") or data.get("fits")
    out: list[dict[str, Any]] = []
    if isinstance(models, Mapping):
        for name, entry in models.items():
            if isinstance(entry, Mapping) and "params" in entry:
                out.append({"model": name, **entry})
    elif isinstance(models, list):
        out = [dict(e) for e in models if isinstance(e, Mapping) and "params" in e and "model" in e]
    return out


def _json_provenance(data: Mapping[str, Any]) -> Mapping[str, Any]:
    record = data.get("provenance")
    return record if isinstance(record, Mapping) else {}


def load_run(run_dir: str | Path) -> RunData:
    """Read every artifact of a run folder that exists (see the module docstring)."""
    run_dir = Path(run_dir)
    artifacts: dict[str, Artifact] = {}
    problems: list[str] = []
    for kind in RUN_ARTIFACTS:
        path = run_dir / SCHEMAS[kind].filename
        if path.is_file():
            try:
                artifacts[kind] = read_artifact(path, kind)
            except PendtrackError as exc:
                problems.append(str(exc))
    fits: dict[str, dict[str, Any]] = {}
    combined: dict[str, Any] | None = None
    json_provenances: dict[str, Mapping[str, Any]] = {}
    for path in sorted(run_dir.glob(FIT_JSON_GLOB)):
        try:
            data = read_json_artifact(path, required=FIT_JSON_KEYS)
        except PendtrackError as exc:
            problems.append(str(exc))
            continue
        json_provenances[path.name] = _json_provenance(data)
        fits.setdefault(str(data["model"]), data)
    path = run_dir / COMBINED_FIT_JSON
    if path.is_file():
        try:
            data = read_json_artifact(path, required=())
        except PendtrackError as exc:
            problems.append(str(exc))
        else:
            json_provenances[path.name] = _json_provenance(data)
            entries = _fit_entries(data)
            for entry in entries:
                fits.setdefault(str(entry["model"]), entry)
            if not ("model" in data and "params" in data):
                combined = data
    discovery = None
    path = run_dir / DISCOVERY_JSON
    if path.is_file():
        try:
            discovery = read_json_artifact(path, required=DISCOVERY_JSON_KEYS)
        except PendtrackError as exc:
            problems.append(str(exc))
        else:
            json_provenances[path.name] = _json_provenance(discovery)
    md_path = run_dir / DISCOVERY_MD
    discovery_md = md_path.read_text(encoding="utf-8", errors="replace") if md_path.is_file() else None
    for p in problems:
        log.warning("report: %s", p)
    provenances: dict[str, Mapping[str, Any]] = {a.path.name: a.provenance.to_dict() for a in artifacts.values()}
    provenances.update(json_provenances)
    return RunData(run_dir=run_dir, name=run_dir.resolve().name, artifacts=artifacts, fits=fits, combined=combined,
                   discovery=discovery, discovery_md=discovery_md, problems=tuple(problems),
                   inputs=tuple(run_files(run_dir)), provenances=provenances)


SUMMARY_PARQUET = "summary.parquet"
SUMMARY_CSV = "summary.csv"
BATCH_JSON = "batch.json"


@dataclass(frozen=True)
class BatchData:
    """Everything readable in one batch folder.

    Attributes
    ----------
    batch_dir : Path
        The folder.
    summary : DataFrame or None
        summary.parquet (validated when the schema is known), else summary.csv.
    batch : dict or None
        batch.json content (counts, two-cuboid fit, failures...).
    problems : tuple of str
        Files that exist but could not be read.
    inputs : tuple of Path
        The files the report is made from.
    """

    batch_dir: Path
    summary: pd.DataFrame | None = None
    batch: dict[str, Any] | None = None
    problems: tuple[str, ...] = ()
    inputs: tuple[Path, ...] = ()

    @property
    def empty(self) -> bool:
        return self.summary is None and self.batch is None


def is_batch_dir(folder: Path) -> bool:
    """True if the folder holds a batch summary or batch.json."""
    return any((folder / n).is_file() for n in (SUMMARY_PARQUET, SUMMARY_CSV, BATCH_JSON))


def _read_summary(batch_dir: Path, problems: list[str]) -> tuple[pd.DataFrame | None, Path | None]:
    path = batch_dir / SUMMARY_PARQUET
    if path.is_file():
        try:
            if "summary" in SCHEMAS:
                return read_artifact(path, "summary").data, path
            return pd.read_parquet(path), path
        except PendtrackError as exc:
            problems.append(str(exc))
        except (OSError, ValueError) as exc:
            problems.append(f"{path}: not a readable Parquet file ({exc})")
    path = batch_dir / SUMMARY_CSV
    if path.is_file():
        try:
            return pd.read_csv(path), path
        except (OSError, ValueError, pd.errors.ParserError) as exc:
            problems.append(f"{path}: not a readable CSV file ({exc})")
    return None, None


def load_batch(batch_dir: str | Path) -> BatchData:
    """Read a batch folder's summary and batch.json (see :class:`BatchData`)."""
    batch_dir = Path(batch_dir)
    problems: list[str] = []
    summary, summary_path = _read_summary(batch_dir, problems)
    batch = None
    path = batch_dir / BATCH_JSON
    if path.is_file():
        try:
            batch = read_json_artifact(path, required=())
        except PendtrackError as exc:
            problems.append(str(exc))
    inputs = [p for p in (summary_path, path) if p is not None and p.is_file()]
    for p in problems:
        log.warning("report: %s", p)
    return BatchData(batch_dir=batch_dir, summary=summary, batch=batch, problems=tuple(problems),
                     inputs=tuple(inputs))
