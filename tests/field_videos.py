"""Rendered pendulum videos with field conditions painted over them (for the tracking tests).

The renderer (:mod:`pendtrack.render`, used as a library) films the pendulum; each frame is
then post-processed in BGR before it is encoded with :class:`pendtrack.video.writer.VideoWriter`:

* ``hand_s``: a skin-coloured hand covers the pink spot for the first seconds, then is gone;
* ``poster``: a static pink disc (the spot's colour, larger) in a corner;
* ``sticker``: a small blue sticker on the spot, off its centre, turning with the pendulum;
* ``bead``: a small pink bead on the bar, nearer the axle than the spot (it swings too).
* ``wanderer``: a smaller pink disc wandering across the bottom of the frame on a zigzag
  (something pink carried past), moving all the time, also while the hand hides the spot.
* ``corner``: a static patch of the marker's colour in the frame's top-left corner, larger
  than the marker (a dark corner of the room: issue 27's first video);
* ``twin``: a second pendulum's bob beside the first, as large, swinging at 0.8 times its
  frequency with a third of its amplitude (two pendulums in view).
* ``cap``: the ball's half towards the axle is clear (pale), turning with the pendulum: only
  the lower half has the marker's colour (issue 27's bauble: a fixed template of it scores
  0.53-0.7 where the swing turns it most).
* ``clutter``: static grey boxes and bars on the floor, below the swing (corners a camera's
  motion can be measured on; the render's plain wall has too few).
* ``shake_px``: a hand-held camera: the whole frame (after every condition above) shifted by a
  drift of up to ``shake_px`` down and ``0.4 shake_px`` across plus a small tremor, 0 in the
  first frame (issue 27's field trial: KatieButler/Non-Linear pendulum.MOV, 8 px in 7 s).

``render`` overrides any ``[render]`` key (the marker's colour and shape, the rig, the lens,
the renderer's own hand): the painted conditions then take the marker's colour.

Deterministic (seeded); 640x360 by default so a few seconds render in about a second.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from pendtrack.config import Config
from pendtrack.render.pipeline import make_renderer, plan_render
from pendtrack.render.scene import SPOT_BGR
from pendtrack.video.writer import VideoWriter

SKIN_BGR = (140.0, 172.0, 224.0)
BLUE_BGR = (220.0, 60.0, 30.0)
CAP_BGR = (200.0, 205.0, 200.0)  # a clear plastic cap, pale
MARKER_BGR = {"dark": (35.0, 35.0, 40.0), "blue": BLUE_BGR}  # the painted conditions' colour for such markers


@dataclass(frozen=True)
class FieldVideo:
    """A rendered video and its truth.

    Attributes
    ----------
    path : Path
    t, theta : ndarray
        Frame times [s] and true angles [rad] (mid-exposure), one per frame.
    spot : ndarray, shape (n, 2)
        Raw pixel position of the spot's centre per frame.
    visible : ndarray, bool
        The spot is not hidden (by the hand).
    radius_px : float
        The spot's radius in the image near the axle's vertical [px].
    shift : ndarray, shape (n, 2)
        The camera's shift of each frame [px] (``shake_px``; zeros without): ``spot`` includes it,
        ``spot - shift`` is the spot in the first frame's view.
    """

    path: Path
    t: np.ndarray
    theta: np.ndarray
    spot: np.ndarray
    visible: np.ndarray
    radius_px: float
    shift: np.ndarray | None = None


def field_video(path: str | Path, *, seconds: float = 3.0, fps: float = 60.0, width: int = 640, height: int = 360,
                theta0: float = 1.2, hand_s: float = 0.0, poster: bool = False, sticker: bool = False,
                bead: bool = False, wanderer: bool = False, corner: bool = False, twin: bool = False, cap: bool = False,
                clutter: bool = False, shake_px: float = 0.0, seed: int = 0,
                **render: object) -> FieldVideo:
    """Render, post-process and encode; see the module docstring for the conditions."""
    cfg = Config().replace("render", width=width, height=height, fps=fps, seconds=seconds, theta0=theta0,
                           seed=seed, **render).render
    plan = plan_render(cfg)
    renderer = make_renderer(plan)
    scene = plan.scene
    motion = plan.motion
    sx, sy = scene.spot_centre_px(motion.theta)
    ex, ey = scene.project(*scene.to_world(scene.spot_distance_m + scene.spot_radius_m, 0.0, 0.0))
    cx0, cy0 = scene.spot_centre_px(0.0)
    radius = float(np.hypot(ex - cx0, ey - cy0))
    visible = (motion.t >= hand_s) & (motion.t >= cfg.hand_release_s)
    twin_period = 2 * np.pi / float(plan.params.get("Omega0", 2 * np.pi)) if twin else 1.0
    light = np.array(SPOT_BGR) * 255.0 * 0.8
    if cfg.marker_color != "pink":
        light = np.array(MARKER_BGR[cfg.marker_color], float)
    ax, ay = scene.spot_centre_px(0.0)
    tt = motion.t - motion.t[0]
    shift = shake_px * np.column_stack([0.4 * tt / seconds + 0.1 * np.sin(2 * np.pi * 0.9 * tt),
                                        tt / seconds + 0.1 * np.sin(2 * np.pi * 1.3 * tt)])
    rng = np.random.default_rng(seed + 7)
    floor = float(np.max(sy)) + 3 * radius
    boxes = [(rng.uniform(0, width - 12), rng.uniform(floor, height - 8), rng.uniform(6, 20), rng.uniform(4, 10),
              float(rng.uniform(20, 230))) for _ in range(40)] if clutter else []
    with VideoWriter(path, width=width, height=height, fps=fps, crf=20) as writer:
        for k in range(motion.n_frames):
            img = renderer.render(motion.frame_thetas(k))
            th = float(motion.theta[k])
            if corner:
                cv2.ellipse(img, (int(0.07 * width), int(0.05 * height)), (int(3 * radius), int(2 * radius)), 0, 0,
                            360, tuple(float(c) for c in light), -1, lineType=cv2.LINE_AA)
            if twin:
                th2 = float(motion.theta[0]) / 3 * np.cos(0.8 * 2 * np.pi * float(motion.t[k]) / twin_period)
                qx, qy = scene.spot_centre_px(th2)
                qx += 0.3 * width * (1 if ax < width / 2 else -1)
                cv2.circle(img, (int(round(4 * qx)), int(round(4 * qy))), int(round(4 * radius)),
                           tuple(float(c) for c in light), -1, lineType=cv2.LINE_AA, shift=2)
            if poster:
                cv2.circle(img, (int(0.8 * width), int(0.2 * height)), int(round(1.4 * radius)),
                           tuple(float(c) for c in light), -1, lineType=cv2.LINE_AA)
            if bead:
                bx, by = scene.project(*scene.to_world(0.55 * scene.spot_distance_m, 0.0, th))
                cv2.circle(img, (int(round(4 * bx)), int(round(4 * by))), int(round(4 * 0.45 * radius)),
                           tuple(float(c) for c in light), -1, lineType=cv2.LINE_AA, shift=2)
            if wanderer:
                tk = float(motion.t[k])
                wx, wy = width * (0.08 + 0.3 * tk), height * (0.9 + 0.04 * np.sin(2 * np.pi * 2.5 * tk))
                cv2.circle(img, (int(round(4 * wx)), int(round(4 * wy))), int(round(4 * 0.6 * radius)),
                           tuple(float(c) for c in light), -1, lineType=cv2.LINE_AA, shift=2)
            if cap:
                qx, qy = scene.project(*scene.to_world(0.5 * scene.spot_distance_m, 0.0, th))
                up = np.degrees(np.arctan2(qy - sy[k], qx - sx[k]))  # towards the axle
                cv2.ellipse(img, (int(round(4 * sx[k])), int(round(4 * sy[k]))), (int(round(4 * radius)),) * 2, 0.0,
                            up - 90.0, up + 90.0, CAP_BGR, -1, lineType=cv2.LINE_AA, shift=2)
            if sticker:
                qx, qy = scene.project(*scene.to_world(scene.spot_distance_m + 0.3 * scene.spot_radius_m, 0.0, th))
                cv2.circle(img, (int(round(4 * qx)), int(round(4 * qy))), int(round(4 * 0.35 * radius)),
                           BLUE_BGR, -1, lineType=cv2.LINE_AA, shift=2)
            if not visible[k]:
                centre = (int(round(sx[k])), int(round(sy[k] + 0.8 * radius)))
                cv2.ellipse(img, centre, (int(2.6 * radius), int(3.4 * radius)), np.degrees(-th), 0, 360,
                            SKIN_BGR, -1, lineType=cv2.LINE_AA)
            for bx, by, bw, bh, grey in boxes:
                cv2.rectangle(img, (int(bx), int(by)), (int(bx + bw), int(min(by + bh, height - 1))), (grey,) * 3, -1)
            if shake_px:
                m = np.array([[1.0, 0.0, shift[k, 0]], [0.0, 1.0, shift[k, 1]]])
                img = cv2.warpAffine(img, m, (width, height), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)
            writer.write(img)
    spot = np.column_stack([sx, sy]) + shift
    return FieldVideo(Path(path), motion.t.copy(), motion.theta.copy(), spot, visible, radius, shift)
