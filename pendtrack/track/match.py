"""Template matching with a normalised score and sub-pixel peak refinement.

Score: OpenCV's ``TM_CCOEFF_NORMED``, the Pearson correlation of the template with the
image patch under it, in [-1, 1] and invariant to the patch's brightness and contrast.
A template of size (th, tw) whose centre is ``((tw - 1) / 2, (th - 1) / 2)`` matched at
integer offset ``(i, j)`` of a window puts the marker centre at ``(i + (tw - 1) / 2,
j + (th - 1) / 2)`` in window coordinates.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np


@dataclass(frozen=True)
class Match:
    """Best match in a window.

    Attributes
    ----------
    score : float
        Normalised correlation at the integer peak, [-1, 1].
    x, y : float
        Marker centre in window coordinates [px], sub-pixel.
    ix, iy : int
        Integer peak in the score map (template top-left offset in the window).
    nx, ny : int
        Size of the score map (columns, rows).
    """

    score: float
    x: float
    y: float
    ix: int
    iy: int
    nx: int
    ny: int


def quadratic_peak(s: np.ndarray) -> tuple[float, float]:
    """Offset ``(dx, dy)`` of the maximum of the least-squares quadric through a 3x3 patch.

    Parameters
    ----------
    s : ndarray, shape (3, 3)
        Scores around an integer peak, ``s[1, 1]`` the peak; rows are y, columns x.

    Returns
    -------
    (dx, dy) : float
        Sub-pixel offset from the centre, each clipped to [-1, 1]. Falls back to separate
        1-D parabolas when the quadric is not a maximum.
    """
    (s00, s01, s02), (s10, s11, s12), (s20, s21, s22) = np.asarray(s, dtype=float).tolist()
    # quadric a + b x + c y + d x^2 + e x y + f y^2 on x, y in {-1, 0, 1} (orthogonal basis)
    c0, c1, c2 = s00 + s10 + s20, s01 + s11 + s21, s02 + s12 + s22  # column sums (x = -1, 0, 1)
    r0, r1, r2 = s00 + s01 + s02, s10 + s11 + s12, s20 + s21 + s22  # row sums (y = -1, 0, 1)
    b = (c2 - c0) / 6.0
    c = (r2 - r0) / 6.0
    d = (c0 + c2 - 2.0 * c1) / 6.0
    f = (r0 + r2 - 2.0 * r1) / 6.0
    e = (s22 - s20 - s02 + s00) / 4.0
    det = 4.0 * d * f - e * e
    if d < 0 and f < 0 and det > 0:
        dx = (e * c - 2.0 * f * b) / det
        dy = (e * b - 2.0 * d * c) / det
    else:
        dx = _parabola(s10, s11, s12)
        dy = _parabola(s01, s11, s21)
    return min(max(dx, -1.0), 1.0), min(max(dy, -1.0), 1.0)


def _parabola(a: float, b: float, c: float) -> float:
    den = a - 2.0 * b + c
    return 0.0 if den >= 0 else 0.5 * (a - c) / den


def match_template(window: np.ndarray, template: np.ndarray) -> Match | None:
    """Best match of ``template`` in ``window`` (both float32), or None if the window is too small.

    The integer peak of the score map is refined with :func:`quadratic_peak` (on the
    interior only; an edge peak keeps its integer position).
    """
    th, tw = template.shape
    if window.shape[0] < th or window.shape[1] < tw:
        return None
    scores = cv2.matchTemplate(window, template, cv2.TM_CCOEFF_NORMED)
    _, best, _, (ix, iy) = cv2.minMaxLoc(scores)
    sh, sw = scores.shape
    fx, fy = float(ix), float(iy)
    if 0 < ix < sw - 1 and 0 < iy < sh - 1:
        dx, dy = quadratic_peak(scores[iy - 1:iy + 2, ix - 1:ix + 2])
        fx += dx
        fy += dy
    return Match(float(best), fx + (tw - 1) / 2.0, fy + (th - 1) / 2.0, ix, iy, sw, sh)


def weighted_centroid(window: np.ndarray, x: float, y: float, radius: float, background: float,
                      threshold: float) -> tuple[float, float] | None:
    """Centroid of ``window - background`` above ``threshold`` inside a disc.

    Parameters
    ----------
    window : ndarray, float32
        Feature window.
    x, y : float
        Centre of the disc [window px].
    radius : float
        Disc radius [px].
    background : float
        Feature level of the surroundings, subtracted before weighting.
    threshold : float
        Weights below this (after subtracting the background) count as 0.

    Returns
    -------
    (x, y) or None
        Weighted centroid [window px]; None if no weight.
    """
    h, w = window.shape
    x0, x1 = max(int(np.floor(x - radius)), 0), min(int(np.ceil(x + radius)) + 1, w)
    y0, y1 = max(int(np.floor(y - radius)), 0), min(int(np.ceil(y + radius)) + 1, h)
    if x1 <= x0 or y1 <= y0:
        return None
    patch = window[y0:y1, x0:x1] - np.float32(background)
    yy, xx = np.mgrid[y0:y1, x0:x1]
    inside = (xx - x) ** 2 + (yy - y) ** 2 <= radius * radius
    wgt = np.where(inside & (patch > threshold), patch, 0.0)
    total = float(wgt.sum())
    if total <= 0:
        return None
    return float((wgt * xx).sum() / total), float((wgt * yy).sum() / total)




def fill_reach(radius_px: float) -> int:
    """Reach [px] of the octagon :func:`fill_holes` closes with (its inradius, ``radius_px`` rounded);
    0 below one pixel. A feature window must extend this far beyond the pixels whose filled values
    are used (the closing looks that far around each)."""
    return int(round(radius_px)) if radius_px >= 1.0 else 0


_CROSS = np.array([[0, 1, 0], [1, 1, 1], [0, 1, 0]], np.uint8)  # cv2.MORPH_CROSS (3, 3)


@lru_cache(maxsize=16)  # one marker size per track: built once, not per frame (read-only kernels)
def _octagon_passes(k: int) -> tuple[np.ndarray | None, int]:
    """A near-regular octagon of inradius ``k`` as a square (half side ``k - b``) dilated ``b`` times by a
    3x3 cross, b = k / (1 + 1/sqrt(2)): OpenCV dilates by a square in separable passes and by the
    cross in one cheap pass each: measured 2.2 ms against 14 ms for a disc kernel at k = 32 on a
    166 px window (a 1080p ball)."""
    b = max(1, int(round(k / (1.0 + 1.0 / np.sqrt(2.0)))))
    a = k - b
    square = cv2.getStructuringElement(cv2.MORPH_RECT, (2 * a + 1, 2 * a + 1)) if a > 0 else None
    return square, b


def fill_holes(feature: np.ndarray, radius_px: float, *, level: float | None = None,
               box: tuple[slice, slice] | None = None) -> np.ndarray:
    """The feature with the dips inside a marker filled: a grey closing with a flat octagon.

    A sticker of another colour on a ball turns with it; matched against a template cut
    with the sticker elsewhere it pulls the match off the ball's centre (by up to a few
    tenths of a px, mostly across the swing: several mrad of theta). The closing (a
    dilation, then an erosion, by a flat octagon of inradius ``radius_px``) lifts every dip
    narrower than the octagon to the level around it -- in the template and in each search window alike --
    and leaves a round marker's outline as it is: a convex blob, or a profile that falls
    off with the distance from its centre, passes unchanged. Dips wider than the octagon
    and everything outside the marker keep their shape, less the gaps narrower than the
    octagon between bright neighbours. With ``level``, only the pixels the closing lifts to
    at least ``level`` change (those surrounded by the marker, when ``level`` is half its
    contrast over the background): the wall's noise and the dark rim compression leaves
    around a marker stay as they are.

    Parameters
    ----------
    feature : ndarray, float32
        Feature window (see :mod:`pendtrack.track.colour`).
    radius_px : float
        Inradius of the octagon [px], rounded to whole px; below 1 px the feature is returned as is.
    level : float, optional
        Only pixels whose closed value reaches this feature level are filled.
    box : (slice, slice), optional
        Return only this part (rows, columns; steps of 1) of the result. The closing still
        sees the whole ``feature`` (the values are those of the whole result's part); only
        its last pass and the ``level`` test are spared outside the box.

    Returns
    -------
    ndarray, float32
        Same shape, or the shape of ``box``.
    """
    k = fill_reach(radius_px)
    if k < 1:
        return feature if box is None else feature[box]
    # an octagon, not a disc, for speed (see _octagon_passes); nearly round, so the filling does not
    # depend on how the sticker has turned (a square's did: theta 1.89 instead of 1.44 mrad RMS)
    square, b = _octagon_passes(k)
    cross = _CROSS
    closed = feature if square is None else cv2.dilate(feature, square, borderType=cv2.BORDER_REPLICATE)
    closed = cv2.dilate(closed, cross, iterations=b, borderType=cv2.BORDER_REPLICATE)
    closed = cv2.erode(closed, cross, iterations=b, borderType=cv2.BORDER_REPLICATE)
    if box is None:
        box = np.s_[:, :]
    if square is not None:
        # the last erosion reads ``k - b`` px around each pixel: on the box grown by that much (clipped
        # to the feature, whose edge then replicates as in the whole), the box's values are the whole's
        grown, inner = _grow_box(box, k - b, feature.shape)
        closed = cv2.erode(closed[grown], square, borderType=cv2.BORDER_REPLICATE)[inner]
    else:
        closed = closed[box]
    if level is None:
        return closed
    return np.where(closed >= np.float32(level), closed, feature[box])


def _grow_box(box: tuple[slice, slice], reach: int,
              shape: tuple[int, ...]) -> tuple[tuple[slice, slice], tuple[slice, slice]]:
    """``box`` grown by ``reach`` px on each side within ``shape``, and ``box`` inside the grown one."""
    rows, cols = (range(*s.indices(n)) for s, n in zip(box, shape))
    r0, c0 = max(rows.start - reach, 0), max(cols.start - reach, 0)
    r1, c1 = min(rows.stop + reach, shape[0]), min(cols.stop + reach, shape[1])
    grown = (slice(r0, r1), slice(c0, c1))
    inner = (slice(rows.start - r0, rows.stop - r0), slice(cols.start - c0, cols.stop - c0))
    return grown, inner
