"""The camera's own motion: a hand-held or nudged camera moves the whole scene under the marker.

A phone held in the hand drifts by pixels over a record; a pendulum's arc may bend by only two
(a 15 deg swing of a 240 px pendulum: sagitta 2 px), so an uncompensated drift bends the track
into no arc about one axle. The background gives the camera's motion away: corners of the static
scene are found in the first frame and followed into every frame (pyramidal Lucas-Kanade), and a
similarity transform (rotation, scale, shift) from each frame to the first is fitted to them by
RANSAC, which leaves out the points on the moving pendulum (OpenCV's
``estimateAffinePartial2D``). The track's points are then mapped into the first frame's view.

A plain wall has too few corners to tell: then the motion is *not measured* and nothing is
changed. A first view whose corners are found again in fewer than half of the frames, in frames
that differ from it over most of the picture, was left: the camera turned away (``lost``), and
the track cannot be held in any one view.
Units: pixels of the full frame.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

MAX_SIDE_PX = 640  # corners are followed in frames scaled down to at most this side [px] (cost ~2 ms a frame)
MAX_CORNERS = 400
MIN_CORNERS = 40  # fewer corners in the first frame: the motion is not measured
# a frame's fit counts when at least this many corners agree on it (RANSAC inliers within 1 px of the scaled frame)
MIN_INLIERS = 20
MIN_INLIER_SHARE = 0.3  # ... and at least this share of the corners followed into it (not a scene mostly moving)
MIN_GOOD_SHARE = 0.9  # ... in at least this share of the measured frames, else the motion is not measured
# found again in fewer than this share of the measured frames, with most of the picture changed in those frames, the
# first view was left: the camera turned away (a phone panned from the floor to the pendulum and on). A still camera
# whose few corners sat on the moving bob or a hand changes only where they move.
LOST_SHARE = 0.5
CHANGED_GREY = 24  # a pixel of the scaled, blurred frame differs from the first frame's by more than this [grey levels]
LOST_CHANGED = 0.5  # ... over at least this share of the picture (median over the frames where the scene was not found)
MEASURE_RATE_HZ = 30.0  # frames measured per second of video at most (a hand shakes below ~10 Hz); linear between
RANSAC_PX = 1.0  # RANSAC threshold [px of the scaled frame]
# a measured motion smaller than this at the marker (95th percentile over the track) is left alone: the fit's own
# scatter is ~0.05 px with 100+ corners, and a camera on a tripod stays well below it
MOVE_PX = 0.5


@dataclass(frozen=True)
class CameraMotion:
    """Similarity transforms from each measured frame to the first.

    Attributes
    ----------
    measured : bool
        Enough static corners in enough frames to tell the camera's motion.
    reason : str
        One sentence: how it was measured, or why not.
    frames : ndarray, int
        Indices of the measured frames (the first is the reference).
    matrices : ndarray, shape (n, 2, 3)
        Frame -> first frame, full-frame px (identity for the first).
    n_corners : int
        Corners found in the first frame.
    lost : bool
        The first frame's static scene was found again in fewer than :data:`LOST_SHARE` of the
        measured frames, and those frames differ from it over most of the picture
        (:data:`LOST_CHANGED`): the camera turned away from it.
    """

    measured: bool
    reason: str
    frames: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    matrices: np.ndarray = field(default_factory=lambda: np.zeros((0, 2, 3)))
    n_corners: int = 0
    lost: bool = False

    def to_reference(self, frames: np.ndarray, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Points ``(x, y)`` [px] seen in ``frames`` mapped into the first frame's view.

        The transforms' parameters (shift, rotation, scale) are interpolated linearly between
        measured frames and held beyond them. Unchanged when the motion is not measured.
        """
        x, y = np.asarray(x, float), np.asarray(y, float)
        if not self.measured or self.frames.size == 0:
            return x, y
        m = self.matrices
        f = np.asarray(frames, float)
        a = np.interp(f, self.frames, m[:, 0, 0])
        b = np.interp(f, self.frames, m[:, 1, 0])
        tx = np.interp(f, self.frames, m[:, 0, 2])
        ty = np.interp(f, self.frames, m[:, 1, 2])
        # a similarity: [[a, -b, tx], [b, a, ty]]
        return a * x - b * y + tx, b * x + a * y + ty

    def displacement(self, frames: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """How far the camera's motion moved each point [px] (0 when not measured)."""
        xr, yr = self.to_reference(frames, x, y)
        return np.hypot(xr - np.asarray(x, float), yr - np.asarray(y, float))

    def to_dict(self) -> dict[str, object]:
        out: dict[str, object] = {"measured": self.measured, "reason": self.reason, "n_corners": self.n_corners,
                                  "n_frames_measured": int(self.frames.size), "lost": self.lost}
        if self.measured and self.frames.size:
            m = self.matrices
            out["max_shift_px"] = float(np.max(np.hypot(m[:, 0, 2], m[:, 1, 2])))
            out["max_rotation_deg"] = float(np.degrees(np.max(np.abs(np.arctan2(m[:, 1, 0], m[:, 0, 0])))))
        return out


class CameraMotionMeter:
    """Feed it the luma planes of a video in order; :meth:`result` gives the :class:`CameraMotion`.

    Parameters
    ----------
    fps : float
        The video's frame rate [1/s] (how many frames to skip between measured ones).
    """

    def __init__(self, *, fps: float) -> None:
        self._stride = max(1, int(round(fps / MEASURE_RATE_HZ))) if np.isfinite(fps) and fps > 0 else 1
        self._ref: np.ndarray | None = None
        self._pts: np.ndarray | None = None
        self._scale = 1.0
        self._first = 0
        self._frames: list[int] = []
        self._mats: list[np.ndarray] = []
        self._good: list[bool] = []
        self._changed: list[float] = []  # share of the picture changed, in each frame where the scene was not found
        self._ref_blur: np.ndarray | None = None

    def _small(self, luma: np.ndarray) -> np.ndarray:
        if self._scale == 1.0:
            return np.ascontiguousarray(luma)
        h, w = luma.shape
        return cv2.resize(luma, (int(round(w / self._scale)), int(round(h / self._scale))),
                          interpolation=cv2.INTER_AREA)

    def add(self, index: int, luma: np.ndarray) -> None:
        """Measure frame ``index`` (its luma plane, uint8) against the first one added."""
        if self._ref is None:
            self._scale = max(1.0, max(luma.shape) / MAX_SIDE_PX)
            self._ref = self._small(luma)
            self._ref_blur = cv2.GaussianBlur(self._ref, (5, 5), 0)  # H.264's noise is no change of scene
            pts = cv2.goodFeaturesToTrack(self._ref, maxCorners=MAX_CORNERS, qualityLevel=0.01,
                                          minDistance=max(4, int(max(self._ref.shape) / 80)), blockSize=7)
            self._pts = pts if pts is not None else np.zeros((0, 1, 2), np.float32)
            self._first = index
            self._frames.append(index)
            self._mats.append(np.array([[1.0, 0, 0], [0, 1.0, 0]]))
            self._good.append(True)
            return
        if (index - self._first) % self._stride or len(self._pts) < MIN_CORNERS:
            return
        img = self._small(luma)
        p1, status, _ = cv2.calcOpticalFlowPyrLK(self._ref, img, self._pts, None, winSize=(21, 21), maxLevel=3)
        sel = status.ravel() == 1
        mat, good = None, False
        if sel.sum() >= MIN_INLIERS:
            # frame -> first frame (the points found in this frame are mapped back to where they were)
            mat, inl = cv2.estimateAffinePartial2D(p1[sel], self._pts[sel], method=cv2.RANSAC,
                                                   ransacReprojThreshold=RANSAC_PX)
            good = mat is not None and int(inl.sum()) >= max(MIN_INLIERS, MIN_INLIER_SHARE * sel.sum())
        if good:
            s = self._scale
            mat = np.array(mat, float)
            mat[:, 2] *= s  # the scaled frame's shift in full-frame px (rotation and scale need no change)
            self._frames.append(index)
            self._mats.append(mat)
        else:
            diff = cv2.absdiff(cv2.GaussianBlur(img, (5, 5), 0), self._ref_blur)
            self._changed.append(float(np.mean(diff > CHANGED_GREY)))
        self._good.append(good)

    def result(self) -> CameraMotion:
        """The measured motion, or why it could not be measured."""
        n = 0 if self._pts is None else len(self._pts)
        if n < MIN_CORNERS:
            return CameraMotion(False, f"the first frame has {n} corners to follow (at least {MIN_CORNERS} are needed "
                                       f"to tell the camera's motion)", n_corners=n)
        share = float(np.mean(self._good)) if self._good else 0.0
        if share < MIN_GOOD_SHARE:
            changed = float(np.median(self._changed)) if self._changed else 0.0
            if share < LOST_SHARE and changed >= LOST_CHANGED:
                return CameraMotion(False, f"the first frame's static scene ({n} corners) was found again in only "
                                           f"{100 * share:.0f} % of the frames measured, the others changed over "
                                           f"{100 * changed:.0f} % of the picture", n_corners=n, lost=True)
            return CameraMotion(False, f"the static scene was followed in only {100 * share:.0f} % of the frames "
                                       f"(at least {100 * MIN_GOOD_SHARE:.0f} % are needed)", n_corners=n)
        return CameraMotion(True, f"{n} corners of the first frame followed into {len(self._frames)} frames",
                            np.asarray(self._frames, int), np.stack(self._mats), n)
