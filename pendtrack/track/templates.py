"""The marker's template: :class:`_Template` and its cutting around a detection (:func:`make_template`,
on the full and the half-resolution grid), the feature windows with the marker's dips filled that the
template and every search window are cut from (:func:`filled_window`), the template warped to the
lens' local distortion (:func:`warp_template`) and the drift of an evolving template from the first
(:func:`template_drift`)."""

from __future__ import annotations

import cv2
import numpy as np

from pendtrack.errors import TrackingError
from pendtrack.track.colour import floored
from pendtrack.track.detect import Detection
from pendtrack.track.match import fill_holes, fill_reach, match_template
from pendtrack.track.sampler import RawSampler

TEMPLATE_REACH = 1.3  # template half-side in marker radii (+ 2 px): the marker and a rim of surroundings
# A marker of at least this radius [px] is matched on the half-resolution (chroma) grid of a raw frame (see
# pendtrack.track.tracker.MarkerTracker): still >= 12 samples of radius there, more than the 960x540 sticker case
# (21 px radius at full resolution, its chroma on a grid of half that) whose theta meets the target, and the filling
# and matching cost a quarter to a sixth (measured on the 1080p blue ball, 43 px: 0.61 -> 0.14 ms filling,
# 0.32 -> 0.07 ms matching).
HALF_RES_RADIUS_PX = 24.0


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
    if not sampler.can_cut(x0, y0, x1, y1):
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
    if half:
        gx0, gy0 = max(x0 - k, 0), max(y0 - k, 0)
        gx1, gy1 = min(x0 + w + k, sampler.half_width), min(y0 + h + k, sampler.half_height)
    else:
        gx0, gy0, gx1, gy1 = sampler.cuttable(x0 - k, y0 - k, x0 + w + k, y0 + h + k)
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
