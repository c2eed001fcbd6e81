"""Templates that hold on real balls (issue #27): a shiny ball whose highlight saturates the
sensor, motion-blurred at the bottom of the swing, is tracked in >= 99 % of its frames, on a
point fixed to the ball.

Video: a small render (``tests/field_videos.py``), 4 s at 60 fps, 640x360, a second or two.
"""

import numpy as np
import pytest
from factory import field_video
from test_track_cli import invoke

from pendtrack.artifacts import read_artifact

pytestmark = pytest.mark.video  # renders of shiny and turning balls

# a shiny blue ball (4 cm) on a string, normal lens, the axle above the frame; the shutter open
# 1/120 s: at the bottom the ball moves 2 Omega0 sin(theta0 / 2) L ~ 1.2 m/s, a streak of ~10 mm,
# a quarter of its diameter
SHINY = dict(rig="string", marker_color="blue", marker_shape="shiny", spot_radius_m=0.02, lens_projection="none",
             lens_fov_deg=70.0, camera_offset_m=(0.0, 0.13), theta0=0.8, exposure_s=1 / 120)


@pytest.fixture(scope="module")
def shiny(tmp_path_factory):
    return field_video(tmp_path_factory.mktemp("shiny") / "video.mp4", seconds=4.0, fps=60.0, **SHINY)


def test_the_highlight_saturates(shiny):
    import av

    with av.open(str(shiny.path)) as c:
        frame = next(c.decode(video=0)).to_ndarray(format="bgr24")
    x, y = shiny.spot[0].astype(int)
    r = int(shiny.radius_px)
    ball = frame[y - r:y + r, x - r:x + r].astype(int)
    # a white spot on a blue ball: some pixels clip in every channel (the highlight), the rest is blue
    assert (ball.min(axis=2) >= 250).sum() >= 5
    assert np.median(ball[..., 0] - ball[..., 2]) > 60


@pytest.mark.integration
def test_a_shiny_motion_blurred_ball_is_tracked_in_99_percent_of_frames(shiny, tmp_path):
    fv = shiny
    res = invoke("track", fv.path, "--projection", "none", "--marker-color", "blue", "--out", tmp_path, "-q")
    assert res.exit_code == 0, res.output
    df = read_artifact(tmp_path / "track.parquet", "track").data
    ok = df.ok.to_numpy()
    assert ok.mean() >= 0.99
    # the tracked point is fixed to the ball: its offset from the ball's centre (the shading pulls it
    # a few px towards the lit side, world-fixed) varies by well under a pixel, also where the ball
    # is blurred at the bottom -- a template that slid onto the highlight would move by ~r/2 ~ 9 px
    dx = df.x_px.to_numpy()[ok] - fv.spot[df.frame[ok], 0]
    dy = df.y_px.to_numpy()[ok] - fv.spot[df.frame[ok], 1]
    assert np.ptp(dx) < 1.0 and np.ptp(dy) < 1.0, (np.ptp(dx), np.ptp(dy))


# a ball whose upper half is clear: only its lower half is blue, turning with the swing (+-29 deg)
CAPPED = dict(rig="string", marker_color="blue", marker_shape="ball", spot_radius_m=0.03, lens_projection="none",
              lens_fov_deg=70.0, camera_offset_m=(0.0, 0.13), theta0=0.5)


@pytest.mark.integration
def test_a_ball_turning_with_the_swing_is_tracked_at_its_turning_points(tmp_path):
    from pendtrack.track.circle import fit_circle

    fv = field_video(tmp_path / "video.mp4", seconds=3.0, fps=30.0, cap=True, **CAPPED)
    res = invoke("track", fv.path, "--projection", "none", "--marker-color", "blue", "--out", tmp_path / "out", "-q")
    assert res.exit_code == 0, res.output
    df = read_artifact(tmp_path / "out" / "track.parquet", "track").data
    ok = df.ok.to_numpy()
    # a template that does not turn scores 0.53-0.6 at every turning point: 71 % ok
    assert ok.mean() >= 0.99
    # the tracked point is fixed to the ball (the blue half's middle, off the ball's centre): it moves on a
    # circle about the ball centre's axle. Turned in 5 deg steps, up to 2.5 deg of the turn is left unmatched,
    # a few tenths of a px on a 27 px ball (measured: 0.44 px rms, centre 0.4 px off); the fixed template's
    # ok frames put the centre 3.8 px off
    truth = fit_circle(fv.spot[:, 0], fv.spot[:, 1])
    got = fit_circle(df.x_px.to_numpy()[ok], df.y_px.to_numpy()[ok])
    assert got.rms < 0.8, got
    assert np.hypot(got.xc - truth.xc, got.yc - truth.yc) < 2.0, (got, truth)


@pytest.mark.integration
def test_a_hand_over_the_ball_with_a_normal_lens_is_never_tracked(tmp_path):
    # a skin-coloured hand covers the blue ball for the first second (painted over the render), then is gone
    fv = field_video(tmp_path / "video.mp4", seconds=3.0, fps=30.0, hand_s=1.0, **(CAPPED | dict(marker_shape="ball")))
    res = invoke("track", fv.path, "--projection", "none", "--marker-color", "blue", "--out", tmp_path / "out", "-q")
    assert res.exit_code == 0, res.output
    df = read_artifact(tmp_path / "out" / "track.parquet", "track").data
    ok = df.ok.to_numpy()
    vis = fv.visible[df.frame.to_numpy()]
    assert not ok[~vis].any()  # nothing is tracked on the hand
    assert ok[vis].mean() >= 0.99
    err = np.hypot(df.x_px.to_numpy() - fv.spot[df.frame, 0], df.y_px.to_numpy() - fv.spot[df.frame, 1])
    # a uniform ball: the shading pulls the point ~3.5 px towards the light (test above), never off the ball
    assert np.nanmax(err[ok]) < 0.5 * fv.radius_px
