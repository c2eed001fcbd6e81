"""DataFrames with provenance, and the scratch folder the stages write into.

A door function returns an artifact's table as a DataFrame with ``.attrs["provenance"]`` (the
artifact's provenance record) and ``.attrs["kind"]`` (its artifact kind); a DataFrame handed back
in is written as that artifact again, provenance included, so the stage reads what the CLI's
stage would read from the file.
"""

from __future__ import annotations

import contextlib
import tempfile
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pendtrack.artifacts import SCHEMAS, Artifact, Provenance, read_artifact, write_artifact
from pendtrack.errors import ArtifactError


def to_frame(art: Artifact, kind: str | None = None) -> pd.DataFrame:
    """An artifact's table with its provenance and kind (default: told by its columns) in ``.attrs``."""
    df = art.data.copy()
    df.attrs["provenance"] = art.provenance.to_dict()
    df.attrs["kind"] = kind or _kind_of(df)
    return df


def read_frame(path: Path, kind: str) -> pd.DataFrame:
    """The artifact at ``path`` as a DataFrame with provenance (:func:`to_frame`)."""
    return to_frame(read_artifact(path, kind), kind)


def _kind_of(df: pd.DataFrame) -> str:
    kind = df.attrs.get("kind")
    if kind in SCHEMAS:
        return str(kind)
    cols = set(df.columns)
    if {"omega", "alpha"} <= cols:
        return "kinematics"
    if {"x_px", "y_px", "score"} <= cols:
        return "track"
    return "angle"


def write_frame(df: pd.DataFrame, folder: Path, *, what: str) -> Path:
    """Write ``df`` into ``folder`` as the artifact it is (track, angle or kinematics), provenance kept.

    A table of ``t``, ``theta`` without ``ok`` counts every finite sample as ok.

    Raises
    ------
    ArtifactError
        ``df`` is not a DataFrame, or lacks a column its artifact needs.
    """
    if not isinstance(df, pd.DataFrame):
        raise ArtifactError(f"{what}: expected a DataFrame (from pt.track, pt.angle, pt.kinematics or "
                            f"pt.read_record), got {type(df).__name__}")
    kind = _kind_of(df)
    if kind not in ("track", "angle", "kinematics"):
        raise ArtifactError(f"{what}: a {kind} table cannot be read here")
    data = df
    if "ok" not in data.columns and "theta" in data.columns:
        data = data.assign(ok=np.isfinite(data["theta"].to_numpy(float)))
    prov = Provenance.from_dict(df.attrs.get("provenance") or {"stage": "library"})
    path = folder / SCHEMAS[kind].filename
    write_artifact(data, path, kind, provenance=prov)
    return path


@contextlib.contextmanager
def workdir(out: str | Path | None) -> Iterator[Path]:
    """``out`` (created), or a scratch folder removed on exit."""
    if out is not None:
        path = Path(out)
        path.mkdir(parents=True, exist_ok=True)
        yield path
        return
    with tempfile.TemporaryDirectory(prefix="pendtrack-") as tmp:
        yield Path(tmp)


@contextlib.contextmanager
def staged(df: pd.DataFrame, *, what: str) -> Iterator[Path]:
    """``df`` written as its artifact (:func:`write_frame`) into a scratch folder, removed on exit."""
    with workdir(None) as folder:
        yield write_frame(df, folder, what=what)


@contextlib.contextmanager
def staged_runs(records: Sequence[Any] | Mapping[str, Any], *, what: str) -> Iterator[list[Path]]:
    """Several records as paths: a path as given, a DataFrame written as its artifact into a scratch
    folder named by its run id (the mapping's key, else ``run1``, ``run2``, ...), removed on exit."""
    items = list(records.items()) if isinstance(records, Mapping) else [(None, r) for r in records]
    with workdir(None) as scratch:
        paths = []
        for i, (run, rec) in enumerate(items):
            if isinstance(rec, pd.DataFrame):
                sub = scratch / str(run or f"run{i + 1}")
                sub.mkdir(parents=True, exist_ok=True)
                paths.append(write_frame(rec, sub, what=what))
            else:
                paths.append(Path(rec))
        yield paths
