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
3. **Refine** the peak to sub-pixel (quadric fit of the score surface, or the
   feature-weighted centroid of the marker, see ``refine``).
4. **Accept** when the score is at least ``min_score`` (the analogue of Tracker's
   automark) and the matched patch's contrast (feature standard deviation) is within a
   factor ``1 / min_contrast_ratio`` of the template's -- the normalised score alone is
   blind to contrast and would happily match faint texture where the marker is hidden.
   Otherwise the frame is kept with ``ok = False``, its best score and the position of
   its best (rejected) candidate, never used as a prediction.

The template is cut from the first frame around the detected marker (by colour or in a
user ROI) and, with ``evolution_rate`` a > 0, blended each ok frame as
``template = (1 - a) template + a patch`` (Tracker's evolution rate; 0 in the paper).
Coordinates are those of the sampler: raw frame px (:class:`RawSampler`; with a fisheye,
:class:`WarpedRawSampler` keeps the template in corrected space and warps it to the lens'
local distortion at each position), or lens-corrected px (:class:`CorrectedSampler`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass

import cv2
import numpy as np

from pendtrack.errors import TrackingError
from pendtrack.track.colour import MarkerColour
from pendtrack.track.detect import Detection, find_marker, marker_in_roi
from pendtrack.track.match import match_template, weighted_centroid
from pendtrack.track.sampler import RawSampler

REFINE_METHODS = ("quadratic", "centroid")
WARP_TOLERANCE = 1e-2  # re-warp the template when an entry of the lens Jacobian changed by more than this
TEMPLATE_REACH = 1.3  # template half-side in marker radii (+ 2 px): the marker and a rim of surroundings


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
    """

    min_score: float = 0.6
    search_margin_px: int = 48
    quick_margin_px: int = 6
    evolution_rate: float = 0.0
    refine: str = "quadratic"
    max_coast_frames: int = 30
    min_contrast_ratio: float = 0.3

    def __post_init__(self) -> None:
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

    @property
    def ok_fraction(self) -> float:
        return float(self.ok.mean()) if self.ok.size else 0.0

    def to_dict(self) -> dict[str, object]:
        return {"n_frames": int(self.frame.size), "n_ok": int(self.ok.sum()), "ok_fraction": self.ok_fraction,
                "detection": self.detection.to_dict(), "template_size": self.template_size, "radius_px": self.radius,
                "searches": dict(self.searches)}


class _Template:
    """The template (float32, odd square side) and what the centroid refinement needs."""

    def __init__(self, image: np.ndarray, radius: float, contrast: float) -> None:
        self.image = np.ascontiguousarray(image, dtype=np.float32)
        self.std = float(self.image.std())
        self.half = image.shape[0] // 2
        self.radius = radius
        self.contrast = contrast
        self._small: np.ndarray | None = None

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


def detect_first(y: np.ndarray, u: np.ndarray, v: np.ndarray, *, colour: MarkerColour,
                 roi: tuple[int, ...] = ()) -> Detection:
    """The marker in the first frame: inside ``roi`` (x, y, w, h) if given, else by colour.

    Raises
    ------
    TrackingError
        Nothing marker-like (no path: the caller adds the file).
    """
    if roi:
        if len(roi) != 4 or roi[2] < 5 or roi[3] < 5:
            raise TrackingError(f"roi must be x, y, w, h with w, h >= 5 px, got {tuple(roi)}")
        det = marker_in_roi(y, u, v, tuple(int(a) for a in roi))  # type: ignore[arg-type]
        if det is None:
            raise TrackingError(f"no marker stands out in the roi {tuple(roi)} of the first frame")
        return det
    det = find_marker(y, u, v, colour)
    if det is None:
        raise TrackingError(f"no {colour.name} marker found in the first frame (try --marker-color or --roi)")
    return det


def make_template(sampler: RawSampler, y: np.ndarray, u: np.ndarray, v: np.ndarray,
                  det: Detection) -> tuple[_Template, float, float]:
    """Cut the template around a detection; returns it and the centre in tracking coordinates.

    With a :class:`~pendtrack.track.sampler.WarpedRawSampler` the template is cut in
    corrected space (and warped per position by the tracker).
    """
    if getattr(sampler, "warps_template", False):
        csam = sampler.corrected_sampler  # type: ignore[attr-defined]
        tpl, _, _ = make_template(csam, y, u, v, det)
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
    win = sampler.window(y, u, v, x0, y0, x1 - x0, y1 - y0)
    image = cv2.getRectSubPix(win, (side, side), (tx - x0, ty - y0))
    return _Template(image, radius, det.contrast), tx, ty


class MarkerTracker:
    """Frame-by-frame tracking state (prediction history, template, counters).

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
        self._warp_key: tuple[int, int] | None = None
        self._warp_jac: tuple[float, float, float, float] | None = None
        self._warped: tuple[np.ndarray, float] = (template.image, template.std)

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
            a, b, c, d = jac
            det = a * d - b * c
            ia, ib, ic, idd = d / det, -b / det, -c / det, a / det  # raw offset -> corrected offset
            canon = self.template.image
            hc = (canon.shape[0] - 1) / 2.0
            grow = max(abs(a) + abs(b), abs(c) + abs(d))
            hr = int(np.ceil(hc * grow))
            side = 2 * hr + 1
            m = np.array([[ia, ib, hc - (ia + ib) * hr], [ic, idd, hc - (ic + idd) * hr]])
            img = cv2.warpAffine(canon, m, (side, side), flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                                 borderMode=cv2.BORDER_REPLICATE)
            self._warped = (img, float(cv2.meanStdDev(img)[1][0, 0]))
            self._warp_jac = jac
        self._warp_key = key
        return self._warped

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
        tpl_img, tpl_std = self._template_at(px, py)
        half = tpl_img.shape[0] // 2
        reach = half + margin
        cx, cy = int(round(px)), int(round(py))
        x0, y0 = max(cx - reach, 0), max(cy - reach, 0)
        x1, y1 = min(cx + reach + 1, self.sampler.width), min(cy + reach + 1, self.sampler.height)
        if x1 - x0 <= 2 * half or y1 - y0 <= 2 * half:
            return None
        win = self.sampler.window(y, u, v, x0, y0, x1 - x0, y1 - y0)
        m = match_template(win, tpl_img)
        if m is None:
            return None
        edge = ((m.ix == 0 and x0 > 0) or (m.iy == 0 and y0 > 0)
                or (m.ix == m.nx - 1 and x1 < self.sampler.width) or (m.iy == m.ny - 1 and y1 < self.sampler.height))
        side = tpl_img.shape[0]
        ratio = float(cv2.meanStdDev(win[m.iy:m.iy + side, m.ix:m.ix + side])[1][0, 0]) / (tpl_std + 1e-12)
        r = self.params.min_contrast_ratio
        return m.score, x0 + m.x, y0 + m.y, edge, win, x0, y0, r <= ratio <= 1.0 / r

    def _whole_frame(self, y: np.ndarray, u: np.ndarray, v: np.ndarray) -> tuple[float, float] | None:
        """Coarse marker centre from a half-resolution whole-frame search."""
        self.n_whole += 1
        f = self.sampler.whole_half(y, u, v)
        small = self.template.small
        if f.shape[0] < small.shape[0] or f.shape[1] < small.shape[1]:
            return None
        scores = cv2.matchTemplate(f, small, cv2.TM_CCOEFF_NORMED)
        _, _, _, (ix, iy) = cv2.minMaxLoc(scores)
        c = (small.shape[0] - 1) / 2.0
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
            cwin = cs.window(y, u, v, wx0, wy0, 2 * pad + 2, 2 * pad + 2)
            patch = cv2.getRectSubPix(cwin, shape, (cx - wx0, cy - wy0))
            self._warp_key = None
            self._warp_jac = None
        else:
            patch = cv2.getRectSubPix(win, shape, (mx - x0, my - y0))
        self.template.evolve(patch, self.params.evolution_rate)

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
        Frames in order (``index``, ``t``, planes ``y``, ``u``, ``v``).
    sampler : RawSampler, WarpedRawSampler or CorrectedSampler
        Feature windows and coordinate system of the result; its colour finds the marker
        in the first frame unless ``roi`` is given (then the colour learned from the ROI
        replaces the sampler's).
    params : TrackParams
    roi : (x, y, w, h), optional
        The marker's rectangle in the first (raw) frame [px]; its colour is learned from it.
    on_progress : callable, optional
        Called with the number of frames just done (every ``progress_every`` frames).

    Returns
    -------
    TrackResult

    Raises
    ------
    TrackingError
        No frames, or no marker in the first frame (message without the file name).
    """
    idx: list[int] = []
    ts: list[float] = []
    xs: list[float] = []
    ys: list[float] = []
    scores: list[float] = []
    oks: list[bool] = []
    tracker: MarkerTracker | None = None
    det: Detection | None = None
    pending = 0
    for fr in frames:
        if tracker is None:
            det = detect_first(fr.y, fr.u, fr.v, colour=sampler.colour, roi=roi)
            if det.colour is not sampler.colour:
                sampler.colour = det.colour
            template, tx, ty = make_template(sampler, fr.y, fr.u, fr.v, det)
            tracker = MarkerTracker(sampler, template, params)
            tracker._hist.append((fr.index - 1, tx, ty))  # seed: the detection predicts frame 0
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
    if tracker is None or det is None:
        raise TrackingError("no frames to track")
    return TrackResult(
        frame=np.asarray(idx, np.int64), t=np.asarray(ts, float), x=np.asarray(xs, float), y=np.asarray(ys, float),
        score=np.asarray(scores, float), ok=np.asarray(oks, bool), detection=det,
        template_size=int(tracker.template.image.shape[0]), radius=float(tracker.template.radius),
        searches={"wide": tracker.n_wide, "whole_frame": tracker.n_whole},
    )
