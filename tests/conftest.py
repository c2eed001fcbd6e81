"""Shared fixtures.

``rendered_run`` -- synthetic videos with a known true angle, rendered once per test
session for each distinct set of arguments and shared by every test module.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest


@pytest.fixture(scope="session")
def rendered_run(tmp_path_factory: pytest.TempPathFactory) -> Callable[..., Path]:
    """Factory: ``rendered_run(seconds=1.0, seed=0, model="standard", params=None, **opts) -> Path``.

    Renders a virtual pendulum with :func:`pendtrack.stages.render.render_stage` and returns
    the folder holding ``video.mp4`` (H.264, yuv420p) and ``truth.parquet`` (``t``,
    ``theta``, ``omega`` per frame; read it with
    ``pendtrack.artifacts.read_artifact(folder / "truth.parquet", "truth")``; its
    provenance ``extra`` holds the model, the full parameters, ``axle_px`` (raw pixels) and
    the scene geometry).

    Parameters
    ----------
    seconds : float
        Video length [s] (120 frames per second by default: keep it short, about 30 frames
        per second of video are rendered and encoded per second of CPU at 1280x720).
    seed : int
        Noise and wall-texture seed.
    model : str
        Registered model name.
    params : dict of str to float, optional
        Model parameters; the others take the renderer's defaults (Omega0 from the tile).
    **opts
        Any other :class:`pendtrack.config.RenderConfig` field, e.g. ``width=640,
        height=360``, ``theta0=1.0``, ``omega0=-2.0``, ``tile_length_m=0.12``,
        ``alley=True``, ``noise_sigma=0.0``, ``exposure_s=0.0``, ``lens_fov_deg=120.0``.

    The same arguments (in any order) return the same folder without rendering again:
    treat it as read-only.
    """
    from pendtrack.config import Config
    from pendtrack.stages.render import render_stage

    cache: dict[Any, Path] = {}

    def make(*, seconds: float = 1.0, seed: int = 0, model: str = "standard",
             params: dict[str, float] | None = None, **opts: Any) -> Path:
        key = (float(seconds), int(seed), model, tuple(sorted((params or {}).items())),
               tuple(sorted((k, tuple(v) if isinstance(v, list) else v) for k, v in opts.items())))
        if key not in cache:
            out = tmp_path_factory.mktemp("rendered_run")
            config = Config().replace("render", seconds=float(seconds), seed=int(seed), model=model,
                                      params=tuple(f"{k}={v!r}" for k, v in (params or {}).items()), **opts)
            render_stage(out_dir=out, config=config, progress=False)
            cache[key] = out
        return cache[key]

    return make
