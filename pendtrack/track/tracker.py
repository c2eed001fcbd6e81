"""Follow the marker through a sequence of frames (Tracker-style template tracking).

Per frame:

1. **Predict** the marker centre from the last ok frames: constant acceleration from three
   consecutive ones (``3 p1 - 3 p2 + p3``), constant velocity from two, else the last
   position (coasting over a gap of at most ``max_coast_frames``).
2. **Match** the template (normalised correlation, :mod:`pendtrack.track.match`) in a small
   window (``quick_margin_px`` around a reliable prediction); if the score is below
   ``min_score`` or the peak sits on the window's edge, again with ``search_margin_px``;
   if that fails too, **re-acquire** by a whole-frame search at half resolution refined
   in a small full-resolution window.
   Before matching, dips inside the marker narrower than ``hole_share`` of its radius
   are filled in the window and in the template (a sticker turning with a ball).
3. **Refine** the peak to sub-pixel (quadric fit of the score surface, or the
   feature-weighted centroid of the marker, see ``refine``).
4. **Accept** when the score is at least ``min_score`` (the analogue of Tracker's
   automark) and the matched patch's contrast (feature standard deviation) is within a
   factor ``1 / min_contrast_ratio`` of the template's -- the normalised score alone is
   blind to contrast and would happily match faint texture where the marker is hidden.
   Otherwise the frame is kept with ``ok = False``, its best score and the position of
   its best (rejected) candidate, never used as a prediction.

The marker is acquired in the first frame where it is visible, told apart from other
objects of its colour by its motion (:class:`_Acquirer`); earlier frames are kept with
``ok = False``. The template is cut from that frame around the detected marker (by colour
or in a user ROI) and, with ``evolution_rate`` a > 0, blended each ok frame as
``template = (1 - a) template + a patch`` (Tracker's evolution rate; 0 in the paper). An
evolving template is compared with the first every few frames and shifted back onto it
when its content has drifted more than ``max_drift_px`` (the drift alarm of the result).
Coordinates are those of the sampler: raw frame px (:class:`RawSampler`; with a fisheye,
:class:`WarpedRawSampler` keeps the template in corrected space and warps it to the lens'
local distortion at each position), or lens-corrected px (:class:`CorrectedSampler`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from itertools import chain

import cv2
import numpy as np

from pendtrack.errors import TrackingError
from pendtrack.track.circle import fit_circle_pratt
from pendtrack.track.colour import MarkerColour, floored
from pendtrack.track.detect import Detection, marker_candidates, marker_in_roi
from pendtrack.track.match import fill_holes, fill_reach, match_template, weighted_centroid
from pendtrack.track.sampler import RawSampler

log = logging.getLogger(__name__)

REFINE_METHODS = ("quadratic", "centroid")
DRIFT_CHECK_EVERY = 8  # evolutions between two measurements of the template's drift
MOVED_PX = 2.0  # a candidate moved when it strayed further than this (and than half its radius) [px]
LINK_REACH = 0.25  # a candidate is followed to the nearest one within this share of the frame diagonal
RADIUS_RATIO = 2.0  # ... whose radius is within this factor of its own
MIN_RADIUS_SHARE = 0.75  # acquired only when its radius is >= this share of its median over the window
WARP_TOLERANCE = 1e-2  # re-warp the template when an entry of the lens Jacobian changed by more than this
TEMPLATE_REACH = 1.3  # template half-side in marker radii (+ 2 px): the marker and a rim of surroundings
ARC_TOL_PX = 1.0  # position noise of a candidate's detections (and at least 0.1 radius) [px]
ARC_MAX_RADIUS = 2.5  # a pendulum's arc has a radius below this many frame diagonals (its pivot up to ~1.5 above the frame: a
# long string filmed close, issue 27's bauble: 2.1 diagonals)
ARC_MIN_RADIUS = 3.0  # ... and above this many marker radii
ARC_MIN_POINTS = 5  # fewer positions over the window: the path's shape is unclear
# Two movers on arcs, within this radius ratio of each other and further apart than this many radii, are two
# pendulums (a bead or a sticker riding on one bob is smaller, or on it): which one is the user's to say.
TWIN_RADIUS_RATIO = 1.5
TWIN_SEPARATION = 4.0
# A whole-frame search takes, among the half-resolution peaks scoring within this of the best, the one nearest
# the last ok position: a second pendulum of the same look is not swapped in when the marker is lost a moment.
WHOLE_FRAME_SCORE_BAND = 0.1
# A marker of at least this radius [px] is matched on the half-resolution (chroma) grid of a raw frame (see
# MarkerTracker): still >= 12 samples of radius there, more than the 960x540 sticker case (21 px radius at full
# resolution, its chroma on a grid of half that) whose theta meets the target, and the filling and matching cost
# a quarter to a sixth (measured on the 1080p blue ball, 43 px: 0.61 -> 0.14 ms filling, 0.32 -> 0.07 ms matching).
HALF_RES_RADIUS_PX = 24.0
_BOX3_PEAK = np.ones((3, 3), np.uint8)  # local maxima of the whole-frame scores (read-only)
MAX_WARPS = 4096  # lens-warped templates kept at most (one per lens Jacobian met; ~8 kB each for the paper's spot)
# A bob turns with the pendulum: a textured ball (half blue, half clear, issue 27's bauble) is turned by the
# amplitude at each turning point, where a fixed template scores 0.53-0.7. When the score falls below
# TURN_SCORE, the template turned one TURN_STEP_DEG further either way is tried too and the better one kept:
# one step a frame, up to TURN_MAX_STEPS (+-60 deg: a template cut at one turning point of a wide swing),
# each turned about its centre, the tracked point.
TURN_SCORE = 0.9
TURN_STEP_DEG = 5.0
TURN_MAX_STEPS = 12


@dataclass(frozen=True, kw_only=True)
class TrackParams:
    """Tuning of :func:`track_frames`.

    Attributes
    ----------
    min_score : float
        Acceptance threshold on the normalised match score, in (-1, 1].
    search_margin_px : int
        Margin of the wide search window around the prediction [px].
    quick_margin_px : int
        Margin of the first, small search window when the prediction is reliable [px].
    evolution_rate : float
        Template evolution per ok frame, in [0, 1).
    refine : str
        ``"quadratic"``: quadric fit of the 3x3 scores around the peak; ``"centroid"``:
        feature-weighted centroid of the marker around the matched position.
    max_coast_frames : int
        After this many frames without an ok match the prediction is dropped and every
        frame is searched whole.
    min_contrast_ratio : float
        The matched patch's feature standard deviation must lie within
        ``[r, 1 / r]`` times the template's, r in (0, 1].
    acquire_step_s : float
        Until the marker is found, frames are searched this often [s]; the frames since
        the last search are then searched one by one (the marker is acquired in the first
        frame where it is visible).
    acquire_window_s : float
        Candidates are told apart by their motion over this time after acquisition [s].
    max_drift_px : float
        An evolving template whose content has moved further than this from the first
        template is shifted back onto it (re-anchored) [px of the template].
    hole_share : float
        Dips of the feature inside the marker narrower than a disc of this share of its
        radius are filled (:func:`pendtrack.track.match.fill_holes`) in the template and in
        every search window, so a sticker turning with a ball does not pull the match off
        its centre; 0 = off. Only pixels the filling lifts to half the marker's contrast
        change. 0.6: measured on the field renders (tests/field_run.py) of a sticker of 0.3
        radii 0.45 radii off a blue ball's centre (theta 2.57 -> 0.79 mrad RMS) and of 0.33
        radii on the paper's spot of 6 px (4.42 -> 1.46 mrad; 1.31 without the sticker),
        every other condition within 0.01 mrad of no filling; 0.8 fills a little more of
        the sticker's blur (0.72, 1.38 mrad) but bridges the gap between a dark ball and the
        dark floor just below it (0.24 -> 0.66 mrad).
    """

    min_score: float = 0.6
    search_margin_px: int = 48
    quick_margin_px: int = 6
    evolution_rate: float = 0.0
    refine: str = "quadratic"
    max_coast_frames: int = 30
    min_contrast_ratio: float = 0.3
    acquire_step_s: float = 0.05
    acquire_window_s: float = 0.5
    max_drift_px: float = 3.0
    hole_share: float = 0.6

    def __post_init__(self) -> None:
        if not (np.isfinite(self.acquire_step_s) and self.acquire_step_s > 0):
            raise ValueError(f"acquire_step_s must be > 0 s, got {self.acquire_step_s}")
        if not (np.isfinite(self.acquire_window_s) and self.acquire_window_s >= 0):
            raise ValueError(f"acquire_window_s must be >= 0 s, got {self.acquire_window_s}")
        if not (np.isfinite(self.hole_share) and 0 <= self.hole_share <= 2):
            raise ValueError(f"hole_share must be in [0, 2], got {self.hole_share}")
        if not (np.isfinite(self.max_drift_px) and self.max_drift_px > 0):
            raise ValueError(f"max_drift_px must be > 0 px, got {self.max_drift_px}")
        if not -1.0 < self.min_score <= 1.0:
            raise ValueError(f"min_score must be in (-1, 1], got {self.min_score}")
        if self.search_margin_px < 1 or self.quick_margin_px < 1:
            raise ValueError("search margins must be >= 1 px")
        if not 0.0 <= self.evolution_rate < 1.0:
            raise ValueError(f"evolution_rate must be in [0, 1), got {self.evolution_rate}")
        if not 0.0 < self.min_contrast_ratio <= 1.0:
            raise ValueError(f"min_contrast_ratio must be in (0, 1], got {self.min_contrast_ratio}")
        if self.refine not in REFINE_METHODS:
            raise ValueError(f"refine must be one of {REFINE_METHODS}, got {self.refine!r}")


@dataclass(frozen=True)
class TrackResult:
    """A marker track, one entry per frame, in the sampler's coordinates.

    Attributes
    ----------
    frame : ndarray, int64
        Frame index.
    t : ndarray, float64
        Time [s].
    x, y : ndarray, float64
        Marker centre [px]; for not-ok frames the best rejected candidate (NaN if none).
    score : ndarray, float64
        Best normalised match score of the frame (NaN if no window could be searched).
    ok : ndarray, bool
        Accepted (score >= min_score and contrast plausible).
    detection : Detection
        The marker found in the first frame (raw px).
    template_size : int
        Side of the (square) template [px].
    radius : float
        The marker's radius in the first frame [px of the result's coordinates].
    searches : dict
        How many frames needed the wide window and the whole-frame search.
    acquisition : dict
        Where and how the marker was found: ``frame``, ``t`` [s], ``row`` (its row in
        these arrays; earlier rows are not ok), ``method`` (``roi``, ``motion``: the
        largest candidate that moved, on an arc if any did, ``single``: the only
        candidate, ``largest``: several and none seen moving), ``candidates`` (how many
        in that frame), ``path`` (the chosen mover's path: ``arc`` or ``unclear``) and
        ``rejected_paths`` (movers passed over as no pendulum's arc).
    drift : dict
        The evolving template against the first: ``max_px`` (largest drift measured),
        ``reanchors`` (times it was shifted back), ``limit_px``, ``alarm`` (True when the
        limit was exceeded at least once).
    match_scale : int
        1: matched at full resolution; 2: on the half-resolution grid (a marker of at least
        :data:`HALF_RES_RADIUS_PX`, see :class:`MarkerTracker`).
    """

    frame: np.ndarray
    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    score: np.ndarray
    ok: np.ndarray
    detection: Detection
    template_size: int
    radius: float
    searches: dict[str, int]
    acquisition: dict[str, object]
    drift: dict[str, object]
    match_scale: int = 1

    @property
    def ok_fraction(self) -> float:
        return float(self.ok.mean()) if self.ok.size else 0.0

    @property
    def n_after_acquisition(self) -> int:
        """Frames from the acquisition on (those where the marker can be lost)."""
        return int(self.frame.size) - int(self.acquisition["row"])  # type: ignore[call-overload]

    def to_dict(self) -> dict[str, object]:
        return {"n_frames": int(self.frame.size), "n_ok": int(self.ok.sum()), "ok_fraction": self.ok_fraction,
                "detection": self.detection.to_dict(), "template_size": self.template_size, "radius_px": self.radius,
                "searches": dict(self.searches), "acquisition": dict(self.acquisition),
                "template_drift": dict(self.drift), "match_scale": self.match_scale}


class _Template:
    """The template (float32, odd square side) and what the centroid refinement needs."""

    def __init__(self, image: np.ndarray, radius: float, contrast: float, background: float = 0.0,
                 half_image: np.ndarray | None = None) -> None:
        self.image = np.ascontiguousarray(image, dtype=np.float32)
        self.background = background
        self.std = float(self.image.std())
        self.half = image.shape[0] // 2
        self.radius = radius
        self.contrast = contrast
        self._small: np.ndarray | None = None
        # the template cut from the half-resolution grid (a large marker, see HALF_RES_RADIUS_PX), or None
        self.half_image = None if half_image is None else np.ascontiguousarray(half_image, dtype=np.float32)
        self.half_std = 0.0 if half_image is None else float(self.half_image.std())  # type: ignore[union-attr]

    @property
    def small(self) -> np.ndarray:
        """Half-resolution template for the whole-frame search (recomputed if the template evolves)."""
        if self._small is None:
            n = max(3, (self.image.shape[0] + 1) // 2)
            self._small = cv2.resize(self.image, (n, n), interpolation=cv2.INTER_AREA)
        return self._small

    def evolve(self, patch: np.ndarray, rate: float) -> None:
        self.image = ((1.0 - rate) * self.image + rate * patch).astype(np.float32)
        self.std = float(self.image.std())
        self._small = None


def make_template(sampler: RawSampler, y: np.ndarray, u: np.ndarray, v: np.ndarray,
                  det: Detection, *, hole_share: float = 0.0) -> tuple[_Template, float, float]:
    """Cut the template around a detection; returns it and the centre in tracking coordinates.

    With a :class:`~pendtrack.track.sampler.WarpedRawSampler` the template is cut in
    corrected space (and warped per position by the tracker).
    """
    if getattr(sampler, "warps_template", False):
        csam = sampler.corrected_sampler  # type: ignore[attr-defined]
        tpl, _, _ = make_template(csam, y, u, v, det, hole_share=hole_share)
        tpl.radius = det.radius
        return tpl, float(det.x), float(det.y)
    tx, ty, radius = sampler.blob_from_raw(det.x, det.y, det.radius)
    half = int(np.ceil(TEMPLATE_REACH * radius)) + 2
    side = 2 * half + 1
    pad = half + 3
    x0, y0 = int(np.floor(tx)) - pad, int(np.floor(ty)) - pad
    x1, y1 = int(np.floor(tx)) + pad + 2, int(np.floor(ty)) + pad + 2
    if x0 < 0 or y0 < 0 or x1 > sampler.width or y1 > sampler.height:
        raise TrackingError("the marker is too close to the frame's edge in the first frame")
    level = det.background + 0.5 * det.contrast
    win = filled_window(sampler, y, u, v, x0, y0, x1 - x0, y1 - y0, hole_share * radius, level)
    image = cv2.getRectSubPix(win, (side, side), (tx - x0, ty - y0))
    return _Template(image, radius, det.contrast, det.background,
                     half_image=_half_template(sampler, y, u, v, tx, ty, radius, hole_share, level)), tx, ty


def _half_template(sampler: RawSampler, y: np.ndarray, u: np.ndarray, v: np.ndarray, tx: float, ty: float,
                   radius: float, hole_share: float, level: float) -> np.ndarray | None:
    """The template cut from the half-resolution grid (odd side, centred on the marker), or None when the
    marker is below :data:`HALF_RES_RADIUS_PX`, the sampler has no half-resolution windows or the template
    does not fit in the frame. Grid sample ``(i, j)`` sits at raw ``(2i + 0.5, 2j + 0.5)``."""
    if radius < HALF_RES_RADIUS_PX or not getattr(sampler, "half_windows", False):
        return None
    hx, hy = (tx - 0.5) / 2.0, (ty - 0.5) / 2.0
    half = int(np.ceil(TEMPLATE_REACH * radius / 2.0)) + 1
    pad = half + 3
    x0, y0 = int(np.floor(hx)) - pad, int(np.floor(hy)) - pad
    x1, y1 = int(np.floor(hx)) + pad + 2, int(np.floor(hy)) + pad + 2
    if x0 < 0 or y0 < 0 or x1 > sampler.half_width or y1 > sampler.half_height:
        return None
    win = filled_window(sampler, y, u, v, x0, y0, x1 - x0, y1 - y0, hole_share * radius / 2.0, level, half=True)
    return cv2.getRectSubPix(win, (2 * half + 1, 2 * half + 1), (hx - x0, hy - y0))


def filled_window(sampler: RawSampler, y: np.ndarray, u: np.ndarray, v: np.ndarray, x0: int, y0: int, w: int,
                  h: int, radius_px: float, level: float, *, half: bool = False) -> np.ndarray:
    """The sampler's feature window with the marker's dips filled (:func:`pendtrack.track.match.fill_holes`).

    The closing runs on a window grown by its reach (clipped to the frame), so each pixel's
    filled value depends on the image only, not on where the window ends: the template and
    every search window see the same filled marker. The window is raised to the colour's floor
    level first (:func:`pendtrack.track.colour.floored`: a touching bar of the marker's colour
    is background). With ``half``, the window (and
    ``radius_px``) are on the sampler's half-resolution grid (:meth:`RawSampler.window_half`).
    """
    window = sampler.window_half if half else sampler.window

    def cut(*box: int) -> np.ndarray:
        return floored(window(y, u, v, *box), sampler.colour)

    k = fill_reach(radius_px)
    if k < 1:
        return cut(x0, y0, w, h)
    width, height = (sampler.half_width, sampler.half_height) if half else (sampler.width, sampler.height)
    gx0, gy0 = max(x0 - k, 0), max(y0 - k, 0)
    gx1, gy1 = min(x0 + w + k, width), min(y0 + h + k, height)
    box = np.s_[y0 - gy0:y0 - gy0 + h, x0 - gx0:x0 - gx0 + w]
    return fill_holes(cut(gx0, gy0, gx1 - gx0, gy1 - gy0), radius_px, level=level, box=box)


def warp_template(canon: np.ndarray, jac: tuple[float, float, float, float]) -> np.ndarray:
    """The template cut in corrected space as the lens shows it where its Jacobian is ``jac``.

    Parameters
    ----------
    canon : ndarray, float32
        Template in corrected (rectilinear) space, odd square side.
    jac : (float, float, float, float)
        ``(dxr/dxc, dxr/dyc, dyr/dxc, dyr/dyc)`` [raw px per corrected px] (see
        :meth:`pendtrack.track.sampler.WarpedRawSampler.jacobian`).

    Returns
    -------
    ndarray, float32
        Odd square side, grown to hold the warped template, centred on its centre.
    """
    a, b, c, d = jac
    det = a * d - b * c
    ia, ib, ic, idd = d / det, -b / det, -c / det, a / det  # raw offset -> corrected offset
    hc = (canon.shape[0] - 1) / 2.0
    grow = max(abs(a) + abs(b), abs(c) + abs(d))
    hr = int(np.ceil(hc * grow))
    side = 2 * hr + 1
    m = np.array([[ia, ib, hc - (ia + ib) * hr], [ic, idd, hc - (ic + idd) * hr]])
    return cv2.warpAffine(canon, m, (side, side), flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                          borderMode=cv2.BORDER_REPLICATE)


def template_drift(anchor: np.ndarray, current: np.ndarray, *, reach: int) -> tuple[float, float]:
    """How far the content of ``current`` has moved from ``anchor`` (same-size templates) [px].

    The anchor's centre, cropped ``reach`` px from each side, is matched (normalised
    correlation, sub-pixel peak) inside ``current``; the offset of the best match from the
    centre is the drift, at most ``reach`` per axis (a larger drift reads as ``reach``).
    """
    side = anchor.shape[0]
    reach = min(reach, (side - 5) // 2)
    if reach < 1:
        return 0.0, 0.0
    core = anchor[reach:side - reach, reach:side - reach]
    m = match_template(current, core)
    if m is None:
        return 0.0, 0.0
    c = (side - 1) / 2.0
    return m.x - c, m.y - c


class MarkerTracker:
    """Frame-by-frame tracking state (prediction history, template, counters).

    A marker of at least :data:`HALF_RES_RADIUS_PX` in raw frames (a phone's 1080p ball) is
    filled and matched on the half-resolution grid (the chroma planes' own grid, luma
    averaged over 2x2 blocks; its own template, cut there), sub-pixel peak included: the
    work per frame drops to about a quarter, and a chroma marker loses nothing (4:2:0 chroma
    has no finer detail to match). Not with an evolving template, the centroid refinement or
    a lens-warped or corrected sampler (they work on full-resolution windows).

    Parameters
    ----------
    sampler : RawSampler or CorrectedSampler
        Where windows come from (sets the coordinate system).
    template : _Template
    params : TrackParams
    """

    def __init__(self, sampler: RawSampler, template: _Template, params: TrackParams) -> None:
        self.sampler = sampler
        self.template = template
        self.params = params
        self._hist: list[tuple[int, float, float]] = []  # last ok frames: (index, x, y)
        self.n_wide = 0
        self.n_whole = 0
        self._warp = bool(getattr(sampler, "warps_template", False))
        # a large marker is matched on the half-resolution grid (HALF_RES_RADIUS_PX), unless the template
        # evolves or the centroid refines (both work on full-resolution windows)
        self._half = (template.half_image is not None and not self._warp and params.evolution_rate == 0
                      and params.refine == "quadratic")
        self._warp_key: tuple[int, int] | None = None
        self._warp_jac: tuple[float, float, float, float] | None = None
        self._warped: tuple[np.ndarray, float] = (template.image, template.std)
        # the template warped per lens Jacobian, kept while it does not change (a pendulum swings over the same
        # grid nodes again and again: each warp is computed once, not at every other frame)
        self._warps: dict[tuple[float, float, float, float], tuple[np.ndarray, float]] = {}
        self._anchor = template.image.copy()
        # turned copies of the template, by steps of TURN_STEP_DEG (not with lens warps or an evolving template)
        self._turnable = not self._warp and params.evolution_rate == 0
        self._turns: dict[int, _Template] = {0: template}
        self.turn = 0
        self._n_evolved = 0
        self.drift_max = 0.0
        self.reanchors = 0

    def _template_at(self, px: float, py: float) -> tuple[np.ndarray, float]:
        """The template (and its standard deviation) for a marker near ``(px, py)``."""
        if not self._warp:
            return self.template.image, self.template.std
        g = self.sampler.grid_px  # type: ignore[attr-defined]
        key = (int(round(px / g)), int(round(py / g)))
        if key == self._warp_key:
            return self._warped
        jac = self.sampler.jacobian(px, py)  # type: ignore[attr-defined]
        last = self._warp_jac
        if last is None or max(abs(p - q) for p, q in zip(jac, last)) > WARP_TOLERANCE:
            if jac not in self._warps:
                if len(self._warps) >= MAX_WARPS:
                    self._warps.clear()
                img = warp_template(self.template.image, jac)
                self._warps[jac] = (img, float(cv2.meanStdDev(img)[1][0, 0]))
            self._warped = self._warps[jac]
            self._warp_jac = jac
        self._warp_key = key
        return self._warped

    def _turned(self, k: int) -> _Template:
        """The template turned by ``k`` steps of :data:`TURN_STEP_DEG` about its centre (cached)."""
        if k not in self._turns:
            t = self._turns[0]

            def turn(img: np.ndarray) -> np.ndarray:
                c = (img.shape[1] - 1) / 2.0
                m = cv2.getRotationMatrix2D((c, c), k * TURN_STEP_DEG, 1.0)
                return cv2.warpAffine(img, m, img.shape[::-1], flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)

            self._turns[k] = _Template(turn(t.image), t.radius, t.contrast, t.background,
                                       None if t.half_image is None else turn(t.half_image))
        return self._turns[k]

    def _try_turns(self, y: np.ndarray, u: np.ndarray, v: np.ndarray, px: float, py: float, margin: int,
                   accepted: tuple | None) -> tuple | None:
        """The match of the template turned one step either way, when it scores above ``accepted`` (kept)."""
        p = self.params
        k0 = self.turn
        for k in (k0 - 1, k0 + 1):
            if abs(k) > TURN_MAX_STEPS:
                continue
            self.template = self._turned(k)
            r = self._match_at(y, u, v, px, py, margin)
            self.template = self._turns[self.turn]
            if (r is not None and r[0] >= p.min_score and r[7] and not r[3]
                    and (accepted is None or r[0] > accepted[0])):
                accepted = r
                self.turn = k
        self.template = self._turns[self.turn]
        return accepted

    def _forget_warps(self) -> None:
        """The template changed: its warps are to be computed anew."""
        self._warp_key = None
        self._warp_jac = None
        self._warps.clear()

    def _predict(self, i: int) -> tuple[float, float, bool] | None:
        """(x, y, reliable) or None when the marker has been lost too long."""
        h = self._hist
        if not h or i - h[-1][0] > self.params.max_coast_frames:
            return None
        i1, x1, y1 = h[-1]
        if len(h) >= 3 and h[-3][0] == i - 3 and i1 == i - 1 and h[-2][0] == i - 2:
            return 3 * x1 - 3 * h[-2][1] + h[-3][1], 3 * y1 - 3 * h[-2][2] + h[-3][2], True
        if len(h) >= 2:
            i2, x2, y2 = h[-2]
            k = (i - i1) / (i1 - i2)
            return x1 + k * (x1 - x2), y1 + k * (y1 - y2), i1 == i - 1 and i2 == i - 2
        return x1, y1, False

    def _match_at(self, y: np.ndarray, u: np.ndarray, v: np.ndarray, px: float, py: float,
                  margin: int) -> tuple[float, float, float, bool, np.ndarray, int, int] | None:
        """Match in the window ``prediction +- (margin + template half)``, clipped to the frame.

        Returns (score, x, y, peak_on_inner_edge, window, x0, y0, contrast_ok) or None.
        """
        if self._half:
            return self._match_half(y, u, v, px, py, margin)
        tpl_img, tpl_std = self._template_at(px, py)
        half = tpl_img.shape[0] // 2
        reach = half + margin
        cx, cy = int(round(px)), int(round(py))
        x0, y0 = max(cx - reach, 0), max(cy - reach, 0)
        x1, y1 = min(cx + reach + 1, self.sampler.width), min(cy + reach + 1, self.sampler.height)
        if x1 - x0 <= 2 * half or y1 - y0 <= 2 * half:
            return None
        t = self.template
        win = filled_window(self.sampler, y, u, v, x0, y0, x1 - x0, y1 - y0, self.params.hole_share * t.radius,
                            t.background + 0.5 * t.contrast)
        m = match_template(win, tpl_img)
        if m is None:
            return None
        edge = ((m.ix == 0 and x0 > 0) or (m.iy == 0 and y0 > 0)
                or (m.ix == m.nx - 1 and x1 < self.sampler.width) or (m.iy == m.ny - 1 and y1 < self.sampler.height))
        side = tpl_img.shape[0]
        ratio = float(cv2.meanStdDev(win[m.iy:m.iy + side, m.ix:m.ix + side])[1][0, 0]) / (tpl_std + 1e-12)
        r = self.params.min_contrast_ratio
        return m.score, x0 + m.x, y0 + m.y, edge, win, x0, y0, r <= ratio <= 1.0 / r

    def _match_half(self, y: np.ndarray, u: np.ndarray, v: np.ndarray, px: float, py: float,
                    margin: int) -> tuple[float, float, float, bool, np.ndarray, int, int] | None:
        """:meth:`_match_at` on the half-resolution grid (margin halved, rounded up); the position returned is
        in full-resolution px (grid sample ``(i, j)`` at ``(2i + 0.5, 2j + 0.5)``), the window and its
        offset are on the grid."""
        t = self.template
        tpl_img = t.half_image
        half = tpl_img.shape[0] // 2  # type: ignore[union-attr]
        reach = half + (margin + 1) // 2
        cx, cy = int(round((px - 0.5) / 2.0)), int(round((py - 0.5) / 2.0))
        width, height = self.sampler.half_width, self.sampler.half_height
        x0, y0 = max(cx - reach, 0), max(cy - reach, 0)
        x1, y1 = min(cx + reach + 1, width), min(cy + reach + 1, height)
        if x1 - x0 <= 2 * half or y1 - y0 <= 2 * half:
            return None
        win = filled_window(self.sampler, y, u, v, x0, y0, x1 - x0, y1 - y0, self.params.hole_share * t.radius / 2.0,
                            t.background + 0.5 * t.contrast, half=True)
        m = match_template(win, tpl_img)  # type: ignore[arg-type]
        if m is None:
            return None
        edge = ((m.ix == 0 and x0 > 0) or (m.iy == 0 and y0 > 0)
                or (m.ix == m.nx - 1 and x1 < width) or (m.iy == m.ny - 1 and y1 < height))
        side = tpl_img.shape[0]  # type: ignore[union-attr]
        ratio = float(cv2.meanStdDev(win[m.iy:m.iy + side, m.ix:m.ix + side])[1][0, 0]) / (t.half_std + 1e-12)
        r = self.params.min_contrast_ratio
        return (m.score, 2.0 * (x0 + m.x) + 0.5, 2.0 * (y0 + m.y) + 0.5, edge, win, x0, y0,
                r <= ratio <= 1.0 / r)

    def _whole_frame(self, y: np.ndarray, u: np.ndarray, v: np.ndarray) -> tuple[float, float] | None:
        """Coarse marker centre from a half-resolution whole-frame search (on the feature raised to the colour's
        floor level, as the template)."""
        self.n_whole += 1
        f = floored(self.sampler.whole_half(y, u, v), self.sampler.colour)
        small = self.template.small
        if f.shape[0] < small.shape[0] or f.shape[1] < small.shape[1]:
            return None
        scores = cv2.matchTemplate(f, small, cv2.TM_CCOEFF_NORMED)
        _, best, _, (ix, iy) = cv2.minMaxLoc(scores)
        c = (small.shape[0] - 1) / 2.0
        if self._hist:
            # the peaks near the best: the one nearest where the marker was last seen
            peaks = (scores >= best - WHOLE_FRAME_SCORE_BAND) & (scores >= cv2.dilate(scores, _BOX3_PEAK))
            py, px = np.nonzero(peaks)
            if px.size > 1:
                _, lx, ly = self._hist[-1]
                k = int(np.argmin((2.0 * (px + c) + 0.5 - lx) ** 2 + (2.0 * (py + c) + 0.5 - ly) ** 2))
                ix, iy = int(px[k]), int(py[k])
        return 2.0 * (ix + c) + 0.5, 2.0 * (iy + c) + 0.5

    def step(self, index: int, y: np.ndarray, u: np.ndarray, v: np.ndarray) -> tuple[float, float, float, bool]:
        """Track one frame: (x, y, score, ok)."""
        p = self.params
        pred = self._predict(index)
        best = None
        accepted = None
        if pred is not None:
            px, py, reliable = pred
            margins = (p.quick_margin_px, p.search_margin_px) if reliable else (p.search_margin_px,)
            for k, margin in enumerate(margins):
                if k:
                    self.n_wide += 1
                r = self._match_at(y, u, v, px, py, margin)
                if r is None:
                    continue
                if best is None or r[0] > best[0]:
                    best = r
                if r[0] >= p.min_score and r[7] and not r[3]:
                    accepted = r
                    break
            if self._turnable and (accepted is None or accepted[0] < TURN_SCORE):
                accepted = self._try_turns(y, u, v, px, py, margins[-1], accepted)
        if accepted is None:
            coarse = self._whole_frame(y, u, v)
            if coarse is not None:
                r = self._match_at(y, u, v, coarse[0], coarse[1], 6)
                if r is not None:
                    if best is None or r[0] > best[0]:
                        best = r
                    if r[0] >= p.min_score and r[7]:
                        accepted = r
        if accepted is None:
            if best is None:
                return np.nan, np.nan, np.nan, False
            return best[1], best[2], best[0], False
        score, mx, my, _, win, x0, y0, _ = accepted
        if p.refine == "centroid":
            mx, my = self._centroid(win, mx - x0, my - y0)
            mx += x0
            my += y0
        if p.evolution_rate > 0:
            self._evolve(y, u, v, win, mx, my, x0, y0)
        self._hist.append((index, mx, my))
        if len(self._hist) > 3:
            del self._hist[0]
        return mx, my, score, True

    def _evolve(self, y: np.ndarray, u: np.ndarray, v: np.ndarray, win: np.ndarray, mx: float, my: float,
                x0: int, y0: int) -> None:
        """Blend the patch at the accepted position into the template (in corrected space when warping)."""
        shape = self.template.image.shape[::-1]
        if self._warp:
            cs = self.sampler.corrected_sampler  # type: ignore[attr-defined]
            # the corrected point the template's centre stands for (as when it was cut)
            cx, cy, _ = cs.blob_from_raw(mx, my, self.template.radius)
            pad = self.template.half + 3
            wx0, wy0 = int(np.floor(cx)) - pad, int(np.floor(cy)) - pad
            if wx0 < 0 or wy0 < 0 or wx0 + 2 * pad + 2 > cs.width or wy0 + 2 * pad + 2 > cs.height:
                return
            t = self.template
            cwin = filled_window(cs, y, u, v, wx0, wy0, 2 * pad + 2, 2 * pad + 2, self.params.hole_share * t.radius,
                                 t.background + 0.5 * t.contrast)
            patch = cv2.getRectSubPix(cwin, shape, (cx - wx0, cy - wy0))
            self._forget_warps()
        else:
            patch = cv2.getRectSubPix(win, shape, (mx - x0, my - y0))
        self.template.evolve(patch, self.params.evolution_rate)
        self._n_evolved += 1
        if self._n_evolved % DRIFT_CHECK_EVERY == 0:
            self._bound_drift()

    def _bound_drift(self) -> None:
        """Measure the evolved template's drift from the first; shift it back beyond ``max_drift_px``."""
        limit = self.params.max_drift_px
        dx, dy = template_drift(self._anchor, self.template.image, reach=int(np.ceil(limit)) + 2)
        d = float(np.hypot(dx, dy))
        self.drift_max = max(self.drift_max, d)
        if d > limit:
            m = np.array([[1.0, 0.0, -dx], [0.0, 1.0, -dy]])
            img = self.template.image
            self.template.image = cv2.warpAffine(img, m, img.shape[::-1], flags=cv2.INTER_LINEAR,
                                                 borderMode=cv2.BORDER_REPLICATE)
            self.template.evolve(self.template.image, 0.0)  # refresh its statistics
            self._forget_warps()
            self._warped = (self.template.image, self.template.std)
            self.reanchors += 1
            log.warning("template drifted %.1f px from the first template: re-anchored", d)

    def _centroid(self, win: np.ndarray, wx: float, wy: float) -> tuple[float, float]:
        """Feature-weighted centroid near ``(wx, wy)`` [window px], two passes; falls back to the input."""
        t = self.template
        border = np.concatenate([win[0], win[-1], win[:, 0], win[:, -1]])
        bg = float(np.median(border))
        for _ in range(2):
            c = weighted_centroid(win, wx, wy, 1.6 * t.radius + 2.0, bg, 0.15 * t.contrast)
            if c is None:
                break
            wx, wy = c
        return wx, wy


class _Acquirer:
    """Find the marker in a stream of frames: the first frame where it is visible and usable.

    Frames are searched every ``acquire_step_s`` for candidates (compact blobs of the
    marker colour, or a marker standing out in the ROI). The candidates of a search frame are told apart by what they do over
    the next ``acquire_window_s``: each is followed, search after search, to the nearest
    candidate of similar size; the marker is the one that moves (a poster of its colour
    does not) on a pendulum's arc (:func:`path_shape`: its positions lie on a circle about a
    fixed point near the frame), the largest if several do (a bead riding on it is smaller).
    A mover whose path is clearly no such arc (straight over a long travel, erratic: a
    coloured object carried or walking past while a hand hides the marker) is passed over;
    one whose path is too short or too straight to tell comes after those on an arc. A
    candidate seen smaller than ``MIN_RADIUS_SHARE`` of its median size over the window is
    partly hidden (a hand). When no candidate moves, the search moves on (a poster is all
    there is to see while a hand hides the marker); when the video ends first, the largest
    candidate of the last search is taken (a marker that never moves: pass a ROI to track it
    from the start). Once the marker is chosen in a search frame, the frames since the
    previous search are searched back for it, so acquisition is not late by a search step.
    """

    def __init__(self, frames: Iterator, *, sampler: RawSampler, params: TrackParams, roi: tuple[int, ...]) -> None:
        self.frames = frames
        self.sampler = sampler
        self.params = params
        self.roi = tuple(int(a) for a in roi)
        if roi and (len(roi) != 4 or roi[2] < 5 or roi[3] < 5):
            raise TrackingError(f"roi must be x, y, w, h with w, h >= 5 px, got {tuple(roi)}")
        self.colour = sampler.colour
        self.pending: list = []
        self.skipped: list = []  # frames before the acquisition (recorded as not ok)
        self.ended = False
        self._cache: dict[int, list[Detection]] = {}
        self.n_searched = 0
        self.path_shape = ""  # the chosen candidate's path over the window (see path_shape)
        self.rejected_paths = 0  # moving candidates passed over because their path is no pendulum's arc

    def _next(self) -> object | None:
        if self.pending:
            return self.pending.pop(0)
        fr = next(self.frames, None)
        if fr is None:
            self.ended = True
        return fr

    def candidates(self, fr: object) -> list[Detection]:
        """Marker candidates of a frame (cached by frame index), largest first."""
        key = fr.index  # type: ignore[attr-defined]
        if key not in self._cache:
            self.n_searched += 1
            if self.roi:
                # a blob of the marker's colour inside the ROI, else whatever stands out in it (its colour learned)
                x0, y0, w, h = self.roi
                inside = [c for c in marker_candidates(fr.y, fr.u, fr.v, self.colour)  # type: ignore[attr-defined]
                          if x0 <= c.x < x0 + w and y0 <= c.y < y0 + h]
                det = inside[0] if inside else marker_in_roi(fr.y, fr.u, fr.v, self.roi)  # type: ignore[attr-defined]
                self._cache[key] = [] if det is None else [det]
            else:
                self._cache[key] = marker_candidates(fr.y, fr.u, fr.v, self.colour)  # type: ignore[attr-defined]
        return self._cache[key]

    def usable(self, fr: object) -> list[tuple[Detection, tuple[_Template, float, float]]]:
        """Candidates a template can be cut around (not too close to the frame's edge)."""
        out = []
        for det in self.candidates(fr):
            self.sampler.colour = det.colour
            try:
                out.append((det, make_template(self.sampler, fr.y, fr.u, fr.v, det,  # type: ignore[attr-defined]
                                               hole_share=self.params.hole_share)))
            except TrackingError:
                continue
        return out

    def run(self) -> tuple[Detection, tuple[_Template, float, float], dict[str, object], Iterator]:
        """The marker, its template and centre, facts, and the frames from the acquisition on."""
        step = self.params.acquire_step_s - 1e-9
        back: list = []  # frames since the last search
        t_last: float | None = None
        while True:
            fr = self._next()
            if fr is None:
                self._raise_not_found()
            if t_last is not None and fr.t - t_last < step:  # type: ignore[attr-defined]
                back.append(fr)
                continue
            t_last = fr.t  # type: ignore[attr-defined]
            found = self.usable(fr)
            window = [fr]
            chosen: tuple | None = None
            if found:
                t_s = fr.t  # type: ignore[attr-defined]
                while (self.pending or not self.ended) and window[-1].t - fr.t < self.params.acquire_window_s:
                    nxt = self._next()
                    if nxt is not None:
                        window.append(nxt)
                        if not self.roi and self._sample_due(nxt, t_s):
                            # searched as it comes, while the decoder goes on (the choice below reads the cache):
                            # the consumer then lags the decoder by the searches less the window's decoding, not
                            # by all of them -- a lag a bounded decode-ahead queue turns into a stalled decoder
                            # or into more frame buffers (page faults)
                            self.candidates(nxt)
                            t_s = nxt.t
                if not self.pending and not self.ended:  # is there a frame after the window?
                    nxt = self._next()
                    if nxt is not None:
                        self.pending.append(nxt)
                chosen, method = self._choose(fr, found, window)
            if chosen is None:
                self.skipped.extend(back)
                self.skipped.append(fr)
                back = []
                self.pending = window[1:] + self.pending
                continue
            det, tpl = chosen
            k = len(back)
            for j in range(len(back) - 1, -1, -1):  # refine back: the marker in the frames before this search
                earlier = self._same(det, back[j])
                if earlier is None:
                    break
                (det, tpl), k = earlier, j
            self.skipped.extend(back[:k])
            a = back[k] if k < len(back) else fr
            self.sampler.colour = det.colour
            info = {"frame": int(a.index), "t": float(a.t), "row": len(self.skipped), "method": method,
                    "candidates": len(found), "frames_searched": self.n_searched, "path": self.path_shape,
                    "rejected_paths": self.rejected_paths}
            self._cache.clear()
            return det, tpl, info, chain(back[k:], window, self.pending, self.frames)

    def _same(self, det: Detection, fr: object) -> tuple[Detection, tuple[_Template, float, float]] | None:
        """The candidate of ``fr`` that is ``det`` seen in a neighbouring frame, whole and usable, or None."""
        reach = LINK_REACH * float(np.hypot(self.sampler.height, self.sampler.width))
        near = [c for c in self.candidates(fr)
                if MIN_RADIUS_SHARE <= c.radius / det.radius <= 1 / MIN_RADIUS_SHARE
                and np.hypot(c.x - det.x, c.y - det.y) <= reach]
        if not near:
            return None
        c = min(near, key=lambda c: (c.x - det.x) ** 2 + (c.y - det.y) ** 2)
        self.sampler.colour = c.colour
        try:
            return c, make_template(self.sampler, fr.y, fr.u, fr.v, c,  # type: ignore[attr-defined]
                                    hole_share=self.params.hole_share)
        except TrackingError:
            return None

    def _sample_due(self, fr: object, t_last: float) -> bool:
        """Is ``fr`` a frame whose candidates the choice follows (``acquire_step_s`` after the last one at
        ``t_last`` [s])?"""
        return fr.t - t_last >= self.params.acquire_step_s - 1e-9  # type: ignore[attr-defined]

    def _choose(self, a: object, found: list, window: list) -> tuple[object | None, str]:
        """The marker among the search frame's candidates, and how it was chosen (None: undecided)."""
        if self.roi:
            return found[0], "roi"
        samples = []
        t_s = a.t  # type: ignore[attr-defined]
        for fr in window[1:]:
            if self._sample_due(fr, t_s):
                samples.append(self.candidates(fr))
                t_s = fr.t
        diagonal = float(np.hypot(self.sampler.height, self.sampler.width))
        reach = LINK_REACH * diagonal
        moving: dict[str, list] = {"arc": [], "unclear": [], "not_arc": []}
        still = []
        for cand in found:
            det = cand[0]
            moved, radii, path = _follow(det, samples, reach)
            if det.radius < MIN_RADIUS_SHARE * float(np.median([det.radius, *radii])):
                continue  # partly hidden here
            if moved > max(MOVED_PX, 0.5 * det.radius):
                moving[path_shape(path, marker_radius=det.radius, diagonal=diagonal)].append(cand)
            else:
                still.append(cand)
        self.rejected_paths += len(moving["not_arc"])
        _refuse_two_pendulums([c[0] for c in moving["arc"]])
        for shape in ("arc", "unclear"):
            if moving[shape]:
                self.path_shape = shape
                return max(moving[shape], key=lambda c: c[0].radius), "motion"
        if self.ended and not self.pending:  # no later frame to decide on
            self.path_shape = ""
            return max(still or found, key=lambda c: c[0].radius * c[0].radius * c[0].contrast), "largest"
        return None, ""

    def _raise_not_found(self) -> None:
        n = len(self.skipped)
        later = f" or any of the {n - 1} frames after it" if n > 1 else ""
        if self.roi:
            raise TrackingError(f"no marker stands out in the roi {self.roi} of the first frame{later} "
                                f"(try another --roi or --start)")
        raise TrackingError(f"no {self.colour.name} marker found in the first frame{later} "
                            f"(try --marker-color, --roi or --start)")


def _refuse_two_pendulums(arcs: list[Detection]) -> None:
    """Raise when two of the movers on pendulum arcs are alike in size and apart: two pendulums in view."""
    for i, a in enumerate(arcs):
        for b in arcs[i + 1:]:
            r = max(a.radius, b.radius)
            if (max(a.radius, b.radius) <= TWIN_RADIUS_RATIO * min(a.radius, b.radius)
                    and np.hypot(a.x - b.x, a.y - b.y) > TWIN_SEPARATION * r):
                raise TrackingError(f"two pendulums in view (markers swinging at ({a.x:.0f}, {a.y:.0f}) px and "
                                    f"({b.x:.0f}, {b.y:.0f}) px); pass --roi X,Y,W,H around the one to track")


def path_shape(path: np.ndarray, *, marker_radius: float, diagonal: float) -> str:
    """Is a moving candidate's path over the acquisition window a pendulum's arc?

    A pendulum's marker swings on a circle about a fixed point (the axle) near the frame:
    the path's positions lie on a circle, within their noise, of radius between
    :data:`ARC_MIN_RADIUS` marker radii and :data:`ARC_MAX_RADIUS` frame diagonals.

    Parameters
    ----------
    path : ndarray, shape (n, 2)
        Positions [px] over the window, in time order.
    marker_radius : float
        The candidate's radius [px].
    diagonal : float
        The frame's diagonal [px].

    Returns
    -------
    str
        ``"arc"``: curved, on such a circle within the noise (``max(ARC_TOL_PX, 0.1 radius)``);
        ``"not_arc"``: off every circle by more than twice the noise (an erratic path), on a
        circle too small or too large, or straight over a travel long enough that a
        pendulum's arc would bend by more than twice the noise; ``"unclear"``: fewer than
        :data:`ARC_MIN_POINTS` positions, or a short straight stretch.
    """
    p = np.asarray(path, float)
    if p.shape[0] < ARC_MIN_POINTS:
        return "unclear"
    tol = max(ARC_TOL_PX, 0.1 * marker_radius)
    r_max, r_min = ARC_MAX_RADIUS * diagonal, ARC_MIN_RADIUS * marker_radius
    q = p - p.mean(axis=0)
    line_rms = float(np.sqrt(max(np.linalg.eigvalsh(q.T @ q / p.shape[0])[0], 0.0)))
    travel = float(np.max(np.hypot(*(p[:, None, :] - p[None, :, :]).transpose(2, 0, 1))))
    if line_rms <= tol:
        return "not_arc" if travel * travel / (8 * r_max) > 2 * tol else "unclear"
    xc, yc, r = fit_circle_pratt(p[:, 0], p[:, 1])
    circle_rms = float(np.sqrt(np.mean((np.hypot(p[:, 0] - xc, p[:, 1] - yc) - r) ** 2)))
    if circle_rms <= 2 * tol and r_min <= r <= r_max:
        return "arc"
    return "not_arc"


def _follow(det: Detection, samples: list[list[Detection]], reach: float) -> tuple[float, list[float], np.ndarray]:
    """Follow a candidate through later searches: its largest distance from the start [px], its radii
    and its positions (the start's first), shape (n, 2) [px].

    Each search links the candidate of similar size nearest to the position predicted at
    constant velocity from the last two links (the last position until there are two), so a
    marker passing another object of its colour is not swapped for it.
    """
    x, y = det.x, det.y
    far = 0.0
    radii = []
    path = [(x, y)]
    links = [(-1, x, y)]  # (sample index, x, y) of the linked positions
    for k, cands in enumerate(samples):
        near = [c for c in cands if 1 / RADIUS_RATIO <= c.radius / det.radius <= RADIUS_RATIO]
        if not near:
            continue
        px, py = x, y
        if len(links) >= 2:
            (k1, x1, y1), (k2, x2, y2) = links[-2], links[-1]
            px, py = x2 + (x2 - x1) * (k - k2) / (k2 - k1), y2 + (y2 - y1) * (k - k2) / (k2 - k1)
        c = min(near, key=lambda c: (c.x - px) ** 2 + (c.y - py) ** 2)
        if np.hypot(c.x - x, c.y - y) > reach:
            continue
        x, y = c.x, c.y
        links.append((k, x, y))
        radii.append(c.radius)
        path.append((x, y))
        far = max(far, float(np.hypot(x - det.x, y - det.y)))
    return far, radii, np.asarray(path, float)


def track_frames(frames: Iterable, *, sampler: RawSampler, params: TrackParams, roi: tuple[int, ...] = (),
                 on_progress: Callable[[int], None] | None = None, progress_every: int = 32) -> TrackResult:
    """Track the marker through ``frames``.

    Parameters
    ----------
    frames : iterable of YuvFrame
        Frames in order (``index``, ``t``, planes ``y``, ``u``, ``v``). Frames are kept
        (not copied) from the acquisition's first search to the end of its motion window.
    sampler : RawSampler, WarpedRawSampler or CorrectedSampler
        Feature windows and coordinate system of the result; its colour finds the marker
        unless ``roi`` is given (then the colour learned from the ROI replaces the sampler's).
    params : TrackParams
    roi : (x, y, w, h), optional
        The marker's rectangle [px of the raw frame] in the first frame where it stands
        out in it; its colour is learned from it.
    on_progress : callable, optional
        Called with the number of frames just done (every ``progress_every`` frames).

    Returns
    -------
    TrackResult
        One row per frame; the frames before the acquisition (see :class:`_Acquirer`)
        have ``ok = False`` and NaN position and score.

    Raises
    ------
    TrackingError
        No frames, or no marker in any frame (message without the file name).
    """
    it = iter(frames)
    first = next(it, None)
    if first is None:
        raise TrackingError("no frames to track")
    acq = _Acquirer(chain([first], it), sampler=sampler, params=params, roi=roi)
    det, (template, tx, ty), acquisition, rest = acq.run()
    n0 = len(acq.skipped)
    idx: list[int] = [fr.index for fr in acq.skipped]
    ts: list[float] = [fr.t for fr in acq.skipped]
    xs: list[float] = [np.nan] * n0
    ys: list[float] = [np.nan] * n0
    scores: list[float] = [np.nan] * n0
    oks: list[bool] = [False] * n0
    acq.skipped.clear()
    pending = n0
    tracker = MarkerTracker(sampler, template, params)
    seeded = False
    for fr in rest:
        if not seeded:
            tracker._hist.append((fr.index - 1, tx, ty))  # seed: the detection predicts its own frame
            seeded = True
        x, y, s, ok = tracker.step(fr.index, fr.y, fr.u, fr.v)
        idx.append(fr.index)
        ts.append(fr.t)
        xs.append(x)
        ys.append(y)
        scores.append(s)
        oks.append(ok)
        pending += 1
        if on_progress is not None and pending >= progress_every:
            on_progress(pending)
            pending = 0
    if on_progress is not None and pending:
        on_progress(pending)
    drift = {"max_px": tracker.drift_max, "reanchors": tracker.reanchors, "limit_px": params.max_drift_px,
             "alarm": tracker.reanchors > 0}
    return TrackResult(
        frame=np.asarray(idx, np.int64), t=np.asarray(ts, float), x=np.asarray(xs, float), y=np.asarray(ys, float),
        score=np.asarray(scores, float), ok=np.asarray(oks, bool), detection=det,
        template_size=int(tracker.template.image.shape[0]), radius=float(tracker.template.radius),
        searches={"wide": tracker.n_wide, "whole_frame": tracker.n_whole}, acquisition=acquisition, drift=drift,
        match_scale=2 if tracker._half else 1,
    )
