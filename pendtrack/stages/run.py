"""`pendtrack run`: the whole pipeline on one video, each stage skipped when up to date."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pendtrack.config import Config
from pendtrack.errors import ConfigError, VideoError
from pendtrack.stages import StageOutput

if TYPE_CHECKING:
    from pendtrack.tables import TableSpec


@dataclass(frozen=True)
class RunOutput:
    """Every stage's output for one video, in pipeline order."""

    out_dir: Path
    stages: dict[str, StageOutput] = field(default_factory=dict)

    @property
    def skipped(self) -> bool:
        return all(s.skipped for s in self.stages.values())

    def to_dict(self) -> dict[str, Any]:
        return {
            "out_dir": str(self.out_dir),
            "stages": {
                name: {"paths": [str(p) for p in s.paths], "skipped": s.skipped, "facts": dict(s.facts)}
                for name, s in self.stages.items()
            },
        }


def run_pipeline(video: str | Path, *, out_dir: str | Path, config: Config, models: tuple[str, ...] | None = None,
                 table: TableSpec | None = None, force: bool = False, progress: bool = True) -> RunOutput:
    """Track, angle, kinematics and fit one video into ``out_dir``, then write report.html.

    A file that is no video by its suffix (:func:`pendtrack.tables.is_video`) is a measured record of
    theta(t) or x, y(t) (:mod:`pendtrack.tables`): kinematics, fit and the report only.

    Parameters
    ----------
    video : path
        Input video (any container/codec FFmpeg decodes), or a measured record.
    out_dir : path
        Folder for the artifacts (created).
    config : Config
        Pipeline configuration.
    models : tuple of str, optional
        Models to fit; default ``config.fit.models`` (the paper's classic, opa, fractional).
    table : TableSpec, optional
        Column names, pivot, track or rate of a measured record (``--columns``, ...); not for a video.
    force : bool
        Recompute every stage even if its output is up to date.
    progress : bool
        Show progress bars on stderr.
    """
    # Stage modules are imported here so that `pendtrack run --help` stays light.
    from pendtrack.stages.angle import angle_stage
    from pendtrack.stages.fit import fit_stage
    from pendtrack.stages.kinematics import kinematics_stage
    from pendtrack.stages.report import report_stage
    from pendtrack.stages.track import track_stage
    from pendtrack.tables import is_video

    video = Path(video)
    if not video.is_file():
        raise VideoError("file not found", path=video)
    out_dir = Path(out_dir)
    common = {"out_dir": out_dir, "config": config, "force": force, "progress": progress}
    stages: dict[str, StageOutput] = {}
    if is_video(video) and table is not None:
        raise ConfigError("--columns, --pivot, --track and --rate describe a measured record's table, and this is a "
                          "video", path=video)
    if is_video(video):
        stages["track"] = track_stage(video, **common)
        stages["angle"] = angle_stage(stages["track"].path, **common)
        record = stages["angle"].path
    else:
        # a measured record (a table, a Tracker project, a logger's file), read as `kinematics` reads it: there is
        # nothing to track, as in `discover`
        record = video
    stages["kinematics"] = kinematics_stage(record, table=table, **common)
    stages["fit"] = fit_stage(stages["kinematics"].path, models=models or config.fit.models, **common)
    stages["report"] = report_stage(out_dir, config=config, force=force, progress=progress)
    return RunOutput(out_dir=out_dir, stages=stages)
