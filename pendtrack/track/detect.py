"""Find the marker in one frame: by colour (whole frame) or inside a user-given ROI.

Both return a :class:`Detection` in raw frame coordinates: the feature-weighted centroid of
the marker's pixels, its equivalent radius and its contrast over the surroundings.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import NamedTuple

import cv2
import numpy as np

from pendtrack.track.colour import MarkerColour, floored, from_direction
from pendtrack.track.sampler import RawSampler

MIN_CONTRAST = 12.0  # feature levels (8-bit) the marker must stand above its surroundings
MIN_SIGMAS = 8.0  # ... and above this many robust standard deviations of the background
CANDIDATE_LEVELS = 3  # marker_candidates looks this many times, each below the brightest blobs found so far
MAX_HUE_DEG = 35.0  # a candidate's chroma must point within this angle of the marker colour's [deg]
# Splitting a ball off the bar it touches (_touching_discs), on the half-resolution grid:
CORE_SHARE = 0.7  # a disc's core: the top of a peak of depth (inscribed radius), cut at least this share deep
DEPTH_STEP = 1.25  # depths the blob is cut at, each this times the last (< 1 / CORE_SHARE: every peak is cut)
MIN_DISC_RADIUS = 2.0  # a disc's inscribed radius is at least this [half px] (a 4 px ball at full resolution)
MAX_SPLIT_AREA = 0.25  # blobs covering more of the frame are not split (the wall under a low threshold)
NEIGHBOUR_REACH = 3.0  # the neighbour: the blob's pixels within this many disc radii
DISC_RIM_PX = 2.0  # the disc's blurred rim: its inscribed circle grown by this is not the neighbour [half px]
NEIGHBOUR_PERCENTILE = 90.0  # the neighbour's level: this percentile of its feature
FLOOR_SHARE = 0.15  # the floor level sits this share of the way from the neighbour's level to the disc's
LEVEL_SAMPLES = 20_000  # the background and noise levels are medians of at least this many pixels (level_step)

_BOX3 = np.ones((3, 3), np.uint8)  # marker_candidates' masking (read-only)
_BOX5 = np.ones((5, 5), np.uint8)  # _refine's dilation (read-only)


@dataclass(frozen=True)
class Detection:
    """A marker found in a frame.

    Attributes
    ----------
    x, y : float
        Centre [raw px], feature-weighted centroid.
    radius : float
        Radius of the disc with the marker's area [px].
    contrast : float
        Marker feature level minus background level [8-bit levels].
    background : float
        Background feature level.
    colour : MarkerColour
        Feature weights used (learned from the ROI in ROI mode).
    """

    x: float
    y: float
    radius: float
    contrast: float
    background: float
    colour: MarkerColour

    def to_dict(self) -> dict[str, object]:
        return {"x": self.x, "y": self.y, "radius": self.radius, "contrast": self.contrast,
                "background": self.background, "colour": self.colour.to_dict()}


def _feature_levels(y: np.ndarray, u: np.ndarray, v: np.ndarray,
                    colour: MarkerColour) -> tuple[np.ndarray, float, float]:
    """Blurred half-resolution feature, its background level and the level a marker must reach."""
    feature = RawSampler(colour, width=1, height=1).whole_half(y, u, v)
    # blurred in place: a 2 MB temporary less per search at 1080p, and one less round of page faults
    half = cv2.GaussianBlur(feature, (3, 3), 0, dst=feature)
    s = level_step(half.size)
    bg = float(np.median(half[::s, ::s]))
    # noise from neighbour differences, blind to smooth lighting gradients (those of every s-th pixel)
    sigma = 1.4826 * float(np.median(np.abs(half[::s, 1::s] - half[::s, :-1:s]))) / np.sqrt(2) + 1e-6
    return half, bg, max(MIN_CONTRAST, MIN_SIGMAS * sigma)


def level_step(n: int) -> int:
    """Grid step [px] of the samples a frame's background and noise levels are the medians of.

    Every ``s``-th pixel in each axis, ``s`` the largest step keeping at least
    :data:`LEVEL_SAMPLES` of the ``n`` pixels (1 for small frames: every pixel). These
    levels are robust statistics of the background, which fills most of the frame: a
    regular sample of ~20 000 pixels estimates them as well (the very same levels on the
    benchmark's 720p and 1080p videos), 9-25 times faster than the whole frame of a
    720p/1080p video (~5 ms per median at 1080p, with the GIL held: the decoding thread waits).
    """
    return max(1, math.isqrt(n // LEVEL_SAMPLES))


class _Blob(NamedTuple):
    """A candidate blob of the half-resolution feature.

    Attributes
    ----------
    stat : ndarray, int32, shape (5,)
        Its box and area in ``connectedComponentsWithStats`` order (x, y, w, h, area) [half px].
    mass : float
        Its integrated contrast over the threshold [levels x half px^2].
    pixels : ndarray, bool
        Its pixels inside the box (shape (h, w)).
    floor_level : float or None
        The floor level of a disc split off a neighbour of the marker's colour (see
        :func:`_touching_discs`), None for a whole compact blob.
    """

    stat: np.ndarray
    mass: float
    pixels: np.ndarray
    floor_level: float | None = None


def _is_compact(w: int, h: int, area: float) -> bool:
    """A blob of box (w, h) and ``area`` [px] is compact: it fills >= 40 % of its box, aspect ratio <= 3."""
    return max(w, h) <= 3 * min(w, h) and area >= 0.4 * w * h


def _above(half: np.ndarray, thr: float, *,
           out: np.ndarray | None = None) -> tuple[np.ndarray, tuple[slice, slice] | None]:
    """``half > thr`` (uint8, a view of the bool mask, written into the bool array ``out`` if given) and
    the box (rows, columns) holding its pixels (None when there are none)."""
    mask = np.greater(half, thr, out=out).view(np.uint8)
    rows = np.flatnonzero(mask.any(axis=1))
    if rows.size == 0:
        return mask, None
    r0, r1 = int(rows[0]), int(rows[-1]) + 1
    cols = np.flatnonzero(mask[r0:r1].any(axis=0))
    return mask, np.s_[r0:r1, int(cols[0]):int(cols[-1]) + 1]


def _compact_blobs(half: np.ndarray, thr: float, *,
                   above: tuple[np.ndarray, tuple[slice, slice] | None] | None = None) -> list[_Blob]:
    """The compact blobs of ``half > thr`` (see :func:`find_marker`), and the discs split off the others
    (:func:`_touching_discs`); ``above``: :func:`_above` of the same, if the caller has it."""
    mask, box = _above(half, thr) if above is None else above
    hh, hw = half.shape
    if box is None:
        return []
    # label only the box holding every pixel above thr (often a few blobs in a corner of the frame: 4 ms saved
    # per level at 1080p); the components, their order and their stats are those of the whole frame
    r0, c0 = box[0].start, box[1].start
    n, labels, stats, _ = cv2.connectedComponentsWithStats(mask[box], connectivity=8)
    stats[:, 0] += c0
    stats[:, 1] += r0
    blobs = []
    for k in range(1, n):
        x, yb, w, h, area = stats[k]
        box = np.s_[yb:yb + h, x:x + w]  # the blob's bounding box: the mask of the whole frame costs 10x more
        pixels = labels[yb - r0:yb - r0 + h, x - c0:x - c0 + w] == k
        if w <= hw / 4 and h <= hh / 4 and _is_compact(w, h, area):
            blobs.append(_Blob(stats[k], float((half[box][pixels] - thr).sum()), pixels))
        elif area <= MAX_SPLIT_AREA * hw * hh:  # larger: the background itself (a low threshold), no bar
            blobs.extend(_touching_discs(half[box], pixels, (int(x), int(yb)), thr))
    return blobs


def _touching_discs(feature: np.ndarray, pixels: np.ndarray, origin: tuple[int, int], thr: float) -> list[_Blob]:
    """Discs of a non-compact blob: a marker touching a thinner thing of its colour (a dark ball on a dark bar).

    The distance transform of the blob is its inscribed radius at each pixel: about the
    ball's radius at its centre, at most half the bar's width along the bar. Cut at depths
    ``t`` from :data:`MIN_DISC_RADIUS` on, each :data:`DEPTH_STEP` times the last, the blob's
    parts at least ``t`` deep are peaks of depth; one no deeper than ``t / CORE_SHARE``
    (the top of its peak, not a cut through a wider region such as the floor the bar ends
    on) and compact is a disc's core, when the bar is narrower than ``CORE_SHARE`` of the
    ball. The blob's pixels around the disc (its inscribed circle grown by
    :data:`DISC_RIM_PX`, out to :data:`NEIGHBOUR_REACH` radii) are the neighbour; its level
    (:data:`NEIGHBOUR_PERCENTILE`-th percentile) plus :data:`FLOOR_SHARE` of the gap to the
    core's median is the disc's floor level: below it everything is background (see
    :func:`pendtrack.track.colour.floored`). A disc standing less than :data:`MIN_CONTRAST`
    above its neighbour is dropped.

    Parameters
    ----------
    feature : ndarray, float32
        Half-resolution feature in the blob's box.
    pixels : ndarray, bool
        The blob's pixels in the box.
    origin : (int, int)
        The box's top-left corner in the half-resolution frame [half px].
    thr : float
        The level the blob was cut at.

    Returns
    -------
    list of _Blob
        One per disc: its box (the inscribed circle's) [half px of the frame], its mass over
        its floor level, its pixels and the floor level.
    """
    depth = cv2.distanceTransform(np.pad(pixels, 1).view(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)[1:-1, 1:-1]
    deepest = float(depth.max())
    out: list[_Blob] = []
    seen: set[tuple[int, int]] = set()
    t = MIN_DISC_RADIUS
    while t <= deepest:
        n, labels, stats, _ = cv2.connectedComponentsWithStats((depth >= t).view(np.uint8), connectivity=8)
        for k in range(1, n):
            x, yb, w, h, area = stats[k]
            if not _is_compact(w, h, area):
                continue
            box = np.s_[yb:yb + h, x:x + w]
            core = labels[box] == k
            local = np.where(core, depth[box], 0.0)
            j = int(np.argmax(local))
            centre = (int(yb) + j // int(w), int(x) + j % int(w))
            if float(local.max()) * CORE_SHARE > t or centre in seen:
                continue
            seen.add(centre)
            disc = _disc(feature, pixels, centre, float(local.max()), float(np.median(feature[box][core])), origin, thr)
            if disc is not None:
                out.append(disc)
        t *= DEPTH_STEP
    return out


def _disc(feature: np.ndarray, pixels: np.ndarray, centre: tuple[int, int], radius: float, top: float,
          origin: tuple[int, int], thr: float) -> _Blob | None:
    """The disc of inscribed ``radius`` [half px] at ``centre`` (row, column of the blob's box), core level
    ``top``, with its floor level from its neighbour (see :func:`_touching_discs`), or None."""
    reach = NEIGHBOUR_REACH * radius + DISC_RIM_PX
    near = _around(pixels.shape, centre, int(np.ceil(reach)))  # every pixel within reach: a blob's box is large
    feature, pixels = feature[near], pixels[near]
    cy, cx = centre[0] - near[0].start, centre[1] - near[1].start
    yy, xx = np.ogrid[:pixels.shape[0], :pixels.shape[1]]
    d2 = (xx - cx) ** 2 + (yy - cy) ** 2
    inside = d2 <= (radius + DISC_RIM_PX) ** 2
    neighbour = feature[pixels & ~inside & (d2 <= reach ** 2)]
    if neighbour.size == 0:
        return None
    level = percentile_of(neighbour, NEIGHBOUR_PERCENTILE)
    if top - level < MIN_CONTRAST:
        return None
    floor_level = level + FLOOR_SHARE * (top - level)
    box = _around(pixels.shape, (cy, cx), int(np.ceil(radius)))
    disc = (pixels & inside)[box]
    by, bx = box[0].start, box[1].start
    stat = np.array([origin[0] + near[1].start + bx, origin[1] + near[0].start + by, disc.shape[1], disc.shape[0],
                     int(disc.sum())], np.int32)
    mass = float(np.clip(feature[box][disc] - max(thr, floor_level), 0, None).sum())
    return _Blob(stat, mass, disc, floor_level)


def _around(shape: tuple[int, ...], centre: tuple[int, int], r: int) -> tuple[slice, slice]:
    """Rows and columns within ``r`` [px] of ``centre`` (row, column), clipped to an array of ``shape``."""
    cy, cx = centre
    return np.s_[max(cy - r, 0):min(cy + r + 1, shape[0]), max(cx - r, 0):min(cx + r + 1, shape[1])]


def _refine_blob(y: np.ndarray, u: np.ndarray, v: np.ndarray, colour: MarkerColour,
                 blob: _Blob) -> Detection | None:
    """Refine a half-resolution blob at full resolution; a disc split off a neighbour (:func:`_touching_discs`)
    on the feature raised to its floor level, which its detection's colour keeps."""
    if blob.floor_level is not None:
        colour = replace(colour, floor_level=blob.floor_level)
    x, yb, w, h, _ = blob.stat
    # refine at full resolution in a window around the blob (half-res sample i at 2i + 0.5)
    pad = max(w, h) + 4
    x0, y0 = max(2 * (x - pad), 0), max(2 * (yb - pad), 0)
    x1, y1 = min(2 * (x + w + pad), y.shape[1]), min(2 * (yb + h + pad), y.shape[0])
    window = RawSampler(colour, width=y.shape[1], height=y.shape[0]).window(y, u, v, x0, y0, x1 - x0, y1 - y0)
    return _refine(floored(window, colour), x0, y0, colour)


def find_marker(y: np.ndarray, u: np.ndarray, v: np.ndarray, colour: MarkerColour) -> Detection | None:
    """The most marker-like compact blob of the frame, or None when nothing stands out.

    Parameters
    ----------
    y, u, v : ndarray, uint8
        4:2:0 planes of the frame.
    colour : MarkerColour
        Feature weights.

    Notes
    -----
    On the half-resolution feature: background = median, noise = 1.4826 MAD of neighbour
    differences / sqrt(2), both over a grid sample of large frames (:func:`level_step`); the marker
    must exceed the background by :data:`MIN_CONTRAST` levels and :data:`MIN_SIGMAS`
    noise. Blobs above half the peak contrast are candidates; the one with the largest
    integrated contrast among compact ones (filling >= 40 % of their bounding box, aspect
    ratio <= 3, smaller than a quarter of the frame) wins, and is then refined at full resolution.
    """
    half, bg, floor = _feature_levels(y, u, v, colour)
    peak = float(half.max())
    if peak - bg < floor:
        return None
    blobs = _compact_blobs(half, bg + 0.5 * (peak - bg))
    if not blobs:
        return None
    return _refine_blob(y, u, v, colour, max(blobs, key=lambda b: b.mass))


def marker_candidates(y: np.ndarray, u: np.ndarray, v: np.ndarray, colour: MarkerColour, *,
                      levels: int = CANDIDATE_LEVELS) -> list[Detection]:
    """Every marker-like compact blob of the frame (at most a few levels of contrast), largest first.

    As :func:`find_marker`, but keeps every compact blob above half the peak contrast,
    then masks the pixels above that threshold and repeats with the peak of the rest (up
    to ``levels`` times), so a fainter marker beside a brighter object of its colour is
    kept. A chroma colour's blob must also *have* that colour: the mean (Cb, Cr) of its
    pixels minus the frame's median must point within :data:`MAX_HUE_DEG` of the colour's
    chroma direction (skin is reddish, not pink).

    Returns
    -------
    list of Detection
        Refined at full resolution, without duplicates (centres closer than a radius),
        largest radius first; empty when nothing stands out.
    """
    work, bg, floor = _feature_levels(y, u, v, colour)  # masked level by level (a new array: no copy)
    above_thr = np.empty(work.shape, bool)  # each level's mask, in one buffer (fewer page faults at 1080p)
    out: list[Detection] = []
    du0 = dv0 = 0.0
    if colour.uses_chroma:
        du0, dv0 = float(np.median(u[::4, ::4])), float(np.median(v[::4, ::4]))
    cos_min = float(np.cos(np.radians(MAX_HUE_DEG)))
    for _ in range(levels):
        peak = float(work.max())
        if peak - bg < floor:
            break
        thr = bg + 0.5 * (peak - bg)
        mask, above = _above(work, thr, out=above_thr)
        for blob in _compact_blobs(work, thr, above=(mask, above)):
            bx, by, bw, bh = (int(a) for a in blob.stat[:4])
            if colour.uses_chroma:
                box = np.s_[by:by + bh, bx:bx + bw]
                bu, bv = u[box][blob.pixels], v[box][blob.pixels]
                # their means (exact integer sums: np.mean's values without its overhead)
                du, dv = int(bu.sum()) / bu.size - du0, int(bv.sum()) / bv.size - dv0
                norm = np.hypot(du, dv) * np.hypot(colour.wu, colour.wv)
                if norm <= 0 or (du * colour.wu + dv * colour.wv) / norm < cos_min:
                    continue
            det = _refine_blob(y, u, v, colour, blob)
            if det is None:
                continue
            cx, cy = 2 * (bx + bw / 2), 2 * (by + bh / 2)
            if np.hypot(det.x - cx, det.y - cy) > max(bw, bh) + 2:
                continue  # the refinement went to a neighbour
            if any(np.hypot(det.x - o.x, det.y - o.y) < max(det.radius, o.radius) for o in out):
                continue
            out.append(det)
        if above is not None:  # mask the pixels above thr and their neighbours (only around them: the same)
            rows, cols = above
            near = np.s_[max(rows.start - 1, 0):rows.stop + 1, max(cols.start - 1, 0):cols.stop + 1]
            work[near][cv2.dilate(mask[near], _BOX3).view(bool)] = bg
    return sorted(out, key=lambda d: -d.radius)


def median_of(a: np.ndarray) -> float:
    """``np.median(a)`` of a non-empty array without NaNs -- the same value (the mean of its middle one or two
    order statistics, as NumPy takes it) -- without NumPy's generic reduction machinery, which triples the
    time on the small arrays of :func:`_refine` (a search frame refines ~18 blobs at 1080p)."""
    flat = a.ravel()
    n = flat.size
    if n < 2:
        return float(np.median(flat))
    k = n // 2
    part = np.partition(flat, (k - 1, k))
    return float(part[k - 1:k + 1].mean() if n % 2 == 0 else part[k:k + 1].mean())


def percentile_of(a: np.ndarray, q: float) -> float:
    """``np.percentile(a, q)`` (its default, linear method) of a non-empty float array without NaNs -- the
    same value, interpolated as NumPy does (in the array's dtype) -- without its generic machinery, which
    costs ~0.1 ms a call, most of :func:`_refine`'s time on the small windows of a search frame's blobs.

    Parameters
    ----------
    a : ndarray
        Values (any shape; float).
    q : float
        Percentile, in [0, 100].

    Returns
    -------
    float
        The percentile, in the units of ``a``.
    """
    flat = a.ravel()
    n = flat.size
    virtual = (n - 1) * (q / 100)
    lo = math.floor(virtual)
    if virtual >= n - 1:
        return float(flat.max())
    part = np.partition(flat, (lo, lo + 1))
    below, above = part[lo], part[lo + 1]
    gamma = virtual - lo
    diff = above - below
    return float(above - diff * (1 - gamma) if gamma >= 0.5 else below + diff * gamma)


def _refine(f: np.ndarray, x0: int, y0: int, colour: MarkerColour) -> Detection | None:
    """Centroid of the brightest blob of a feature window; ``(x0, y0)`` its frame offset."""
    bg = median_of(np.concatenate([f[0], f[-1], f[:, 0], f[:, -1]]))
    peak = percentile_of(f, 99.5)
    if peak - bg <= 0:
        return None
    thr = bg + 0.5 * (peak - bg)
    n, labels, stats, _ = cv2.connectedComponentsWithStats((f > thr).view(np.uint8), connectivity=8)
    if n < 2:
        return None
    k = 1
    if n > 2:  # each blob's mass above thr, in one pass (not a mask of the window per blob)
        k += int(np.argmax(np.bincount(labels.ravel(), weights=(f - np.float32(thr)).ravel(), minlength=n)[1:]))
    area = float(stats[k, cv2.CC_STAT_AREA])
    radius = float(np.sqrt(area / np.pi))
    # weights: contrast over the background inside the blob grown by 2 px (soft edges count)
    blob = labels == k
    grown = cv2.dilate(blob.view(np.uint8), _BOX5).view(bool)
    wgt = np.where(grown, np.clip(f - bg, 0, None), 0.0)
    total = float(wgt.sum())
    cx = float(wgt.sum(axis=0) @ np.arange(f.shape[1]) / total)
    cy = float(wgt.sum(axis=1) @ np.arange(f.shape[0]) / total)
    contrast = median_of(f[blob]) - bg
    return Detection(x0 + cx, y0 + cy, radius, contrast, bg, colour)


def marker_in_roi(y: np.ndarray, u: np.ndarray, v: np.ndarray, roi: tuple[int, int, int, int]) -> Detection | None:
    """The marker inside a rectangle ``(x, y, w, h)`` [raw px], its colour learned from the ROI.

    The feature direction is the mean Y, Cb, Cr of the ROI's central disc (radius 0.3 of the
    smaller side) minus that of its 2-px outer frame: whatever makes the marker differ from
    what surrounds it (dark on pale, pink on grey, ...).

    Returns None when the ROI has no contrast.
    """
    x0, y0, w, h = (int(a) for a in roi)
    h_img, w_img = y.shape
    x0, y0 = max(x0, 0), max(y0, 0)
    w, h = min(w, w_img - x0), min(h, h_img - y0)
    if w < 5 or h < 5:
        return None
    planes = []
    for k, (wy, wu, wv) in enumerate(((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))):
        probe = MarkerColour(f"c{k}", wy, wu, wv)
        planes.append(RawSampler(probe, width=w_img, height=h_img).window(y, u, v, x0, y0, w, h))
    yy, xx = np.indices((h, w))
    core = (xx - (w - 1) / 2) ** 2 + (yy - (h - 1) / 2) ** 2 <= (0.3 * min(w, h)) ** 2
    frame = np.zeros((h, w), bool)
    frame[:2], frame[-2:], frame[:, :2], frame[:, -2:] = True, True, True, True
    d = [float(p[core].mean() - p[frame].mean()) for p in planes]
    if np.sqrt(sum(c * c for c in d)) < 0.5 * 12.0:
        return None
    colour = from_direction("roi", *d)
    f = sum(np.float32(wt) * p for wt, p in zip((colour.wy, colour.wu, colour.wv), planes))
    return _refine(np.asarray(f, np.float32), x0, y0, colour)
