"""A video's track: the marker through the frames, checked to swing, in raw and corrected coordinates.

:func:`track_video` is what the track stage writes (and ``pt.track`` returns), the frames given
by the caller (the stage's :class:`pendtrack.video.reader.VideoReader`): the options checked,
the sampler of the lens, the tracker (:func:`pendtrack.track.tracker.track_frames`), the
camera's own motion (:mod:`pendtrack.track.camera`), and the verdicts -- a marker lost in most
frames, a point that does not swing -- that make a video no track. No files here.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pandas as pd

from pendtrack.config import Config
from pendtrack.errors import ConfigError, TrackingError
from pendtrack.lens.fisheye import (Fisheye, fisheye_from_config, local_scale, raw_centroid_offset,
                                    undistort_blob_centres)
from pendtrack.track.camera import MOVE_PX, CameraMotion, CameraMotionMeter
from pendtrack.track.colour import MarkerColour, parse_marker_colour
from pendtrack.track.params import TrackParams
from pendtrack.track.sampler import CorrectedSampler, RawSampler, WarpedRawSampler
from pendtrack.track.swing import swing_of_track
from pendtrack.track.tracker import TrackResult, track_frames
from pendtrack.video.reader import VideoInfo, check_time_range

log = logging.getLogger(__name__)

MIN_OK_FRACTION = 0.5  # below this the marker was mostly lost: an error, not a track
# flags of `track` and `run` named in the errors about the config keys they set (phrase in message -> flag)
FLAGS = {"min_score": "--min-score", "marker colour": "--marker-color", "roi": "--roi", "field of view": "--fov",
         "fixed_pixels": "--fixed-pixels", "projection": "--projection", "fps": "--fps"}


def config_error(section: str, exc: Exception) -> ConfigError:
    """``[section] <problem>`` naming the command-line flags of the keys the problem mentions."""
    text = str(exc)
    flags = [flag for phrase, flag in FLAGS.items() if phrase in text]
    return ConfigError(f"[{section}] {text}" + (f" ({', '.join(flags)})" if flags else ""))


def track_params(config: Config) -> TrackParams:
    """Core tracking parameters from the ``[track]`` section."""
    tc = config.track
    try:
        return TrackParams(min_score=tc.min_score, search_margin_px=tc.search_margin_px,
                           quick_margin_px=tc.quick_margin_px, evolution_rate=tc.evolution_rate,
                           refine=tc.refine, max_coast_frames=tc.max_coast_frames,
                           min_contrast_ratio=tc.min_contrast_ratio, acquire_step_s=tc.acquire_step_s,
                           acquire_window_s=tc.acquire_window_s, max_drift_px=tc.max_drift_px,
                           hole_share=tc.hole_share)
    except ValueError as exc:
        raise config_error("track", exc) from None


def _fisheye(config: Config, width: int, height: int) -> Fisheye:
    try:
        return fisheye_from_config(config.lens, width=width, height=height)
    except ValueError as exc:
        raise config_error("lens", exc) from None


def track_dataframe(result: TrackResult, fisheye: Fisheye, *, corrected: bool) -> pd.DataFrame:
    """The track artifact's columns from a core result in raw or corrected coordinates.

    Raw coordinates (``x_px``, ``y_px``) are the marker blob's centroid in the raw frame;
    corrected ones (``x``, ``y``) the image of the marker's centre after lens correction.
    The two differ by more than :meth:`Fisheye.undistort_points`: the lens shifts a round
    marker's raw blob off the image of its centre by a second-order amount (~0.1 px for
    the paper's spot), accounted for here (:func:`pendtrack.lens.fisheye.undistort_blob_centres`).
    """
    if corrected:
        x, y = result.x, result.y
        ox, oy = raw_centroid_offset(fisheye, x, y, result.radius)
        x_px, y_px = fisheye.distort_points(x, y)
        x_px, y_px = x_px + ox, y_px + oy
    else:
        x_px, y_px = result.x, result.y
        radius_c = result.radius * local_scale(fisheye, result.detection.x, result.detection.y)
        x, y = undistort_blob_centres(fisheye, x_px, y_px, radius_c)
    return pd.DataFrame({
        "frame": result.frame.astype(np.int64), "t": result.t.astype(float),
        "x_px": np.asarray(x_px, float), "y_px": np.asarray(y_px, float),
        "x": np.asarray(x, float), "y": np.asarray(y, float),
        "score": result.score.astype(float), "ok": result.ok.astype(bool),
    })


def _stayed(camera: CameraMotion, source: Any) -> None:
    """Raise :class:`TrackingError` when the camera turned away from its first view (``camera.lost``).

    A marker's positions seen from views that are not one another's (a phone panned across the
    room) are no arc about one axle, and no transform maps them back; tracking stops with a
    reason rather than handing on a track that only looks like one.
    """
    if camera.lost:
        raise TrackingError(f"the camera turned away from its first view: {camera.reason}; pendtrack needs a camera "
                            f"that stays on the pendulum (a tripod, or the phone resting), or --start at a time "
                            f"after it has settled", path=source)


def steady_track(result: TrackResult, camera: CameraMotion, *, corrected: bool,
                 video: Any) -> tuple[TrackResult, dict[str, object]]:
    """The track mapped into the first frame's view when the camera moved (:mod:`pendtrack.track.camera`).

    Only a measured motion of at least :data:`~pendtrack.track.camera.MOVE_PX` at the marker
    (95th percentile over the ok frames) changes the track; the report (the provenance's
    ``camera``) says what was measured and whether it was applied.
    """
    report = camera.to_dict()
    ok = result.ok & np.isfinite(result.x) & np.isfinite(result.y)
    moved = camera.displacement(result.frame[ok], result.x[ok], result.y[ok])
    report["marker_shift_p95_px"] = float(np.percentile(moved, 95)) if moved.size else 0.0
    report["applied"] = False
    if not camera.measured or report["marker_shift_p95_px"] < MOVE_PX:
        return result, report
    if corrected:  # the transforms are the raw frame's; a track in corrected frames is left as it is
        log.warning("%s: the camera moved by up to %.1f px at the marker; tracking in corrected frames does not "
                    "compensate it (track raw frames: --raw)", video, report["marker_shift_p95_px"])
        return result, report
    x, y = camera.to_reference(result.frame, result.x, result.y)
    report["applied"] = True
    log.warning("%s: the camera moved: the scene shifted by up to %.1f px at the marker (%s); the track is mapped "
                "into the first frame's view", video, report["marker_shift_p95_px"], camera.reason)
    return replace(result, x=x, y=y), report


def make_sampler(colour: MarkerColour, fisheye: Fisheye, *, corrected: bool) -> RawSampler:
    """Corrected-frame sampler, or raw-frame sampler with a lens-warped template (plain if no lens)."""
    if corrected:
        return CorrectedSampler(colour, fisheye=fisheye)
    if fisheye.projection == "none":
        return RawSampler(colour, width=fisheye.width, height=fisheye.height)
    return WarpedRawSampler(colour, fisheye=fisheye)


@dataclass(frozen=True)
class TrackTable:
    """What the track stage writes.

    Attributes
    ----------
    frame : DataFrame
        track.parquet's columns (frame, t [s], x_px, y_px, x, y [px], score, ok).
    extra : dict
        The provenance facts: ``video``, ``coordinates``, ``sampler``, ``lens_output_fov_deg``,
        ``tracking_fps``, ``time_range_s``, the tracker's result, ``swing``, ``camera``.
    facts : dict
        The stage's facts: frames, ok fraction, tracking rate [frames/s], acquisition time [s],
        drift alarm.
    """

    frame: pd.DataFrame
    extra: dict[str, Any]
    facts: dict[str, Any]


def check_video_options(config: Config) -> None:
    """``[video]``'s rate and time range and ``[track]``'s marker colour and parameters, checked before any
    decoding (a one-line :class:`~pendtrack.errors.ConfigError` naming the flag)."""
    vc = config.video
    if not (np.isfinite(vc.fps) and vc.fps >= 0):
        raise ConfigError(f"[video] fps must be 0 (the container's timestamps) or a rate > 0, got {vc.fps:g} (--fps)")
    try:
        check_time_range(vc.start, vc.end)
    except ValueError as exc:
        raise ConfigError(f"[video] {exc} (--start, --end)") from None
    marker_colour(config)
    track_params(config)


def marker_colour(config: Config) -> MarkerColour:
    """``[track] marker_color`` parsed (a :class:`~pendtrack.errors.ConfigError` naming ``--marker-color``)."""
    try:
        return parse_marker_colour(config.track.marker_color)
    except ValueError as exc:
        raise config_error("track", exc) from None


def track_video(frames: Iterable[Any], *, info: VideoInfo, config: Config, source: Any = None,
                on_progress: Callable[[int], None] | None = None) -> TrackTable:
    """Track the marker through ``frames`` and decide whether it is a pendulum's track.

    Parameters
    ----------
    frames : iterable
        Decoded frames (``index``, ``t``, ``y`` luma, ...), as :class:`pendtrack.video.reader.VideoReader` gives them.
    info : VideoInfo
        The video's size and rate.
    config : Config
        Uses ``[lens]``, ``[video]`` and ``[track]``.
    source : path-like, optional
        Named in errors and warnings.
    on_progress : callable, optional
        Called with 1 per frame.

    Returns
    -------
    TrackTable

    Raises
    ------
    TrackingError
        No marker in any frame, lost in more than half of the frames from its acquisition, or a
        tracked point that does not swing (:func:`pendtrack.track.swing.swing_of_track`).
    ConfigError
        Invalid ``[lens]``/``[track]`` values.
    """
    colour = marker_colour(config)
    params = track_params(config)
    corrected = config.track.track_in_corrected
    vc = config.video
    t0 = time.perf_counter()
    fisheye = _fisheye(config, info.width, info.height)
    sampler = make_sampler(colour, fisheye, corrected=corrected)
    meter = CameraMotionMeter(fps=info.fps)

    def metered():  # the camera's motion measured on the frames as they pass to the tracker
        for fr in frames:
            meter.add(fr.index, fr.y)
            yield fr

    try:
        result = track_frames(metered(), sampler=sampler, params=params, roi=config.track.roi, on_progress=on_progress)
    except TrackingError as exc:
        _stayed(meter.result(), source)  # a camera that turned away is the cause to name
        raise TrackingError(str(exc), path=source) from None
    elapsed = time.perf_counter() - t0
    camera = meter.result()
    _stayed(camera, source)
    result, camera_report = steady_track(result, camera, corrected=corrected, video=source)
    n = int(result.frame.size)
    n_after = result.n_after_acquisition
    if result.ok.sum() < MIN_OK_FRACTION * n_after:
        acq = result.acquisition
        found = f", found at {acq['t']:.3f} s" if acq["row"] else ""
        raise TrackingError(f"marker lost in {n_after - int(result.ok.sum())} of {n_after} frames{found} "
                            f"(best scores below min_score {params.min_score}); try "
                            + ("a lower --min-score" if config.track.roi else "--roi or --min-score"),
                            path=source)
    swing = swing_of_track(result.t, result.x, result.y, result.ok)
    if not swing.swings:
        # a static look-alike (a dark corner, a shadow, a poster) tracked "ok" in every frame is no result
        raise TrackingError(f"{swing.reason}, so it is no pendulum's marker; pass --roi X,Y,W,H around the bob in "
                            f"a frame where it swings (or --marker-color, --start)", path=source)
    if result.drift["alarm"]:
        log.warning("%s: the evolving template drifted up to %.1f px from the first one (limit %.1f px, "
                    "re-anchored %d times)", source, result.drift["max_px"], params.max_drift_px,
                    result.drift["reanchors"])
    extra = {
        "video": info.to_dict(),
        "coordinates": "corrected" if corrected else "raw",
        "sampler": type(sampler).__name__,
        "lens_output_fov_deg": fisheye.output_fov_deg,
        "tracking_fps": n / elapsed if elapsed > 0 else None,
        "time_range_s": {"start": vc.start, "end": vc.end if vc.end > 0 else None},
        **result.to_dict(),
        "swing": swing.to_dict(),
        "camera": camera_report,
    }
    facts = {"frames": n, "ok_fraction": result.ok_fraction, "fps": extra["tracking_fps"],
             "acquired_t": result.acquisition["t"], "drift_alarm": result.drift["alarm"]}
    return TrackTable(track_dataframe(result, fisheye, corrected=corrected), extra, facts)
