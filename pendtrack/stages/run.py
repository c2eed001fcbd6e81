"""`pendtrack run`: the whole pipeline on one video, each stage skipped when up to date."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pendtrack.config import Config
from pendtrack.errors import VideoError
from pendtrack.stages import StageOutput


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
                 force: bool = False, progress: bool = True) -> RunOutput:
    """Track, angle, kinematics and fit one video into ``out_dir``, then write report.html.

    Parameters
    ----------
    video : path
        Input video (any container/codec FFmpeg decodes).
    out_dir : path
        Folder for the artifacts (created).
    config : Config
        Pipeline configuration.
    models : tuple of str, optional
        Models to fit; default ``config.fit.models`` (the paper's classic, opa, fractional).
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

    video = Path(video)
    if not video.is_file():
        raise VideoError("file not found", path=video)
    out_dir = Path(out_dir)
    common = {"out_dir": out_dir, "config": config, "force": force, "progress": progress}
    stages: dict[str, StageOutput] = {}
    stages["track"] = track_stage(video, **common)
    stages["angle"] = angle_stage(stages["track"].path, **common)
    stages["kinematics"] = kinematics_stage(stages["angle"].path, **common)
    stages["fit"] = fit_stage(stages["kinematics"].path, models=models or config.fit.models, **common)
    stages["report"] = report_stage(out_dir, config=config, force=force, progress=progress)
    return RunOutput(out_dir=out_dir, stages=stages)
