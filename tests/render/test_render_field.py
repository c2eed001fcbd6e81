"""Field conditions in the renderer: lens, frame rates and sizes, the bob's look, framing, hand, roll, sticker.

Each condition is a key of ``[render]`` and a flag of ``pendtrack render``; ``pendtrack run``
on such renders is scored in ``tests/track/test_field_run.py``.
"""

from __future__ import annotations

import dataclasses
from fractions import Fraction

import av
import numpy as np
import pytest
from click.testing import CliRunner

from pendtrack.artifacts import read_artifact
from pendtrack.cli import cli
from pendtrack.config import Config, RenderConfig, load_config
from pendtrack.errors import ConfigError
from pendtrack.render import plan_render
from pendtrack.render.physics import string_omega0
from pendtrack.render.raster import _raster_nb, _raster_py
from pendtrack.render.scene import BALL, MARKER_BGR, Scene, marker_reflectance, scene_from_config
from pendtrack.stages.render import render_stage
from test_render_stage import decode

SMALL = dict(width=320, height=180, seconds=0.25)


@pytest.mark.parametrize("thetas", [np.array([0.7]), np.linspace(0.70, 0.73, 5)])
def test_ball_and_sticker_kernel_matches_python_twin(thetas):
    scene = Scene(width=320, height=180, marker_shape="ball", marker_bgr=MARKER_BGR["blue"],
                  sticker_bgr=MARKER_BGR["pink"], spot_radius_m=0.02)
    parts = scene.parts()
    assert parts[-2, 0] == BALL and parts.shape[0] == 7  # rod, bar, disc, bearing, axle, ball, sticker
    xw, yw, size = scene.pixel_world_maps()
    rng = np.random.default_rng(2)
    light = rng.uniform(100, 255, (180, 320, 1)).astype(np.float32)
    back = rng.uniform(0, 255, (180, 320, 3)).astype(np.float32)
    u, v = scene.spot_centre_px(thetas[0])
    x0, y0 = int(u) - 12, int(v) - 12
    outs = []
    for kernel in (_raster_py, _raster_nb):
        bgr = np.full((25, 25, 3), np.nan, np.float32)
        alpha = np.full((25, 25), np.nan, np.float32)
        kernel(xw, yw, size, light, back, x0, y0, np.sin(thetas), np.cos(thetas), parts, bgr, alpha)
        outs.append((bgr, alpha))
    (b_py, a_py), (b_nb, a_nb) = outs
    assert np.isfinite(b_py).all() and a_py.max() == pytest.approx(1.0)
    np.testing.assert_allclose(b_nb, b_py, rtol=0, atol=1e-3)  # float32 outputs of float64 arithmetic
    np.testing.assert_allclose(a_nb, a_py, rtol=0, atol=1e-6)


def test_ball_is_shaded_by_a_light_fixed_in_the_world():
    # lit from the upper left: the ball's upper-left half is brighter than its lower-right,
    # at any angle of the pendulum (the shading does not turn with it)
    cfg = RenderConfig(width=640, height=360, seconds=0.1, marker_shape="ball", marker_color="#808080",
                       spot_radius_m=0.02, noise_sigma=0.0, exposure_s=0.0, illumination_gradient=0.0,
                       vignetting=0.0)
    plan = plan_render(cfg)
    from pendtrack.render.pipeline import make_renderer

    renderer = make_renderer(plan)
    for theta in (0.0, 1.0, -1.0):
        img = renderer.render_linear(np.array([theta]))[..., 1]
        u, v = plan.scene.spot_centre_px(theta)
        r = 0.5 * plan.scene.spot_radius_m * plan.scene.px_per_m_max
        up_left = img[int(v - r), int(u - r)]
        down_right = img[int(v + r), int(u + r)]
        assert up_left > down_right + 20, (theta, up_left, down_right)


def test_normal_lens_is_a_similarity_of_the_pendulums_plane():
    # projection none: a pinhole camera; the raw image needs no correction, the raw angle is theta
    scene = scene_from_config(RenderConfig(lens_projection="none", lens_fov_deg=75.0))
    assert scene.fisheye.projection == "none"
    theta = np.linspace(-1.2, 1.2, 9)
    u, v = scene.spot_centre_px(theta)
    ax, ay = scene.axle_px
    np.testing.assert_allclose(np.arctan2(u - ax, v - ay), theta, atol=1e-12)
    r = np.hypot(u - ax, v - ay)
    np.testing.assert_allclose(r, r[0], rtol=1e-12)  # the spot's circle stays a circle


@pytest.mark.parametrize("projection", ["equisolid", "equidistant", "stereographic", "orthographic", "none"])
def test_every_lens_projection_renders_and_its_correction_recovers_theta(projection):
    cfg = RenderConfig(lens_projection=projection, lens_fov_deg=100.0, seconds=0.05)
    plan = plan_render(cfg)
    scene = plan.scene
    theta = np.array([-1.0, 0.3, 1.1])
    cu, cv = scene.fisheye.undistort_points(*scene.spot_centre_px(theta))
    ax, ay = scene.fisheye.undistort_points(*np.array(scene.axle_px))
    np.testing.assert_allclose(np.arctan2(cu - ax, cv - ay), theta, atol=1e-9)
    assert plan.to_dict()["lens_projection"] == projection


@pytest.mark.parametrize("projection", ["equisolid", "none"])
def test_camera_roll_adds_to_theta_in_the_image(projection):
    roll = 4.0
    scene = scene_from_config(RenderConfig(camera_roll_deg=roll, lens_projection=projection))
    level = dataclasses.replace(scene, roll_deg=0.0)
    theta = np.array([-1.0, 0.0, 0.5, 2.0])
    cu, cv = scene.fisheye.undistort_points(*scene.spot_centre_px(theta))
    ax, ay = scene.fisheye.undistort_points(*np.array(scene.axle_px))
    np.testing.assert_allclose(np.arctan2(cu - ax, cv - ay), theta + np.radians(roll), atol=1e-9)
    # the roll turns the whole picture about the image centre, the optical axis
    centre = scene.fisheye.centre
    u0, v0 = level.project(0.0, 0.0)
    u1, v1 = scene.project(0.0, 0.0)
    assert np.hypot(u0 - centre[0], v0 - centre[1]) == pytest.approx(np.hypot(u1 - centre[0], v1 - centre[1]))
    x, y = scene.unproject(*scene.project(0.1, 0.2))
    assert (float(x), float(y)) == pytest.approx((0.1, 0.2), abs=1e-12)


@pytest.mark.video
@pytest.mark.integration
def test_roll_is_recorded_and_the_truth_stays_physical(tmp_path):
    out = render_stage(out_dir=tmp_path, config=Config().replace("render", **SMALL, camera_roll_deg=-3.0),
                       progress=False)
    level = render_stage(out_dir=tmp_path / "level", config=Config().replace("render", **SMALL), progress=False)
    truth, truth_level = (read_artifact(o.paths[1], "truth") for o in (out, level))
    assert truth.data.equals(truth_level.data)
    assert truth.provenance.extra["camera_roll_rad"] == pytest.approx(np.radians(-3.0))
    assert truth_level.provenance.extra["camera_roll_rad"] == 0.0


def test_axle_above_the_frame_with_the_bob_in_it():
    cfg = RenderConfig(width=640, height=360, seconds=0.05, lens_projection="none", lens_fov_deg=70.0,
                       camera_offset_m=(0.0, 0.22))
    plan = plan_render(cfg)
    scene = plan.scene
    assert scene.axle_px[1] < 0 and not plan.to_dict()["axle_in_frame"]
    u, v = scene.spot_centre_px(np.linspace(-0.8, 0.8, 33))
    r = scene.spot_radius_m * scene.px_per_m_max
    assert (u > r).all() and (u < 640 - r).all() and (v > r).all() and (v < 360 - r).all()
    assert plan_render(RenderConfig(seconds=0.05)).to_dict()["axle_in_frame"]


def test_hand_holds_the_bob_until_release_then_the_motion_is_the_free_one():
    fps, release = 60.0, 0.5
    free = plan_render(RenderConfig(seconds=1.0, fps=fps, theta0=1.0)).motion
    held = plan_render(RenderConfig(seconds=1.5, fps=fps, theta0=1.0, hand_release_s=release)).motion
    before = held.t < release
    assert before.sum() == 30 and held.release_s == release
    assert (held.theta[before] == 1.0).all() and (held.omega[before] == 0.0).all()
    assert (held.hand[before] == 1.0).all() and (held.hand[~before] == 0.0).all()
    assert all((held.frame_thetas(k) == 1.0).all() for k in np.flatnonzero(before))
    # after the release: the free motion shifted by the release time (same solver, times t - release)
    np.testing.assert_allclose(held.theta[~before], free.theta, atol=1e-9)
    np.testing.assert_allclose(held.omega[~before], free.omega, atol=1e-9)
    assert free.hand is None and free.frame_hand(0) == 0.0


def test_hand_release_within_a_frame_blurs_and_shares_the_exposure():
    fps = 60.0
    motion = plan_render(RenderConfig(seconds=1.0, fps=fps, theta0=2.0, omega0=-3.0, exposure_s=1 / fps,
                                      hand_release_s=0.5 + 0.25 / fps)).motion
    k = 30  # exposed over [0.5 - 0.5/fps, 0.5 + 0.5/fps]: held for its first three quarters
    assert motion.hand[k] == pytest.approx(0.75, abs=0.05)
    th = motion.frame_thetas(k)
    assert th.size > 1 and th[0] == 2.0 and th[-1] < 2.0  # launched by the hand at omega0 < 0
    assert motion.theta[k] == 2.0 and motion.omega[k] == 0.0  # mid-exposure: still held


@pytest.mark.video
@pytest.mark.integration
def test_hand_is_drawn_while_it_holds(tmp_path):
    cfg = Config().replace("render", width=640, height=360, seconds=1.0, fps=30.0, theta0=1.0, hand_release_s=0.5)
    out = render_stage(out_dir=tmp_path, config=cfg, progress=False)
    frames, _ = decode(out.paths[0])
    truth = read_artifact(out.paths[1], "truth")
    assert truth.provenance.extra["hand_release_s"] == 0.5
    scene = scene_from_config(cfg.render)
    u, v = scene.spot_centre_px(1.0)
    # over the bob's centre: skin (red > green > blue) while held, the pink spot after the hand
    # is gone (the bob swung away: frame 29 shows the wall or bar there)
    b, g, r = frames[0][int(v), int(u)].astype(int)
    assert r > g > b and r - b > 40, (b, g, r)
    assert not np.array_equal(frames[0], frames[29])
    b2, g2, r2 = frames[29][int(v), int(u)].astype(int)
    assert not (r2 > g2 > b2 and r2 - b2 > 40)


@pytest.mark.video
@pytest.mark.integration
@pytest.mark.parametrize("colour, channel", [("dark", None), ("blue", 0), ("#20c020", 1)])
def test_bob_colour_and_sticker(tmp_path, colour, channel):
    cfg = Config().replace("render", width=640, height=360, seconds=0.05, theta0=0.5, marker_color=colour,
                           marker_shape="ball", spot_radius_m=0.016, sticker_color="pink")
    out = render_stage(out_dir=tmp_path, config=cfg, progress=False)
    frame = decode(out.paths[0])[0][0].astype(int)
    scene = scene_from_config(cfg.render)
    u, v = scene.spot_centre_px(0.5)
    k = scene.px_per_m_max
    # a point of the bob half a radius across the bar from its centre: off the sticker and the highlight
    pu, pv = scene.project(*scene.to_world(scene.spot_distance_m, 0.5 * scene.spot_radius_m, 0.5))
    bgr = frame[int(round(float(pv))), int(round(float(pu)))]
    if channel is None:
        assert bgr.max() < 60, bgr
    else:
        assert bgr[channel] > bgr.sum() / 3 + 30, bgr
    # the sticker, beyond the centre, is pink: red over green
    a = scene.spot_distance_m + scene.sticker_offset * scene.spot_radius_m
    su, sv = scene.project(*scene.to_world(a, 0.0, 0.5))
    sb, sg, sr = frame[int(round(float(sv))), int(round(float(su)))]
    assert sr > sg + 60, (sb, sg, sr)
    assert k > 0 and (u, v) != (su, sv)


def test_string_rig_has_the_ball_pendulums_omega0_unless_given():
    plan = plan_render(RenderConfig(seconds=0.05, rig="string", spot_radius_m=0.015))
    assert plan.params["Omega0"] == pytest.approx(string_omega0(length_m=0.26, radius_m=0.015, gravity=9.81))
    assert plan.params["Omega0"] == pytest.approx(np.sqrt(9.81 / 0.26), rel=2e-3)  # a small ball: sqrt(g/L)
    assert plan_render(RenderConfig(seconds=0.05, rig="string", params=("Omega0=5.0",))).params["Omega0"] == 5.0
    kinds = plan.scene.parts()[:, 0]
    assert len(kinds) == 3  # string, hook, bob: no bar, disc or tile


@pytest.mark.video
@pytest.mark.integration
@pytest.mark.parametrize("fps, size, n", [(30.0, (640, 360), 6), (60.0, (640, 360), 12), (60.0, (1920, 1080), 3)])
def test_frame_rates_and_1080p(tmp_path, fps, size, n):
    seconds = n / fps
    cfg = Config().replace("render", width=size[0], height=size[1], fps=fps, seconds=seconds, theta0=1.0)
    out = render_stage(out_dir=tmp_path, config=cfg, progress=False)
    frames, times = decode(out.paths[0])
    truth = read_artifact(out.paths[1], "truth").data
    assert len(frames) == len(truth) == n and frames[0].shape == (size[1], size[0], 3)
    np.testing.assert_allclose(times, np.arange(n) / fps, atol=1e-9)
    with av.open(str(out.paths[0])) as container:
        assert container.streams.video[0].average_rate == Fraction(int(fps))
    # the spot is where the truth says (pink: red minus green), within a pixel at every size
    scene = scene_from_config(cfg.render)
    f = frames[-1].astype(float)
    pink = np.clip(f[..., 2] - f[..., 1] - 60, 0, None)
    vv, uu = np.nonzero(pink)
    w = pink[vv, uu]
    pu, pv = scene.spot_centre_px(truth.theta.iloc[-1])
    assert np.hypot((w * uu).sum() / w.sum() - pu, (w * vv).sum() / w.sum() - pv) < 1.0


@pytest.mark.integration
@pytest.mark.parametrize("values, fragment", [
    (dict(marker_color="green"), "render.marker_color"),
    (dict(sticker_color="nope"), "render.sticker_color"),
    (dict(marker_shape="cube"), "render.marker_shape"),
    (dict(rig="rope"), "render.rig"),
    (dict(rig="string", tile_length_m=0.06), "render.tile_length_m must be 0 with rig = 'string'"),
    (dict(sticker_radius_m=0.01), "render.sticker_radius_m"),
    (dict(hand_release_s=0.25), "render.hand_release_s"),
    (dict(camera_roll_deg=50.0), "render.camera_roll_deg"),
    (dict(lens_projection="none", lens_fov_deg=175.0), "render.lens_fov_deg"),
])
def test_bad_field_condition_raises_and_writes_nothing(tmp_path, values, fragment):
    with pytest.raises(ConfigError, match=fragment):
        render_stage(out_dir=tmp_path / "out", config=Config().replace("render", **(SMALL | values)), progress=False)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("text, fragment", [
    ('marker_color = "green"', "render.marker_color"),
    ('sticker_color = "x"', "render.sticker_color"),
    ('rig = "rope"', "render.rig"),
    ('marker_shape = "cube"', "render.marker_shape"),
    ("hand_release_s = -1.0", "render.hand_release_s"),
    ("camera_roll_deg = 90.0", "render.camera_roll_deg"),
    ("sticker_radius_m = 0.0", "render.sticker_radius_m"),
])
def test_field_condition_keys_are_checked_when_the_config_is_loaded(tmp_path, text, fragment):
    path = tmp_path / "c.toml"
    path.write_text(f"[render]\n{text}\n")
    with pytest.raises(ConfigError, match=fragment):
        load_config(path)


def test_marker_reflectance():
    assert marker_reflectance("pink") == MARKER_BGR["pink"]
    assert marker_reflectance("#FF0000") == (0.0, 0.0, 1.0)
    with pytest.raises(ValueError):
        marker_reflectance("#12345")


@pytest.mark.video
@pytest.mark.integration
def test_render_cli_takes_the_field_condition_flags(tmp_path):
    args = ["render", "--seconds", "0.5", "--size", "320x180", "--fps", "30", "--out", str(tmp_path), "-q",
            "--projection", "none", "--fov", "70", "--camera-offset", "0,0.22", "--camera-distance", "0.6",
            "--roll", "2.5", "--marker-color", "blue", "--marker-shape", "ball", "--rig", "string",
            "--sticker", "#ff8000", "--hand-release", "0.2", "--theta0", "0.7"]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    truth = read_artifact(tmp_path / "truth.parquet", "truth")
    cfg = truth.provenance.config["render"]
    assert (cfg["lens_projection"], cfg["lens_fov_deg"], cfg["camera_offset_m"], cfg["camera_distance_m"],
            cfg["camera_roll_deg"], cfg["marker_color"], cfg["marker_shape"], cfg["rig"], cfg["sticker_color"],
            cfg["hand_release_s"]) == ("none", 70.0, [0.0, 0.22], 0.6, 2.5, "blue", "ball", "string", "#ff8000", 0.2)
    assert (truth.data.theta[truth.data.t < 0.2] == 0.7).all()
    help_text = CliRunner().invoke(cli, ["render", "--help"]).output
    for flag in ("--projection", "--fov", "--camera-offset", "--roll", "--marker-color", "--marker-shape", "--rig",
                 "--sticker", "--hand-release", "--fps", "--size"):
        assert flag in help_text
    bad = CliRunner().invoke(cli, ["render", "--seconds", "0.1", "--out", str(tmp_path / "x"), "--roll", "60"])
    assert bad.exit_code == 2 and "render.camera_roll_deg" in bad.stderr
