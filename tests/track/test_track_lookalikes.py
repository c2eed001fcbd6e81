"""The marker is what swings (issue #27): a static look-alike is never the marker, a track whose
point does not swing is an error, two pendulums in view are a one-line error naming --roi, and
with --roi the track stays on the one chosen.

Videos: small renders post-processed (``tests/field_videos.py``), a few seconds each.
"""

import numpy as np
import pytest
from factory import field_video, write_swing_video
from test_track_cli import invoke, one_line_error

from pendtrack.artifacts import read_artifact
from pendtrack.track.swing import crossing_times, period_from_crossings, swing_of_track


# a dark ball on a string, normal lens, the axle above the frame (issue 27's first video, smaller)
DARK_STRING = dict(rig="string", marker_color="dark", marker_shape="ball", spot_radius_m=0.015, lens_projection="none",
                   lens_fov_deg=70.0, camera_offset_m=(0.0, 0.22), theta0=0.8)


# --- the swing check on arrays ----------------------------------------------------------------

def test_a_swing_its_period_and_what_is_no_swing():
    rng = np.random.default_rng(0)
    t = np.arange(600) / 30.0
    period = 1.37
    x = 300 + 80 * np.exp(-t / 15) * np.cos(2 * np.pi * t / period) + rng.normal(0, 0.3, t.size)
    y = 100 + 0.05 * (x - 300) ** 2 / 80 + rng.normal(0, 0.3, t.size)
    ok = rng.random(t.size) > 0.05  # 5 % of the frames lost
    s = swing_of_track(t, x, y, ok)
    assert s.swings and s.crossings >= 25
    # 29 crossings on a 30 fps grid, linearly interpolated, noise 0.3 px on an 80 px swing: well under 0.5 %
    assert s.period_s == pytest.approx(period, rel=2e-3)
    still = swing_of_track(t, 45 + rng.normal(0, 0.3, t.size), 25 + rng.normal(0, 0.3, t.size), np.ones(t.size, bool))
    assert not still.swings and "does not swing" in still.reason and "(45, 25)" in still.reason
    carried = swing_of_track(t, 10 + 20 * t + rng.normal(0, 0.3, t.size), 200 + rng.normal(0, 0.3, t.size),
                             np.ones(t.size, bool))
    assert not carried.swings and carried.crossings < 2


def test_a_point_that_swung_only_until_the_tracker_lost_it_does_not_swing():
    # SonyNeto/analise_dados_pendulo_simples@d61bcbb pendulo.avi: the tracker followed the bob for its first swing,
    # then held a static green patch for 21 s (jitter 0.3-1 px, a few jumps of 20-30 px): 4 crossings and a 28.8 px
    # amplitude, so crossings and amplitude alone called it a swing
    rng = np.random.default_rng(1)
    t = np.arange(446) / 20.0
    x = 105 + rng.normal(0, 0.8, t.size)
    y = 293 + rng.normal(0, 0.3, t.size)
    first = t < 0.8
    x[first] = 105 + 95 * np.cos(2 * np.pi * t[first] / 0.77)
    y[first] = 293 + 10 * np.cos(4 * np.pi * t[first] / 0.77)
    jumps = rng.choice(np.flatnonzero(~first), 6, replace=False)
    x[jumps] -= rng.uniform(20, 30, jumps.size)
    s = swing_of_track(t, x, y, np.ones(t.size, bool))
    assert s.crossings >= 2 and s.amplitude_px > 20  # what alone would pass
    assert not s.swings and "does not swing" in s.reason and "(105, 293)" in s.reason
    # a swing that decays and rests still for its last fifth is a swing (its rest is the middle of its path)
    x = 300 + 60 * np.exp(-t / 4) * np.cos(2 * np.pi * t / 1.5) + rng.normal(0, 0.3, t.size)
    x[t > 0.8 * t[-1]] = 300 + rng.normal(0, 0.3, int((t > 0.8 * t[-1]).sum()))
    assert swing_of_track(t, x, 100 + rng.normal(0, 0.3, t.size), np.ones(t.size, bool)).swings


def test_crossings_skip_noise_and_gaps_keep_the_period():
    t = np.arange(0, 10, 0.01)
    d = np.sin(2 * np.pi * t / 2.0)
    d[(t > 3.2) & (t < 4.9)] = np.nan  # a lost stretch spanning a crossing
    tc = crossing_times(t, d, hysteresis=0.2)
    assert np.all(np.diff(tc) > 0.5)  # noise-free: one crossing per half-period, none doubled
    assert period_from_crossings(tc) == pytest.approx(2.0, rel=1e-3)


# --- static look-alikes -----------------------------------------------------------------------

@pytest.fixture(scope="module")
def dark_corner(tmp_path_factory):
    d = tmp_path_factory.mktemp("corner")
    # a dark patch in the top-left corner, larger than the ball; a hand holds the ball for the first second
    fv = field_video(d / "video.mp4", seconds=4.0, fps=30.0, width=428, height=240, corner=True, hand_release_s=1.0,
                     **DARK_STRING)
    return fv


@pytest.mark.video
@pytest.mark.integration
def test_a_dark_corner_is_never_the_marker(dark_corner, tmp_path):
    fv = dark_corner
    res = invoke("track", fv.path, "--projection", "none", "--marker-color", "dark", "--out", tmp_path, "-q")
    assert res.exit_code == 0, res.output
    art = read_artifact(tmp_path / "track.parquet", "track")
    df = art.data
    ok = df.ok.to_numpy()
    vis = fv.visible[df.frame.to_numpy()]
    assert ok[vis].mean() >= 0.99
    err = np.hypot(df.x_px.to_numpy() - fv.spot[df.frame, 0], df.y_px.to_numpy() - fv.spot[df.frame, 1])
    # on the ball wherever ok (a 9 px ball at 428x240: measured < 1 px), never on the corner (> 100 px away)
    assert np.nanmax(err[ok]) < 2.0
    assert art.provenance.extra["swing"]["swings"]


@pytest.mark.video
@pytest.mark.integration
def test_a_point_that_does_not_swing_is_an_error(tmp_path):
    video = tmp_path / "still.mp4"
    write_swing_video(video, width=160, height=120, n_frames=60, radius=6, pivot=(80, 20), arm=60, amplitude=0.0)
    res = invoke("track", video, "--out", tmp_path / "out", "-q")
    one_line_error(res, "does not swing", "--roi")
    assert not (tmp_path / "out" / "track.parquet").exists()


# --- two pendulums ----------------------------------------------------------------------------

@pytest.fixture(scope="module")
def twins(tmp_path_factory):
    d = tmp_path_factory.mktemp("twins")
    return field_video(d / "video.mp4", seconds=3.0, fps=30.0, width=480, height=272, twin=True)


@pytest.mark.video
@pytest.mark.integration
def test_two_pendulums_in_view_are_an_error_naming_roi(twins, tmp_path):
    res = invoke("track", twins.path, "--out", tmp_path, "-q")
    one_line_error(res, "two pendulums in view", "--roi")
    assert not (tmp_path / "track.parquet").exists()


@pytest.mark.video
@pytest.mark.integration
def test_with_roi_the_track_stays_on_that_pendulum(twins, tmp_path):
    fv = twins
    x, y = fv.spot[0]
    res = invoke("track", fv.path, "--roi", f"{int(x) - 15},{int(y) - 15},30,30", "--out", tmp_path, "-q")
    assert res.exit_code == 0, res.output
    df = read_artifact(tmp_path / "track.parquet", "track").data
    ok = df.ok.to_numpy()
    err = np.hypot(df.x_px.to_numpy() - fv.spot[df.frame, 0], df.y_px.to_numpy() - fv.spot[df.frame, 1])
    assert ok.mean() >= 0.99 and np.nanmax(err[ok]) < 2.0  # the other bob is > 100 px away
