"""Wall-clock time of `pendtrack run` on a 60-s, 720p/120 fps render, stage by stage (prints; no pass/fail).

Usage::

    .venv/bin/python benchmarks/bench_run.py [--seconds 60] [--cache DIR] [--time-budget S]

The video is rendered once with the renderer's defaults (the paper's setup: fisheye, pink
spot, 1280x720 at 120 fps) into a cache folder and reused. The pipeline then runs with the
default config -- the three models (classic, OPA, fractional), 150 starts each, the
uncertainties and the report -- exactly as :func:`pendtrack.stages.run.run_pipeline` chains
the stages (track -> angle -> kinematics -> fit -> report), each stage timed on its own, the
fit split per model by each model's ``runtime_s`` in ``fit_<model>.json``. A warm-up run of
a short clip first fills numba's on-disk cache, so the timing pays no JIT compilation (a
user's second run does not either). Target of issue #16: the whole run within 60 s on 2
cores; issue #15's bound: within 3 min. ``--time-budget 0`` times the fits with every start run
(no budget: ``[fit] time_budget_s`` overridden), what the defaults need to finish all 150 starts.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

from pendtrack.config import Config
from pendtrack.stages.angle import angle_stage
from pendtrack.stages.fit import fit_stage
from pendtrack.stages.kinematics import kinematics_stage
from pendtrack.stages.render import render_stage
from pendtrack.stages.report import report_stage
from pendtrack.stages.track import track_stage


def render_once(folder: Path, seconds: float) -> Path:
    """The cached render (video.mp4, truth.parquet) of ``seconds`` s with the default scene."""
    if not (folder / "video.mp4").is_file():
        config = Config().replace("render", seconds=seconds, seed=16)
        render_stage(out_dir=folder, config=config, progress=False)
    return folder / "video.mp4"


def run_timed(video: Path, out: Path, config: Config) -> dict[str, float]:
    """Each stage of `pendtrack run` in the pipeline's order, forced; wall seconds by stage."""
    common = {"out_dir": out, "config": config, "force": True, "progress": False}
    times: dict[str, float] = {}

    def timed(name, fn, *args, **kwargs):
        t0 = time.perf_counter()
        res = fn(*args, **kwargs)
        times[name] = time.perf_counter() - t0
        return res

    track = timed("track", track_stage, video, **common)
    angle = timed("angle", angle_stage, track.path, **common)
    kin = timed("kinematics", kinematics_stage, angle.path, **common)
    timed("fit", fit_stage, kin.path, models=config.fit.models, **common)
    timed("report", report_stage, out, config=config, force=True, progress=False)
    return times


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--cache", default=os.path.join(tempfile.gettempdir(), "pendtrack-bench-run"))
    ap.add_argument("--time-budget", type=float, default=None, help="[fit] time_budget_s [s] (default: the config's)")
    args = ap.parse_args(argv)
    cache = Path(args.cache)
    video = render_once(cache / f"render_{args.seconds:g}s", args.seconds)
    warm = render_once(cache / "render_warmup_4s", 4.0)
    config = Config()
    if args.time_budget is not None:
        config = config.replace("fit", time_budget_s=args.time_budget)
    print(f"fit time budget {config.fit.time_budget_s:g} s; video: {video} ({args.seconds:g} s, 1280x720, 120 fps); load average {os.getloadavg()[0]:.2f}")
    with tempfile.TemporaryDirectory() as tmp:
        run_timed(warm, Path(tmp) / "warm", config.replace("fit", n_starts=4))  # numba cache, imports
        out = Path(tmp) / "run"
        times = run_timed(video, out, config)
        for name, sec in times.items():
            print(f"  {name:<12} {sec:7.1f} s")
            if name == "fit":
                for model in config.fit.models:
                    rec = json.loads((out / f"fit_{model}.json").read_text())
                    print(f"    {model:<10} {rec['runtime_s']:7.1f} s  ({rec.get('n_starts', '?')} starts, "
                          f"converged={rec['converged']})")
        total = sum(times.values())
    print(f"  {'total':<12} {total:7.1f} s   (issue #16 target <= 60 s; issue #15 bound <= 180 s); "
          f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
