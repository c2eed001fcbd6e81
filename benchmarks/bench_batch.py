"""Batch speed-up: 4 rendered videos on 2 local worker processes against 1 (prints, no pass/fail).

Each worker is single-threaded (BLAS/OpenMP/numba/OpenCV capped at 1 thread, fit starts
serial), so on a machine with >= 2 free cores the 2-worker batch should take a little over
half the time of the 1-worker batch: target speed-up >= 1.7x. Each worker process pays a
fixed start-up (imports, numba cache load, a few s), so the work per run must dominate:
6 s videos and 16 fit starts by default. The videos are rendered once into a cache folder;
a warm-up batch fills numba's on-disk cache so neither timing pays JIT compilation. The
workers' CPU time, the cores it kept busy and the load average are printed: on a shared
machine the speed-up is bounded by the cores the batch actually got (Linux's autogroup
scheduler shares the CPU between sessions, not processes, so a second worker gains nothing
while other sessions keep the cores busy). With ``--dask`` the same batch also runs on a 2-worker ``LocalCluster``.

Usage: ``.venv/bin/python benchmarks/bench_batch.py [--seconds 6] [--size 640x360] [--dask]``
"""

from __future__ import annotations

import argparse
import logging
import os
import resource
import shutil
import tempfile
import time
from pathlib import Path

from pendtrack.config import Config
from pendtrack.stages.batch import batch_stage
from pendtrack.stages.render import render_stage

# (tile cm, launched, alley, trial): four different runs of the paper's kinds.
RUNS = ((0, False, False, 1), (6, False, True, 1), (12, True, False, 1), (18, True, True, 1))


def render_videos(folder: Path, *, seconds: float, width: int, height: int) -> None:
    """Render the four benchmark videos into ``folder`` (skipped when up to date)."""
    for tile, launched, alley, trial in RUNS:
        cfg = Config().replace("render", seconds=seconds, width=width, height=height, tile_length_m=tile / 100,
                               alley=alley, trial=trial, omega0=-1.5 if launched else 0.0, seed=tile)
        render_stage(out_dir=folder, config=cfg, progress=False, name_by_run_code=True)


def timed_batch(folder: Path, out: Path, config: Config, *, workers: int, scheduler: str = "processes") -> float:
    """Wall time of one batch from scratch [s]; prints it with the workers' CPU time and the load."""
    shutil.rmtree(out, ignore_errors=True)
    load0 = os.getloadavg()[0]
    cpu0 = _children_cpu()
    t0 = time.perf_counter()
    res = batch_stage(folder, out_dir=out, config=config, workers=workers, scheduler=scheduler, progress=False)
    elapsed = time.perf_counter() - t0
    cpu = _children_cpu() - cpu0  # local worker processes only (they have exited when the batch returns)
    bad = [r for r in res.runs if r.status != "ok"]
    if bad:
        print(f"  warning: {len(bad)} run(s) failed: {bad[0].reason}")
    per_run = ", ".join(f"{r.run_id} {r.runtime_s:.1f}s" for r in res.runs)
    who = f"{workers} worker(s)" if scheduler == "processes" else "dask"
    print(f"  {who}: wall {elapsed:.1f} s, workers' CPU {cpu:.1f} s (= {cpu / elapsed:.2f} cores busy), "
          f"load {load0:.1f}->{os.getloadavg()[0]:.1f}  ({per_run})")
    return elapsed


def _children_cpu() -> float:
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=6.0, help="length of each video [s]")
    parser.add_argument("--size", default="640x360", help="frame size WxH [px]")
    parser.add_argument("--n-starts", type=int, default=16, help="fit starts per run (work per run)")
    parser.add_argument("--cache", default=os.path.join(tempfile.gettempdir(), "pendtrack-bench-batch"),
                        help="folder for the rendered videos and outputs")
    parser.add_argument("--dask", action="store_true", help="also time a 2-worker Dask LocalCluster")
    args = parser.parse_args()
    width, height = (int(v) for v in args.size.lower().split("x"))
    root = Path(args.cache)
    videos = root / f"videos-{args.seconds:g}s-{width}x{height}"
    print(f"rendering {len(RUNS)} videos of {args.seconds:g} s at {width}x{height} into {videos} (cached)")
    render_videos(videos, seconds=args.seconds, width=width, height=height)
    config = Config().replace("fit", models=("classic",), n_starts=args.n_starts)
    print(f"cores: {len(os.sched_getaffinity(0))}; models classic, {args.n_starts} starts")
    print("warm-up (numba cache):")
    timed_batch(videos, root / "out-warm", config, workers=2)
    print("timings:")
    one = timed_batch(videos, root / "out-1", config, workers=1)
    two = timed_batch(videos, root / "out-2", config, workers=2)
    print(f"speed-up 2 workers vs 1: {one / two:.2f}x (target >= 1.7x on 2 otherwise idle cores; "
          f"a load above the core count lowers it)")
    if args.dask:
        from dask.distributed import LocalCluster

        with LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None,
                          silence_logs=logging.ERROR) as cluster:
            dask_t = timed_batch(videos, root / "out-dask", config, workers=2, scheduler=cluster.scheduler_address)
        print(f"speed-up dask (2 workers) vs 1 local worker: {one / dask_t:.2f}x")


if __name__ == "__main__":
    main()
