"""Decode a video into raw 4:2:0 planes with presentation timestamps (PyAV).

Conventions
-----------
Frames come as :class:`YuvFrame`: the luma plane ``y`` (H, W) and the chroma planes ``u``
(Cb) and ``v`` (Cr) (ceil(H/2), ceil(W/2)), uint8 views into the decoder's buffers (no copy,
no colour conversion: converting a whole 720p frame to BGR costs more than tracking it).
Pixel centres are at integer coordinates, x right, y down.

Frames are shown as players show them: a phone filmed upright stores its frames on their side with a
display rotation (the display matrix; iPhone portrait: -90 degrees), and each frame's planes are turned
by it (quarter turns) before anything sees them; :class:`VideoInfo`'s size is the turned one.

Time ``t`` [s] is the frame's presentation timestamp (``pts * time_base``) minus the first
frame's, so variable frame rates survive; a positive ``fps`` override gives ``index / fps``.
Frames without a timestamp fall back to the container's average rate. ``t`` and ``index``
stay those of the whole video when only a part of it is read (``start``, ``end``): the
times a user reads in a player are the times of the artifacts.

What the container declares (frame count, duration, average rate) is a hint: the frames are
what decodes, each at its own timestamp. A file whose decoded frames cover the declared duration
but not the declared count (re-encoded clips, variable rates, filler samples) is read as it is; a
real shortfall (the decoded frames end before the declared duration, or decoding fails part-way:
a cut download) is a warning, and the frames before it are used. Only a file of which nothing can
be decoded (missing file, not a video, no frames) raises :class:`pendtrack.errors.VideoError`
naming the file. :attr:`VideoReader.decode_report` says what was found.
"""

from __future__ import annotations

import logging
import queue
import sys
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import av
import numpy as np

from pendtrack.errors import VideoError
from pendtrack.gitlfs import is_lfs_pointer, lfs_message

log = logging.getLogger(__name__)

_PLANAR_420 = ("yuv420p", "yuvj420p")
TIME_TOLERANCE_S = 1e-6  # a frame within this of ``start`` or ``end`` is inside the range [s]


def check_time_range(start: float, end: float) -> None:
    """Raise ValueError unless ``0 <= start`` and (``end == 0`` or ``end > start``) [s]."""
    if not (np.isfinite(start) and start >= 0):
        raise ValueError(f"start must be a time >= 0 s, got {start!r}")
    if not (np.isfinite(end) and (end == 0 or end > start)):
        raise ValueError(f"end must be 0 (the last frame) or a time after start ({start:g} s), got {end!r}")


@dataclass(frozen=True)
class VideoInfo:
    """What the container says about its first video stream.

    Attributes
    ----------
    path : Path
    width, height : int
        Frame size [px].
    n_frames : int
        Frames declared by the container (0 when it does not say): a hint, often wrong.
    fps : float
        Average frame rate [1/s] (0 when unknown): a hint.
    duration_s : float
        Stream (else container) duration declared [s] (0 when unknown): a hint.
    codec : str
    pix_fmt : str
        Decoded pixel format (frames in other formats are converted to yuv420p).
    rotation_deg : int
        Display rotation the frames are turned by, counterclockwise [deg] (0, 90, 180 or 270).
    """

    path: Path
    width: int
    height: int
    n_frames: int
    fps: float
    codec: str
    pix_fmt: str
    duration_s: float = 0.0
    rotation_deg: int = 0

    def to_dict(self) -> dict[str, object]:
        return {"path": str(self.path), "width": self.width, "height": self.height, "n_frames": self.n_frames,
                "fps": self.fps, "codec": self.codec, "pix_fmt": self.pix_fmt, "duration_s": self.duration_s,
                "rotation_deg": self.rotation_deg}


class YuvFrame:
    """One decoded frame as 4:2:0 planes.

    Attributes
    ----------
    index : int
        0-based decode (presentation) order.
    t : float
        Time [s] since the first frame.
    y, u, v : ndarray, uint8
        Luma (H, W) and chroma Cb, Cr (ceil(H/2), ceil(W/2)) planes; views into the
        decoder's buffer, valid while this object lives (do not write to them).
    """

    __slots__ = ("index", "t", "y", "u", "v", "_frame")

    def __init__(self, index: int, t: float, y: np.ndarray, u: np.ndarray, v: np.ndarray,
                 frame: av.VideoFrame | None = None) -> None:
        self.index = index
        self.t = t
        self.y = y
        self.u = u
        self.v = v
        self._frame = frame

    def bgr(self) -> np.ndarray:
        """The whole frame as a BGR uint8 image (H, W, 3): slow, for single frames only."""
        import cv2

        h, w = self.y.shape
        if h % 2 or w % 2:
            raise ValueError("bgr() needs an even frame size")
        i420 = np.concatenate([self.y, self.u.reshape(-1, w), self.v.reshape(-1, w)], axis=0)
        return cv2.cvtColor(i420, cv2.COLOR_YUV2BGR_I420)


def _plane(plane: av.video.plane.VideoPlane, h: int, w: int) -> np.ndarray:
    buf = np.frombuffer(plane, dtype=np.uint8)
    return buf.reshape(-1, plane.line_size)[:h, :w]


def quarter_turns(frame: av.VideoFrame) -> int:
    """Counterclockwise quarter turns (0-3) that show ``frame`` as players do: its display matrix's rotation.

    A rotation that is no multiple of 90 degrees (never written by a camera) is not applied.
    """
    try:
        deg = float(frame.rotation or 0.0)
    except (AttributeError, TypeError, ValueError):  # no display matrix, or one PyAV cannot read
        return 0
    k = round(deg / 90.0)
    return k % 4 if abs(deg - 90.0 * k) < 1.0 else 0


def frame_planes(frame: av.VideoFrame) -> tuple[np.ndarray, np.ndarray, np.ndarray, av.VideoFrame]:
    """Y, U, V planes of a decoded frame (converted to yuv420p first if it is in another format), turned
    by its display rotation (:func:`quarter_turns`; then copies, else views)."""
    k = quarter_turns(frame)
    if frame.format.name not in _PLANAR_420:
        frame = frame.reformat(format="yuv420p")
    h, w = frame.height, frame.width
    ch, cw = (h + 1) // 2, (w + 1) // 2
    p = frame.planes
    y, u, v = _plane(p[0], h, w), _plane(p[1], ch, cw), _plane(p[2], ch, cw)
    if k:
        y, u, v = (np.ascontiguousarray(np.rot90(plane, k)) for plane in (y, u, v))
    return y, u, v, frame


def _open(path: Path) -> av.container.InputContainer:
    if not path.exists():
        raise VideoError("file not found", path=path)
    if not path.is_file():
        raise VideoError("not a file", path=path)
    try:
        container = av.open(str(path), mode="r")
    except av.error.FFmpegError as exc:
        if is_lfs_pointer(path):
            raise VideoError(lfs_message("the video"), path=path) from None
        raise VideoError(f"not a readable video ({_reason(exc)})", path=path) from None
    if not container.streams.video:
        container.close()
        raise VideoError("no video stream", path=path)
    return container


def _reason(exc: BaseException) -> str:
    return getattr(exc, "strerror", None) or str(exc) or type(exc).__name__


def _declared_duration(stream: av.video.stream.VideoStream) -> float:
    if stream.duration and stream.time_base:
        return float(stream.duration * stream.time_base)
    container_us = stream.container.duration
    return float(container_us) / av.time_base if container_us else 0.0


def _first_quarter_turns(path: Path) -> int:
    """:func:`quarter_turns` of the first frame (PyAV gives the display matrix with the frames only)."""
    try:
        with av.open(str(path), mode="r") as container:
            stream = container.streams.video[0]
            stream.thread_count = 1
            for frame in container.decode(stream):
                return quarter_turns(frame)
    except (av.error.FFmpegError, IndexError):  # nothing decodes: the reader says so
        pass
    return 0


def _info(path: Path, stream: av.video.stream.VideoStream) -> VideoInfo:
    cc = stream.codec_context
    rate = stream.average_rate or stream.base_rate or stream.guessed_rate
    fmt = cc.format.name if cc.format is not None else ""
    k = _first_quarter_turns(path)
    w, h = (int(cc.height), int(cc.width)) if k % 2 else (int(cc.width), int(cc.height))
    return VideoInfo(path=path, width=w, height=h, n_frames=int(stream.frames or 0),
                     fps=float(rate) if rate else 0.0, codec=cc.name, pix_fmt=fmt,
                     duration_s=max(0.0, _declared_duration(stream)), rotation_deg=90 * k)


# The decoded frames "cover" the declared duration when they reach it within this many frame
# intervals (containers round durations and count the last frame's display time or not).
COVER_FRAMES = 2.0

def probe_video(path: str | Path) -> VideoInfo:
    """Open a video, read its header and close it; raises :class:`VideoError` if unreadable."""
    path = Path(path)
    container = _open(path)
    try:
        info = _info(path, container.streams.video[0])
    finally:
        container.close()
    if info.width < 1 or info.height < 1:
        raise VideoError("video stream has no frame size", path=path)
    return info


def prefetch_depth(frames: int, budget_mb: float, width: int, height: int) -> int:
    """Frames to decode ahead: ``frames``, or as many 4:2:0 frames as fit ``budget_mb`` if more.

    Parameters
    ----------
    frames : int
        The least depth [frames]; <= 0: no prefetching (0 whatever the budget).
    budget_mb : float
        Memory the queued frames may take [MiB] (0: just ``frames``).
    width, height : int
        Frame size [px]; a frame takes ``width * height * 1.5`` bytes.

    Returns
    -------
    int
        Depth [frames], 0 or >= ``frames``.
    """
    if frames <= 0:
        return 0
    frame_bytes = max(1, width * height * 3 // 2)
    return max(frames, int(budget_mb * 2**20) // frame_bytes)


class VideoReader:
    """Iterate over a video's frames as :class:`YuvFrame` (a context manager).

    Parameters
    ----------
    path : path
        Any container/codec FFmpeg decodes.
    fps : float
        0: time from presentation timestamps; > 0: ``t = index / fps`` [s].
    threads : bool
        Let FFmpeg decode with frame/slice threads (``thread_type = "AUTO"``); False
        decodes on one thread (``thread_count = 1``).
    prefetch : int
        If > 0, decode in a background thread up to this many frames ahead of the
        consumer, so decoding overlaps the consumer's work on another core (FFmpeg
        releases the GIL while decoding). Frames and errors arrive in the same order.
    prefetch_mb : float
        With ``prefetch``, decode ahead as many frames as fit this many MiB (4:2:0
        planes), if more than ``prefetch`` (see :func:`prefetch_depth`): a consumer that
        pauses (a search of whole frames) does not stop the decoder. 0: ``prefetch`` frames.
        The depth used is the attribute ``prefetch`` [frames].
    start, end : float
        Yield only the frames with ``start <= t <= end`` [s] (``t`` as above, 0 at the
        video's first frame); ``end = 0`` reads to the last frame. Earlier frames are
        decoded (their timestamps and indices count) but not handed over; decoding stops
        after ``end``.

    Attributes
    ----------
    decode_report : dict
        After a whole iteration: ``declared_frames``, ``decoded_frames``, ``declared_s``,
        ``decoded_s`` (first to last frame plus one median interval) [s], ``shortfall``
        (True when the frames end before the declared duration or decoding failed part-way)
        and ``note`` (a sentence, or "").

    Raises
    ------
    VideoError
        On open (missing, not a video, no video stream) and at the end of the iteration when
        no frame decoded. A shortfall against the container's declarations is a warning.
    """

    def __init__(self, path: str | Path, *, fps: float = 0.0, threads: bool = False, prefetch: int = 0,
                 prefetch_mb: float = 0.0, start: float = 0.0, end: float = 0.0) -> None:
        self.path = Path(path)
        if fps < 0:
            raise ValueError("fps must be >= 0")
        check_time_range(start, end)
        self._fps = fps
        self._start = float(start)
        self._end = float(end)
        if prefetch_mb < 0:
            raise ValueError("prefetch_mb must be >= 0")
        self._container = _open(self.path)
        self._stream = self._container.streams.video[0]
        if threads:
            self._stream.thread_type = "AUTO"
        else:
            self._stream.thread_count = 1
        self.info = _info(self.path, self._stream)
        self.prefetch = prefetch_depth(int(prefetch), prefetch_mb, self.info.width, self.info.height)
        self.n_decoded = 0
        self.decode_report: dict[str, object] = {}
        self._prefetcher: _Prefetcher | None = None

    def __enter__(self) -> "VideoReader":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Stop a prefetching thread, then close the container."""
        self._stop_prefetch()
        self._container.close()

    def _stop_prefetch(self) -> None:
        if self._prefetcher is not None:
            self._prefetcher.close()
            self._prefetcher = None

    def __iter__(self) -> Iterator[YuvFrame]:
        decoded: Iterator[av.VideoFrame] = self._container.decode(self._stream)
        if self.prefetch > 0:
            if self._prefetcher is not None:
                self._prefetcher.close()
            # the thread only decodes; timestamps and planes are the consumer's (the decoder is the slower side)
            self._prefetcher = _Prefetcher(decoded, self.prefetch)
            decoded = iter(self._prefetcher)
        return self._frames(decoded)

    def _frames(self, decoder: Iterator[av.VideoFrame]) -> Iterator[YuvFrame]:
        """Frames of the time range from an iterator of decoded frames (its FFmpeg errors become VideoError)."""
        fps_override = self._fps
        avg_rate = self.info.fps
        t_first: float | None = None
        t = 0.0
        index = 0
        n_yielded = 0
        start, end = self._start - TIME_TOLERANCE_S, self._end + TIME_TOLERANCE_S
        times: list[float] = []
        failure = ""
        while True:
            try:
                frame = next(decoder)
            except StopIteration:
                break
            except av.error.FFmpegError as exc:
                if index == 0:
                    raise VideoError(f"not decodable ({_reason(exc)})", path=self.path) from None
                failure = _reason(exc)
                break
            if fps_override > 0:
                t = index / fps_override
            else:
                pts_time = frame.time
                if pts_time is None:
                    if avg_rate <= 0:
                        raise VideoError("frames have no timestamps and the frame rate is unknown; pass --fps",
                                         path=self.path)
                    pts_time = index / avg_rate
                if t_first is None:
                    t_first = pts_time
                t = pts_time - t_first
            times.append(t)
            if self._end > 0 and t > end and n_yielded:
                self._stop_prefetch()
                return  # past ``end``: the rest of the file is not read
            self.n_decoded = index + 1
            index += 1
            if t < start or (self._end > 0 and t > end):
                continue
            y, u, v, frame = frame_planes(frame)
            n_yielded += 1
            yield YuvFrame(index - 1, t, y, u, v, frame)
        if index == 0:
            raise VideoError("no video frames", path=self.path)
        self.decode_report = self._report(np.asarray(times), failure)
        if self.decode_report["shortfall"]:
            log.warning("%s: %s", self.path, self.decode_report["note"])
        elif self.decode_report["note"]:
            log.info("%s: %s", self.path, self.decode_report["note"])
        if n_yielded == 0:
            until = f"end {self._end:g} s" if self._end > 0 else "the end"
            raise VideoError(f"no frames from start {self._start:g} s to {until}: the last frame is at {t:g} s "
                             f"(--start and --end are times from the first frame [s])", path=self.path)

    def _report(self, times: np.ndarray, failure: str) -> dict[str, object]:
        """What decoded against what the container declares (the whole file was read)."""
        n = int(times.size)
        step = float(np.median(np.diff(times))) if n > 1 else (1.0 / self.info.fps if self.info.fps > 0 else 0.0)
        decoded_s = float(times[-1] - times[0]) + step
        declared_n, declared_s = self.info.n_frames, self.info.duration_s
        report: dict[str, object] = {"declared_frames": declared_n, "decoded_frames": n, "declared_s": declared_s,
                                     "decoded_s": decoded_s, "shortfall": False, "note": ""}
        if failure:
            report["shortfall"] = True
            report["note"] = (f"decoding stopped after {n} frames ({decoded_s:.3f} s) with '{failure}': the rest of "
                              f"the file is damaged or missing; using the frames before it")
        elif self._fps > 0 or (self._end > 0 and times[-1] >= self._end):
            pass  # an fps override makes the declared duration incomparable; a range stops before the end
        elif declared_s > 0 and decoded_s < declared_s - COVER_FRAMES * max(step, 1e-3):
            report["shortfall"] = True
            report["note"] = (f"decoded {n} frames covering {decoded_s:.3f} s of the {declared_s:.3f} s the "
                              f"container declares: the file may be cut short; using the frames there are")
        elif declared_n and declared_n != n:
            report["note"] = (f"decoded {n} frames where the container declares {declared_n}; they cover its "
                              f"{declared_s:.3f} s, so the count is wrong, not the file")
        return report


_END = object()

# While a decoder thread runs, the interpreter hands the GIL over at least this often [s].
# FFmpeg releases the GIL while decoding, but the decoder thread takes it back several times
# per frame (packets, the frame object, the queue); at CPython's default 5 ms each of those
# waits out a consumer running Python. Measured on 1080p/60: decoding beside a pure-Python
# loop took 6.3x as long as alone at 5 ms, 2.1x at 1 ms.
PREFETCH_SWITCH_INTERVAL_S = 0.001


class _SwitchInterval:
    """Shorten ``sys.setswitchinterval`` while at least one holder is open; restore it after the last."""

    _lock = threading.Lock()
    _holders = 0
    _saved = 0.0

    @classmethod
    def acquire(cls) -> None:
        with cls._lock:
            if cls._holders == 0:
                cls._saved = sys.getswitchinterval()
                sys.setswitchinterval(min(cls._saved, PREFETCH_SWITCH_INTERVAL_S))
            cls._holders += 1

    @classmethod
    def release(cls) -> None:
        with cls._lock:
            cls._holders -= 1
            if cls._holders == 0:
                sys.setswitchinterval(cls._saved)


class _Prefetcher:
    """Run an iterator in a daemon thread, ``depth`` items ahead; re-raise its exception in the consumer."""

    def __init__(self, frames: Iterator, depth: int) -> None:
        self._frames = frames
        self._q: queue.Queue = queue.Queue(maxsize=depth)
        self._stop = threading.Event()
        self._open = True
        _SwitchInterval.acquire()
        self._worker = threading.Thread(target=self._produce, name="pendtrack-decode", daemon=True)
        self._worker.start()

    def _put(self, item: object) -> bool:
        while not self._stop.is_set():
            try:
                self._q.put(item, timeout=0.05)
                return True
            except queue.Full:
                continue
        return False

    def _produce(self) -> None:
        try:
            for item in self._frames:
                if not self._put(item):
                    return
            self._put(_END)
        except BaseException as exc:  # noqa: BLE001 - handed to the consumer
            self._put(exc)

    def __iter__(self) -> Iterator:
        try:
            while True:
                item = self._q.get()
                if item is _END:
                    return
                if isinstance(item, BaseException):
                    raise item
                yield item
        finally:
            self.close()

    def close(self) -> None:
        """Stop the decoding thread and wait for it (before the container may be closed)."""
        self._stop.set()
        while self._worker.is_alive():
            try:
                self._q.get_nowait()
            except queue.Empty:
                self._worker.join(timeout=0.05)
        if self._open:
            self._open = False
            _SwitchInterval.release()


def read_frame(path: str | Path, index: int = 0) -> YuvFrame:
    """One frame (default the first) of a video, decoded from the start; a copy that outlives the file."""
    with VideoReader(path) as reader:
        for frame in reader:
            if frame.index == index:
                return YuvFrame(frame.index, frame.t, frame.y.copy(), frame.u.copy(), frame.v.copy())
    raise VideoError(f"has no frame {index}", path=path)
