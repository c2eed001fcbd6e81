"""Video reader: planes, presentation timestamps (VFR), fps override and bad files."""

import fractions

import av
import numpy as np
import pytest
from factory import write_swing_video

from pendtrack.errors import VideoError
from pendtrack.video.reader import VideoReader, prefetch_depth, probe_video, read_frame


def _encode(path, frames, *, fps=30, pix_fmt="yuv420p", faststart=False):
    options = {"movflags": "faststart"} if faststart else {}
    c = av.open(str(path), "w", format="mp4", options=options)
    s = c.add_stream("libx264", rate=fps)
    s.height, s.width = frames[0].shape[:2]
    s.pix_fmt = pix_fmt
    for img in frames:
        for p in s.encode(av.VideoFrame.from_ndarray(img, format="bgr24")):
            c.mux(p)
    for p in s.encode():
        c.mux(p)
    c.close()
    return path


def _grey_frames(n=12, h=48, w=64):
    return [np.full((h, w, 3), 20 * i % 250, np.uint8) for i in range(n)]


@pytest.mark.video
def test_planes_shapes_and_times(tmp_path):
    video = _encode(tmp_path / "v.mp4", _grey_frames(), fps=30)
    info = probe_video(video)
    assert (info.width, info.height, info.n_frames, info.fps, info.codec) == (64, 48, 12, 30.0, "h264")
    with VideoReader(video) as reader:
        frames = [(f.index, f.t, f.y.shape, f.u.shape, f.v.shape, int(f.y.mean())) for f in reader]
    assert [f[0] for f in frames] == list(range(12))
    np.testing.assert_allclose([f[1] for f in frames], np.arange(12) / 30, atol=1e-9)
    assert frames[0][2:5] == ((48, 64), (24, 32), (24, 32))
    # grey levels survive (limited-range luma: 16 + 219/255 * level, H.264 rounding)
    assert abs(frames[5][5] - (16 + 100 * 219 / 255)) < 3


@pytest.mark.video
def test_bgr_of_a_frame_round_trips_colour(tmp_path):
    img = np.zeros((48, 64, 3), np.uint8)
    img[:] = (180, 105, 255)  # pink, BGR
    video = _encode(tmp_path / "pink.mp4", [img] * 3)
    f = read_frame(video, 1)
    assert f.index == 1 and f.t == pytest.approx(1 / 30)
    np.testing.assert_allclose(f.bgr()[24, 32].astype(float), (180, 105, 255), atol=6)


@pytest.mark.video
def test_variable_frame_rate_times_survive(tmp_path):
    times = np.cumsum(np.r_[0, np.tile([0.008, 0.009, 0.0085], 6)])  # irregular steps [s]
    write_swing_video(tmp_path / "vfr.mp4", width=96, height=64, n_frames=times.size, fps=120.0,
                      radius=5, pivot=(48, 5), arm=40, times=times)
    with VideoReader(tmp_path / "vfr.mp4") as reader:
        t = np.array([f.t for f in reader])
    np.testing.assert_allclose(t, times - times[0], atol=1e-3)  # timestamps are stored in ms


@pytest.mark.video
@pytest.mark.parametrize("rotation", [-90, 90, 180])
def test_a_display_rotation_turns_the_frames_as_players_do(tmp_path, rotation):
    # frames stored turned, with the display matrix that turns them back (a phone's portrait take): the planes
    # come out as the upright take's (checked by hand against ffmpeg's own autorotation: the same image)
    shown = dict(width=96, height=64, n_frames=3, fps=30.0, radius=5, pivot=(30, 8), arm=40, noise=0.0)
    write_swing_video(tmp_path / "upright.mp4", **shown)
    write_swing_video(tmp_path / "turned.mp4", display_rotation=rotation, **shown)
    info = probe_video(tmp_path / "turned.mp4")
    assert (info.width, info.height, info.rotation_deg) == (96, 64, rotation % 360)
    with VideoReader(tmp_path / "upright.mp4") as a, VideoReader(tmp_path / "turned.mp4") as b:
        for fa, fb in zip(a, b):
            assert fb.y.shape == (64, 96) and fb.u.shape == fb.v.shape == (32, 48)
            assert fb.y.flags.c_contiguous
            # the same scene encoded in another orientation: codec differences of a level or two
            assert np.abs(fa.y.astype(int) - fb.y.astype(int)).mean() < 2.0
            assert np.abs(fa.u.astype(int) - fb.u.astype(int)).mean() < 2.0


@pytest.mark.video
def test_fps_override(tmp_path):
    video = _encode(tmp_path / "v.mp4", _grey_frames(5), fps=30)
    with VideoReader(video, fps=120.0) as reader:
        t = [f.t for f in reader]
    np.testing.assert_allclose(t, np.arange(5) / 120)


@pytest.mark.video
def test_other_pixel_formats_are_converted(tmp_path):
    video = _encode(tmp_path / "v444.mp4", _grey_frames(3), pix_fmt="yuv444p")
    with VideoReader(video) as reader:
        shapes = [(f.y.shape, f.u.shape) for f in reader]
    assert shapes == [((48, 64), (24, 32))] * 3


@pytest.mark.video
def test_threaded_decoding_gives_the_same_frames(tmp_path):
    video = _encode(tmp_path / "v.mp4", _grey_frames(8))
    with VideoReader(video) as a, VideoReader(video, threads=True) as b:
        for fa, fb in zip(a, b):
            assert fa.t == fb.t and np.array_equal(fa.y, fb.y)


@pytest.mark.video
def test_missing_file(tmp_path):
    with pytest.raises(VideoError, match=r"absent\.mp4: file not found"):
        VideoReader(tmp_path / "absent.mp4")


@pytest.mark.video
def test_not_a_video(tmp_path):
    p = tmp_path / "notes.mp4"
    p.write_text("this is not a video\n" * 50)
    with pytest.raises(VideoError, match=r"notes\.mp4: not a readable video"):
        VideoReader(p)


@pytest.mark.video
def test_a_git_lfs_pointer_is_named_as_one(tmp_path):
    # a user's repository cloned without git lfs (seanmacb/PHYS-311-Project@6cde4b3: IMG_0343.MOV, 134 bytes)
    p = tmp_path / "IMG_0343.MOV"
    p.write_text("version https://git-lfs.github.com/spec/v1\n"
                 "oid sha256:4d7a214614ab2935c943f9e0ff69d22eadbb8f32b1258daaa5e2ca24d17e2393\nsize 12345\n")
    with pytest.raises(VideoError, match=r"IMG_0343\.MOV: a Git LFS pointer, not the video itself"):
        VideoReader(p)


@pytest.mark.video
def test_truncated_video_moov_at_end(tmp_path):
    good = _encode(tmp_path / "v.mp4", _grey_frames(30))
    bad = tmp_path / "cut.mp4"
    bad.write_bytes(good.read_bytes()[: good.stat().st_size // 2])
    with pytest.raises(VideoError, match=r"cut\.mp4: not a readable video"):
        VideoReader(bad)


def _cut_faststart(tmp_path, n=40, keep=0.6):
    """A faststart mp4 of ``n`` noise frames cut to ``keep`` of its bytes: the header declares all of them."""
    frames = [np.random.default_rng(i).integers(0, 255, (48, 64, 3), dtype=np.uint8) for i in range(n)]
    good = _encode(tmp_path / "v.mp4", frames, faststart=True)
    bad = tmp_path / "cut.mp4"
    bad.write_bytes(good.read_bytes()[: int(good.stat().st_size * keep)])
    return bad


@pytest.mark.video
def test_a_cut_file_is_a_warning_and_its_frames_are_used(tmp_path, caplog):
    # faststart: the header declares 40 frames, the data of the later ones is missing (decoding fails part-way)
    bad = _cut_faststart(tmp_path)
    with caplog.at_level("WARNING"), VideoReader(bad) as reader:
        frames = [f.index for f in reader]
        report = reader.decode_report
    assert 0 < len(frames) < 40 and frames == list(range(len(frames)))
    assert report["shortfall"] and report["declared_frames"] == 40 and report["decoded_frames"] == len(frames)
    assert any("cut.mp4" in r.getMessage() and "decoding stopped" in r.getMessage() for r in caplog.records)


def _with_filler_samples(path, n=30, fps=30):
    """An mp4 whose track holds a filler sample (an H.264 access-unit delimiter, no picture) after every
    other frame: the container declares ~1.5 n frames over the n frames' duration, as re-encoded clips do."""
    tb = fractions.Fraction(1, 2 * fps)
    c = av.open(str(path), "w", format="mp4")
    s = c.add_stream("libx264", rate=fps)
    s.height, s.width = 48, 64
    s.pix_fmt = "yuv420p"
    s.options = {"bframes": "0"}
    s.codec_context.time_base = tb
    packets = []
    for i in range(n):
        f = av.VideoFrame.from_ndarray(np.full((48, 64, 3), 7 * i % 250, np.uint8), format="bgr24")
        f.pts, f.time_base = 2 * i, tb
        packets += list(s.encode(f))
    packets += list(s.encode())
    for k, p in enumerate(packets):
        c.mux(p)
        if k % 2 == 0:
            q = av.Packet(b"\x00\x00\x00\x02\x09\xf0")  # one length-prefixed AUD NAL unit
            q.stream, q.pts, q.dts, q.time_base = s, p.pts + 1, p.dts + 1, p.time_base
            c.mux(q)
    c.close()
    return path


@pytest.mark.video
def test_a_wrong_declared_frame_count_is_a_hint(tmp_path, caplog):
    video = _with_filler_samples(tmp_path / "filler.mp4")
    assert probe_video(video).n_frames > 40  # the container's count is wrong ...
    with caplog.at_level("WARNING"), VideoReader(video) as reader:
        t = np.array([f.t for f in reader])
        report = reader.decode_report
    assert t.size == 30 and np.allclose(np.diff(t), 1 / 30)  # ... every frame decodes at its own time
    assert not report["shortfall"] and "count is wrong" in report["note"]
    assert not [r for r in caplog.records if r.levelname == "WARNING"]


@pytest.mark.video
def test_zero_frame_video(tmp_path):
    # a valid header (moov first) whose media data is gone: a video stream without frames
    good = _encode(tmp_path / "v.mp4", _grey_frames(10), faststart=True)
    data = good.read_bytes()
    bad = tmp_path / "empty.mp4"
    bad.write_bytes(data[: data.find(b"mdat") + 4])
    with pytest.raises(VideoError, match=r"empty\.mp4: no video frames"):
        with VideoReader(bad) as reader:
            for _ in reader:
                pass


def test_prefetch_depth_fills_the_memory_budget():
    mib = 2**20
    assert prefetch_depth(8, 192.0, 1920, 1080) == 192 * mib // (1920 * 1080 * 3 // 2) == 64
    assert prefetch_depth(8, 0.0, 1920, 1080) == 8  # no budget: the frames asked for
    assert prefetch_depth(8, 10.0, 3840, 2160) == 8  # a budget smaller than 8 4K frames: still 8
    assert prefetch_depth(0, 192.0, 1920, 1080) == 0  # no prefetching whatever the budget


@pytest.mark.video
def test_prefetch_gives_the_same_frames_and_errors(tmp_path):
    video = _encode(tmp_path / "v.mp4", _grey_frames(20))
    with VideoReader(video) as a, VideoReader(video, prefetch=3) as b, VideoReader(video, prefetch=3,
                                                                              prefetch_mb=1.0) as c:
        assert (a.prefetch, b.prefetch) == (0, 3) and c.prefetch > 20  # 1 MiB: > 20 frames of this size
        fa = [(f.index, f.t, f.y.copy()) for f in a]
        fb = [(f.index, f.t, f.y.copy()) for f in b]
        fc = [(f.index, f.t, f.y.copy()) for f in c]  # deeper than the video: every frame queued at once
    for other in (fb, fc):
        assert [(i, t) for i, t, _ in fa] == [(i, t) for i, t, _ in other]
        assert all(np.array_equal(x, y) for (_, _, x), (_, _, y) in zip(fa, other))
    # an error in the decoding thread reaches the consumer: the same frames, the same shortfall
    bad = _cut_faststart(tmp_path)
    with VideoReader(bad) as a, VideoReader(bad, prefetch=4) as b:
        assert [f.index for f in a] == [f.index for f in b]
        assert a.decode_report == b.decode_report and b.decode_report["shortfall"]
    # leaving early (consumer error) stops the thread before the container closes
    with pytest.raises(RuntimeError):
        with VideoReader(video, prefetch=2) as reader:
            for f in reader:
                if f.index == 3:
                    raise RuntimeError("consumer gave up")


@pytest.mark.video
def test_prefetch_shortens_the_gil_switch_interval_only_while_it_runs(tmp_path):
    import sys

    import pendtrack.video.reader as reader_module

    video = _encode(tmp_path / "v.mp4", _grey_frames(12))
    before = sys.getswitchinterval()
    seen = []
    with VideoReader(video, prefetch=2) as a, VideoReader(video, prefetch=2) as b:
        for fa, fb in zip(a, b):  # two prefetchers at once: restored only after both
            seen.append(sys.getswitchinterval())
            if fa.index == 4:
                break  # leaving early restores it too
    assert max(seen) <= reader_module.PREFETCH_SWITCH_INTERVAL_S
    assert sys.getswitchinterval() == before
    for _ in VideoReader(video, prefetch=0):  # no decoder thread: left alone
        assert sys.getswitchinterval() == before
