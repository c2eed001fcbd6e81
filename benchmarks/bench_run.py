"""`pendtrack run` on a 60-s, 720p/120 fps render: first run (empty numba cache), warm run, and a run
on loaded cores; wall time of each and whether their fits agree (prints; no pass/fail).

Usage::

    .venv/bin/python benchmarks/bench_run.py [--seconds 60] [--cache DIR] [--no-loaded]

The video is rendered once with the renderer's defaults (the paper's setup: fisheye, pink
spot, 1280x720 at 120 fps) into a cache folder and reused. Then ``pendtrack run`` with the
default config (the three models classic, OPA and fractional, 150 starts each, their
uncertainties, the report) runs as a user runs it, in a process of its own:

1. **first run**: with an empty ``NUMBA_CACHE_DIR``, so every kernel compiles (a fresh clone);
2. **warm run**: the same cache, now filled;
3. **loaded run** (unless ``--no-loaded``): the warm run again while a second ``pendtrack run``
   of the same video keeps both cores busy.

Each run's stage times come from its own provenance (track, fit per model: ``runtime_s``), the
total from the wall clock around the process. Last, every ``fit_<model>.json`` of runs 2 and 3
is compared with run 1's, apart from the runtime fields: the same input must give the same
fit whatever the cache and the load.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from pendtrack.config import Config
from pendtrack.stages.render import render_stage

RUNTIME_KEYS = ("runtime_s", "provenance")  # fields that say when and how fast, not what was found


def cpu_model() -> str:
    """The CPU's model name (Linux /proc/cpuinfo), else the platform's processor string."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def render_once(folder: Path, seconds: float) -> Path:
    """The cached render (video.mp4, truth.parquet) of ``seconds`` s with the default scene."""
    if not (folder / "video.mp4").is_file():
        config = Config().replace("render", seconds=seconds, seed=16)
        render_stage(out_dir=folder, config=config, progress=False)
    return folder / "video.mp4"


def start_run(video: Path, out: Path, cache: Path) -> subprocess.Popen:
    """``pendtrack run VIDEO --out OUT -q`` in its own process, numba caching into ``cache``."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    cmd = [str(Path(sys.executable).parent / "pendtrack"), "run", str(video), "--out", str(out), "-q", "--force"]
    # a session of its own, so the loader can be stopped with its worker processes (killpg)
    return subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)


def finish(proc: subprocess.Popen, t0: float, out: Path, label: str) -> float:
    """Wait for a run; print its wall time and the fit's per-model times; return the wall time [s]."""
    _, err = proc.communicate()
    wall = time.perf_counter() - t0
    print(f"  {label:<28} {wall:7.1f} s  exit {proc.returncode}")
    for line in (err or "").strip().splitlines()[-3:]:
        print(f"      {line}")
    for path in sorted(out.glob("fit_*.json")):
        rec = json.loads(path.read_text())
        print(f"      {rec['model']:<11} {rec['runtime_s']:7.1f} s  ({rec['n_starts']} starts, "
              f"converged={rec['converged']}, trustworthy={rec['trustworthy']})")
    return wall


def strip_runtime(record: dict) -> dict:
    """A fit record without the fields that say when and how fast it ran."""
    return {k: v for k, v in record.items() if k not in RUNTIME_KEYS}


def compare(reference: Path, other: Path) -> list[str]:
    """Names of the fit files of ``other`` that differ from ``reference``'s apart from runtime fields."""
    differ = []
    for path in sorted(reference.glob("fit_*.json")):
        a = strip_runtime(json.loads(path.read_text()))
        b_path = other / path.name
        b = strip_runtime(json.loads(b_path.read_text())) if b_path.is_file() else None
        if a != b:
            differ.append(path.name)
    return differ


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--cache", default=os.path.join(tempfile.gettempdir(), "pendtrack-bench-run"))
    ap.add_argument("--no-loaded", action="store_true", help="skip the run on loaded cores")
    args = ap.parse_args(argv)
    video = render_once(Path(args.cache) / f"render_{args.seconds:g}s", args.seconds)
    print(f"pendtrack run, defaults; video {video} ({args.seconds:g} s, 1280x720, 120 fps); "
          f"{cpu_model()}, {os.cpu_count()} cores; load average {os.getloadavg()[0]:.2f}")
    with tempfile.TemporaryDirectory() as tmp:
        tmp_path = Path(tmp)
        numba_cache = tmp_path / "numba-cache"  # empty: the first run compiles every kernel
        runs = {"first run (empty cache)": tmp_path / "cold", "warm run": tmp_path / "warm"}
        walls = {}
        for label, out in runs.items():
            t0 = time.perf_counter()
            walls[label] = finish(start_run(video, out, numba_cache), t0, out, label)
        if not args.no_loaded:
            label = "warm run, both cores loaded"
            out = runs[label] = tmp_path / "loaded"
            load = start_run(video, tmp_path / "load", tmp_path / "numba-cache-load")
            time.sleep(5.0)  # the loader is past its imports and tracking its video
            t0 = time.perf_counter()
            walls[label] = finish(start_run(video, out, numba_cache), t0, out, label)
            os.killpg(load.pid, signal.SIGKILL)  # the loader and its worker processes
            load.wait()
        cold = runs["first run (empty cache)"]
        for label, out in runs.items():
            if out == cold:
                continue
            differ = compare(cold, out)
            print(f"  fits of the {label} vs the first run: "
                  f"{'identical apart from runtime fields' if not differ else 'DIFFER: ' + ', '.join(differ)}")
    print(f"  first run {walls['first run (empty cache)']:.1f} s, warm {walls['warm run']:.1f} s "
          f"(target: warm <= 60 s on 2 cores)")


if __name__ == "__main__":
    main()
