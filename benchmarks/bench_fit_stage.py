"""The fit stage alone on bench_run's 60-s record, every start run; optionally against another run (prints; no pass/fail).

Usage::

    .venv/bin/python benchmarks/bench_fit_stage.py [--out DIR] [--compare DIR] [--cache DIR]

The record is bench_run's render (``--cache``, rendered if missing) tracked once into
``<cache>/record_60s/kinematics.parquet`` and reused, so runs of different code fit the very
same samples. The fit stage then runs with the default config
(all 150 starts of the three models, their uncertainties) into ``--out`` and prints its wall
time and each model's ``runtime_s``. ``--compare DIR`` (the ``--out`` of an earlier run,
e.g. of older code) prints issue #16's "nothing found changes" table: each model's Xi^2_min
(relative change), n_accepted, and per parameter the change of its value and its u_paper in
standard errors (of the earlier run).

To compare with older code (its fit stage must take the same arguments), run this file from
the current tree first (it tracks the record), then with the older tree on the path::

    git worktree add /tmp/base <commit>
    .venv/bin/python benchmarks/bench_fit_stage.py --out /tmp/fit-new
    PYTHONPATH=/tmp/base .venv/bin/python benchmarks/bench_fit_stage.py --out /tmp/fit-base
    .venv/bin/python benchmarks/bench_fit_stage.py --out /tmp/fit-new2 --compare /tmp/fit-base
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

from bench_run import render_once

from pendtrack.config import Config
from pendtrack.stages.angle import angle_stage
from pendtrack.stages.fit import fit_stage
from pendtrack.stages.kinematics import kinematics_stage
from pendtrack.stages.track import track_stage


def record_once(cache: Path, seconds: float) -> Path:
    """The bench record's kinematics.parquet (tracked once from bench_run's cached render)."""
    folder = cache / f"record_{seconds:g}s"
    path = folder / "kinematics.parquet"
    if not path.is_file():
        video = render_once(cache / f"render_{seconds:g}s", seconds)
        common = {"out_dir": folder, "config": Config(), "progress": False}
        track = track_stage(video, **common)
        angle = angle_stage(track.path, **common)
        kinematics_stage(angle.path, **common)
    return path


def compare(old: Path, new: Path, models: tuple[str, ...]) -> None:
    """Print the change from the fit files in ``old`` to those in ``new``."""
    for m in models:
        ra, rb = (json.loads((d / f"fit_{m}.json").read_text()) for d in (old, new))
        rel = (rb["xi2_min"] - ra["xi2_min"]) / ra["xi2_min"]
        print(f"{m}: Xi2_min {ra['xi2_min']:.10g} -> {rb['xi2_min']:.10g} ({rel:+.2e} relative); "
              f"n_accepted {ra['n_accepted']} -> {rb['n_accepted']}")
        for name, pa in ra["params"].items():
            pb = rb["params"].get(name)
            se = pa.get("stderr") or float("nan")
            if pb is None:
                print(f"  {name:<10} not in the new fit")
                continue
            print(f"  {name:<10} {pa['value']:.9g} -> {pb['value']:.9g}: {(pb['value'] - pa['value']) / se:+.2e} SE; "
                  f"u_paper {pa['u_paper'] / se:.3g} -> {pb['u_paper'] / se:.3g} SE")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--cache", default=os.path.join(tempfile.gettempdir(), "pendtrack-bench-run"))
    ap.add_argument("--out", default=None, help="output folder (default: a temporary one)")
    ap.add_argument("--compare", default=None, help="an earlier --out to compare with")
    args = ap.parse_args(argv)
    record = record_once(Path(args.cache), args.seconds)
    config = Config()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(args.out) if args.out else Path(tmp)
        print(f"record {record}; load average {os.getloadavg()[0]:.2f}")
        t0 = time.perf_counter()
        fit_stage(record, out_dir=out, config=config, models=config.fit.models, force=True, progress=False)
        print(f"fit stage {time.perf_counter() - t0:.1f} s (no time budget); load average {os.getloadavg()[0]:.2f}")
        for m in config.fit.models:
            rec = json.loads((out / f"fit_{m}.json").read_text())
            print(f"  {m:<10} {rec['runtime_s']:6.1f} s  ({rec['n_starts']} starts, {rec['n_accepted']} accepted)")
        if args.compare:
            compare(Path(args.compare), out, config.fit.models)


if __name__ == "__main__":
    main()
