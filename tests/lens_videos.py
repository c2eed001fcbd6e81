"""Rendered pendulum videos through a chosen camera lens (for the lens-check tests).

The renderer (:mod:`pendtrack.render`, as a library) films the pendulum through the lens of
its :class:`~pendtrack.render.scene.Scene`; here the scene's projection and field of view
are set directly, so a normal (rectilinear) lens can be filmed whatever the render
command accepts. Deterministic (seeded); small frames so a few seconds render in seconds.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from pendtrack.config import Config
from pendtrack.render.pipeline import make_renderer, plan_render
from pendtrack.video.writer import VideoWriter


def lens_video(path: str | Path, *, projection: str = "equisolid", fov_deg: float = 120.0,
               offset_m: tuple[float, float] = (0.14, 0.02), seconds: float = 2.0, fps: float = 60.0,
               width: int = 640, height: int = 360, theta0: float = 2.0, camera_distance_m: float = 0.58,
               seed: int = 0) -> tuple[Path, np.ndarray]:
    """Render and encode a swing filmed through ``projection`` / ``fov_deg``; returns the path and true theta.

    Parameters
    ----------
    projection : str
        The camera's projection: a fisheye one, or ``"rectilinear"`` (a normal lens).
    fov_deg : float
        The camera's diagonal field of view [deg].
    offset_m : (float, float)
        Optical-axis point minus axle in the pendulum's plane [m] (0.14 m: the axle well off-axis).
    """
    cfg = Config().replace("render", width=width, height=height, fps=fps, seconds=seconds, theta0=theta0,
                           seed=seed, camera_offset_m=tuple(offset_m), camera_distance_m=camera_distance_m).render
    plan = plan_render(cfg)
    plan = dataclasses.replace(plan, scene=dataclasses.replace(plan.scene, projection=projection, fov_deg=fov_deg))
    renderer = make_renderer(plan)
    with VideoWriter(path, width=width, height=height, fps=fps, crf=20) as writer:
        for k in range(plan.n_frames):
            writer.write(renderer.render(plan.motion.frame_thetas(k)))
    return Path(path), plan.motion.theta.copy()
