"""Renderer geometry: lens, angle convention and where the spot's blob lands."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pendtrack.config import RenderConfig
from pendtrack.lens.fisheye import Fisheye
from pendtrack.render.film import FrameRenderer
from pendtrack.render.raster import raster_pendulum
from pendtrack.render.scene import SPOT_BGR, Scene, scene_from_config

THETAS = (0.0, 0.4, 1.2, -0.9, -2.0, 3.0, np.pi)


def predicted_centroid(scene: Scene, theta: float, n_r: int = 120, n_a: int = 480) -> tuple[float, float]:
    """Lens-model prediction of the centroid of the spot's image [px].

    The spot's disc is cut into a dense polar mesh (``n_r`` rings x ``n_a`` sectors) in the
    pendulum's plane; every mesh cell's corners are projected through the lens
    (:meth:`Scene.project`), and the image of the disc is the union of these projected
    quadrilaterals. Its centroid is the area-weighted mean of the quadrilaterals' centroids
    (shoelace formulas), i.e. the world sampling weighted by the lens' local area scale.
    """
    xc, yc = scene.spot_centre(theta)
    r = np.linspace(0.0, scene.spot_radius_m, n_r + 1)
    a = np.linspace(0.0, 2 * np.pi, n_a + 1)
    rr, aa = np.meshgrid(r, a, indexing="ij")
    u, v = scene.project(xc + rr * np.cos(aa), yc + rr * np.sin(aa))
    qu = np.stack([u[:-1, :-1], u[1:, :-1], u[1:, 1:], u[:-1, 1:]])
    qv = np.stack([v[:-1, :-1], v[1:, :-1], v[1:, 1:], v[:-1, 1:]])
    cross = qu * np.roll(qv, -1, 0) - np.roll(qu, -1, 0) * qv
    area = 0.5 * cross.sum(0)
    cu = ((qu + np.roll(qu, -1, 0)) * cross).sum(0) / (6 * np.where(area == 0, 1, area))
    cv = ((qv + np.roll(qv, -1, 0)) * cross).sum(0) / (6 * np.where(area == 0, 1, area))
    return float((area * cu).sum() / area.sum()), float((area * cv).sum() / area.sum())


def centroid(weight: np.ndarray, box: tuple[int, int, int, int]) -> tuple[float, float]:
    v, u = np.mgrid[box[1]:box[3], box[0]:box[2]]
    w = weight.astype(float)
    return float((w * u).sum() / w.sum()), float((w * v).sum() / w.sum())


def spot_box(scene: Scene, theta: float, half: int) -> tuple[int, int, int, int]:
    u, v = scene.spot_centre_px(theta)
    return int(u) - half, int(v) - half, int(u) + half + 1, int(v) + half + 1


def test_project_unproject_round_trip():
    scene = Scene(width=1280, height=720)
    x = np.array([-0.4, 0.0, 0.05, 0.2, 0.3])
    y = np.array([0.3, -0.26, 0.02, 0.1, -0.2])
    for depth in (0.0, 0.3, -0.03):
        u, v = scene.project(x, y, depth)
        x2, y2 = scene.unproject(u, v, depth)
        np.testing.assert_allclose(x2, x, atol=1e-12)
        np.testing.assert_allclose(y2, y, atol=1e-12)


def test_lens_follows_equisolid_formula_and_image_centre_is_optical_axis():
    scene = Scene(width=1280, height=720)
    fe = Fisheye(width=1280, height=720)
    u, v = scene.project(*scene.offset_m)
    assert (u, v) == pytest.approx(fe.centre, abs=1e-12)
    # a point 0.2 m straight right of the optical axis: phi = atan(0.2 / 0.58)
    u, v = scene.project(scene.offset_m[0] + 0.2, scene.offset_m[1])
    rho = np.sin(np.arctan(0.2 / 0.58) / 2) / np.sin(np.radians(120) / 4)
    assert u - fe.centre[0] == pytest.approx(fe.half_diagonal * rho, rel=1e-12)
    assert v == pytest.approx(fe.centre[1], abs=1e-12)


def test_axle_is_off_the_optical_axis():
    # otherwise the spot's circle would stay a circle for any field of view
    scene = scene_from_config(RenderConfig())
    fe = scene.fisheye
    assert np.hypot(scene.axle_px[0] - fe.centre[0], scene.axle_px[1] - fe.centre[1]) > 20


@pytest.mark.parametrize("theta", THETAS)
def test_truth_angle_matches_corrected_geometry(theta):
    # the lens correction maps the pendulum's plane to the corrected image by a similarity,
    # so the angle of spot - axle there is the true angle (to rounding)
    scene = scene_from_config(RenderConfig())
    fe = scene.fisheye
    su, sv = fe.undistort_points(*scene.spot_centre_px(theta))
    au, av = fe.undistort_points(*scene.axle_px)
    measured = np.arctan2(su - au, sv - av)
    assert np.angle(np.exp(1j * (measured - theta))) == pytest.approx(0.0, abs=1e-9)


def test_angle_sign_convention_in_the_raw_image():
    scene = scene_from_config(RenderConfig())
    au, av = scene.axle_px
    u, v = scene.spot_centre_px(0.0)
    assert v > av + 100 and abs(u - au) < 5  # hanging down
    u, _ = scene.spot_centre_px(0.5)
    assert u > au + 50  # positive theta: to the image's right


def test_spot_stays_in_frame_over_the_whole_circle():
    scene = scene_from_config(RenderConfig())
    th = np.linspace(-np.pi, np.pi, 721)
    u, v = scene.spot_centre_px(th)
    r_px = scene.spot_radius_m * scene.px_per_m_max
    assert u.min() > r_px and v.min() > r_px
    assert u.max() < scene.width - 1 - r_px and v.max() < scene.height - 1 - r_px


@pytest.mark.parametrize("theta", THETAS)
def test_rendered_spot_centroid_matches_lens_model(theta):
    # The spot alone through the raster kernel: no noise, no blur, uniform light, black
    # background. 0.1 px is the brief's bound; the one-pixel anti-aliasing ramp is
    # symmetric, so the measured error is ~0.01 px.
    scene = Scene(width=1280, height=720)
    xw, yw, size = scene.pixel_world_maps()
    light = np.full((scene.height, scene.width, 1), 255.0, np.float32)
    back = np.zeros((scene.height, scene.width, 3), np.float32)
    box = spot_box(scene, theta, 30)
    bgr, _ = raster_pendulum(xw, yw, size, light, back, box, np.array([theta]), scene.parts()[-1:])
    cu, cv = centroid(bgr[..., 2], box)
    pu, pv = predicted_centroid(scene, theta)
    assert np.hypot(cu - pu, cv - pv) < 0.1


def test_spot_centroid_differs_from_projected_centre():
    # why the prediction above integrates the disc: the lens shifts the blob's centroid by
    # ~0.1 px from the image of the spot's centre
    scene = Scene(width=1280, height=720)
    pu, pv = predicted_centroid(scene, 0.0)
    u, v = scene.spot_centre_px(0.0)
    assert 0.03 < np.hypot(pu - u, pv - v) < 0.5


@pytest.mark.parametrize("theta", (0.3, -1.3, 2.6))
def test_full_frame_spot_centroid_matches_lens_model(theta):
    # Whole frame (wall, bar, disc...) without noise, blur or lighting variation. The
    # spot's coverage is recovered exactly per pixel from the red channel:
    # f = cov * spot + (1 - cov) * under, with `under` rendered with the spot moved away.
    cfg = RenderConfig(width=640, height=360)
    scene = scene_from_config(cfg)
    moved = dataclasses.replace(scene, spot_distance_m=0.45)
    kw = dict(alley=False, gradient=0.0, vignetting=0.0, noise_sigma=0.0, seed=3)
    f = FrameRenderer(scene, **kw).render_linear(np.array([theta]))
    under = FrameRenderer(moved, **kw).render_linear(np.array([theta]))
    box = spot_box(scene, theta, 16)
    sl = (slice(box[1], box[3]), slice(box[0], box[2]), 2)
    light = 0.92 * 255  # illumination() with no gradient and no vignetting
    cov = (f[sl] - under[sl]) / (SPOT_BGR[2] * light - under[sl])
    assert cov.max() == pytest.approx(1.0, abs=1e-4) and cov.min() == pytest.approx(0.0, abs=1e-4)
    cu, cv = centroid(cov, box)
    pu, pv = predicted_centroid(scene, theta)
    assert np.hypot(cu - pu, cv - pv) < 0.1
