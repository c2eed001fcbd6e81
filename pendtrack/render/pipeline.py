"""From a :class:`~pendtrack.config.RenderConfig` to frames and truth (no files here).

:func:`plan_render` checks the configuration, resolves the model and its parameters and
samples the motion; :func:`render_frames` films it. The stage
(:mod:`pendtrack.stages.render`) writes the results.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from pendtrack.config import RENDER_MARKER_SHAPES, RENDER_RIGS, RenderConfig
from pendtrack.errors import ConfigError
from pendtrack.lens.fisheye import PROJECTIONS, Fisheye
from pendtrack.render.film import FrameRenderer
from pendtrack.render.motion import Motion, run_code, sample_motion
from pendtrack.render.physics import model_simulator, parse_params, resolve_params, string_omega0
from pendtrack.render.scene import Scene, marker_reflectance, scene_from_config

X264_PRESETS = ("ultrafast", "superfast", "veryfast", "faster", "fast", "medium", "slow", "slower", "veryslow")


@dataclass(frozen=True)
class RenderPlan:
    """Everything needed to film one run.

    Attributes
    ----------
    config : RenderConfig
    scene : Scene
    model : str
        Model name.
    params : dict of str to float
        All the model's parameters (defaults filled in).
    motion : Motion
        Truth at the frame times and the sub-sample angles.
    run_code : str or None
        The paper's run code (e.g. ``"06na1"``) when one can be formed.
    """

    config: RenderConfig
    scene: Scene
    model: str
    params: dict[str, float]
    motion: Motion
    run_code: str | None

    @property
    def n_frames(self) -> int:
        return self.motion.n_frames

    def to_dict(self) -> dict[str, Any]:
        """Facts for provenance (no arrays)."""
        return {
            "model": self.model,
            "params": dict(self.params),
            "run_code": self.run_code,
            "n_frames": self.n_frames,
            "axle_px": list(self.scene.axle_px),
            "subsamples_max": int(np.diff(self.motion.sub_start).max()),
            # field conditions: the truth is physical; in the image theta reads theta + camera_roll_rad
            "camera_roll_rad": self.scene.roll_rad,
            "lens_projection": self.scene.projection,
            "axle_in_frame": bool(0 <= self.scene.axle_px[0] <= self.scene.width - 1
                                  and 0 <= self.scene.axle_px[1] <= self.scene.height - 1),
            "hand_release_s": self.motion.release_s,  # before it theta = theta0, omega = 0 (held); 0: no hand
            "marker": {"color": self.config.marker_color, "shape": self.config.marker_shape,
                       "sticker": self.config.sticker_color, "rig": self.config.rig},
            "scene": {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self.scene).items()},
        }


def _require(ok: bool, key: str, text: str, value: Any) -> None:
    if not ok:
        raise ConfigError(f"render.{key} {text}, got {value!r}")


def check_render_config(cfg: RenderConfig) -> int:
    """Check a render configuration; return the number of frames.

    Raises
    ------
    ConfigError
        Naming the key and the problem (e.g. ``render.seconds must be > 0, got -1.0``).
    """
    def finite(v: float) -> bool:
        return math.isfinite(v)

    _require(16 <= cfg.width <= 8192 and cfg.width % 2 == 0, "width", "must be even, 16..8192 px", cfg.width)
    _require(16 <= cfg.height <= 8192 and cfg.height % 2 == 0, "height", "must be even, 16..8192 px", cfg.height)
    _require(finite(cfg.fps) and cfg.fps > 0, "fps", "must be > 0", cfg.fps)
    _require(finite(cfg.seconds) and cfg.seconds > 0, "seconds", "must be > 0", cfg.seconds)
    n_frames = int(round(cfg.seconds * cfg.fps))
    _require(n_frames >= 1, "seconds", "must last at least one frame", cfg.seconds)
    _require(finite(cfg.theta0), "theta0", "must be finite", cfg.theta0)
    _require(finite(cfg.omega0), "omega0", "must be finite", cfg.omega0)
    _require(finite(cfg.exposure_s) and 0 <= cfg.exposure_s <= 1 / cfg.fps, "exposure_s",
             f"must be within 0..1/fps = {1 / cfg.fps:.6g} s", cfg.exposure_s)
    _require(finite(cfg.noise_sigma) and cfg.noise_sigma >= 0, "noise_sigma", "must be >= 0", cfg.noise_sigma)
    _require(0 <= cfg.crf <= 51, "crf", "must be within 0..51", cfg.crf)
    _require(cfg.x264_preset in X264_PRESETS, "x264_preset", f"must be one of {', '.join(X264_PRESETS)}",
             cfg.x264_preset)
    _require(finite(cfg.blur_step_px) and cfg.blur_step_px > 0, "blur_step_px", "must be > 0", cfg.blur_step_px)
    _require(cfg.trial >= 1, "trial", "must be >= 1", cfg.trial)
    for key in ("camera_distance_m", "spot_distance_m", "spot_radius_m", "bar_length_m", "bar_width_m",
                "disc_diameter_m", "tile_width_m", "two_cuboid_x", "two_cuboid_l0_m", "gravity"):
        value = getattr(cfg, key)
        _require(finite(value) and value > 0, key, "must be > 0", value)
    _require(len(cfg.camera_offset_m) == 2 and all(finite(v) for v in cfg.camera_offset_m), "camera_offset_m",
             "must be two finite numbers [m]", list(cfg.camera_offset_m))
    _require(cfg.bar_length_m <= cfg.two_cuboid_l0_m, "bar_length_m", "must not exceed two_cuboid_l0_m",
             cfg.bar_length_m)
    _require(cfg.spot_distance_m + cfg.spot_radius_m <= cfg.two_cuboid_l0_m, "spot_distance_m",
             "must put the spot on the bar (spot_distance_m + spot_radius_m <= two_cuboid_l0_m)", cfg.spot_distance_m)
    _require(finite(cfg.tile_length_m) and 0 <= cfg.tile_length_m <= cfg.two_cuboid_l0_m, "tile_length_m",
             "must be within 0..two_cuboid_l0_m", cfg.tile_length_m)
    for key in ("illumination_gradient", "vignetting"):
        value = getattr(cfg, key)
        _require(finite(value) and 0 <= value < 1, key, "must be within [0, 1)", value)
    _require(cfg.lens_projection in PROJECTIONS, "lens_projection", f"must be one of {', '.join(PROJECTIONS)}",
             cfg.lens_projection)
    try:  # "none" is a normal (rectilinear) lens of that field of view
        Fisheye(width=cfg.width, height=cfg.height, fov_deg=cfg.lens_fov_deg,
                projection="rectilinear" if cfg.lens_projection == "none" else cfg.lens_projection)
    except ValueError as exc:
        raise ConfigError(f"render.lens_fov_deg: {exc}") from None
    _require(cfg.lens_fov_deg < 170, "lens_fov_deg", "must be below 170 deg (the pendulum's plane is flat)",
             cfg.lens_fov_deg)
    _check_field_conditions(cfg)
    return n_frames


def _check_field_conditions(cfg: RenderConfig) -> None:
    """The bob's look, the rig, the hand and the roll (see :func:`check_render_config`)."""
    for key, none in (("marker_color", ""), ("sticker_color", " or '' (none)")):
        value = getattr(cfg, key)
        try:
            if value or not none:
                marker_reflectance(value)
        except ValueError:
            _require(False, key, f"must be pink, dark, blue, #RRGGBB{none}", value)
    _require(cfg.marker_shape in RENDER_MARKER_SHAPES, "marker_shape", f"must be one of {', '.join(RENDER_MARKER_SHAPES)}",
             cfg.marker_shape)
    _require(cfg.rig in RENDER_RIGS, "rig", f"must be one of {', '.join(RENDER_RIGS)}", cfg.rig)
    _require(cfg.rig == "bar" or cfg.tile_length_m == 0, "tile_length_m", "must be 0 with rig = 'string'",
             cfg.tile_length_m)
    limit = (1 - Scene.sticker_offset) * cfg.spot_radius_m
    _require(math.isfinite(cfg.sticker_radius_m) and 0 < cfg.sticker_radius_m <= limit, "sticker_radius_m",
             f"must be > 0 and keep the sticker on the bob (<= {limit:.4g} m)", cfg.sticker_radius_m)
    _require(math.isfinite(cfg.hand_release_s) and 0 <= cfg.hand_release_s < cfg.seconds, "hand_release_s",
             "must be within [0, seconds)", cfg.hand_release_s)
    _require(math.isfinite(cfg.camera_roll_deg) and abs(cfg.camera_roll_deg) <= 45, "camera_roll_deg",
             "must be within [-45, 45] deg", cfg.camera_roll_deg)


def plan_render(cfg: RenderConfig) -> RenderPlan:
    """Check ``cfg``, resolve the model and sample the motion (the slow part is the model).

    Raises
    ------
    ConfigError
        Bad configuration or a malformed ``params`` item.
    ModelError
        Unknown model, unknown or out-of-range parameter.
    """
    n_frames = check_render_config(cfg)
    given = parse_params(cfg.params)
    if cfg.rig == "string" and "Omega0" not in given:
        given = {"Omega0": string_omega0(length_m=cfg.spot_distance_m, radius_m=cfg.spot_radius_m,
                                         gravity=cfg.gravity)} | given
    model, params = resolve_params(cfg.model, given, tile_length_m=cfg.tile_length_m, x=cfg.two_cuboid_x,
                                   l0_m=cfg.two_cuboid_l0_m, gravity=cfg.gravity)
    scene = scene_from_config(cfg)
    simulate = model_simulator(model, params, theta0=cfg.theta0, omega0=cfg.omega0, fps=cfg.fps)
    motion = sample_motion(simulate, n_frames=n_frames, fps=cfg.fps, exposure_s=cfg.exposure_s,
                           theta0=cfg.theta0, omega0=cfg.omega0,
                           px_per_rad=scene.spot_distance_m * scene.px_per_m_max, step_px=cfg.blur_step_px,
                           release_s=cfg.hand_release_s)
    code = run_code(tile_length_m=cfg.tile_length_m, omega0=cfg.omega0, alley=cfg.alley, trial=cfg.trial)
    return RenderPlan(config=cfg, scene=scene, model=model.name, params=params, motion=motion, run_code=code)


def make_renderer(plan: RenderPlan, *, use_numba: bool = True) -> FrameRenderer:
    """The frame renderer of a plan (precomputes the static picture; about a second at 720p)."""
    cfg = plan.config
    return FrameRenderer(plan.scene, alley=cfg.alley, gradient=cfg.illumination_gradient, vignetting=cfg.vignetting,
                         noise_sigma=cfg.noise_sigma, seed=cfg.seed, use_numba=use_numba,
                         hand_theta=cfg.theta0 if cfg.hand_release_s > 0 else None)


def render_frames(plan: RenderPlan, *, use_numba: bool = True,
                  on_progress: Callable[[int], None] | None = None) -> Iterator[np.ndarray]:
    """Yield the run's frames, BGR uint8 (height, width, 3), in order.

    Deterministic: the same plan (same seed) yields identical frames.
    """
    renderer = make_renderer(plan, use_numba=use_numba)
    for k in range(plan.n_frames):
        yield renderer.render(plan.motion.frame_thetas(k), hand=plan.motion.frame_hand(k))
        if on_progress is not None:
            on_progress(1)
