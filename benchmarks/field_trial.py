"""Field trial: `pendtrack run` on every video of a folder, as a user would run it.

    python benchmarks/field_trial.py FOLDER [--out DIR] [--model classic] [--flags "--projection none"]

Each video is run with at most the lens and marker flags: those of ``--flags`` (for every
video) and of a sidecar file ``VIDEO.flags`` beside it (one line, e.g.
``--projection none --marker-color dark``); any other flag in them is refused. One line per
video:

* ``ok``: share of the frames from the marker's acquisition on that are tracked ok [%];
* ``swings``: whether the tracked point swings (the track's provenance, ``swing``);
* ``arc``: the arc the track spans about the fitted axle [deg] (``-`` with a given axle);
* ``T_zc``: the zero-crossing period of theta [s] (crossings of theta's median, with
  hysteresis: :mod:`pendtrack.track.swing`);
* ``Omega0``: the first fitted model's Omega0 [rad/s] and its period 2 pi / Omega0 [s];
* ``T_ind``: an independent period [s]: the video decoded anew (PyAV, grey, every frame's
  own timestamp), each frame differenced against the per-pixel median frame, the centroid of
  the most changed pixels (the moving bob) followed in x, its zero-crossing period -- no
  template, no colour, no lens, nothing of pendtrack's tracking;
* ``dT``: T_zc / T_ind - 1 [%];
* ``rc``: the exit code; ``wall``: the wall time [s]; then the error line, if any.

``--model`` is passed to `run` (default: the config's models; ``classic`` alone keeps a
trial of many videos short). Nothing is written outside ``--out`` (default: a temporary
folder, removed at the end unless ``--keep``).
"""

from __future__ import annotations

import argparse
import json
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from pendtrack.artifacts import read_artifact
from pendtrack.track.swing import crossing_times, period_from_crossings

VIDEO_SUFFIXES = (".mp4", ".mov", ".avi", ".mkv", ".m4v", ".webm")
ALLOWED = {"--projection": 1, "--fov": 1, "--fixed-pixels": 1, "--marker-color": 1}


def allowed_flags(words: list[str], *, source: str) -> list[str]:
    """``words`` if they are only lens and marker flags with their values; else SystemExit."""
    i = 0
    while i < len(words):
        if words[i] not in ALLOWED:
            raise SystemExit(f"error: {source}: {words[i]!r} is not a lens or marker flag ({', '.join(ALLOWED)})")
        i += 1 + ALLOWED[words[i]]
    return words


def theta_period(t: np.ndarray, theta: np.ndarray, ok: np.ndarray) -> float:
    """Zero-crossing period [s] of theta about its median (hysteresis: 4 noise sigmas, at least 2 mrad)."""
    t, th = t[ok], theta[ok]
    if th.size < 5:
        return float("nan")
    dd = np.diff(th, 2)
    noise = 1.4826 * float(np.median(np.abs(dd - np.median(dd)))) / np.sqrt(6.0)
    return period_from_crossings(crossing_times(t, th - np.median(th), hysteresis=max(2e-3, 4 * noise)))


def independent_period(video: Path, *, max_side: int = 320) -> float:
    """Zero-crossing period [s] of the frame-difference centroid's x (see the module docstring)."""
    import av

    frames, times = [], []
    with av.open(str(video)) as c:
        stream = c.streams.video[0]
        step = max(1, int(np.ceil(max(stream.codec_context.width, stream.codec_context.height) / max_side)))
        for fr in c.decode(stream):
            frames.append(fr.to_ndarray(format="gray")[::step, ::step].astype(np.float32))
            times.append(float(fr.time) if fr.time is not None else np.nan)
    if len(frames) < 10:
        return float("nan")
    stack = np.stack(frames)
    t = np.asarray(times) - times[0]
    bg = np.median(stack[:: max(1, len(frames) // 150)], axis=0)
    xs = np.full(len(frames), np.nan)
    cols = np.arange(stack.shape[2], dtype=float)
    for k, f in enumerate(stack):
        d = np.abs(f - bg)
        thr = max(25.0, float(np.percentile(d, 99.7)))
        w = np.where(d > thr, d, 0.0)
        if w.sum() > 0:
            xs[k] = float(w.sum(axis=0) @ cols / w.sum())
    ok = np.isfinite(xs)
    if ok.sum() < 10:
        return float("nan")
    x = xs[ok] - np.median(xs[ok])
    spread = float(np.percentile(np.abs(x), 90))
    return period_from_crossings(crossing_times(t[ok], x, hysteresis=0.2 * spread))


def summarise(out: Path) -> dict[str, object]:
    """What the run left in ``out``."""
    row: dict[str, object] = {}
    track_path, angle_path = out / "track.parquet", out / "angle.parquet"
    if track_path.is_file():
        track = read_artifact(track_path, "track")
        extra = track.provenance.extra
        n_after = int(extra["n_frames"]) - int(extra["acquisition"]["row"])
        row["ok"] = 100.0 * float(track.data.ok.sum()) / max(n_after, 1)
        row["swings"] = bool(extra.get("swing", {}).get("swings", False))
    if angle_path.is_file():
        angle = read_artifact(angle_path, "angle")
        circle = angle.provenance.extra.get("circle") or {}
        row["arc"] = circle.get("arc_span_deg")
        d = angle.data
        row["T_zc"] = theta_period(d.t.to_numpy(float), d.theta.to_numpy(float), d.ok.to_numpy(bool))
    for fit_path in sorted(out.glob("fit_*.json")):
        fit = json.loads(fit_path.read_text())
        omega0 = fit.get("params", {}).get("Omega0", {}).get("value")
        if omega0:
            row["Omega0"] = float(omega0)
            row["model"] = fit.get("model")
            break
    return row


def fmt(row: dict[str, object]) -> str:
    def num(key: str, spec: str) -> str:
        v = row.get(key)
        return format(v, spec) if isinstance(v, (int, float)) and np.isfinite(v) else "-"

    if isinstance(row.get("T_zc"), float) and isinstance(row.get("T_ind"), float):
        row["dT"] = 100.0 * (row["T_zc"] / row["T_ind"] - 1.0)  # type: ignore[operator]
    omega = row.get("Omega0")
    o = f"{omega:.4f} (T {2 * np.pi / omega:.4f} s)" if isinstance(omega, float) else "-"
    swings = {True: "yes", False: "no"}.get(row.get("swings"), "-")  # type: ignore[arg-type]
    return (f"{row['video']:<40} ok {num('ok', '6.2f')} %  swings {swings:<3}  arc {num('arc', '6.1f')} deg  "
            f"T_zc {num('T_zc', '.4f')} s  T_ind {num('T_ind', '.4f')} s  dT {num('dT', '+.2f')} %  "
            f"Omega0 {o}  rc {row['rc']}  wall {row['wall']:.1f} s"
            + (f"  | {row['error']}" if row.get("error") else ""))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folder", type=Path)
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--keep", action="store_true", help="keep the temporary output folder")
    ap.add_argument("--model", default=None, help="model passed to `run` (default: the config's)")
    ap.add_argument("--flags", default="", help="lens/marker flags for every video")
    args = ap.parse_args(argv)
    common = allowed_flags(shlex.split(args.flags), source="--flags")
    videos = sorted(p for p in args.folder.iterdir() if p.suffix.lower() in VIDEO_SUFFIXES)
    tmp = None
    out_root = args.out
    if out_root is None:
        tmp = tempfile.TemporaryDirectory(prefix="field_trial_")
        out_root = Path(tmp.name)
    try:
        for video in videos:
            side = video.with_name(video.name + ".flags")
            flags = common + (allowed_flags(shlex.split(side.read_text()), source=str(side)) if side.is_file() else [])
            out = out_root / video.stem
            cmd = [sys.executable, "-m", "pendtrack", "run", str(video), "--out", str(out), "-q", *flags]
            if args.model:
                cmd += ["--model", args.model]
            t0 = time.perf_counter()
            proc = subprocess.run(cmd, capture_output=True, text=True)
            wall = time.perf_counter() - t0
            errors = [ln for ln in proc.stderr.splitlines() + proc.stdout.splitlines() if ln.startswith("error:")]
            row = {"video": video.name + (f" [{' '.join(flags)}]" if flags else ""), "rc": proc.returncode,
                   "wall": wall, "error": errors[0] if errors else "", **summarise(out),
                   "T_ind": independent_period(video)}
            print(fmt(row), flush=True)
    finally:
        if tmp is not None and not args.keep:
            tmp.cleanup()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
