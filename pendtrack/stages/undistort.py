"""`undistort` stage: video -> lens-corrected video (Tracker's "Fisheye" filter applied to every frame).

Writes ``out_dir/undistorted.mp4`` (H.264, same size, the input's average frame rate) and
``out_dir/undistort.json`` (its provenance and the correction's parameters, by which the
stage knows the video is up to date).
"""

from __future__ import annotations

from pathlib import Path

from pendtrack.artifacts import Provenance, file_sha256, inputs_for, is_up_to_date, write_json_artifact
from pendtrack.config import Config
from pendtrack.errors import ConfigError, VideoError
from pendtrack.lens.fisheye import fisheye_from_config
from pendtrack.lens.remap import remap_tables, undistort_image
from pendtrack.progress import progress_bar
from pendtrack.stages import StageOutput
from pendtrack.video.reader import VideoReader

VIDEO_NAME = "undistorted.mp4"
SIDECAR_NAME = "undistort.json"
SIDECAR_KEYS = ("video", "video_sha256", "frames", "output_fov_deg")
CRF = 18  # visually lossless H.264


def undistort_stage(video: str | Path, *, out_dir: str | Path, config: Config, force: bool = False,
                    progress: bool = True) -> StageOutput:
    """Write the lens-corrected copy of ``video``.

    Parameters
    ----------
    video : path
        Input video.
    out_dir : path
        Output folder (created).
    config : Config
        Uses ``[lens]`` and ``[video]``.
    force, progress : bool
        Recompute even if up to date; progress bar on stderr.

    Returns
    -------
    StageOutput
        Paths: the video, then the sidecar JSON.

    Raises
    ------
    VideoError
        Missing, unreadable, empty or truncated input; odd frame size.
    """
    from pendtrack.video.writer import VideoWriter

    video = Path(video)
    if not video.is_file():
        raise VideoError("file not found", path=video)
    out_dir = Path(out_dir)
    out_video, sidecar = out_dir / VIDEO_NAME, out_dir / SIDECAR_NAME
    sections = config.sections("lens", "video")
    inputs = inputs_for(video)
    if (not force and out_video.is_file()
            and is_up_to_date(sidecar, "undistort", inputs=inputs, config=sections)):
        return StageOutput((out_video, sidecar), skipped=True)
    with VideoReader(video, fps=config.video.fps, start=config.video.start, end=config.video.end) as reader:
        info = reader.info
        try:
            fisheye = fisheye_from_config(config.lens, width=info.width, height=info.height)
        except ValueError as exc:
            raise ConfigError(f"[lens] {exc}") from None
        tables = remap_tables(fisheye)
        fps = config.video.fps if config.video.fps > 0 else (info.fps or 30.0)
        writer = VideoWriter(out_video, width=info.width, height=info.height, fps=fps, crf=CRF)
        try:
            with progress_bar(info.n_frames or None, "undistort", enabled=progress) as advance:
                for frame in reader:
                    writer.write(undistort_image(frame.bgr(), tables))
                    advance(1)
            n = writer.n_frames
            writer.close()
        except BaseException:
            writer.abort()
            raise
    payload = {"video": VIDEO_NAME, "video_sha256": file_sha256(out_video), "frames": n,
               "output_fov_deg": fisheye.output_fov_deg, "fps": fps}
    write_json_artifact(payload, sidecar, required=SIDECAR_KEYS,
                        provenance=Provenance(stage="undistort", config=sections, inputs=inputs))
    return StageOutput((out_video, sidecar), facts={"frames": n, "output_fov_deg": fisheye.output_fov_deg})
