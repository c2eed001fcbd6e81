"""Fisheye correction (Tracker's radial distortion filter) against hand-computed values."""

import numpy as np
import pytest

from pendtrack.config import LensConfig
from pendtrack.lens.fisheye import (
    Fisheye,
    angle_from_rho,
    fisheye_from_config,
    local_scale,
    raw_centroid_offset,
    rho_from_angle,
    undistort_blob_centres,
)
from pendtrack.lens.remap import chroma_maps, remap_tables, undistort_image

W, H = 1280, 720
CX, CY = (W - 1) / 2, (H - 1) / 2
R = np.hypot(W, H) / 2  # half diagonal, 734.30 px


def test_output_fov_for_paper_settings_is_95_3_deg():
    # phi_fixed = 2 asin(0.48 sin(120/4 deg)) = 2 asin(0.24) = 27.773 deg;
    # tan(fov_out / 2) = tan(27.773 deg) / 0.48 -> fov_out = 95.305 deg (Tracker shows 95.3).
    fe = Fisheye(width=W, height=H)
    assert fe.output_fov_deg == pytest.approx(95.3055, abs=1e-3)
    assert round(fe.output_fov_deg, 1) == 95.3


@pytest.mark.parametrize("projection", ["equisolid", "equidistant", "stereographic", "orthographic"])
def test_fixed_circle_does_not_move(projection):
    fe = Fisheye(width=W, height=H, projection=projection)
    a = np.linspace(0, 2 * np.pi, 37)
    x, y = CX + 0.48 * R * np.cos(a), CY + 0.48 * R * np.sin(a)
    ux, uy = fe.undistort_points(x, y)
    # float64 arithmetic through asin/tan: exact to rounding (1e-9 px is 1e-12 relative)
    np.testing.assert_allclose(ux, x, atol=1e-9)
    np.testing.assert_allclose(uy, y, atol=1e-9)


@pytest.mark.parametrize("projection", ["equisolid", "equidistant", "stereographic", "orthographic", "none"])
def test_round_trip_to_1e_9_px(projection):
    fe = Fisheye(width=W, height=H, projection=projection)
    rng = np.random.default_rng(1)
    x, y = rng.uniform(0, W - 1, 500), rng.uniform(0, H - 1, 500)
    x = np.append(x, CX)  # the centre itself (radius 0 takes the limit gain)
    y = np.append(y, CY)
    ux, uy = fe.undistort_points(x, y)
    bx, by = fe.distort_points(ux, uy)
    np.testing.assert_allclose(bx, x, atol=1e-9, rtol=0)
    np.testing.assert_allclose(by, y, atol=1e-9, rtol=0)


# A raw point at rho = 0.5 on the horizontal through the centre, 120 deg input field of
# view, 48 % fixed pixels. phi = ray angle, phi_f = the fixed circle's ray angle; the
# corrected radius is rho_c = 0.48 tan(phi) / tan(phi_f).
HAND = {
    # phi = 2 asin(0.5 sin 30) = 28.9550 deg, phi_f = 2 asin(0.24) = 27.7731 deg
    "equisolid": 0.504284,
    # phi = 0.5 * 60 = 30 deg, phi_f = 0.48 * 60 = 28.8 deg: 0.48 tan 30 / tan 28.8
    "equidistant": 0.504094,
    # phi = 2 atan(0.5 tan 30), tan(phi) = 0.629837; tan(phi_f) = 0.600369
    "stereographic": 0.503564,
    # phi = asin(0.5 sin 60) = 25.6589 deg, phi_f = asin(0.48 sin 60) = 24.5629 deg
    "orthographic": 0.504503,
    "none": 0.5,
}


@pytest.mark.parametrize("projection", list(HAND))
def test_each_projection_at_a_hand_computed_point(projection):
    fe = Fisheye(width=W, height=H, projection=projection)
    x, y = fe.undistort_points(np.array(CX + 0.5 * R), np.array(CY))
    assert (x - CX) / R == pytest.approx(HAND[projection], abs=2e-6)  # 6 digits were carried by hand
    assert y == pytest.approx(CY, abs=1e-9)


def test_projection_formulas_and_inverses():
    f = np.radians(120)
    phi = np.radians(30)
    assert rho_from_angle(phi, "equisolid", f) == pytest.approx(np.sin(phi / 2) / np.sin(f / 4))
    assert rho_from_angle(phi, "equidistant", f) == pytest.approx(0.5)
    assert rho_from_angle(phi, "stereographic", f) == pytest.approx(np.tan(phi / 2) / np.tan(f / 4))
    assert rho_from_angle(phi, "orthographic", f) == pytest.approx(0.5 / np.sin(f / 2))
    for p in ("equisolid", "equidistant", "stereographic", "orthographic", "rectilinear"):
        fov = f if p != "rectilinear" else np.radians(95.3)
        assert angle_from_rho(rho_from_angle(phi, p, fov), p, fov) == pytest.approx(phi, abs=1e-14)


def test_bad_lens_parameters_raise():
    with pytest.raises(ValueError):
        Fisheye(width=W, height=H, projection="fishy")
    with pytest.raises(ValueError):
        Fisheye(width=W, height=H, fixed_pixels=0)
    with pytest.raises(ValueError):
        Fisheye(width=W, height=H, fov_deg=400)


def test_from_config_and_smaller_fov_corrects_less():
    fe = fisheye_from_config(LensConfig(fov_deg=110.0), width=W, height=H)
    assert fe.fov_deg == 110.0 and fe.projection == "equisolid"
    # a narrower assumed field of view bends less: a point outside the fixed circle moves less
    x120, _ = Fisheye(width=W, height=H).undistort_points(np.array(CX + 0.9 * R), np.array(CY))
    x110, _ = fe.undistort_points(np.array(CX + 0.9 * R), np.array(CY))
    assert CX + 0.9 * R < x110 < x120


def test_remap_tables_match_distort_points():
    fe = Fisheye(width=64, height=48)
    t = remap_tables(fe)
    assert t.shape == (48, 64) and t.map_x.dtype == np.float32
    sx, sy = fe.distort_points(np.array(10.0), np.array(40.0))
    assert t.map_x[40, 10] == pytest.approx(sx, abs=1e-4) and t.map_y[40, 10] == pytest.approx(sy, abs=1e-4)
    part = remap_tables(fe, region=(10, 40, 5, 3))
    np.testing.assert_array_equal(part.map_x, t.map_x[40:43, 10:15])
    c = chroma_maps(t)
    assert c.map_x[40, 10] == pytest.approx((sx + 0.5) / 2 - 0.5, abs=1e-4)


def test_undistort_image_moves_a_dot_where_undistort_points_says():
    fe = Fisheye(width=W, height=H)
    raw_x, raw_y = 1100.3, 150.6  # far from the fixed circle: the correction moves it by ~100 px
    yy, xx = np.mgrid[0:H, 0:W]
    img = (200 * np.exp(-((xx - raw_x) ** 2 + (yy - raw_y) ** 2) / (2 * 3.0**2))).astype(np.float32)
    out = undistort_image(img, remap_tables(fe))
    ex, ey = fe.undistort_points(np.array(raw_x), np.array(raw_y))
    assert np.hypot(ex - raw_x, ey - raw_y) > 50
    win = out[int(ey) - 25:int(ey) + 26, int(ex) - 25:int(ex) + 26].astype(float)
    gy, gx = np.mgrid[int(ey) - 25:int(ey) + 26, int(ex) - 25:int(ex) + 26]
    cx, cy = (win * gx).sum() / win.sum(), (win * gy).sum() / win.sum()
    # the dot is stretched (~1.5x) by the correction; its centroid moves by second-order terms only
    assert np.hypot(cx - ex, cy - ey) < 0.15


def test_none_projection_is_identity_image():
    fe = Fisheye(width=32, height=24, projection="none")
    img = np.arange(32 * 24, dtype=np.float32).reshape(24, 32)
    np.testing.assert_allclose(undistort_image(img, remap_tables(fe)), img, atol=1e-3)


def test_blob_centroid_offset_and_its_removal():
    fe = Fisheye(width=W, height=H)
    # a 14 px disc far out (corrected (600, 60)): its raw blob's centroid is ~0.1 px off the
    # image of its centre; brute force with a dense grid over the disc agrees
    x, y, a = 600.0, 60.0, 14.0
    ox, oy = raw_centroid_offset(fe, np.array(x), np.array(y), a)
    g = np.linspace(-a, a, 401)
    gx, gy = np.meshgrid(g, g)
    m = gx**2 + gy**2 <= a * a
    px, py = x + gx[m], y + gy[m]
    sx, sy = fe.distort_points(px, py)
    h = 1e-3
    ax_, ay_ = fe.distort_points(px + h, py)
    bx_, by_ = fe.distort_points(px, py + h)
    jac = np.abs((ax_ - sx) * (by_ - sy) - (bx_ - sx) * (ay_ - sy))
    cx, cy = (sx * jac).sum() / jac.sum(), (sy * jac).sum() / jac.sum()
    dx, dy = fe.distort_points(np.array(x), np.array(y))
    assert 0.03 < np.hypot(cx - dx, cy - dy) < 0.5
    assert ox == pytest.approx(cx - dx, abs=2e-3) and oy == pytest.approx(cy - dy, abs=2e-3)
    bx, by = undistort_blob_centres(fe, np.array(cx), np.array(cy), a)
    assert bx == pytest.approx(x, abs=1e-3) and by == pytest.approx(y, abs=1e-3)


def test_local_scale_shrinks_the_centre_and_stretches_the_rim():
    fe = Fisheye(width=W, height=H)
    s_centre = local_scale(fe, CX, CY)
    s_out = local_scale(fe, CX + 0.9 * R, CY)
    assert s_centre < 1.0 < s_out  # equisolid -> rectilinear shrinks the centre, stretches the rim
