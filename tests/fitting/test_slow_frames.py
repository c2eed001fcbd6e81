"""A compressed video's slow frames: the marker sticks at the turning points, and the fit leaves them out."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from factory import filtered, swing

from pendtrack.config import FitConfig
from pendtrack.fitting import fit_model
from pendtrack.fitting.leastsq.samples import slow_frames
from pendtrack.models import get_model

FPS = 120.0
RADIUS_PX = 150.0  # the marker's distance from the axle in a 640x360 render
TRUTH = {"Omega0": 5.1, "C0": 0.012, "C3": 0.02, "p": 1.4, "Ca": 0.007}


def test_slow_frames_are_those_moving_less_than_the_threshold():
    omega = np.array([-2.0, -0.9, -0.7, 0.0, 0.5, 0.79, 0.81, 3.0, np.nan])
    extra = {"marker_radius_px": RADIUS_PX, "h": 1 / FPS}
    # 1 px a frame at 150 px from the axle and 120 fps: |omega| < 0.8 rad/s
    assert slow_frames(extra, omega, min_px=1.0).tolist() == [False, False, True, True, True, True, False, False,
                                                             False]
    assert slow_frames(extra, omega, min_px=0.0) is None  # off
    assert slow_frames({"h": 1 / FPS}, omega, min_px=1.0) is None  # a table, a given axle: no radius
    assert slow_frames({**extra, "marker_radius_px": None}, omega, min_px=1.0) is None
    assert slow_frames(extra, np.full(4, 5.0), min_px=1.0) is None  # nothing slow
    # a release from rest stays in the cost: the fit's initial state is the release's
    release = np.array([0.0, 0.3, 0.7, 2.0, 0.5, 3.0])
    assert slow_frames(extra, release, min_px=1.0).tolist() == [False, False, False, False, True, False]


def test_a_swing_slow_throughout_loses_only_its_slowest_frames():
    # 0.25 rad at 5.2 rad/s: at most 1.6 px a frame, under a pixel 48 % of the time; with the 12 samples on each
    # side that a 25-point filter window reaches, 82 % would leave the cost (the 0.25-rad render's measured share)
    t = np.arange(2400) / FPS
    extra = {"marker_radius_px": RADIUS_PX, "h": 1 / FPS}
    speed = 0.25 * 5.2 * np.cos(5.2 * t)
    assert slow_frames(extra, speed, min_px=1.0, reach=0).mean() > 0.4  # alone, they would be a minority
    out = slow_frames(extra, speed, min_px=1.0, reach=12)
    reached = np.convolve(out.astype(int), np.ones(25, int), mode="same") > 0
    # the threshold is lowered until half the samples stay: the slowest frames leave, the share kept is half
    # (to within a turning point's worth of samples: 72 frames a half-period here)
    assert 0.5 <= 1.0 - reached.mean() < 0.55
    assert np.abs(speed)[out].max() < np.abs(speed)[~out].min()
    # every frame under 3 px: no release from rest (the record starts at full speed), the same slowest frames
    assert np.array_equal(slow_frames(extra, speed, min_px=3.0, reach=12), out)
    # a swing a little faster loses a little more, never all of its protection at once (a threshold that would
    # leave more than half out is lowered, not dropped)
    # (at 3 px: 0.25, 0.5 and 1 rad lose the slowest 17 % of their frames and keep half the samples; 2 rad has
    # 15 % of its frames under 3 px, all out, and keeps 52 %)
    shares = [np.mean(slow_frames(extra, a * 5.2 * np.cos(5.2 * t), min_px=3.0, reach=12))
              for a in (0.25, 0.5, 1.0, 2.0)]
    assert min(shares) > 0.1


def _sticky_record(seed: int):
    """A classic swing from 2.7 rad as a compressed video tracks it: where the marker moves less than a pixel a
    frame it is read one frame late (the encoder drops the sub-pixel motion; docs/decisions.md 2026-12-02);
    0.5 mrad of noise."""
    t, theta = swing("classic", TRUTH, seconds=40.0, fps=FPS, theta0=2.7)
    omega = np.gradient(theta, t)
    slow = np.abs(omega) * RADIUS_PX / FPS < 1.0
    tracked = np.where(slow, np.r_[theta[0], theta[:-1]], theta)
    tracked = tracked + np.random.default_rng(seed).normal(0.0, 5e-4, t.size)
    kin, obs = filtered(t, tracked)
    return kin, obs


def test_a_marker_stuck_at_the_turning_points_biases_the_damping_unless_its_slow_frames_are_left_out():
    kin, obs = _sticky_record(seed=1)
    opts = replace(FitConfig(), n_starts=6, workers=1, profile=False)

    def fit(cost_out):
        return fit_model(get_model("classic"), kin.t, kin.theta, kin.omega, alpha=kin.alpha, ok=kin.ok,
                         observation=obs, options=opts, seed=0, cost_out=cost_out)

    def z(res):
        return {k: (res.params[k].value - v) / res.params[k].stderr for k, v in TRUTH.items()}

    kept = fit(None)
    out = slow_frames({"marker_radius_px": RADIUS_PX, "h": 1 / FPS}, kin.omega, min_px=1.0, reach=obs.trim)
    left = fit(out)
    # kept: C0, C3 and p 8.6-11.5 standard errors off; left out (3333 of 4776 samples in the cost): within 1.4
    assert max(abs(v) for v in z(kept).values()) > 3.0
    assert max(abs(v) for v in z(left).values()) < 3.0  # 3: 1.3 % for the largest of five Gaussian z-scores
    assert left.n < 0.8 * kept.n
