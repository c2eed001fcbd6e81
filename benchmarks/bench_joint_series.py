"""A joint fit of a rendered 12-run series of one rig: wall time, and how well it recovers the truth.

Usage::

    .venv/bin/python benchmarks/bench_joint_series.py [--runs 12] [--cache DIR]

The series (``tests/rig_series.py``: one bar pendulum, tiles of 3, 6 and 9 cm, with and without
the alley, each released from 2.7 rad and launched to about 2 rad; 20 s, 640x360, 120 fps; the
classic model with one C0 for the rig and a drag and added mass per tile and alley) is rendered
and tracked once into a cache folder (``pendtrack batch``, kinematics kept) and reused. Then
``pendtrack fit`` of every run's kinematics.parquet, ``--model classic``, with the default
config (each run's own fit with 150 starts, then the joint search and uncertainties), runs in a
process of its own and is timed by the wall clock around it. It prints the time, the joint fit's
convergence, every value it shares between runs against the truth (z = error / standard error),
and the shared C0's standard error over the mean of the runs' own (``stderr_ratio``).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_run import cpu_model

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from rig_series import group_truth, render_series  # noqa: E402

from pendtrack.artifacts import read_artifact  # noqa: E402

TRACK_CONFIG = """\
[fit]
models = ["classic"]
n_starts = 1
profile = false

[batch]
report = false
"""


def track_series(folder: Path, n_runs: int) -> tuple[list[Path], dict[str, dict[str, float]]]:
    """The series rendered and tracked (cached): each run's kinematics.parquet, and its true values."""
    videos = folder / "videos"
    runs = render_series(videos, n_runs)
    cfg = folder / "track.toml"
    cfg.write_text(TRACK_CONFIG)
    pendtrack = str(Path(sys.executable).parent / "pendtrack")
    subprocess.run([pendtrack, "batch", str(videos), "--out", str(folder / "batch"), "--config", str(cfg), "-q"],
                   check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    truth = {r.code: read_artifact(videos / f"{r.code}.truth.parquet", "truth").provenance.extra["params"]
             for r in runs}
    return [folder / "batch" / r.code / "kinematics.parquet" for r in runs], truth


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=12, help="4, 8 or 12 runs")
    ap.add_argument("--cache", default=os.path.join(tempfile.gettempdir(), "pendtrack-bench-series"))
    ap.add_argument("--model", default="classic",
                    help="the model fitted (default classic; e.g. classic+angle_gain: a gain of theta per run)")
    args = ap.parse_args(argv)
    kinematics, truth = track_series(Path(args.cache) / f"series_{args.runs}", args.runs)
    print(f"joint fit of {args.runs} rendered runs (20 s, 640x360, 120 fps), {args.model}, default config; "
          f"{cpu_model()}, {os.cpu_count()} cores; load average {os.getloadavg()[0]:.2f}")
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [str(Path(sys.executable).parent / "pendtrack"), "fit", *map(str, kinematics), "--model", args.model,
               "--out", tmp, "-q"]
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        wall = time.perf_counter() - t0
        print(f"  wall {wall:.1f} s, exit {proc.returncode} (target: <= 600 s for 12 runs on 2 cores)")
        if proc.returncode not in (0, 1):
            print(proc.stderr.strip().splitlines()[-1])
            return
        rec = json.loads(next(Path(tmp).glob("fit_*.json")).read_text())
    print(f"  joint fit {rec['runtime_s']:.1f} s: converged={rec['converged']} trustworthy={rec['trustworthy']} "
          f"({rec['message']}), {rec['n_params']} parameters, {rec['n_starts']} starts")
    rows = [("C0", rec["params"]["C0"], truth[next(iter(truth))]["C0"])]
    for name, groups in rec["groups"].items():
        for group, est in groups.items():
            code = est["runs"][0]
            true = truth[code][name] if name == "Omega0" else group_truth(int(code[:2]), code[3] == "a")[name]
            rows.append((f"{name}[{group}]", est, true))
    for label, est, true in rows:
        print(f"  {label:>20} {est['value']:.6g} +- {est['stderr']:.2g}  true {true:.6g}  "
              f"z {(est['value'] - true) / est['stderr']:+.2f}")
    gains = {run: r["params"]["theta_gain"] for run, r in rec["runs"].items() if "theta_gain" in r["params"]}
    if gains:
        print("  theta_gain per run: " + ", ".join(f"{run} {g['value']:+.1e} +- {g['stderr']:.0e}"
                                                 for run, g in gains.items()))
    print(f"  C0 stderr_ratio {rec['stderr_ratio']['C0']:.4f} (bar 1.5/sqrt(n) = {1.5 / args.runs ** 0.5:.3f})")


if __name__ == "__main__":
    main()
