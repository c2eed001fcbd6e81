"""Tracking on footage filmed like a user's (issue #15): a hand over the bob at first, a pink
poster, a sticker on the bob, a bead on the bar, a start and an end time; the run command's flags;
the evolving template's drift alarm.

Videos: the renderer as a library, post-processed (``tests/field_videos.py``). Accuracy is
compared with the renderer's truth as in ``tests/track/test_track_rendered.py`` (the run still
swings at its end, so theta's zero is the image vertical and theta is compared with the
truth directly).
"""

import numpy as np
import pytest
from click.testing import CliRunner
from factory import field_video, write_swing_video

from pendtrack.artifacts import read_artifact
from pendtrack.cli import cli as main
from pendtrack.config import Config
from pendtrack.errors import VideoError
from pendtrack.stages.angle import angle_stage
from pendtrack.stages.track import track_stage
from pendtrack.track.colour import parse_marker_colour
from pendtrack.track.params import TrackParams
from pendtrack.track.sampler import RawSampler
from pendtrack.track.templates import template_drift
from pendtrack.track.tracker import track_frames
from pendtrack.video.reader import VideoReader


# Issue #15's targets on the frames where the marker is visible.
OK_MIN, RMS_MAX = 0.99, 2e-3


def _theta_errors(angle, fv, frames):
    ok = angle.data.ok.to_numpy()
    d = angle.data.theta.to_numpy() - fv.theta[frames]
    d -= 2 * np.pi * np.round(np.nanmedian(d[ok]) / (2 * np.pi))  # same branch
    return d, ok


@pytest.fixture(scope="module")
def hand_poster_sticker(tmp_path_factory):
    """960x540, 60 fps, 2.5 s: a hand hides the spot for 0.7 s, a static pink disc, a blue sticker on the spot."""
    d = tmp_path_factory.mktemp("field")
    fv = field_video(d / "video.mp4", seconds=2.5, fps=60.0, width=960, height=540, hand_s=0.7, poster=True,
                     sticker=True)
    tr = track_stage(fv.path, out_dir=d, config=Config(), progress=False)
    an = angle_stage(tr.path, out_dir=d, config=Config(), progress=False)
    return fv, read_artifact(tr.path, "track"), read_artifact(an.path, "angle")


@pytest.mark.video
@pytest.mark.integration
def test_marker_found_in_the_first_frame_where_it_shows_not_the_poster(hand_poster_sticker):
    fv, track, angle = hand_poster_sticker
    acq = track.provenance.extra["acquisition"]
    first_visible = int(np.flatnonzero(fv.visible)[0])
    # the old detector took the poster (largest pink blob) in frame 0; now: the spot, as soon as the hand is gone
    assert acq["frame"] == first_visible and acq["method"] == "motion" and acq["candidates"] == 2
    frames = track.data.frame.to_numpy()
    assert frames[0] == 0 and len(frames) == len(fv.t)  # one row per frame, as before
    ok = track.data.ok.to_numpy()
    assert not ok[:first_visible].any() and np.isnan(track.data.x.to_numpy()[:first_visible]).all()
    assert ok[fv.visible].mean() >= OK_MIN
    # on the spot, not the poster (> 100 px away): within a few px of the image of its centre
    # (measured median 1.6 px: the sticker's hole, turning with the bar, biases the match radially)
    dist = np.hypot(*(track.data[["x_px", "y_px"]].to_numpy()[ok] - fv.spot[frames[ok]]).T)
    assert np.median(dist) < 3.0, np.median(dist)


@pytest.mark.video
@pytest.mark.integration
def test_theta_within_2_mrad_after_the_hand(hand_poster_sticker):
    fv, track, angle = hand_poster_sticker
    assert angle.provenance.extra["zero_reference"] == "vertical"
    d, ok = _theta_errors(angle, fv, track.data.frame.to_numpy())
    vis = fv.visible
    assert ok[vis].mean() >= OK_MIN
    # measured 1.48 mrad rms (0.84 without the sticker, whose hole turns with the bar and
    # bends the template match); 2 mrad is the target
    assert np.sqrt(np.mean(d[ok] ** 2)) <= RMS_MAX


@pytest.mark.video
@pytest.mark.integration
def test_the_larger_of_two_swinging_blobs_is_the_marker(tmp_path):
    # a smaller pink bead on the bar, nearer the axle, swings with the spot: both move
    fv = field_video(tmp_path / "bead.mp4", seconds=1.5, fps=60.0, bead=True)
    tr = track_stage(fv.path, out_dir=tmp_path, config=Config(), progress=False)
    track = read_artifact(tr.path, "track")
    assert track.provenance.extra["acquisition"]["frame"] == 0
    ok = track.data.ok.to_numpy()
    assert ok.mean() >= OK_MIN
    dist = np.hypot(*(track.data[["x_px", "y_px"]].to_numpy()[ok] - fv.spot[ok]).T)
    assert np.percentile(dist, 99) < 1.0  # the spot, not the bead (some 100 px away)


@pytest.fixture(scope="module")
def swing_60(tmp_path_factory):
    path = tmp_path_factory.mktemp("se") / "swing.mp4"
    # a period of 0.45 s: the 0.5 s of a --start/--end range see it swing (across and back)
    truth = write_swing_video(path, n_frames=90, fps=60.0, radius=8.0, period_s=0.45)
    return path, truth


@pytest.mark.video
@pytest.mark.integration
def test_start_and_end_keep_the_videos_times(swing_60, tmp_path):
    path, truth = swing_60
    cfg = Config().replace("video", start=0.5, end=1.0).replace("lens", projection="none")
    track = read_artifact(track_stage(path, out_dir=tmp_path, config=cfg, progress=False).path, "track")
    df = track.data
    # frames outside [start, end] have no row; the others keep the video's index and time (0 at frame 0)
    assert df.frame.tolist() == list(range(30, 61))
    np.testing.assert_allclose(df.t.to_numpy(), truth[30:61, 0], atol=1e-6)
    assert df.ok.all() and track.provenance.extra["time_range_s"] == {"start": 0.5, "end": 1.0}
    assert track.provenance.extra["acquisition"]["frame"] == 30
    # measured 0.46 px max (H.264 at crf 18 on a 8-px spot with a bar through it)
    assert np.hypot(df.x_px - truth[30:61, 1], df.y_px - truth[30:61, 2]).max() < 0.6


@pytest.mark.video
def test_reader_range_and_errors(swing_60):
    path, _ = swing_60
    with VideoReader(path, start=1.2) as reader:
        frames = [(f.index, round(f.t, 6)) for f in reader]
    assert frames[0] == (72, 1.2) and frames[-1][0] == 89
    with pytest.raises(VideoError, match="no frames from start 9 s"):
        list(VideoReader(path, start=9.0))
    for start, end in ((-1.0, 0.0), (1.0, 0.5)):
        with pytest.raises(ValueError):
            VideoReader(path, start=start, end=end)


@pytest.mark.video
@pytest.mark.integration
def test_start_after_the_end_is_a_one_line_error(swing_60, tmp_path):
    path, _ = swing_60
    res = CliRunner().invoke(main, ["track", str(path), "--start", "9", "--out", str(tmp_path), "-q"])
    assert res.exit_code == 2 and "no frames from start 9 s" in res.output and "Traceback" not in res.output
    res = CliRunner().invoke(main, ["track", str(path), "--start", "1", "--end", "0.5", "--out", str(tmp_path)])
    assert res.exit_code == 2 and "--start" in res.output and "Traceback" not in res.output


@pytest.mark.video
@pytest.mark.integration
def test_run_takes_the_flags_of_its_stages(monkeypatch, tmp_path, swing_60):
    import pendtrack.stages.run as run_mod

    seen = {}

    def fake(video, *, out_dir, config, models, table, force, progress):
        seen["config"] = config
        return run_mod.RunOutput(out_dir=out_dir)

    monkeypatch.setattr(run_mod, "run_pipeline", fake)
    path, _ = swing_60
    res = CliRunner().invoke(main, [
        "run", str(path), "--marker-color", "dark", "--roi", "1,2,30,40", "--min-score", "0.5",
        "--projection", "none", "--fov", "100", "--fixed-pixels", "0.5", "--fps", "30", "--start", "1.5",
        "--end", "9", "--axle", "10,-20", "--window-s", "0.1", "--out", str(tmp_path), "-q"])
    assert res.exit_code == 0, res.output
    c = seen["config"]
    assert (c.track.marker_color, c.track.roi, c.track.min_score) == ("dark", (1, 2, 30, 40), 0.5)
    assert (c.lens.projection, c.lens.fov_deg, c.lens.fixed_pixels) == ("none", 100.0, 0.5)
    assert (c.video.fps, c.video.start, c.video.end) == (30.0, 1.5, 9.0)
    assert c.angle.axle == (10.0, -20.0) and c.kinematics.savgol_window_s == 0.1


@pytest.mark.video
@pytest.mark.integration
def test_error_texts_name_flags_that_run_has(tmp_path):
    # the flags the track and angle stages suggest in their messages
    help_text = CliRunner().invoke(main, ["run", "--help"]).output
    for flag in ("--marker-color", "--roi", "--min-score", "--start", "--axle", "--fps", "--projection", "--end",
                 "--fov", "--window-s"):
        assert flag in help_text, flag
    video = tmp_path / "wall.mp4"
    write_swing_video(video, width=160, height=120, n_frames=5, hide=(0, 5))
    res = CliRunner().invoke(main, ["run", str(video), "--out", str(tmp_path / "o"), "-q"])
    assert res.exit_code == 2 and "--marker-color" in res.output and "--start" in res.output


def test_template_drift_is_measured():
    rng = np.random.default_rng(0)
    img = np.zeros((41, 41), np.float32)
    yy, xx = np.mgrid[:41, :41]
    img += 50 * np.exp(-((xx - 20.0) ** 2 + (yy - 20.0) ** 2) / 30) + rng.normal(0, 1, img.shape).astype(np.float32)
    shifted = np.roll(np.roll(img, 3, axis=1), -2, axis=0)
    dx, dy = template_drift(img, shifted, reach=6)
    assert dx == pytest.approx(3, abs=0.2) and dy == pytest.approx(-2, abs=0.2)
    assert template_drift(img, img, reach=6) == pytest.approx((0, 0), abs=0.01)  # quadric peak: ~1e-3 px


def test_a_drifted_template_is_shifted_back_onto_the_first():
    from test_track_core import scene, yuv_frame

    from pendtrack.track.detect import marker_candidates
    from pendtrack.track.templates import make_template
    from pendtrack.track.tracker import MarkerTracker

    rng = np.random.default_rng(0)
    fr = yuv_frame(scene(120, 160, 80.0, 60.0, r=9.0, rng=rng))
    pink = parse_marker_colour("pink")
    sampler = RawSampler(pink, width=160, height=120)
    det = marker_candidates(fr.y, fr.u, fr.v, pink)[0]
    template, _, _ = make_template(sampler, fr.y, fr.u, fr.v, det)
    tracker = MarkerTracker(sampler, template, TrackParams(evolution_rate=0.5, max_drift_px=2.0))
    first = template.image.copy()
    template.image = np.roll(first, 4, axis=1)  # as if evolution had slid its content 4 px right
    tracker._bound_drift()
    assert tracker.reanchors == 1 and tracker.drift_max == pytest.approx(4, abs=0.3)
    dx, dy = template_drift(first, tracker.template.image, reach=6)
    assert np.hypot(dx, dy) < 0.3


def _fading_marker_frames():
    """A pink disc moving right whose right half fades into the wall over the first 30 frames."""
    from test_track_core import scene, yuv_frame

    rng = np.random.default_rng(1)
    frames = []
    for i in range(60):
        cx = 50.0 + 0.5 * i
        on = scene(120, 160, cx, 60.0, r=10.0, rng=rng).astype(float)
        off = scene(120, 160, None, None, rng=rng).astype(float)
        fade = min(1.0, i / 30) * (np.arange(160)[None, :, None] >= cx)
        frames.append(yuv_frame((on * (1 - fade) + off * fade).astype(np.uint8), index=i, t=i / 60))
    return frames


def test_an_evolving_template_that_changes_raises_the_drift_alarm():
    frames = _fading_marker_frames()
    pink = parse_marker_colour("pink")
    res = track_frames(frames, sampler=RawSampler(pink, width=160, height=120),
                       params=TrackParams(evolution_rate=0.2, max_drift_px=1.5, min_score=0.3))
    # measured: drift 2.1 px at the check after the fade, one re-anchoring
    assert res.ok.all() and res.drift["alarm"] and res.drift["reanchors"] >= 1 and res.drift["max_px"] > 1.5
    assert res.to_dict()["template_drift"]["alarm"]
    steady = track_frames(frames[:20], sampler=RawSampler(pink, width=160, height=120),
                          params=TrackParams(evolution_rate=0.2, max_drift_px=3.0))
    assert not steady.drift["alarm"] and steady.drift["max_px"] < 3.0
