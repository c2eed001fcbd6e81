"""Encode frames to an H.264 MP4 (PyAV, libx264, yuv420p), atomically.

Frames are BGR uint8 arrays (H, W, 3), the OpenCV convention. They are converted here to
YUV 4:2:0 with the BT.601 limited-range matrix, rounded to nearest, chroma the mean of
each 2x2 block (libswscale's default conversion truncates, which shifts greys by about
one level and tints them), and the stream is tagged BT.601 / limited range. The stream
has no B-frames (:data:`X264_PARAMS`), which makes the bitstream a function of the frames
alone (bit-identical videos for identical frames, in any order and in any process). Frame ``i``
gets the presentation timestamp ``i / fps`` exactly (time base ``1 / fps`` as a fraction).

The file is written under a temporary name (``.NAME.XXXX.tmp``) in the target folder and
renamed over ``path`` only when the encoder has been flushed and the file synced; an
exception (or a kill) never leaves a half video under ``path``.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterable
from fractions import Fraction
from pathlib import Path
from types import TracebackType

import av
import numpy as np

from pendtrack.errors import VideoError


# libx264 options beyond crf and preset. No B-frames: with them, x264's AVX-512 macroblock-tree
# code (the lookahead's propagation through bidirectional references) reads heap memory it never
# initialised, so on AVX-512 CPUs the same frames gave different bitstreams depending on what the
# process had allocated and freed before (two renders alternated in one process). Without B-frames
# (or without AVX-512, or with MALLOC_PERTURB_ set) the bitstream depends on the frames only (and
# on the CPU's instruction set, as x264's SIMD levels differ in the last bits); mbtree keeps working
# and the files are no larger for these static-camera scenes. Checked by
# tests/render/test_render_stage.py::test_render_is_bit_identical_across_calls_and_processes.
X264_PARAMS = "bframes=0"

# BT.601 limited range: rows Y, Cb, Cr; columns B, G, R (inputs 0..255), then the offset.
_BGR_TO_YUV = np.array([
    [24.966, 128.553, 65.481, 16.0 * 255],
    [112.0, -74.203, -37.797, 128.0 * 255],
    [-18.214, -93.786, 112.0, 128.0 * 255],
]) / 255.0


def bgr_to_i420(frame: np.ndarray) -> np.ndarray:
    """BGR uint8 (H, W, 3), H and W even -> planar I420 uint8 of shape (3 H / 2, W).

    Rows ``0..H-1`` hold Y, then the (H/2, W/2) Cb plane and the Cr plane, each flattened
    into ``H / 4`` rows of ``W`` (the layout ``av.VideoFrame.from_ndarray`` expects).
    Values are rounded to nearest; chroma is computed from the 2x2 block means.
    """
    import cv2

    h, w = frame.shape[:2]
    out = np.empty((h * 3 // 2, w), dtype=np.uint8)
    out[:h] = cv2.transform(frame, _BGR_TO_YUV[:1])  # rounds and saturates
    half = cv2.resize(frame.astype(np.float32), (w // 2, h // 2), interpolation=cv2.INTER_AREA)
    chroma = cv2.transform(half, _BGR_TO_YUV[1:])
    chroma = np.clip(chroma + 0.5, 0, 255).astype(np.uint8)
    out[h:h + h // 4] = chroma[..., 0].reshape(h // 4, w)
    out[h + h // 4:] = chroma[..., 1].reshape(h // 4, w)
    return out


def fps_fraction(fps: float) -> Fraction:
    """A frame rate [1/s] as an exact fraction (``119.88`` -> ``120000/1001`` style)."""
    return Fraction(fps).limit_denominator(100_000)


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


class VideoWriter:
    """Stream frames into an H.264 MP4; use as a context manager.

    Parameters
    ----------
    path : str or Path
        Final file name (``.mp4``).
    width, height : int
        Frame size [px], both even (4:2:0 chroma).
    fps : float
        Frame rate [1/s], > 0.
    crf : int
        libx264 constant rate factor, 0 (lossless) .. 51.
    preset : str
        libx264 speed preset (``ultrafast`` .. ``veryslow``).

    Examples
    --------
    >>> with VideoWriter(path, width=1280, height=720, fps=120, crf=20) as w:  # doctest: +SKIP
    ...     for frame in frames:
    ...         w.write(frame)
    """

    def __init__(self, path: str | Path, *, width: int, height: int, fps: float, crf: int = 20,
                 preset: str = "veryfast") -> None:
        if width < 2 or height < 2 or width % 2 or height % 2:
            raise VideoError(f"frame size {width}x{height} must be even and positive for H.264 4:2:0", path=path)
        if not fps > 0:
            raise VideoError(f"frame rate must be positive, got {fps!r}", path=path)
        if not 0 <= crf <= 51:
            raise VideoError(f"crf must be within 0..51, got {crf!r}", path=path)
        self.path = Path(path)
        self.width, self.height = int(width), int(height)
        self.n_frames = 0
        self._rate = fps_fraction(fps)
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(prefix=f".{self.path.name}.", suffix=".tmp", dir=self.path.parent)
            os.close(fd)
        except OSError as exc:
            raise VideoError(f"cannot write here ({exc.strerror})", path=self.path) from None
        self._tmp = Path(tmp)
        try:
            self._container = av.open(str(self._tmp), mode="w", format="mp4")
            stream = self._container.add_stream("libx264", rate=self._rate)
            stream.width, stream.height = self.width, self.height
            stream.pix_fmt = "yuv420p"
            stream.time_base = 1 / self._rate
            stream.codec_context.time_base = 1 / self._rate
            stream.options = {"crf": str(int(crf)), "preset": preset, "x264-params": X264_PARAMS}
            stream.codec_context.color_range = 1  # MPEG (limited) range
            stream.codec_context.colorspace = 6  # SMPTE 170M = BT.601
            self._stream = stream
        except Exception:
            self._tmp.unlink(missing_ok=True)
            raise
        self._closed = False

    def write(self, frame: np.ndarray) -> None:
        """Encode one BGR uint8 frame of shape (height, width, 3)."""
        if frame.shape != (self.height, self.width, 3) or frame.dtype != np.uint8:
            raise ValueError(f"frame must be uint8 of shape {(self.height, self.width, 3)}, "
                             f"got {frame.dtype} {frame.shape}")
        vf = av.VideoFrame.from_ndarray(bgr_to_i420(frame), format="yuv420p")
        vf.pts = self.n_frames
        vf.time_base = 1 / self._rate
        for packet in self._stream.encode(vf):
            self._container.mux(packet)
        self.n_frames += 1

    def close(self) -> Path:
        """Flush, sync and rename into place; returns the final path."""
        if self._closed:
            return self.path
        try:
            if self.n_frames == 0:
                raise VideoError("no frames to write", path=self.path)
            for packet in self._stream.encode(None):
                self._container.mux(packet)
            self._container.close()
            with open(self._tmp, "rb") as fh:
                os.fsync(fh.fileno())
            os.chmod(self._tmp, 0o666 & ~_umask())  # mkstemp made it owner-only
            os.replace(self._tmp, self.path)
        except BaseException:
            self.abort()
            raise
        self._closed = True
        return self.path

    def abort(self) -> None:
        """Drop the partial file; ``path`` stays as it was."""
        if self._closed:
            return
        self._closed = True
        try:
            self._container.close()
        except Exception:  # noqa: BLE001 - the half file is discarded anyway
            pass
        self._tmp.unlink(missing_ok=True)

    def __enter__(self) -> "VideoWriter":
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()


def write_video(frames: Iterable[np.ndarray], path: str | Path, *, fps: float, crf: int = 20,
                preset: str = "veryfast") -> Path:
    """Encode BGR uint8 frames (H, W, 3) into an H.264 MP4 at ``path``, atomically.

    The frame size is taken from the first frame. Returns the path written.

    Raises
    ------
    VideoError
        No frames, odd frame size, bad fps/crf, or the folder cannot be written.
    """
    it = iter(frames)
    first = next(it, None)
    if first is None:
        raise VideoError("no frames to write", path=path)
    h, w = first.shape[:2]
    with VideoWriter(path, width=w, height=h, fps=fps, crf=crf, preset=preset) as writer:
        writer.write(first)
        for frame in it:
            writer.write(frame)
    return writer.path
