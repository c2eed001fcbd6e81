"""Render speed: prints figures, asserts nothing.

    .venv/bin/python benchmarks/bench_render.py [--seconds 2] [--size 1280x720]

Reports the one-off set-up (per-pixel world maps, backdrop), the raster kernel alone at
a few poses, frames/s of rendering alone, of H.264 encoding alone and of the whole stage
(simulate + render + encode + truth) on a run that passes the bottom at full speed.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from pendtrack.config import Config
from pendtrack.render import make_renderer, plan_render
from pendtrack.render.raster import raster_pendulum
from pendtrack.stages.render import render_stage
from pendtrack.video.writer import VideoWriter


def timed(fn, repeat: int = 1) -> float:
    start = time.perf_counter()
    for _ in range(repeat):
        fn()
    return (time.perf_counter() - start) / repeat


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=2.0)
    ap.add_argument("--size", default="1280x720")
    args = ap.parse_args()
    w, h = (int(v) for v in args.size.split("x"))
    config = Config().replace("render", width=w, height=h, seconds=args.seconds, theta0=3.1, omega0=-1.0,
                              tile_length_m=0.12, alley=True)
    print(f"render benchmark: {w}x{h}, {args.seconds:g} s at {config.render.fps:g} fps, tile 12 cm, alley")

    t_plan = timed(lambda: plan_render(config.render))
    plan = plan_render(config.render)
    counts = np.diff(plan.motion.sub_start)
    print(f"  simulate (reference model)   {t_plan * 1e3:8.1f} ms  "
          f"(sub-samples per frame: mean {counts.mean():.1f}, max {counts.max()})")

    renderer = make_renderer(plan)  # first call also loads/compiles the numba kernel
    renderer.render(plan.motion.frame_thetas(0))
    t_setup = timed(lambda: make_renderer(plan))
    print(f"  set-up (world maps, backdrop) {t_setup * 1e3:7.1f} ms")

    r = renderer
    for label, theta, n_sub in (("bottom, 22 sub-samples", 0.0, 22), ("side, 12", 1.3, 12), ("top, 1", 3.1, 1)):
        th = theta + np.linspace(-0.01, 0.01, n_sub) if n_sub > 1 else np.array([theta])
        box = plan.scene.bbox_px(th)
        t = timed(lambda: raster_pendulum(r._x, r._y, r._size, r._light, r._back, box, th, r._parts), 20)
        print(f"  raster kernel, {label:<22} {t * 1e3:6.2f} ms  box {box[2] - box[0]}x{box[3] - box[1]} px")

    frames = []
    t = timed(lambda: frames.extend(r.render(plan.motion.frame_thetas(k)) for k in range(plan.n_frames)))
    print(f"  render frames only            {plan.n_frames / t:7.1f} frames/s")

    with tempfile.TemporaryDirectory() as tmp:
        def encode() -> None:
            with VideoWriter(Path(tmp) / "v.mp4", width=w, height=h, fps=config.render.fps, crf=config.render.crf,
                             preset=config.render.x264_preset) as writer:
                for f in frames:
                    writer.write(f)

        t = timed(encode)
        print(f"  H.264 encode only             {len(frames) / t:7.1f} frames/s")
        t = timed(lambda: render_stage(out_dir=Path(tmp) / "stage", config=config, progress=False, force=True))
        print(f"  whole render stage            {plan.n_frames / t:7.1f} frames/s "
              f"({t:.1f} s for {plan.n_frames} frames)")


if __name__ == "__main__":
    main()
