"""Stage ``render``: config -> ``video.mp4`` + ``truth.parquet`` (a filmed virtual pendulum).

Output names: ``video.mp4`` and ``truth.parquet`` in ``out_dir``, or, with
``name_by_run_code``, ``<code>.mp4`` and ``<code>.truth.parquet`` (e.g. ``06na1.mp4``).
The truth's provenance records the config section ``render``, the model and its full
parameter set, the run code, the video's file name and sha256, the axle's raw pixel
position and the scene geometry (``extra``).

The video is encoded under a temporary name and renamed when complete, then the truth is
written atomically; a stale truth of the same name is removed first, so a crash never
leaves a truth paired with another video. Bad input raises before any file is touched.
"""

from __future__ import annotations

import time
from pathlib import Path

import pandas as pd

from pendtrack.artifacts import Provenance, file_sha256, read_metadata, write_artifact
from pendtrack.config import Config
from pendtrack.errors import ConfigError
from pendtrack.progress import progress_bar
from pendtrack.render.motion import run_code
from pendtrack.render.pipeline import check_render_config, plan_render, render_frames
from pendtrack.stages import StageOutput, up_to_date
from pendtrack.video.writer import VideoWriter

VIDEO_NAME = "video.mp4"
TRUTH_NAME = "truth.parquet"


def output_paths(out_dir: str | Path, config: Config, *, name_by_run_code: bool = False) -> tuple[Path, Path]:
    """``(video, truth)`` paths the stage writes for ``config``.

    Raises
    ------
    ConfigError
        ``name_by_run_code`` but no run code can be formed (tile length not a whole
        number of cm below 1 m, or trial < 1).
    """
    out_dir = Path(out_dir)
    if not name_by_run_code:
        return out_dir / VIDEO_NAME, out_dir / TRUTH_NAME
    rc = config.render
    code = run_code(tile_length_m=rc.tile_length_m, omega0=rc.omega0, alley=rc.alley, trial=rc.trial)
    if code is None:
        raise ConfigError(f"no run code for tile length {rc.tile_length_m * 100:g} cm and trial {rc.trial} "
                          "(needs a whole number of cm below 100 and trial >= 1)")
    return out_dir / f"{code}.mp4", out_dir / f"{code}.truth.parquet"


def _video_matches(video: Path, truth: Path) -> bool:
    extra = (read_metadata(truth) or {}).get("extra", {})
    return video.is_file() and extra.get("video_sha256") == file_sha256(video)


def render_stage(*, out_dir: str | Path, config: Config, force: bool = False, progress: bool = True,
                 name_by_run_code: bool = False) -> StageOutput:
    """Film the virtual pendulum ``config.render`` describes.

    Parameters
    ----------
    out_dir : str or Path
        Output folder (created if needed).
    config : Config
        Only the ``render`` section is used (and recorded).
    force : bool
        Re-render even if the outputs are up to date.
    progress : bool
        Progress bar on standard error.
    name_by_run_code : bool
        Name the files by the run code (``06na1.mp4``, ``06na1.truth.parquet``).

    Returns
    -------
    StageOutput
        ``paths = (video, truth)``; ``facts``: frames, size, fps, model, params, run
        code and the render speed [frames/s].

    Raises
    ------
    ConfigError, ModelError
        Bad configuration or model (before any file is written).
    VideoError
        The video cannot be written.
    """
    check_render_config(config.render)
    video_path, truth_path = output_paths(out_dir, config, name_by_run_code=name_by_run_code)
    prov_config = config.sections("render")
    if up_to_date((truth_path,), "truth", inputs={}, config=prov_config, force=force) and \
            _video_matches(video_path, truth_path):
        return StageOutput(paths=(video_path, truth_path), skipped=True)

    plan = plan_render(config.render)
    rc = config.render
    start = time.perf_counter()
    writer = VideoWriter(video_path, width=rc.width, height=rc.height, fps=rc.fps, crf=rc.crf,
                         preset=rc.x264_preset)
    try:
        with progress_bar(plan.n_frames, "render", enabled=progress) as advance:
            for frame in render_frames(plan, on_progress=advance):
                writer.write(frame)
        truth_path.unlink(missing_ok=True)  # a stale truth must not outlive its video
        writer.close()
    except BaseException:
        writer.abort()
        raise
    elapsed = time.perf_counter() - start

    extra = plan.to_dict() | {"video": video_path.name, "video_sha256": file_sha256(video_path)}
    df = pd.DataFrame({"t": plan.motion.t, "theta": plan.motion.theta, "omega": plan.motion.omega})
    write_artifact(df, truth_path, "truth", provenance=Provenance(stage="render", config=prov_config, extra=extra))
    facts = {"frames": plan.n_frames, "size": f"{rc.width}x{rc.height}", "fps": rc.fps, "model": plan.model,
             "params": plan.params, "run_code": plan.run_code, "render_fps": plan.n_frames / max(elapsed, 1e-9)}
    return StageOutput(paths=(video_path, truth_path), facts=facts)
