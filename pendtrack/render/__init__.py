"""Synthetic videos of the paper's pendulum with a known true angle.

Public API::

    from pendtrack.render import plan_render, render_frames, Scene, scene_from_config
    plan = plan_render(RenderConfig(seconds=2.0, seed=1))   # checks, simulates
    for frame in render_frames(plan): ...                  # BGR uint8 frames
    plan.motion.t, plan.motion.theta, plan.motion.omega     # the truth

Modules: :mod:`~pendtrack.render.scene` (camera, lens, parts), :mod:`~pendtrack.render.raster`
(numba kernel and its Python twin), :mod:`~pendtrack.render.backdrop` (wall, alley,
lighting), :mod:`~pendtrack.render.film` (frames), :mod:`~pendtrack.render.motion`
(frame and blur sampling), :mod:`~pendtrack.render.physics` (model and parameters),
:mod:`~pendtrack.render.pipeline` (config -> plan -> frames).

Importing this package imports no numba and does no work.
"""

from pendtrack.render.motion import Motion, run_code
from pendtrack.render.pipeline import RenderPlan, check_render_config, make_renderer, plan_render, render_frames
from pendtrack.render.scene import Scene, scene_from_config

__all__ = [
    "Motion", "RenderPlan", "Scene", "check_render_config", "make_renderer", "plan_render", "render_frames",
    "run_code", "scene_from_config",
]
