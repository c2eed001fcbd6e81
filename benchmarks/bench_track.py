"""Speed of the track stage beside the decode-only rate of the same video (prints; no pass/fail).

Usage::

    .venv/bin/python benchmarks/bench_track.py [VIDEO ...] [--repeats N | --bracketed N]

VIDEO defaults to two cases, each measured and printed on its own:

* ``sample_videos/12na1.mp4``: a rendered 1280x720, 120 fps H.264 run, 10 s;
* a rendered 1920x1080, 60 fps run (a phone's 1080p video: a blue ball on a string,
  normal lens, 10 s), rendered once by the project's renderer into
  ``.benchmarks/bench_1080p60/video.mp4`` (git-ignored) and reused afterwards.

Each repetition measures, back to back on the same file:

* ``decode 1T``   -- PyAV decode only (``for f in container.decode(stream): pass``),
                     one decoder thread (``thread_count = 1``), no pixel conversion;
* ``decode AUTO`` -- the same with FFmpeg threads (``thread_type = "AUTO"``);
* ``track 1T``    -- the whole track stage (sha256 of the input, decode to YUV planes,
                     tracking, track.parquet with provenance) with the stage's settings:
                     one decoder thread, no prefetch;
* ``track 1T+pf`` -- the same with the decoder in a background thread, as the stage runs
                     it: at least 8 frames ahead (``DECODE_PREFETCH``), as many as fit
                     ``DECODE_PREFETCH_MB`` (256 MiB: 86 frames at 1080p, 194 at 720p);
                     decoding overlaps tracking on a second core;
* ``track AUTO``  -- the stage with FFmpeg threads, to compare with ``decode AUTO``.

``--bracketed N`` measures only the stage as it runs: N stage runs, each between two decode-only
runs of the same file, each ratio over the mean of the two (this machine's speed drifts by
+-20 % within a minute; bracketing cancels a drift to first order). Its median over ~24 runs
is the steadiest reading of the ratio here.

Rates are frames per second of wall-clock time (median over repetitions) and, for the
single-threaded variants, per second of process CPU time, which is steadier on a shared
machine. The ratio of interest is ``track / decode`` with the same decoder settings; for
``1T+pf`` it is also given paired (each repetition's track rate over that repetition's
decode rate, median over repetitions), which a drift of the machine's load between
repetitions moves less than the ratio of the two medians.

On a loaded machine the two threads of ``track 1T+pf`` seldom get two cores, and its wall
ratio says little. The ``model`` line is steadier: each repetition also times, in CPU
seconds, every frame's decoding and every frame's tracking in a serial run of the stage,
and replays them through a decoder and a consumer on two free cores joined by a queue of
the stage's depth (and of 8 frames, the former default) -- the ratio a quiet machine
would give without contention between the two threads (the GIL, shared caches), so an
upper bound of ``1T+pf``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import av

from pendtrack.config import Config
from pendtrack.video.reader import VideoReader, prefetch_depth, probe_video

ROOT = Path(__file__).resolve().parents[1]
CACHE_1080P = ROOT / ".benchmarks" / "bench_1080p60"
# the 1080p case: what issue 15's phone video looks like (its field conditions but the hand and the sticker)
RENDER_1080P = dict(width=1920, height=1080, fps=60.0, seconds=10.0, theta0=1.0, rig="string", marker_color="blue",
                    marker_shape="ball", spot_radius_m=0.02, lens_projection="none", lens_fov_deg=75.0,
                    camera_offset_m=(0.0, 0.13), seed=0)


def video_1080p60() -> Path:
    """The rendered 1080p/60 fps video, rendered on first use into :data:`CACHE_1080P`."""
    video = CACHE_1080P / "video.mp4"
    if not video.is_file():
        from pendtrack.stages.render import render_stage

        print(f"rendering the 1080p/60 fps case into {CACHE_1080P} (once) ...", flush=True)
        render_stage(out_dir=CACHE_1080P, config=Config().replace("render", **RENDER_1080P), progress=False)
    return video


def config_for(video: Path) -> Config:
    """The stage's config for a case: the 1080p render is a blue ball through a normal lens."""
    if video.resolve() == (CACHE_1080P / "video.mp4").resolve():
        return Config().replace("lens", projection="none").replace("track", marker_color="blue")
    return Config()


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
    res = st.track_stage(video, out_dir=out, config=config_for(video), force=True, progress=False)
    return int(res.facts["frames"]), time.perf_counter() - w0, time.process_time() - c0


class _TimedReader(VideoReader):
    """The stage's reader, recording each frame's decoding and the consumer's work on it [CPU s]."""

    runs: list[tuple[list[float], list[float]]] = []

    def _frames(self, decoder: Iterator) -> Iterator:
        decode: list[float] = []
        work: list[float] = []
        self.runs.append((decode, work))

        def timed() -> Iterator:
            while True:
                c0 = time.thread_time()
                try:
                    frame = next(decoder)
                except StopIteration:
                    return
                decode.append(time.thread_time() - c0)
                yield frame

        for frame in super()._frames(timed()):
            c0 = time.thread_time()
            yield frame
            work.append(time.thread_time() - c0)


def pipeline_wall(decode: list[float], work: list[float], depth: int) -> float:
    """Seconds for a decoder and a consumer on two cores to get through frames costing ``decode`` and
    ``work`` [s each], the decoder at most ``depth`` frames ahead of the consumer's next frame."""
    put = [0.0] * len(decode)  # when frame i enters the queue
    taken = [0.0] * len(decode)  # when the consumer takes it
    done = 0.0
    for i, (d, w) in enumerate(zip(decode, work)):
        decoded = (put[i - 1] if i else 0.0) + d
        put[i] = max(decoded, taken[i - depth] if i >= depth else 0.0)
        taken[i] = max(done, decoded)
        done = taken[i] + w
    return done


def model(video: Path, out: Path) -> dict[str, float]:
    """``track / decode`` of the two-core pipeline model (see the module's docstring) at the stage's
    prefetch depth and at 8 frames, from one serial run of the stage."""
    import pendtrack.stages.track as st

    _TimedReader.runs.clear()
    st.VideoReader = _TimedReader
    try:
        c0 = time.thread_time()
        track(video, out, threads=False, prefetch=0)
        total = time.thread_time() - c0
    finally:
        st.VideoReader = VideoReader
    (decode, work), = _TimedReader.runs
    other = total - sum(decode) - sum(work)  # hashing, setup, the artifact
    info = probe_video(video)
    depth = prefetch_depth(8, st.DECODE_PREFETCH_MB, info.width, info.height)
    return {f"{depth} ahead": sum(decode) / (pipeline_wall(decode, work, depth) + other),
            "8 ahead": sum(decode) / (pipeline_wall(decode, work, 8) + other)}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("video", nargs="*", help="videos to measure (default: the 720p/120 and 1080p/60 cases)")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--bracketed", type=int, default=0, metavar="N",
                    help="instead: N runs of the stage as it runs (decoder thread), each between two decode-only "
                         "runs of the same file; the ratio is its rate over their mean (see bracketed())")
    args = ap.parse_args(argv)
    videos = [Path(v) for v in args.video] or [ROOT / "sample_videos" / "12na1.mp4", video_1080p60()]
    for video in videos:
        if args.bracketed:
            bracketed(video, args.bracketed)
        else:
            measure(video, args.repeats)


def bracketed(video: Path, runs: int) -> None:
    """``track / decode-only`` of the stage as it runs, each stage run against the mean rate of the
    decode-only runs just before and just after it (a drift of the machine's speed during the pair
    cancels to first order). Prints the median over ``runs`` and the share of runs at or above 0.8."""
    import pendtrack.stages.track as st

    ratios = []
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        track(video, out, threads=False, prefetch=st.DECODE_PREFETCH)  # warm-up: imports, file cache
        n, w, _ = decode_only(video, threads=False)
        before = n / w
        for _ in range(runs):
            n, w, _ = track(video, out, threads=False, prefetch=st.DECODE_PREFETCH)
            rate = n / w
            n, w, _ = decode_only(video, threads=False)
            after = n / w
            ratios.append(rate / ((before + after) / 2))
            before = after
    print(f"{video.name}: stage / decode-only (bracketed), {runs} runs, load average {os.getloadavg()[0]:.2f} "
          f"at the end: median {statistics.median(ratios):.2f} ({min(ratios):.2f}..{max(ratios):.2f}), "
          f"{sum(r >= 0.8 for r in ratios) / runs:.0%} of runs >= 0.8", flush=True)


def measure(video: Path, repeats: int) -> None:
    """Measure and print one video's rates and ratios."""
    import pendtrack.stages.track as st

    defaults = (st.DECODE_THREADS, st.DECODE_PREFETCH)
    wall: dict[str, list[float]] = {}
    cpu: dict[str, list[float]] = {}
    models: dict[str, list[float]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        track(video, out, threads=False, prefetch=0)  # warm-up: imports, file cache
        for _ in range(repeats):
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
            for name, ratio in model(video, out).items():
                models.setdefault(name, []).append(ratio)
    st.DECODE_THREADS, st.DECODE_PREFETCH = defaults
    med = {k: statistics.median(v) for k, v in wall.items()}
    medc = {k: statistics.median(v) for k, v in cpu.items()}
    info = av.open(str(video)).streams.video[0]
    print(f"video: {video} ({info.codec_context.width}x{info.codec_context.height}, {info.frames} frames, "
          f"{float(info.average_rate):g} fps, {info.codec_context.name})")
    print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f} at the end; "
          f"{repeats} repetitions, medians; stage defaults: threads={defaults[0]}, prefetch={defaults[1]} "
          f"frames or {st.DECODE_PREFETCH_MB:g} MiB")
    print(f"{'':14s}{'wall fps':>10s}{'cpu fps':>10s}   (min..max wall)")
    for k in wall:
        print(f"{k:14s}{med[k]:10.0f}{medc[k]:10.0f}   ({min(wall[k]):.0f}..{max(wall[k]):.0f})")
    paired = [t / d for t, d in zip(wall["track 1T+pf"], wall["decode 1T"])]
    print("ratios (track / decode-only, same decoder settings):")
    print(f"  1T    wall {med['track 1T'] / med['decode 1T']:.2f}   cpu {medc['track 1T'] / medc['decode 1T']:.2f}")
    print(f"  1T+pf wall {med['track 1T+pf'] / med['decode 1T']:.2f}   (decoder on its own thread); paired, each "
          f"repetition's own decode: median {statistics.median(paired):.2f} ({min(paired):.2f}..{max(paired):.2f})")
    print(f"  AUTO  wall {med['track AUTO'] / med['decode AUTO']:.2f}")
    print("  model (serial run's per-frame CPU times, two free cores, no contention): 1T+pf "
          + ", ".join(f"{statistics.median(v):.2f} ({k})" for k, v in models.items()))
    print(f"  decode AUTO / decode 1T wall {med['decode AUTO'] / med['decode 1T']:.2f}")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
