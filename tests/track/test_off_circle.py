"""Points off the marker's circle about the axle: what the tracker took for the marker and is not."""

import logging

import numpy as np
import pandas as pd
import pytest

from pendtrack.config import AngleConfig
from pendtrack.errors import TrackingError
from pendtrack.track.axle import angle_table
from pendtrack.track.circle import off_circle

AXLE = (320.0, 100.0)
ARM = 250.0


def swing_path(n=600, *, fps=120.0, amp=1.4, noise=0.3, lens=0.0, seed=0):
    """A decaying swing's marker positions [px] about AXLE, with tracking noise, and a lens's smooth radial error
    ``lens`` [px] that grows with the angle as a wrong radial correction's does (largest at the turning points)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fps
    theta = amp * np.exp(-0.1 * t) * np.cos(3.5 * t)
    r = ARM + lens * (theta / amp) ** 2
    x = AXLE[0] + r * np.sin(theta) + rng.normal(0, noise, n)
    y = AXLE[1] + r * np.cos(theta) + rng.normal(0, noise, n)
    return t, theta, x, y


def test_a_look_alike_for_two_frames_is_off_the_circle_and_a_lens_bend_is_not():
    # a wrong lens bends the circle by 6 px at the turning points, 20 times the tracking noise: every point stays;
    # two frames on the pivot (3 px from the axle) and two on a look-alike 12 px outside the circle do not
    _, theta, x, y = swing_path(lens=6.0)
    x[200:202], y[200:202] = AXLE[0] + 3.0, AXLE[1] + 1.0
    look = slice(400, 402)
    x[look], y[look] = AXLE[0] + (ARM + 12) * np.sin(theta[look]), AXLE[1] + (ARM + 12) * np.cos(theta[look])
    off, threshold = off_circle(x, y, AXLE)
    assert np.flatnonzero(off).tolist() == [200, 201, 400, 401]
    # 8 robust sigmas of 0.3-px noise's differences from a running median: ~3 px, well below the 12-px look-alike
    assert 1.0 <= threshold < 6.0


def test_noise_alone_is_never_off_the_circle():
    for seed in range(5):
        _, _, x, y = swing_path(noise=0.5, seed=seed)
        off, _ = off_circle(x, y, AXLE)
        assert not off.any()


def track_frame(x, y, t):
    return pd.DataFrame({"frame": np.arange(t.size), "t": t, "x": x, "y": y, "x_px": x, "y_px": y,
                         "ok": np.ones(t.size, bool)})


@pytest.mark.parametrize("axle", [(), AXLE])
def test_angle_leaves_out_the_pivot_taken_for_the_marker(axle, caplog):
    # the tracker sat on the pivot for the first 0.2 s (a drawn pendulum's pivot dot, its centre pulled by the rod)
    # and jumped to it for two frames later: those points are left out, the axle is the marker's circle's and
    # theta is the swing's
    t, theta, x, y = swing_path()
    x[:24], y[:24] = AXLE[0] + 2.0 * np.cos(np.arange(24)), AXLE[1] + 2.0 * np.sin(np.arange(24))
    x[300:302], y[300:302] = AXLE[0] - 1.0, AXLE[1] + 3.0
    bad = np.zeros(t.size, bool)
    bad[:24] = bad[300:302] = True
    with caplog.at_level(logging.WARNING):
        table = angle_table(track_frame(x, y, t), options=AngleConfig(axle=axle, lens_check="off"), track_extra={},
                            track_config={}, source="track.parquet")
    ok = table.frame["ok"].to_numpy()
    assert (ok == ~bad).all()
    assert table.extra["off_circle"]["n"] == 26 and table.extra["off_circle"]["far"] == 26
    assert "26 of 600 tracked points are not on the marker's circle" in caplog.text
    # the marker's own points: 0.3-px noise on a 250-px arm is ~1.2 mrad per point; the axle from ~570 points
    np.testing.assert_allclose(table.frame["theta"].to_numpy()[ok], theta[ok], atol=6e-3)
    if not axle:
        assert np.hypot(*(np.subtract(table.facts["axle"], AXLE))) < 0.2
        assert table.facts["circle_rms_px"] < 0.5


def test_a_clean_track_keeps_every_point():
    t, theta, x, y = swing_path(lens=4.0)
    table = angle_table(track_frame(x, y, t), options=AngleConfig(lens_check="off"), track_extra={},
                        track_config={}, source="track.parquet")
    assert table.frame["ok"].all() and table.extra["off_circle"]["n"] == 0



def test_a_swing_held_before_and_resting_after_keeps_every_point():
    # the track sits still where the hand holds the bob and where it rests: those places are on the circle, and
    # the circle fitted without them (where the track does not sit still) keeps them
    rng = np.random.default_rng(2)
    t = np.arange(900) / 120.0
    theta = np.where(t < 1.0, 1.2, 1.2 * np.exp(-1.5 * (t - 1.0)) * np.cos(3.5 * (t - 1.0)))
    x = AXLE[0] + ARM * np.sin(theta) + rng.normal(0, 0.3, t.size)
    y = AXLE[1] + ARM * np.cos(theta) + rng.normal(0, 0.3, t.size)
    table = angle_table(track_frame(x, y, t), options=AngleConfig(lens_check="off"), track_extra={},
                        track_config={}, source="track.parquet")
    assert table.frame["ok"].all() and table.extra["off_circle"]["n"] == 0


@pytest.mark.parametrize("share, refused", [(0.3, False), (0.4, False), (0.6, True)])
def test_a_track_mostly_on_other_things_is_refused(share, refused):
    # a red ball held at the frame's side, the floor's boards taken for it (FiloSottile/Pendolo-OpenCV@749ad2b,
    # esempio.avi, --marker-color red --projection none): 205 of 380 points off the marker's circle, and angle
    # wrote theta of it, exit 0. Here the tracker sits on one of four spots below the arc (the floor) for
    # stretches of 30 frames, the given share of the record. Fitted to every point, the first circle went through
    # the spots (radius 195 px, not 250) at 0.4, and most points were off it; fitted to the points where the track
    # does not sit still, it is the marker's: the spots are left out up to half of the record, and beyond half
    # the track is refused.
    t, theta, x, y = swing_path()
    rng = np.random.default_rng(1)
    bad = (np.arange(t.size) // 30) % 10 < round(10 * share)
    spot = (np.flatnonzero(bad) // 30) % 4
    sx, sy = rng.uniform(100.0, 540.0, 4), rng.uniform(420.0, 470.0, 4)
    x[bad] = sx[spot] + rng.normal(0, 0.3, bad.sum())
    y[bad] = sy[spot] + rng.normal(0, 0.3, bad.sum())

    def run():
        return angle_table(track_frame(x, y, t), options=AngleConfig(lens_check="off"), track_extra={},
                           track_config={}, source="track.parquet")

    if refused:
        with pytest.raises(TrackingError, match=r"of 600 tracked points are not on one circle about an axle"):
            run()
    else:
        assert (run().frame["ok"].to_numpy() == ~bad).all()


@pytest.mark.parametrize("projection", ["equisolid", "none"])
def test_an_arc_bending_about_an_axle_below_it_is_no_hanging_pendulum(projection):
    # a long pendulum filmed through a phone's lens, the axle far above the frame and a 2-deg swing
    # (Niettzche/PenduloNewton@34bbab5, videos/pendulo3.mp4): the default fisheye correction bent the flat arc the
    # other way, and the angle stage put the axle 9000 px below the bob, theta a third of the swing's, exit 0
    t, _, x, y = swing_path(amp=0.3, noise=0.2)
    y = 2 * AXLE[1] + 2 * ARM - y  # the same arc mirrored: it bends up, about an axle below it
    with pytest.raises(TrackingError, match="bends about an axle below it") as err:
        angle_table(track_frame(x, y, t), options=AngleConfig(lens_check="off"), track_extra={},
                    track_config={"lens": {"projection": projection}}, source="track.parquet")
    assert ("--projection none" in str(err.value)) == (projection != "none")
