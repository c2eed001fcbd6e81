"""Follow the marker through a sequence of frames (Tracker-style template tracking): :func:`track_frames`,
the per-frame state and step :class:`MarkerTracker`, and the track :class:`TrackResult`.

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
objects of its colour by its motion (:class:`pendtrack.track.acquisition._Acquirer`); earlier
frames are kept with ``ok = False``. The template (:mod:`pendtrack.track.templates`) is cut
from that frame around the detected marker (by colour or in a user ROI) and, with
``evolution_rate`` a > 0, blended each ok frame as ``template = (1 - a) template + a patch``
(Tracker's evolution rate; 0 in the paper). An
evolving template is compared with the first every few frames and shifted back onto it
when its content has drifted more than ``max_drift_px`` (the drift alarm of the result).
Coordinates are those of the sampler: raw frame px (:class:`RawSampler`; with a fisheye,
:class:`WarpedRawSampler` keeps the template in corrected space and warps it to the lens'
local distortion at each position), or lens-corrected px (:class:`CorrectedSampler`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from itertools import chain

import cv2
import numpy as np

from pendtrack.errors import TrackingError
from pendtrack.track.acquisition import _Acquirer
from pendtrack.track.colour import floored
from pendtrack.track.detect import Detection
from pendtrack.track.match import match_template, weighted_centroid
from pendtrack.track.params import TrackParams
from pendtrack.track.sampler import RawSampler
from pendtrack.track.templates import _Template, filled_window, template_drift, warp_template

log = logging.getLogger(__name__)

DRIFT_CHECK_EVERY = 8  # evolutions between two measurements of the template's drift
WARP_TOLERANCE = 1e-2  # re-warp the template when an entry of the lens Jacobian changed by more than this
# A whole-frame search takes, among the half-resolution peaks scoring within this of the best, the one nearest
# the last ok position: a second pendulum of the same look is not swapped in when the marker is lost a moment.
WHOLE_FRAME_SCORE_BAND = 0.1
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
        :data:`pendtrack.track.templates.HALF_RES_RADIUS_PX`, see :class:`MarkerTracker`).
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


class MarkerTracker:
    """Frame-by-frame tracking state (prediction history, template, counters).

    A marker of at least :data:`pendtrack.track.templates.HALF_RES_RADIUS_PX` in raw frames (a phone's
    1080p ball) is filled and matched on the half-resolution grid (the chroma planes' own grid, luma
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
            if not cs.can_cut(wx0, wy0, wx0 + 2 * pad + 2, wy0 + 2 * pad + 2):
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
        One row per frame; the frames before the acquisition (see
        :class:`pendtrack.track.acquisition._Acquirer`) have ``ok = False`` and NaN position and score.

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
