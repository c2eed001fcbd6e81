"""Acquisition of the marker: the first frames where a candidate of the marker's colour (or one
standing out in a ROI) is usable, told apart from look-alikes by its motion over a short window
(:class:`_Acquirer`), following each candidate from search to search (:func:`_follow`), the test
that a mover's path is a pendulum's arc (:func:`path_shape`) and the refusal of two pendulums in
view (:func:`_refuse_two_pendulums`)."""

from __future__ import annotations

from collections.abc import Iterator
from itertools import chain

import numpy as np

from pendtrack.errors import TrackingError
from pendtrack.track.circle import fit_circle_pratt
from pendtrack.track.detect import Detection, marker_candidates, marker_in_roi
from pendtrack.track.params import TrackParams
from pendtrack.track.sampler import RawSampler
from pendtrack.track.templates import _Template, make_template

MOVED_PX = 2.0  # a candidate moved when it strayed further than this (and than half its radius) [px]
LINK_REACH = 0.25  # a candidate is followed to the nearest one within this share of the frame diagonal
RADIUS_RATIO = 2.0  # ... whose radius is within this factor of its own
MIN_RADIUS_SHARE = 0.75  # acquired only when its radius is >= this share of its median over the window
ARC_TOL_PX = 1.0  # position noise of a candidate's detections (and at least 0.1 radius) [px]
ARC_MAX_RADIUS = 2.5  # a pendulum's arc has a radius below this many frame diagonals (its pivot up to ~1.5 above the frame: a
# long string filmed close, issue 27's bauble: 2.1 diagonals)
ARC_MIN_RADIUS = 3.0  # ... and above this many marker radii
ARC_MIN_POINTS = 5  # fewer positions over the window: the path's shape is unclear
MAX_STILL_STEPS = 0.5  # a path still (within its noise) from one search to the next in more of its steps is unclear
# A mover whose path is unclear must travel at least this many of its radii to be taken for the marker: the
# centre of a fixed dot that a swinging rod joins wobbles by half its radius (a drawn pendulum's pivot)
UNCLEAR_TRAVEL = 1.0
# Two movers on arcs, within this radius ratio of each other and further apart than this many radii, are two
# pendulums (a bead or a sticker riding on one bob is smaller, or on it): which one is the user's to say.
TWIN_RADIUS_RATIO = 1.5
TWIN_SEPARATION = 4.0


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
    partly hidden (a hand). A mover whose path is unclear counts only once it travels
    :data:`UNCLEAR_TRAVEL` radii. When no candidate moves, the search moves on (a poster is all
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
        """The candidate of ``fr`` that is ``det`` seen in a neighbouring frame, whole and usable, or None.

        Within the tracker's own reach from one frame to the next (its wide search margin plus the marker's
        radius): a look-alike further off in the frame before is another object, not the marker.
        """
        reach = self.params.search_margin_px + det.radius
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
            shape = path_shape(path, marker_radius=det.radius, diagonal=diagonal)
            if moved > max(MOVED_PX, 0.5 * det.radius) and (shape != "unclear" or moved >= UNCLEAR_TRAVEL * det.radius):
                moving[shape].append(cand)
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
        :data:`ARC_MIN_POINTS` positions, still in more than :data:`MAX_STILL_STEPS` of its steps, or a short
        straight stretch.
    """
    p = np.asarray(path, float)
    if p.shape[0] < ARC_MIN_POINTS:
        return "unclear"
    tol = max(ARC_TOL_PX, 0.1 * marker_radius)
    if np.sum(np.hypot(*np.diff(p, axis=0).T) <= tol) > MAX_STILL_STEPS * (p.shape[0] - 1):
        # a swinging marker is never still for half the window; a still thing linked to a neighbour of its colour
        # for a search or two (a poster's corner pieces) is, and three distinct places make any circle
        return "unclear"
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
