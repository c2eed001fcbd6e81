"""Speed of the track stage beside the decode-only rate of the same video (prints; no pass/fail).

Usage::

    .venv/bin/python benchmarks/bench_track.py [VIDEO] [--repeats N]

VIDEO defaults to ``sample_videos/12na1.mp4`` (a rendered 1280x720, 120 fps H.264 run,
10 s). Each repetition measures, back to back on the same file:

* ``decode 1T``   -- PyAV decode only (``for f in container.decode(stream): pass``),
                     one decoder thread (``thread_count = 1``), no pixel conversion;
* ``decode AUTO`` -- the same with FFmpeg threads (``thread_type = "AUTO"``);
* ``track 1T``    -- the whole track stage (sha256 of the input, decode to YUV planes,
                     tracking, track.parquet with provenance) with the stage's settings:
                     one decoder thread, no prefetch;
* ``track 1T+pf`` -- the same with the decoder in a background thread (``prefetch=8``):
                     decoding overlaps tracking on a second core;
* ``track AUTO``  -- the stage with FFmpeg threads, to compare with ``decode AUTO``.

Rates are frames per second of wall-clock time (median over repetitions) and, for the
single-threaded variants, per second of process CPU time, which is steadier on a shared
machine. The ratio of interest is ``track / decode`` with the same decoder settings.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import av

from pendtrack.config import Config

ROOT = Path(__file__).resolve().parents[1]


def decode_only(video: Path, *, threads: bool) -> tuple[int, float, float]:
    """Frames, wall seconds, CPU seconds of a plain decode."""
    with av.open(str(video)) as c:
        s = c.streams.video[0]
        if threads:
            s.thread_type = "AUTO"
        else:
            s.thread_count = 1
        w0, c0 = time.perf_counter(), time.process_time()
        n = 0
        for _ in c.decode(s):
            n += 1
        return n, time.perf_counter() - w0, time.process_time() - c0


def track(video: Path, out: Path, *, threads: bool, prefetch: int) -> tuple[int, float, float]:
    """Frames, wall seconds, CPU seconds of the track stage (forced, no progress bar)."""
    import pendtrack.stages.track as st

    st.DECODE_THREADS, st.DECODE_PREFETCH = threads, prefetch
    w0, c0 = time.perf_counter(), time.process_time()
    res = st.track_stage(video, out_dir=out, config=Config(), force=True, progress=False)
    return int(res.facts["frames"]), time.perf_counter() - w0, time.process_time() - c0


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("video", nargs="?", default=str(ROOT / "sample_videos" / "12na1.mp4"))
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args(argv)
    video = Path(args.video)
    import pendtrack.stages.track as st

    defaults = (st.DECODE_THREADS, st.DECODE_PREFETCH)
    wall: dict[str, list[float]] = {}
    cpu: dict[str, list[float]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        track(video, out, threads=False, prefetch=0)  # warm-up: imports, file cache
        for _ in range(args.repeats):
            runs = {
                "decode 1T": lambda: decode_only(video, threads=False),
                "track 1T": lambda: track(video, out, threads=False, prefetch=0),
                "track 1T+pf": lambda: track(video, out, threads=False, prefetch=8),
                "decode AUTO": lambda: decode_only(video, threads=True),
                "track AUTO": lambda: track(video, out, threads=True, prefetch=0),
            }
            for name, run in runs.items():
                n, w, c = run()
                wall.setdefault(name, []).append(n / w)
                cpu.setdefault(name, []).append(n / c)
    st.DECODE_THREADS, st.DECODE_PREFETCH = defaults
    med = {k: statistics.median(v) for k, v in wall.items()}
    medc = {k: statistics.median(v) for k, v in cpu.items()}
    info = av.open(str(video)).streams.video[0]
    print(f"video: {video} ({info.codec_context.width}x{info.codec_context.height}, {info.frames} frames, "
          f"{float(info.average_rate):g} fps, {info.codec_context.name})")
    print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f} at the end; "
          f"{args.repeats} repetitions, medians; stage defaults: threads={defaults[0]}, prefetch={defaults[1]}")
    print(f"{'':14s}{'wall fps':>10s}{'cpu fps':>10s}   (min..max wall)")
    for k in wall:
        print(f"{k:14s}{med[k]:10.0f}{medc[k]:10.0f}   ({min(wall[k]):.0f}..{max(wall[k]):.0f})")
    print("ratios (track / decode-only, same decoder settings):")
    print(f"  1T    wall {med['track 1T'] / med['decode 1T']:.2f}   cpu {medc['track 1T'] / medc['decode 1T']:.2f}")
    print(f"  1T+pf wall {med['track 1T+pf'] / med['decode 1T']:.2f}   (decoder on its own thread)")
    print(f"  AUTO  wall {med['track AUTO'] / med['decode AUTO']:.2f}")
    print(f"  decode AUTO / decode 1T wall {med['decode AUTO'] / med['decode 1T']:.2f}")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
