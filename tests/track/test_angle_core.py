"""Circle fit (axle) and theta: conventions, unwrapping, zero at rest or vertical."""

import numpy as np
import pytest

from pendtrack.track.angle import raw_theta, rest_angle, theta_from_track, wrap
from pendtrack.track.circle import arc_span, fit_circle, fit_circle_kasa, fit_circle_pratt


def arc(n, *, xc=600.0, yc=340.0, r=300.0, a0=-1.0, a1=1.0, noise=0.0, seed=0):
    rng = np.random.default_rng(seed)
    a = np.linspace(a0, a1, n)
    return xc + r * np.sin(a) + rng.normal(0, noise, n), yc + r * np.cos(a) + rng.normal(0, noise, n)


def test_algebraic_fits_exact_on_a_clean_circle():
    x, y = arc(50)
    for fit in (fit_circle_kasa, fit_circle_pratt):
        assert fit(x, y) == pytest.approx((600.0, 340.0, 300.0), abs=1e-6)


def test_geometric_fit_on_a_short_noisy_arc_beats_kasa():
    # Kasa is biased towards small circles on short arcs; Pratt + geometric is not
    x, y = arc(400, a0=-0.3, a1=0.3, noise=0.3, seed=2)
    fit = fit_circle(x, y)
    assert np.hypot(fit.xc - 600, fit.yc - 340) < 3.0 and fit.radius == pytest.approx(300, abs=3.0)
    assert fit.rms == pytest.approx(0.3, rel=0.15)
    assert np.degrees(fit.arc_span) == pytest.approx(np.degrees(0.6), abs=0.5)
    kasa_r = fit_circle_kasa(x, y)[2]
    assert abs(fit.radius - 300) < abs(kasa_r - 300)


def test_robust_loss_ignores_a_few_outliers():
    x, y = arc(300, a0=-2.5, a1=2.5, noise=0.2, seed=3)
    x[::30] += 25.0  # 10 wild points
    fit = fit_circle(x, y)
    assert np.hypot(fit.xc - 600, fit.yc - 340) < 0.2 and fit.radius == pytest.approx(300, abs=0.2)
    assert fit.mad < 0.3 < fit.rms  # the rms reports the outliers honestly


def test_arc_span_full_circle():
    a = np.linspace(0, 2 * np.pi, 73)[:-1]
    assert arc_span(np.cos(a), np.sin(a), 0, 0) == pytest.approx(2 * np.pi - 2 * np.pi / 72)


def test_too_few_points():
    with pytest.raises(ValueError):
        fit_circle([1, 2], [3, 4])


def test_theta_convention_down_zero_right_positive():
    axle = (100.0, 100.0)
    # image y down: straight below the axle is +y
    assert raw_theta(100.0, 150.0, axle) == pytest.approx(0.0)
    assert raw_theta(150.0, 100.0, axle) == pytest.approx(np.pi / 2)  # to the image's right
    assert raw_theta(50.0, 100.0, axle) == pytest.approx(-np.pi / 2)
    assert abs(raw_theta(100.0, 50.0, axle)) == pytest.approx(np.pi)  # over the top
    assert wrap(3 * np.pi / 2) == pytest.approx(-np.pi / 2)


def motion(theta, t, axle=(640.0, 360.0), r=300.0):
    return axle[0] + r * np.sin(theta), axle[1] + r * np.cos(theta)


def test_full_turns_unwrap_and_zero_at_rest():
    t = np.arange(0, 12, 1 / 120)
    # two turns over the top (theta grows by 4 pi), then settles at rest 0.02 rad right of vertical
    theta_true = np.where(t < 6, 3.0 + 4 * np.pi * t / 6, 3.0 + 4 * np.pi)
    theta_true = np.where(t < 8, theta_true, 4 * np.pi + 0.02)  # still for the last 4 s
    theta_true[(t >= 6) & (t < 8)] = np.linspace(3.0 + 4 * np.pi, 4 * np.pi + 0.02, ((t >= 6) & (t < 8)).sum())
    x, y = motion(theta_true, t)
    ok = np.ones(t.size, bool)
    ok[100:103] = False
    res = theta_from_track(t, x, y, ok, axle=(640.0, 360.0), rest_seconds=2.0, rest_omega_max=0.05)
    assert res.zero_reference == "rest" and res.zero_offset == pytest.approx(0.02, abs=1e-9)
    np.testing.assert_allclose(res.theta[ok], theta_true[ok] - (4 * np.pi + 0.02), atol=1e-9)
    assert np.isnan(res.theta[100:103]).all() and not res.ok[100:103].any()


def test_vertical_fallback_when_never_at_rest():
    t = np.arange(0, 5, 1 / 120)
    theta_true = 2.5 * np.cos(2 * np.pi * t / 1.3)  # still swinging at the end
    x, y = motion(theta_true, t)
    res = theta_from_track(t, x, y, np.ones(t.size, bool), axle=(640.0, 360.0), rest_seconds=2.0,
                           rest_omega_max=0.05)
    assert res.zero_reference == "vertical" and res.zero_offset == 0.0
    np.testing.assert_allclose(res.theta, theta_true, atol=1e-9)


def test_rest_needs_the_whole_stretch_still():
    t = np.arange(0, 4, 0.01)
    still = np.full(t.size, 0.1)
    assert rest_angle(t, still, rest_seconds=2.0, omega_max=0.05) == pytest.approx(0.1)
    slow = 0.1 + 0.03 * np.sin(2 * np.pi * t / 1.0)  # |omega| up to 0.19 rad/s
    assert rest_angle(t, slow, rest_seconds=2.0, omega_max=0.05) is None
    noisy = 0.1 + np.random.default_rng(0).normal(0, 0.0005, t.size)  # 0.5 mrad tracking noise is still
    assert rest_angle(t, noisy, rest_seconds=2.0, omega_max=0.05) == pytest.approx(0.1, abs=1e-3)
    assert rest_angle(t[:50], still[:50], rest_seconds=2.0, omega_max=0.05) is None  # too short a record
