"""Small synthetic test videos for the tracking tests (and the script that made the committed ones).

Run ``python tests/data/make_test_videos.py`` to (re)write the committed files:

* ``dark_ball.mp4`` + ``dark_ball_truth.csv``: a dark ball on a pale, unevenly lit wall,
  swinging on an arc whose pivot lies above the frame (outside it), 320x240, 60 fps,
  90 frames, H.264 crf 18 -- other footage than the paper's pink spot, tracked with
  ``--marker-color dark`` or ``--roi``. The CSV holds the ball's true centre per frame.

The tests also import :func:`write_swing_video` to make throw-away videos (hidden marker,
variable frame rate, ...). Everything is seeded and deterministic.
"""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import av
import numpy as np

HERE = Path(__file__).resolve().parent
PINK_BGR = (180, 105, 255)
DARK_BGR = (40, 38, 36)


def disc_coverage(width: int, height: int, cx: float, cy: float, r: float, *, ss: int = 6) -> np.ndarray:
    """Fraction of each pixel covered by a disc (pixel centres at integer coordinates), float (H, W)."""
    out = np.zeros((height, width))
    x0, x1 = max(int(np.floor(cx - r - 2)), 0), min(int(np.ceil(cx + r + 2)) + 1, width)
    y0, y1 = max(int(np.floor(cy - r - 2)), 0), min(int(np.ceil(cy + r + 2)) + 1, height)
    if x1 <= x0 or y1 <= y0:
        return out
    o = (np.arange(ss) + 0.5) / ss - 0.5
    gy, gx = np.mgrid[y0:y1, x0:x1].astype(float)
    acc = np.zeros(gx.shape)
    for a in o:
        for b in o:
            acc += (gx + a - cx) ** 2 + (gy + b - cy) ** 2 <= r * r
    out[y0:y1, x0:x1] = acc / (ss * ss)
    return out


def wall(width: int, height: int, *, base: float = 205.0, gradient: float = 0.25, seed: int = 0) -> np.ndarray:
    """A pale, unevenly lit wall, BGR float (H, W, 3)."""
    rng = np.random.default_rng(seed)
    xx = np.linspace(-1, 1, width)[None, :]
    yy = np.linspace(-1, 1, height)[:, None]
    light = 1.0 + gradient * (0.7 * xx - 0.3 * yy) - 0.15 * (xx**2 + yy**2)
    texture = rng.normal(0, 3.0, (height // 8 + 1, width // 8 + 1)).repeat(8, 0).repeat(8, 1)[:height, :width]
    img = base * light[..., None] * np.array([0.97, 1.0, 1.02]) + texture[..., None]
    return img


def write_swing_video(path: str | Path, *, width: int = 320, height: int = 240, n_frames: int = 60,
                      fps: float = 60.0, marker: str = "pink", radius: float = 9.0,
                      pivot: tuple[float, float] = (160.0, 40.0), arm: float = 120.0, amplitude: float = 0.8,
                      period_s: float = 1.2, hide: tuple[int, int] | None = None, noise: float = 2.0,
                      crf: int = 18, seed: int = 0, times: np.ndarray | None = None,
                      faststart: bool = False, display_rotation: int = 0) -> np.ndarray:
    """Film a marker swinging on a circular arc and encode it (H.264, yuv420p, MP4).

    Parameters
    ----------
    path : path
        Output file.
    width, height, n_frames, fps
        Frame size [px], number of frames, nominal rate [1/s].
    marker : str
        ``"pink"`` (the paper's spot on a grey bar) or ``"dark"`` (a dark ball, no bar).
    radius : float
        Marker radius [px].
    pivot : (float, float)
        Pivot of the arc [px]; may lie outside the frame.
    arm : float
        Pivot to marker centre [px].
    amplitude : float
        Swing amplitude [rad], ``theta(t) = amplitude cos(2 pi t / period)``.
    hide : (start, stop), optional
        Frames ``start <= i < stop`` have the marker painted over with the wall.
    noise : float
        Gaussian noise, standard deviation in 8-bit levels.
    times : ndarray, optional
        Presentation times [s] of the frames (variable frame rate); default ``i / fps``.
    faststart : bool
        Put the MP4 header (with its frame count) before the media data.
    display_rotation : int
        A phone's display rotation [deg, counterclockwise, a multiple of 90]: each frame is stored turned
        the other way and the stream says to turn it back (an upright phone: -90), so a player shows the
        scene as drawn. The returned positions are those of the scene as shown.

    Returns
    -------
    ndarray, shape (n_frames, 3)
        t [s], x, y [px] of the marker centre per frame.
    """
    rng = np.random.default_rng(seed)
    bg = wall(width, height, seed=seed)
    t = np.arange(n_frames) / fps if times is None else np.asarray(times, float)
    theta = amplitude * np.cos(2 * np.pi * t / period_s)
    xs = pivot[0] + arm * np.sin(theta)
    ys = pivot[1] + arm * np.cos(theta)
    colour = np.array(PINK_BGR if marker == "pink" else DARK_BGR, float)
    time_base = Fraction(1, 1000) if times is not None else Fraction(1, int(round(fps)))
    container = av.open(str(path), mode="w", format="mp4", options={"movflags": "faststart"} if faststart else {})
    stream = container.add_stream("libx264", rate=int(round(fps)))
    turns = (display_rotation // 90) % 4
    stored = (height, width) if turns % 2 else (width, height)
    stream.width, stream.height, stream.pix_fmt = *stored, "yuv420p"
    if turns:
        stream.set_display_rotation(display_rotation)
    stream.time_base = time_base
    stream.codec_context.time_base = time_base
    # no B-frames, as pendtrack's own writer: with them, x264 on AVX-512 CPUs gives a bitstream that depends
    # on what the process allocated before (pendtrack.video.writer.X264_PARAMS), so a test's video, and the
    # track measured on it, changed with the tests that ran before it in the same process
    stream.options = {"crf": str(crf), "preset": "veryfast", "x264-params": "bframes=0"}
    for i in range(n_frames):
        img = bg.copy()
        if marker == "pink":  # a grey bar from the pivot through the spot
            yy, xx = np.mgrid[0:height, 0:width].astype(float)
            ux, uy = np.sin(theta[i]), np.cos(theta[i])
            along = (xx - pivot[0]) * ux + (yy - pivot[1]) * uy
            across = np.abs(-(xx - pivot[0]) * uy + (yy - pivot[1]) * ux)
            bar = np.clip(0.8 * radius + 0.5 - across, 0, 1) * (along > 0) * (along < arm + 3 * radius)
            img = img * (1 - bar[..., None]) + np.array([92.0, 90.0, 86.0]) * bar[..., None]
        if hide is None or not hide[0] <= i < hide[1]:
            cov = disc_coverage(width, height, xs[i], ys[i], radius)[..., None]
            img = img * (1 - cov) + colour * cov
        img = np.clip(img + rng.normal(0, noise, img.shape), 0, 255).astype(np.uint8)
        if turns:
            img = np.ascontiguousarray(np.rot90(img, -turns))
        frame = av.VideoFrame.from_ndarray(img, format="bgr24")
        frame.pts = int(round(t[i] / time_base)) if times is not None else i
        frame.time_base = time_base
        for packet in stream.encode(frame):
            container.mux(packet)
    for packet in stream.encode():
        container.mux(packet)
    container.close()
    return np.column_stack([t, xs, ys])


def make_dark_ball(folder: Path = HERE) -> Path:
    """``dark_ball.mp4`` and ``dark_ball_truth.csv`` in ``folder``."""
    video = folder / "dark_ball.mp4"
    truth = write_swing_video(video, marker="dark", n_frames=90, fps=60.0, radius=10.0, pivot=(150.0, -150.0),
                              arm=330.0, amplitude=0.3, period_s=1.5, noise=2.0, seed=3)
    np.savetxt(folder / "dark_ball_truth.csv", truth, delimiter=",", header="t,x,y", comments="", fmt="%.6f")
    return video


if __name__ == "__main__":
    print(make_dark_ball())
