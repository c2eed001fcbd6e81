"""What the CLI wrote, read back: :func:`load` of a run folder."""

from __future__ import annotations

from dataclasses import dataclass
from html import escape
from pathlib import Path
from typing import Any

import pandas as pd

from pendtrack.api.findings import Discovery, discovery_from_run
from pendtrack.api.fits import FitSet, fitset_from_run
from pendtrack.api.frames import to_frame
from pendtrack.errors import ArtifactError


@dataclass(frozen=True)
class Run:
    """A run folder's results: the records as DataFrames with provenance, the fits, the discovery.

    Attributes
    ----------
    folder : Path
    track, angle, kinematics : DataFrame or None
        track.parquet, angle.parquet, kinematics.parquet (``.attrs["provenance"]``).
    fits : FitSet or None
        fit.json, fit_<model>.json, fit.parquet.
    discovery : Discovery or None
        discovery.json, discovery.md.
    """

    folder: Path
    track: pd.DataFrame | None = None
    angle: pd.DataFrame | None = None
    kinematics: pd.DataFrame | None = None
    fits: FitSet | None = None
    discovery: Discovery | None = None

    def _repr_html_(self) -> str:
        parts = [f"<p>Run folder <code>{escape(str(self.folder))}</code></p>"]
        if self.fits is not None:
            parts.append(self.fits._repr_html_())
        if self.discovery is not None:
            parts.append(self.discovery._repr_html_())
        return "".join(parts)

    def plot(self) -> Any:
        """The fits' figure (:meth:`FitSet.plot`)."""
        if self.fits is None:
            raise ArtifactError("no fit in this run folder", path=self.folder)
        return self.fits.plot()


def load(folder: str | Path) -> Run:
    """Read a folder written by ``pendtrack run``/``fit``/``discover`` (or by the door's ``out=``).

    Raises
    ------
    ArtifactError
        The folder does not exist, holds nothing pendtrack wrote, or an artifact in it is unreadable.
    """
    from pendtrack.report.load import load_run

    folder = Path(folder)
    if not folder.is_dir():
        raise ArtifactError("no such folder", path=folder)
    run = load_run(folder)
    if run.problems:
        raise ArtifactError(run.problems[0])
    if run.empty:
        raise ArtifactError("no pendtrack results in this folder", path=folder)
    frames = {kind: to_frame(art, kind) for kind, art in run.artifacts.items() if kind != "fit"}
    return Run(folder, frames.get("track"), frames.get("angle"), frames.get("kinematics"), fitset_from_run(run),
               discovery_from_run(run))
