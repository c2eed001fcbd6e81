"""Accuracy of video -> theta(t) on rendered videos (1280x720, 120 fps, fisheye, blur, noise, H.264).

Zero convention: the truth's zero is the spot hanging straight down. Our theta's zero is
the final rest position when the record ends still (``zero_reference == "rest"``),
else the image vertical (``"vertical"``). The renderer's camera is upright (image y along
gravity), so in the vertical case theta is compared to the truth directly, on the same
2 pi branch; in the rest case to ``truth - truth's final angle``.
"""

import numpy as np
import pytest

from pendtrack.artifacts import read_artifact
from pendtrack.config import Config
from pendtrack.lens.fisheye import Fisheye
from pendtrack.stages.angle import angle_stage
from pendtrack.stages.track import track_stage

pytestmark = [pytest.mark.video, pytest.mark.integration]  # the track and angle stages on rendered videos

# Targets of the issue: RMS <= 1 mrad and max <= 5 mrad over ok frames, >= 99.5 % ok.
RMS_MAX, ERR_MAX, OK_MIN = 1e-3, 5e-3, 0.995


def _run(folder, out, config=None):
    config = config or Config()
    tr = track_stage(folder / "video.mp4", out_dir=out, config=config, progress=False)
    an = angle_stage(tr.path, out_dir=out, config=config, progress=False)
    return read_artifact(tr.path, "track"), read_artifact(an.path, "angle")


def _errors(angle, truth, *, zero):
    th = angle.data.theta.to_numpy()
    ok = angle.data.ok.to_numpy()
    ref = truth.data.theta.to_numpy()
    if zero == "rest":
        ref = ref - ref[-1]
    d = th - ref
    d -= 2 * np.pi * np.round(np.nanmedian(d[ok]) / (2 * np.pi))  # same branch (full turns)
    return d[ok], ok


@pytest.fixture(scope="module")
def swing4(rendered_run, tmp_path_factory):
    """A 3 s run released near the top (theta0 = 3.0 rad): fast, blurred swings; not at rest at the end."""
    folder = rendered_run(seconds=3.0)
    out = tmp_path_factory.mktemp("swing4")
    track, angle = _run(folder, out)
    return folder, out, track, angle, read_artifact(folder / "truth.parquet", "truth")


def test_accuracy_on_a_rendered_swing(swing4):
    folder, out, track, angle, truth = swing4
    assert angle.provenance.extra["zero_reference"] == "vertical"  # still swinging at 3 s
    d, ok = _errors(angle, truth, zero="vertical")
    rms, worst = float(np.sqrt(np.mean(d**2))), float(np.max(np.abs(d)))
    # measured: ~0.65 mrad rms, ~2.5 mrad max, 100 % ok (H.264 chroma noise dominates)
    assert ok.mean() >= OK_MIN
    assert rms <= RMS_MAX, rms
    assert worst <= ERR_MAX, worst
    # the circle fit finds the renderer's axle (raw px -> corrected) within half a pixel
    fe = Fisheye(width=1280, height=720)
    ax, ay = fe.undistort_points(*np.array(truth.provenance.extra["axle_px"]))
    fx, fy = angle.provenance.extra["axle_px"]
    assert np.hypot(fx - ax, fy - ay) < 0.5
    assert angle.provenance.extra["circle_rms_px"] < 0.3


def test_wrong_field_of_view_inflates_the_circle_residual(rendered_run, tmp_path):
    # A wrong field of view bends the spot's circle into a non-circle only as far as the
    # axle sits off the optical axis. With the renderer's default 5 cm offset the noise-free
    # residual at 110 deg is 0.09 px, hidden in the ~0.13 px tracking noise (measured
    # 0.126 -> 0.134 px); with the axle 14 cm off axis it is 0.57 px noise-free.
    folder = rendered_run(seconds=2.0, camera_offset_m=(0.14, -0.02))
    rms = {}
    for corrected in (False, True):
        for fov in (120.0, 110.0):
            # lens_check = warn: the angle stage's lens check would stop at 110 deg (its own tests:
            # tests/track/test_lens_check.py); this test looks at the residual it is built on
            cfg = (Config().replace("lens", fov_deg=fov).replace("track", track_in_corrected=corrected)
                   .replace("angle", lens_check="warn"))
            _, angle = _run(folder, tmp_path / f"{corrected}{fov}", cfg)
            if fov == 110.0:
                assert angle.provenance.extra["lens_check"]["verdict"] == "mismatch"
            rms[corrected, fov] = angle.provenance.extra["circle_rms_px"]
    # measured: 0.13 -> 0.50 px on both paths (raw frames with the lens-warped template,
    # and corrected frames)
    for corrected in (False, True):
        assert rms[corrected, 120.0] < 0.2 and rms[corrected, 110.0] > 3 * rms[corrected, 120.0], rms


def test_tracking_in_corrected_frames_agrees_with_correcting_raw_coordinates(swing4, tmp_path):
    folder, out, track, angle, truth = swing4
    cfg = Config().replace("track", track_in_corrected=True)
    cor = read_artifact(track_stage(folder / "video.mp4", out_dir=tmp_path, config=cfg, progress=False).path,
                        "track")
    a, b = track.data, cor.data
    ok = (a.ok & b.ok).to_numpy()
    dx = (a.x - b.x).to_numpy()[ok]
    dy = (a.y - b.y).to_numpy()[ok]
    # The raw path warps its (corrected-space) template to the lens' local distortion and
    # removes the blob-centroid shift; the two paths then see the same marker the same way.
    # Measured on rendered runs: ~0.015-0.02 px rms, ~0.05 px max.
    dist = np.hypot(dx, dy)
    assert np.hypot(dx.mean(), dy.mean()) < 0.01
    assert np.sqrt(np.mean(dist**2)) < 0.03 and np.percentile(dist, 99) < 0.05, (
        np.sqrt(np.mean(dist**2)), np.percentile(dist, 99), dist.max())


def test_zero_at_the_final_rest(rendered_run, tmp_path):
    # strongly damped, released at 0.3 rad: stops at ~2.0 s, 6 mrad right of the vertical
    # (Coulomb friction), and that stop is theta's zero; still for the last ~1 s
    folder = rendered_run(seconds=3.0, theta0=0.3, params={"C1": 3.0, "C0": 0.3})
    truth = read_artifact(folder / "truth.parquet", "truth")
    # a +-0.3 rad arc pins the axle's distance poorly (a 1 % radius error is a 1 % angle
    # scale error): give the renderer's axle, this test is about the zero
    axle = Fisheye(width=1280, height=720).undistort_points(*np.array(truth.provenance.extra["axle_px"]))
    cfg = Config().replace("angle", rest_seconds=0.8, axle=tuple(float(a) for a in axle))
    _, angle = _run(folder, tmp_path, cfg)
    extra = angle.provenance.extra
    assert extra["zero_reference"] == "rest"
    assert extra["zero_offset_rad"] == pytest.approx(truth.data.theta.iloc[-1], abs=1e-3)
    d, ok = _errors(angle, truth, zero="rest")
    assert ok.mean() >= OK_MIN and np.sqrt(np.mean(d**2)) <= RMS_MAX and np.max(np.abs(d)) <= ERR_MAX


@pytest.mark.slow
def test_accuracy_on_a_full_10_s_render(rendered_run, tmp_path):
    folder = rendered_run(seconds=10.0)
    truth = read_artifact(folder / "truth.parquet", "truth")
    _, angle = _run(folder, tmp_path)
    d, ok = _errors(angle, truth, zero=angle.provenance.extra["zero_reference"])
    assert ok.mean() >= OK_MIN and np.sqrt(np.mean(d**2)) <= RMS_MAX and np.max(np.abs(d)) <= ERR_MAX
