"""The axle a pendulum swings about, and theta(t) about it.

:func:`angle_table` is what the angle stage writes (and ``pt.angle`` returns): the lens check, the
axle (given, or a circle fit with its uncertainty), theta and its zero. :func:`fitted_pivot` is the
pivot of a measured x, y path (a table of positions without ``--pivot``). No files here.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from pendtrack.config import AngleConfig, LensConfig
from pendtrack.errors import ArtifactError, ConfigError, TrackingError
from pendtrack.track.angle import theta_from_track
from pendtrack.track.circle import circle_uncertainty, fit_circle, off_circle
from pendtrack.track.lens_check import LensCheck, check_lens, suggestion_flags
from pendtrack.track.plane_tilt import find_plane_tilt

log = logging.getLogger(__name__)

MIN_ARC_RAD = 0.1  # a path spanning less arc (~6 deg) does not locate its pivot: --pivot is needed


def fitted_pivot(x: np.ndarray, y: np.ndarray) -> tuple[tuple[float, float], dict[str, Any]]:
    """The pivot of an x, y path: the centre of a robust circle fit (:func:`pendtrack.track.circle.fit_circle`).

    Parameters
    ----------
    x, y : ndarray
        Positions (any length unit).

    Returns
    -------
    (px, py), facts
        The centre, and ``radius``, ``rms`` (radial residual) and ``arc_deg`` for the provenance; where the path
        is an ellipse, a swing filmed obliquely (:func:`pendtrack.track.plane_tilt.find_plane_tilt`), the centre is
        the ellipse's and ``swing_plane`` holds its ``stretch`` (2 x 2: ``pivot + stretch @ (p - pivot)`` is the
        position seen square to the swing plane, where theta is read), its axes ratio and tilt, and ``note``, the
        line to warn with.

    Raises
    ------
    ArtifactError
        The path covers too little arc (below :data:`MIN_ARC_RAD`) to locate the centre.
    """
    scale = float(np.hypot(np.ptp(x), np.ptp(y))) if x.size else 0.0
    fit = fit_circle(x, y, f_scale=max(0.01 * scale, 1e-12)) if x.size >= 3 and scale > 0 else None
    if fit is None or fit.arc_span < MIN_ARC_RAD:
        span = 0.0 if fit is None else math.degrees(fit.arc_span)
        raise ArtifactError(f"the x, y path spans {span:.2g} deg of arc, too little to fit its pivot: "
                            "give --pivot X Y")
    facts: dict[str, Any] = {"radius": fit.radius, "rms": fit.rms, "arc_deg": math.degrees(fit.arc_span)}
    tilt = find_plane_tilt(x, y, fit, f_scale=max(0.01 * scale, 1e-12))
    if tilt is None:
        return (fit.xc, fit.yc), facts
    return (tilt.xc, tilt.yc), {**facts, "swing_plane": {**tilt.to_dict(), "note": tilt_text(tilt, unit="")}}


def tilt_text(tilt: Any, *, unit: str) -> str:
    """One line: the swing plane's tilt (:class:`pendtrack.track.plane_tilt.PlaneTilt`) and what is done about it."""
    return (f"the bob's path is an ellipse, not a circle (axes {tilt.axes_ratio:.4f} +- {tilt.axes_ratio_sigma:.4f}, "
            f"the short one at {tilt.short_axis_deg:.0f} deg; residual {tilt.rms:.3g}{unit} against the circle's "
            f"{tilt.circle_rms:.3g}{unit}): the swing's plane is turned {tilt.tilt_deg:.1f} deg from the camera's (or the "
            "image is stretched along one axis), and theta is read in the swing's plane; film square to the swing to "
            "need no such correction")


MIN_ARC_SPAN_DEG = 20.0  # a shorter arc locates the axle poorly: theta with a warning stating its uncertainty
# theta is given only while the axle's uncertainty scales it by at most this share (a 5 % scale error on theta
# is a 5 % error on the nonlinear terms' amplitudes; Omega0 rests on the period, which no scale changes). Beyond
# it the track is no arc about one axle: a short arc that bends within the noise, a point that is not the bob,
# a bob swinging out of the image plane (a conical swing seen from the side: radius uncertain by 37-74 %)
MAX_SCALE_REL = 0.05


def lens_check_of_track(df: pd.DataFrame, ok: np.ndarray, track_extra: Mapping[str, Any],
                        track_config: Mapping[str, Any], *, ratio: float) -> LensCheck | None:
    """The lens check (:func:`pendtrack.track.lens_check.check_lens`) of a track's ok raw positions.

    The lens is the one the track stage used (its provenance's ``[lens]``), the frame size
    that of its video; None when the track does not record them (not made by the track stage).
    """
    lens = track_config.get("lens")
    video = track_extra.get("video")
    try:
        width, height = int(video["width"]), int(video["height"])
        projection, fov, fixed = str(lens["projection"]), float(lens["fov_deg"]), float(lens["fixed_pixels"])
    except (TypeError, KeyError, ValueError):
        return None
    return check_lens(df["x_px"].to_numpy(float)[ok], df["y_px"].to_numpy(float)[ok], width=width, height=height,
                      projection=projection, fov_deg=fov, fixed_pixels=fixed, ratio=ratio)


def _in_frame(x: float, y: float, track_extra: Mapping[str, Any], *, sx: float = 0.0, sy: float = 0.0) -> bool:
    """Could ``(x, y)`` [px], within ``2 sx`` and ``2 sy``, be inside the track's video frame?

    The margins count only when they are smaller than the frame (an axle known no better than the
    frame's size is nowhere a user could point to). False when the track does not record its size.
    """
    video = track_extra.get("video") or {}
    try:
        width, height = float(video["width"]), float(video["height"])
    except (KeyError, TypeError, ValueError):
        return False
    mx, my = (2.0 * sx, 2.0 * sy) if 2.0 * sx < width and 2.0 * sy < height else (0.0, 0.0)
    return -mx <= x < width + mx and -my <= y < height + my


def lens_was_named(track_config: Mapping[str, Any]) -> bool:
    """True when the track's ``[lens]`` is not the default one: a flag or a config file named it."""
    lens = track_config.get("lens")
    if not isinstance(lens, Mapping):
        return False
    default = LensConfig()
    return any(lens.get(k) != getattr(default, k) for k in ("projection", "fov_deg", "fixed_pixels"))


def lens_mismatch_text(check: LensCheck) -> str:
    """One line: the mismatch and the flags that fix it."""
    fix = suggestion_flags(check.suggestion) if check.suggestion else "another --projection/--fov"
    return (f"lens mismatch: {check.reason}; track again with {fix} (pendtrack track/run), or set [angle] "
            f"lens_check = \"warn\" in --config to go on")


#: The lens left in doubt (:func:`unchecked_lens_text`) moves theta by more than this share of the swing's own rms
#: angle: theta is then an assumption's, not a measurement's (a webcam's 0.5-rad swing under the default fisheye
#: read 20 % off, its Omega0 3.5 %), and the angle stage stops and asks for the lens (``lens_check = "error"``)
LENS_DOUBT_SHARE = 0.05


def _refuse_a_doubtful_lens(df: pd.DataFrame, ok: np.ndarray, axle: tuple[float, float], check: LensCheck, doubt: str,
                            *, options: AngleConfig, source: Any) -> None:
    """ConfigError when the unchecked default lens moves theta by more than :data:`LENS_DOUBT_SHARE` of the swing
    (and ``lens_check = "error"``); else the warning ``doubt``."""
    x, y = df["x"].to_numpy(float)[ok], df["y"].to_numpy(float)[ok]
    swing = float(np.std(np.unwrap(np.arctan2(x - axle[0], y - axle[1])))) if x.size else 0.0
    change = 1e-3 * max((h.theta_change_mrad for h in check.hypotheses if h.name != "configured"), default=0.0)
    if options.lens_check == "error" and swing > 0 and change > LENS_DOUBT_SHARE * swing:
        raise ConfigError(f"{doubt}: {change / swing:.0%} of the swing's {swing:.3g}-rad rms, too much to read theta on an "
                          "assumed lens; name the camera's lens (--projection none for a phone's or a webcam's, or the "
                          "fisheye's --projection/--fov), or set [angle] lens_check = \"warn\" in --config to go on",
                          path=source)
    log.warning("%s: %s", source, doubt)


def unchecked_lens_text(check: LensCheck) -> str:
    """One line when the default lens could not be checked and another lens would move theta by more than
    the track's own scatter about its circle (what the lens decides exceeds what tracking does); else ""."""
    configured = next((h for h in check.hypotheses if h.name == "configured"), None)
    if configured is None:
        return ""
    other = max((h for h in check.hypotheses if h.name != "configured"), key=lambda h: h.theta_change_mrad,
                default=None)
    scatter_mrad = 1e3 * configured.rms_rel  # the track's radial scatter as an angle about the axle
    if other is None or not other.theta_change_mrad > scatter_mrad:
        return ""
    return (f"the lens could not be checked ({check.reason}), and theta depends on it: under {other.label} it would "
            f"differ by {other.theta_change_mrad:.2g} mrad rms, more than the track's {scatter_mrad:.2g}-mrad scatter. "
            f"theta assumes the default lens ({check.configured}); if the camera is another, track again with its "
            "--projection/--fov (--projection none for a lens without distortion)")


#: A point further than this share of the radius from the marker's circle about the axle is no position of the
#: marker, whatever the lens (one that bends the circle this much fails the lens check): the pivot, a look-alike
#: the tracker followed for a while
FAR_FROM_CIRCLE = 0.25
#: When more than this share of the tracked points is off the circle, the circle is not the track's: the tracker
#: followed other things for most of the record, and which circle is the marker's is anyone's guess
MAX_OFF_SHARE = 0.5


PARK_WINDOW_S = 0.1  # a point is parked when the track stays within PARK_PX of it for half of this time either side [s]
PARK_PX = 2.0


def _parked(t: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The points where the track sits still: within :data:`PARK_PX` of at least half of the points within
    :data:`PARK_WINDOW_S` either side.

    A swinging marker passes each place but its turning points and its final rest; a look-alike the tracker sat
    on stays. The first circle is fitted without the parked points, so it is not pulled through the places a
    look-alike sat (the final rest, on the circle, is left to the refit)."""
    n = t.size
    dt = float(np.median(np.diff(t))) if n > 1 else 0.0
    reach = int(np.clip(round(PARK_WINDOW_S / dt), 1, max(n - 1, 1))) if dt > 0 else 1
    close = np.zeros(n, int)
    for k in range(1, reach + 1):
        d = np.hypot(x[k:] - x[:-k], y[k:] - y[:-k]) <= PARK_PX
        close[k:] += d
        close[:-k] += d
    return close >= reach


def _without_off_circle(df: pd.DataFrame, ok: np.ndarray, axle: tuple[float, ...],
                        source: Any) -> tuple[np.ndarray, dict[str, Any]]:
    """``ok`` without the points that are not on the marker's circle about the axle, and the provenance facts
    (empty with too few points to judge).

    A rigid pendulum's marker keeps its distance from the axle. Left out: the points further than
    :data:`FAR_FROM_CIRCLE` of the radius from the circle (fitted again without them), then those that jump off
    it for a few frames and back (:func:`pendtrack.track.circle.off_circle`).
    """
    idx = np.flatnonzero(ok)
    if idx.size < 10:
        return ok, {}
    x, y = df["x"].to_numpy(float)[idx], df["y"].to_numpy(float)[idx]

    def circle_of(keep: np.ndarray) -> tuple[tuple[float, float], float]:
        if len(axle) == 2:
            c = (float(axle[0]), float(axle[1]))
            return c, float(np.median(np.hypot(x[keep] - c[0], y[keep] - c[1])))
        fit = fit_circle(x[keep], y[keep])
        return (fit.xc, fit.yc), fit.radius

    t = df["t"].to_numpy(float)[idx] if "t" in df else idx.astype(float)
    keep = ~_parked(t, x, y)
    if keep.sum() < 10:
        keep = np.ones(idx.size, bool)
    centre, radius = circle_of(keep)
    far = np.abs(np.hypot(x - centre[0], y - centre[1]) - radius) > FAR_FROM_CIRCLE * radius
    if far.any() and (~far & keep).sum() >= 10:
        centre, radius = circle_of(~far & keep)
        far = np.abs(np.hypot(x - centre[0], y - centre[1]) - radius) > FAR_FROM_CIRCLE * radius
    if (~far).sum() < 10:
        return ok, {}  # no circle to judge by: the axle's own checks refuse such a track
    near = np.flatnonzero(~far)
    jumps, threshold = off_circle(x[near], y[near], centre)
    off = far.copy()
    off[near[jumps]] = True
    frames = df["frame"].to_numpy()[idx] if "frame" in df else idx
    facts: dict[str, Any] = {"n": int(off.sum()), "far": int(far.sum()), "jumps": int(jumps.sum()),
                             "jump_threshold_px": threshold, "frames": [int(f) for f in frames[off][:20]]}
    if off.sum() > MAX_OFF_SHARE * idx.size:
        raise TrackingError(f"{int(off.sum())} of {idx.size} tracked points are not on one circle about an axle (the "
                            f"best one, radius {radius:.0f} px, holds {int((~off).sum())}): the tracker followed other "
                            "things for most of the record, so theta would be no swing's; track again with --roi "
                            "X,Y,W,H around the bob in a frame where it swings (or --marker-color, --start)", path=source)
    if off.any():
        ok = ok.copy()
        ok[idx[off]] = False
        r = np.hypot(x[off] - centre[0], y[off] - centre[1])
        log.warning("%s: %d of %d tracked points are not on the marker's circle about the axle (radius %.0f px; they "
                    "lie %s px from the axle, %d of them further than %.0f px off the circle, %d jumping off it for a "
                    "few frames and back by more than %.2g px): something else was taken for the marker there "
                    "(first at frame %d), and those points are left out", source, int(off.sum()), idx.size, radius,
                    _span(r), int(far.sum()), FAR_FROM_CIRCLE * radius, int(jumps.sum()), threshold,
                    int(frames[off][0]))
    return ok, facts


def _span(v: np.ndarray) -> str:
    """``"a"`` or ``"a-b"``: the range of ``v`` to whole units."""
    lo, hi = f"{float(v.min()):.0f}", f"{float(v.max()):.0f}"
    return lo if lo == hi else f"{lo}-{hi}"


def _plane_tilt(df: pd.DataFrame, ok: np.ndarray) -> Any:
    """The swing plane's tilt (:func:`pendtrack.track.plane_tilt.find_plane_tilt`) from the ok corrected positions
    less the parked ones (:func:`_parked`: a look-alike the tracker sat on), or None."""
    idx = np.flatnonzero(ok)
    if idx.size < 10:
        return None
    x, y = df["x"].to_numpy(float)[idx], df["y"].to_numpy(float)[idx]
    t = df["t"].to_numpy(float)[idx] if "t" in df else idx.astype(float)
    keep = ~_parked(t, x, y)
    if keep.sum() < 10:
        return None
    return find_plane_tilt(x[keep], y[keep], fit_circle(x[keep], y[keep]))


@dataclass(frozen=True)
class AngleTable:
    """What the angle stage writes.

    Attributes
    ----------
    frame : DataFrame
        t [s], theta [rad], ok.
    extra : dict
        The provenance facts: ``axle_source``, the angle result (axle [px], zero, rest),
        ``lens``, ``lens_check``, and with a fitted axle ``circle_rms_px`` and
        ``axle_uncertainty`` (axle and radius sigmas [px], ``theta_scale_rel``, ``zero_sigma_rad``); for a
        swing filmed obliquely ``swing_plane`` (:meth:`pendtrack.track.plane_tilt.PlaneTilt.to_dict`): the
        circle, the axle and theta are then those of the positions seen square to the swing plane.
    facts : dict
        The stage's facts: axle, zero reference, circle RMS [px], lens verdict.
    """

    frame: pd.DataFrame
    extra: dict[str, Any]
    facts: dict[str, Any]


def angle_table(df: pd.DataFrame, *, options: AngleConfig, track_extra: Mapping[str, Any],
                track_config: Mapping[str, Any], source: Any = None) -> AngleTable:
    """Axle and theta(t) from a track's columns.

    Parameters
    ----------
    df : DataFrame
        track.parquet's columns (x, y, x_px, y_px [px], t [s], ok).
    options : AngleConfig
        ``[angle]``: the axle (else a robust circle fit to the ok corrected points), the rest
        stretch that sets theta's zero, and the lens check: the track's circle under the
        track's lens against no correction, the paper's fisheye and a fitted field of view
        (:mod:`pendtrack.track.lens_check`); a mismatch is an error (``lens_check = "error"``,
        only when the track used the default lens: a lens the user named is kept with a
        warning), a warning (``"warn"``) or not looked for (``"off"``).
    track_extra, track_config : mapping
        The track's provenance (``video``: frame size; ``lens``: the lens it used).
    source : path-like, optional
        Named in errors and warnings.

    Returns
    -------
    AngleTable

    Raises
    ------
    TrackingError
        Too few ok points, a circle that locates the axle so poorly that theta's scale is
        uncertain by more than :data:`MAX_SCALE_REL` (an arc bending within the noise, or no arc
        about one axle), or an axle below every tracked position (an arc bending the wrong way:
        a wrong lens correction, or no hanging bob), or more than :data:`MAX_OFF_SHARE` of the tracked points off
        the marker's circle (the tracker followed other things). An arc shorter than :data:`MIN_ARC_SPAN_DEG` within it gives theta with
        a warning.
    ConfigError
        Invalid ``[angle]`` values, or (``lens_check = "error"``) the track's default lens is
        clearly not the footage's.
    """
    ok = df["ok"].to_numpy(bool) & np.isfinite(df["x"].to_numpy()) & np.isfinite(df["y"].to_numpy())
    ac = options
    raw = df
    tilt = None if ac.axle else _plane_tilt(df, ok)
    if tilt is not None:  # a swing filmed obliquely: from here on its positions as seen square to its plane
        x_sq, y_sq = tilt.square(df["x"].to_numpy(float), df["y"].to_numpy(float))
        df = df.assign(x=x_sq, y=y_sq)
    ok_in = ok
    ok, off = _without_off_circle(df, ok_in, ac.axle, source)
    check = None
    if ac.lens_check != "off":
        check = lens_check_of_track(df, ok, track_extra, track_config, ratio=ac.lens_ratio)  # raw x_px, y_px
        if check is not None and check.verdict == "mismatch":
            # a lens the user named is theirs to keep: the check only warns
            if ac.lens_check == "error" and not lens_was_named(track_config):
                raise ConfigError(lens_mismatch_text(check), path=source)
            log.warning("%s: %s", source, lens_mismatch_text(check))
    doubt = ""  # the default lens unchecked, and theta depending on it beyond the track's scatter
    if check is not None and check.verdict == "undecided" and not lens_was_named(track_config):
        doubt = unchecked_lens_text(check)
    # a wrong lens bends the circle too: where the lens is wrong or in doubt (it moves theta beyond the track's
    # scatter), the ellipse is not the swing plane's to tell, and the positions stay as tracked
    lens_in_doubt = check is not None and (check.verdict == "mismatch" or bool(doubt))
    if tilt is not None and lens_in_doubt:
        tilt, df = None, raw
        ok, off = _without_off_circle(df, ok_in, ac.axle, source)
    if tilt is not None:
        log.warning("%s: %s", source, tilt_text(tilt, unit=" px"))
    circle = None
    uncertainty: dict[str, object] = {}
    if ac.axle:
        if len(ac.axle) != 2:
            raise ConfigError(f"[angle] axle must be x, y, got {list(ac.axle)}")
        axle = (float(ac.axle[0]), float(ac.axle[1]))
    else:
        if ok.sum() < 10:
            raise TrackingError(f"only {int(ok.sum())} ok points: too few to fit the axle", path=source)
        xs, ys = df["x"].to_numpy()[ok], df["y"].to_numpy()[ok]
        circle = fit_circle(xs, ys)
        span = float(np.degrees(circle.arc_span))
        sx, sy, sr = circle_uncertainty(xs, ys, circle)
        scale_rel = sr / circle.radius if circle.radius > 0 else np.inf
        # the axle off sideways by dx turns the vertical through it, theta's zero, by dx / radius
        uncertainty = {"axle_sigma_px": [sx, sy], "radius_sigma_px": sr, "theta_scale_rel": scale_rel,
                       "zero_sigma_rad": sx / circle.radius if circle.radius > 0 else np.inf}
        if not scale_rel <= MAX_SCALE_REL:
            if span < MIN_ARC_SPAN_DEG:
                # a flat arc's centre is uncertain: suggest --axle where the axle may well be in view
                in_frame = _in_frame(circle.xc, circle.yc, track_extra, sx=sx, sy=sy)
                raise TrackingError(
                    f"the marker's arc spans {span:.1f} deg and bends too little to locate the axle (radius "
                    f"{circle.radius:.0f} +- {sr:.0f} px): film a wider swing or more swings"
                    + (", or pass --axle X,Y (the axle's pixel, if it is in view)" if in_frame else ""), path=source)
            raise TrackingError(
                f"the track is no arc about one axle (circle residual {circle.rms:.1f} px rms, radius "
                f"{circle.radius:.0f} +- {sr:.0f} px): the tracked point is not the bob, or the bob swings out "
                f"of the image plane; track again with --roi X,Y,W,H around the bob, filmed square to its swing",
                path=source)
        if circle.yc > float(np.max(ys)):
            # image y points down: a hanging bob's arc bends about an axle above it, never below every position
            lens = track_config.get("lens")
            projection = lens.get("projection") if isinstance(lens, Mapping) else None
            fix = ("the lens correction may bend the arc so: track again with --projection none if the camera's "
                   "lens has no fisheye distortion (a phone's, a webcam's), or with its own --projection/--fov"
                   if projection not in (None, "none") else
                   "the camera is upside down, or the tracked point is not a hanging bob")
            raise TrackingError(
                f"the marker's arc bends about an axle below it (at ({circle.xc:.0f}, {circle.yc:.0f}) px, under "
                f"every tracked position, lowest at y = {float(np.max(ys)):.0f} px): no hanging pendulum's; {fix}",
                path=source)
        if span < MIN_ARC_SPAN_DEG:
            log.warning("%s: the marker's arc spans %.1f deg: the axle is located to +-%.1f px (radius %.0f +- %.1f "
                        "px), so theta carries a scale uncertainty of %.1f %%", source, span, max(sx, sy),
                        circle.radius, sr, 100 * scale_rel)
        axle = (circle.xc, circle.yc)
    if doubt:
        _refuse_a_doubtful_lens(df, ok, axle, check, doubt, options=ac, source=source)
    res = theta_from_track(df["t"].to_numpy(float), df["x"].to_numpy(float), df["y"].to_numpy(float), ok,
                           axle=axle, rest_seconds=ac.rest_seconds, rest_omega_max=ac.rest_omega_max,
                           circle=circle)
    frame = pd.DataFrame({"t": res.t, "theta": res.theta, "ok": res.ok})
    lens_used = track_config.get("lens")
    extra = {"axle_source": "config" if ac.axle else "circle_fit", **res.to_dict(),
             "lens": dict(lens_used) if isinstance(lens_used, dict) else {},
             "lens_check": check.to_dict() if check is not None else {"verdict": "not checked", "reason": (
                 "lens_check = off" if ac.lens_check == "off" else "the track records no lens or frame size")}}
    if off:
        extra["off_circle"] = off
    if circle is not None:
        extra["circle_rms_px"] = circle.rms
        extra["axle_uncertainty"] = uncertainty
    if tilt is not None:
        extra["swing_plane"] = tilt.to_dict()
    facts = {"axle": axle, "zero_reference": res.zero_reference,
             "circle_rms_px": circle.rms if circle is not None else None,
             "lens_verdict": check.verdict if check is not None else "not checked"}
    return AngleTable(frame, extra, facts)
