"""`track` stage: video -> track.parquet (marker centre per frame, raw and lens-corrected).

The stage decodes the video (its reader and decoding settings), calls
:func:`pendtrack.track.video_track.track_video` (every decision is made there) and writes what it returns.
"""

from __future__ import annotations

from pathlib import Path

from pendtrack.artifacts import Provenance, inputs_for, write_artifact
from pendtrack.config import Config
from pendtrack.errors import VideoError
from pendtrack.progress import progress_bar
from pendtrack.stages import StageOutput, up_to_date
from pendtrack.track.video_track import check_video_options, track_video
from pendtrack.video.reader import VideoReader

CONFIG_SECTIONS = ("lens", "video", "track")
DECODE_THREADS = False  # FFmpeg's own decoder threads (benchmarks/bench_track.py measures both)
DECODE_PREFETCH = 8  # decode at least this many frames ahead in a background thread (0: same thread)
# ... or as many as fit this many MiB (86 frames at 1080p, 194 at 720p, 21 at 4K), held only while the consumer
# lags: the decoder keeps going through the acquisition, whose choice of the marker costs ~0.1 s at 1080p (11
# whole-frame searches, each searched as its frame arrives: the consumer lags the decoder by the searches less
# the motion window's decoding). Per-frame times of the serial stage in a two-core pipeline model (no
# contention, 1080p/60, 2026-11-25): track/decode 0.93 with 8 frames, 0.94 with 16, 0.96 with 32 or more (before
# the searches overlapped the window: 0.89 with 8, 0.96 with 86). Frames queued beyond the lag cost nothing; the
# lag's frames do (fresh FFmpeg frame buffers: ~20k page faults at 1080p, mostly the motion window's 31 frames).
DECODE_PREFETCH_MB = 256.0


def track_stage(video: str | Path, *, out_dir: str | Path, config: Config, force: bool = False,
                progress: bool = True) -> StageOutput:
    """Track the marker through ``video`` and write ``out_dir/track.parquet``.

    Parameters
    ----------
    video, out_dir : path
        The video read, and the folder written (created).
    config : Config
        Uses ``[lens]``, ``[video]`` and ``[track]``. Only the frames from ``video.start``
        to ``video.end`` are read; their rows keep the video's frame indices and times (0
        at its first frame), and frames outside that range have no row. Frames before the
        marker's acquisition (:func:`pendtrack.track.tracker.track_frames`) are rows with
        ``ok = False``.
    force, progress : bool
        Recompute even if the output is up to date; a progress bar on stderr.

    Returns
    -------
    StageOutput
        ``facts``: frames, ok fraction, tracking rate [frames/s].

    Raises
    ------
    VideoError
        Missing, unreadable or empty video (a shortfall against the container's declared
        frames or duration is a warning; ``decode`` in the provenance says what decoded).
    TrackingError
        No marker in any frame, lost in more than half of the frames from its acquisition,
        or a tracked point that does not swing (:func:`pendtrack.track.swing.swing_of_track`).
    ConfigError
        Invalid ``[lens]``/``[track]`` values.
    """
    video = Path(video)
    if not video.is_file():
        raise VideoError("file not found", path=video)
    out = Path(out_dir) / "track.parquet"
    sections = config.sections(*CONFIG_SECTIONS)
    inputs = inputs_for(video)
    if up_to_date((out,), "track", inputs=inputs, config=sections, force=force):
        return StageOutput((out,), skipped=True)
    check_video_options(config)  # before any decoding
    vc = config.video
    with VideoReader(video, fps=vc.fps, threads=DECODE_THREADS, prefetch=DECODE_PREFETCH,
                     prefetch_mb=DECODE_PREFETCH_MB, start=vc.start, end=vc.end) as reader:
        with progress_bar(reader.info.n_frames or None, "track", enabled=progress) as advance:
            table = track_video(reader, info=reader.info, config=config, source=video, on_progress=advance)
        extra = {**table.extra, "decode": dict(reader.decode_report), "decode_threads": DECODE_THREADS,
                 "decode_prefetch": reader.prefetch}
    write_artifact(table.frame, out, "track", provenance=Provenance(stage="track", config=sections, inputs=inputs,
                                                                    extra=extra))
    return StageOutput((out,), facts=table.facts)
