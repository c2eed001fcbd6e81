"""A swing filmed obliquely: its plane's tilt from the marker's elliptical path, theta read in its own plane."""

import logging
import math

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from factory import swing

from pendtrack.cli import cli
from pendtrack.config import AngleConfig
from pendtrack.track.axle import angle_table
from pendtrack.track.circle import fit_circle
from pendtrack.track.plane_tilt import MAX_AXES_RATIO, find_plane_tilt

PARAMS = {"Omega0": 5.2, "C0": 0.02, "C3": 0.01, "p": 2.0, "Ca": 0.0}
RADIUS_PX = 200.0
NOISE_PX = 0.2  # a good track's scatter: 1 mrad of theta at this radius


def oblique_path(*, tilt_deg: float, short_axis_deg: float, theta0: float = 2.0, seconds: float = 30.0,
                 seed: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """t [s], theta [rad] and the marker's x, y [px, y down] of a swing whose plane is turned ``tilt_deg`` from the
    image plane: its circle shortened by cos(tilt) along ``short_axis_deg`` (a camera far from the swing)."""
    t, theta = swing("classic", PARAMS, seconds=seconds, theta0=theta0, fps=120.0)
    x, y = RADIUS_PX * np.sin(theta), RADIUS_PX * np.cos(theta)
    c, s = math.cos(math.radians(short_axis_deg)), math.sin(math.radians(short_axis_deg))
    along = (math.cos(math.radians(tilt_deg)) - 1.0) * (x * c + y * s)
    rng = np.random.default_rng(seed)
    x = 640.0 + x + along * c + rng.normal(0.0, NOISE_PX, t.size)
    y = 100.0 + y + along * s + rng.normal(0.0, NOISE_PX, t.size)
    return t, theta, x, y


def _frame(t: np.ndarray, x: np.ndarray, y: np.ndarray) -> pd.DataFrame:
    return pd.DataFrame({"frame": np.arange(t.size), "t": t, "x": x, "y": y, "x_px": x, "y_px": y,
                         "ok": np.ones(t.size, bool)})


@pytest.mark.parametrize(("tilt_deg", "short_axis_deg"), [(10.0, 0.0), (10.0, 35.0), (30.0, 90.0)])
def test_a_swing_filmed_obliquely_is_read_in_its_own_plane(tilt_deg, short_axis_deg, caplog):
    # read about the circle fitted to the ellipse, theta of the 10-deg swing was up to 18 mrad wrong, a pattern at
    # twice the swing's frequency that no model of the pendulum has
    t, theta, x, y = oblique_path(tilt_deg=tilt_deg, short_axis_deg=short_axis_deg)
    with caplog.at_level(logging.WARNING):
        table = angle_table(_frame(t, x, y), options=AngleConfig(lens_check="off"), track_extra={},
                            track_config={}, source="oblique")
    plane = table.extra["swing_plane"]
    # the axes ratio to 3 of its standard errors and to 1e-3 (the noise's own limit on a 200-px circle)
    ratio = math.cos(math.radians(tilt_deg))
    assert abs(plane["axes_ratio"] - ratio) < max(3.0 * plane["axes_ratio_sigma"], 1e-3)
    assert abs((plane["short_axis_deg"] - short_axis_deg + 90.0) % 180.0 - 90.0) < 1.0
    assert f"turned {tilt_deg:.1f} deg from the camera's" in caplog.text
    got = table.frame["theta"].to_numpy()
    err = (got - np.mean(got - theta)) - theta  # theta's zero (no rest at the end) is the image's vertical
    # 1 mrad of noise per sample: within 1.5 of it rms; the circle's reading was 5-60 times that
    assert float(np.sqrt(np.mean(err ** 2))) < 1.5 * NOISE_PX / RADIUS_PX
    circle = fit_circle(x, y)
    old = np.unwrap(np.arctan2(x - circle.xc, y - circle.yc))
    assert float(np.sqrt(np.mean((old - np.mean(old - theta) - theta) ** 2))) > 5.0 * NOISE_PX / RADIUS_PX


def test_a_square_swing_and_a_short_arc_are_left_as_they_are():
    # square to the camera: a circle within its noise (the tracked renders read 0.9997-0.9999)
    t, _, x, y = oblique_path(tilt_deg=0.0, short_axis_deg=0.0)
    assert find_plane_tilt(x, y, fit_circle(x, y)) is None
    # 3 deg off square: theta off by at most (1 - cos 3 deg) / 2 = 0.7 mrad, under the correction's threshold
    t, _, x, y = oblique_path(tilt_deg=3.0, short_axis_deg=0.0)
    assert math.cos(math.radians(3.0)) > MAX_AXES_RATIO and find_plane_tilt(x, y, fit_circle(x, y)) is None
    # a swing of 0.8 rad spans 92 deg: an ellipse fits it about as well as a circle, and nothing is changed
    t, _, x, y = oblique_path(tilt_deg=20.0, short_axis_deg=0.0, theta0=0.8)
    assert find_plane_tilt(x, y, fit_circle(x, y)) is None
    table = angle_table(_frame(t, x, y), options=AngleConfig(lens_check="off"), track_extra={}, track_config={})
    assert "swing_plane" not in table.extra


@pytest.mark.integration
def test_a_table_of_positions_filmed_obliquely_gives_the_square_swings_omega0(tmp_path, caplog):
    # a t, x, y table in metres (y up) from a swing 10 deg off square: the model-free Omega0 came out +0.58 %
    results = {}
    for tilt in (0.0, 10.0):
        t, _, x, y = oblique_path(tilt_deg=tilt, short_axis_deg=0.0)
        src = tmp_path / f"tilt{tilt:.0f}.csv"
        # metres, y up: 200 px of radius as 0.25 m
        pd.DataFrame({"t": t, "x": x * 0.25 / RADIUS_PX, "y": -y * 0.25 / RADIUS_PX}).to_csv(src, index=False)
        caplog.clear()
        with caplog.at_level(logging.WARNING):
            res = CliRunner().invoke(cli, ["kinematics", str(src), "--out", str(tmp_path / f"k{tilt:.0f}")])
        assert res.exit_code == 0, res.output
        assert ("turned 10.0 deg from the camera's" in caplog.text) == (tilt > 0)
        results[tilt] = float(res.output.split("Omega0 = ")[1].split(" ")[0])
    # the same swing: the two agree to the noise's share (the estimate's own error is 0.0015 rad/s)
    assert abs(results[10.0] - results[0.0]) < 1e-3
