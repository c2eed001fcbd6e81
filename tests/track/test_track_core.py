"""Tracking core on synthetic arrays: colours, detection, template matching, the tracker loop."""

import numpy as np
import pytest

from pendtrack.errors import TrackingError
from pendtrack.track.colour import MarkerColour, parse_marker_colour, rgb_to_ycbcr
from pendtrack.track.detect import find_marker, level_step, marker_in_roi, median_of, percentile_of
from pendtrack.track.match import match_template, quadratic_peak, weighted_centroid
from pendtrack.track.params import TrackParams
from pendtrack.track.sampler import CorrectedSampler, RawSampler, WarpedRawSampler
from pendtrack.track.tracker import track_frames
from pendtrack.lens.fisheye import Fisheye
from pendtrack.video.reader import YuvFrame
from pendtrack.video.writer import bgr_to_i420

PINK = (180, 105, 255)  # BGR


def disc(h, w, cx, cy, r, ss=4, blur=(0.0, 0.0), nsub=1):
    """Anti-aliased disc coverage; optional motion blur ``blur`` = (dx, dy) over ``nsub`` sub-positions."""
    out = np.zeros((h, w))
    reach = r + 0.5 * max(abs(blur[0]), abs(blur[1])) + 2
    x0, x1 = max(int(cx - reach), 0), min(int(cx + reach) + 2, w)
    y0, y1 = max(int(cy - reach), 0), min(int(cy + reach) + 2, h)
    if x1 <= x0 or y1 <= y0:
        return out
    yy, xx = np.mgrid[y0:y1, x0:x1].astype(float)
    o = (np.arange(ss) + 0.5) / ss - 0.5
    acc = np.zeros(xx.shape)
    for k in range(nsub):
        f = (k + 0.5) / nsub - 0.5 if nsub > 1 else 0.0
        px, py = cx + f * blur[0], cy + f * blur[1]
        for a in o:
            for b in o:
                acc += (xx + a - px) ** 2 + (yy + b - py) ** 2 <= r * r
    out[y0:y1, x0:x1] = acc / (ss * ss * nsub)
    return out


def yuv_frame(bgr, index=0, t=0.0):
    h, w = bgr.shape[:2]
    i420 = bgr_to_i420(bgr)
    y = i420[:h]
    u = i420[h:h + h // 4].reshape(h // 2, w // 2)
    v = i420[h + h // 4:].reshape(h // 2, w // 2)
    return YuvFrame(index, t, y, u, v)


def scene(h, w, cx, cy, r=9.0, colour=PINK, wall=(150, 160, 165), gradient=0.2, noise=2.0, rng=None, **kw):
    base = np.array(wall, float) * (1 + gradient * np.linspace(-1, 1, w))[None, :, None]
    base = np.broadcast_to(base, (h, w, 3)).copy()
    if cx is not None:
        cov = disc(h, w, cx, cy, r, **kw)[..., None]
        base = base * (1 - cov) + np.array(colour, float) * (base[..., :1] / wall[0]) * cov
    if noise and rng is not None:
        base += rng.normal(0, noise, base.shape)
    return np.clip(base, 0, 255).astype(np.uint8)


# --- colours -------------------------------------------------------------------------------

def test_named_and_hex_colours():
    pink = parse_marker_colour("pink")
    assert pink.wy == 0 and pink.wv > 0.9 and pink.wu > 0  # mostly Cr, a little Cb
    assert parse_marker_colour("dark") == MarkerColour("dark", -1.0, 0.0, 0.0)
    blue = parse_marker_colour("blue")
    assert blue.wu > 0.9 and blue.wv < 0
    # the colours a physicist names: red mostly +Cr, green -Cr and -Cb, yellow mostly -Cb, orange between red and
    # yellow; each a chroma direction of its own (none within 20 degrees of another)
    red, green, yellow, orange = (parse_marker_colour(c) for c in ("red", "green", "yellow", "Orange"))
    assert red.wv > 0.85 and red.wu < 0 and green.wv < 0 and green.wu < 0 and yellow.wu < -0.9
    assert red.wu > orange.wu > yellow.wu and red.wv > orange.wv > yellow.wv
    named = [parse_marker_colour(c) for c in ("pink", "red", "orange", "yellow", "green", "blue")]
    for i, a in enumerate(named):
        for b in named[i + 1:]:
            assert a.wu * b.wu + a.wv * b.wv < np.cos(np.radians(20)), (a.name, b.name)
    assert parse_marker_colour("#FF69B4").wv > 0.9  # hot pink, as a hex colour
    assert parse_marker_colour("#202020") == MarkerColour("#202020", -1.0, 0.0, 0.0)  # grey -> luma, dark
    assert parse_marker_colour("#f0f0f0").wy == 1.0  # pale -> luma, bright
    for bad in ("purple-ish", "#12345", "#GGGGGG", ""):
        with pytest.raises(ValueError):
            parse_marker_colour(bad)


def test_ycbcr_of_primaries():
    assert rgb_to_ycbcr(255, 255, 255) == pytest.approx((255, 128, 128), abs=1e-3)
    y, cb, cr = rgb_to_ycbcr(255, 0, 0)
    assert (y, cb, cr) == pytest.approx((76.245, 84.97, 255.5), abs=0.01)


# --- sub-pixel peak and matching -------------------------------------------------------------

def test_quadratic_peak_of_an_exact_quadric():
    dx, dy = 0.3, -0.2
    yy, xx = np.mgrid[-1:2, -1:2].astype(float)
    s = 1 - 0.5 * (xx - dx) ** 2 - 0.1 * (xx - dx) * (yy - dy) - 0.3 * (yy - dy) ** 2
    assert quadratic_peak(s) == pytest.approx((dx, dy), abs=1e-12)
    flat = np.ones((3, 3))
    assert quadratic_peak(flat) == (0.0, 0.0)


@pytest.mark.parametrize("cx, cy", [(30.0, 30.0), (30.37, 29.81), (31.5, 28.25)])
def test_match_template_finds_a_blob_to_a_few_hundredths_px(cx, cy):
    template = disc(31, 31, 15.0, 15.0, 8.0).astype(np.float32)
    window = disc(61, 61, cx, cy, 8.0).astype(np.float32) * 50 + 10  # brightness/contrast do not matter
    m = match_template(window, template)
    assert m.score > 0.95  # the template is sampled on another sub-pixel grid
    # quadric fit on a correlation peak of a sharp disc: bias below ~0.05 px
    assert (m.x, m.y) == pytest.approx((cx, cy), abs=0.05)
    assert match_template(window[:20, :20], template) is None


def test_weighted_centroid():
    win = disc(41, 41, 20.3, 19.6, 7.0).astype(np.float32) * 40 + 5
    c = weighted_centroid(win, 20.0, 20.0, 12.0, 5.0, 1.0)
    assert c == pytest.approx((20.3, 19.6), abs=0.02)  # 4x4 supersampled edge
    assert weighted_centroid(np.zeros((9, 9), np.float32), 4, 4, 3, 0, 0.5) is None


def test_fill_holes_fills_a_sticker_and_keeps_the_outline():
    from pendtrack.track.match import fill_holes

    ball = disc(41, 41, 20.3, 19.6, 9.0) * 40 + 5
    sticker = ball - 60 * disc(41, 41, 23.0, 17.0, 2.7)  # 0.3 radii, off centre: a dip below the wall
    filled = fill_holes(sticker.astype(np.float32), 0.8 * 9.0)
    # the dip is lifted to the ball's level (within the anti-aliased rim's 1/16 steps)
    assert np.abs(filled - ball)[disc(41, 41, 20.3, 19.6, 7.0) > 0].max() < 3.0
    # a plain ball passes unchanged (a convex blob)
    assert np.abs(fill_holes(ball.astype(np.float32), 7.2) - ball).max() < 1e-4
    below = sticker.astype(np.float32)
    assert fill_holes(below, 0.4) is below  # below 1 px: as is
    # with a level (half the ball's contrast over the wall), a dip on the wall stays as it is
    pit = sticker - 30 * disc(41, 41, 4.0, 4.0, 2.0)
    gated = fill_holes(pit.astype(np.float32), 7.2, level=5 + 20)
    assert np.abs(gated - ball)[disc(41, 41, 20.3, 19.6, 7.0) > 0].max() < 3.0
    np.testing.assert_array_equal(gated[:9, :9], pit.astype(np.float32)[:9, :9])


@pytest.mark.parametrize("radius", [0.4, 1.0, 2.0, 7.2])
def test_fill_holes_box_is_that_part_of_the_whole_result(radius):
    from pendtrack.track.match import fill_holes

    rng = np.random.default_rng(5)
    feature = (disc(37, 45, 20.3, 17.6, 9.0) * 40 + rng.normal(0, 3, (37, 45))).astype(np.float32)
    for level in (None, 20.0):
        whole = fill_holes(feature, radius, level=level)
        for box in (np.s_[0:37, 0:45], np.s_[6:31, 5:40], np.s_[0:12, 30:45], np.s_[20:37, 0:3]):
            np.testing.assert_array_equal(fill_holes(feature, radius, level=level, box=box), whole[box])


def test_filled_window_does_not_depend_on_where_the_window_ends():
    from pendtrack.track.templates import filled_window

    rng = np.random.default_rng(3)
    fr = yuv_frame(scene(120, 160, 80.0, 60.0, r=9.0, rng=rng))
    sampler = RawSampler(parse_marker_colour("pink"), width=160, height=120)
    big = filled_window(sampler, fr.y, fr.u, fr.v, 50, 30, 60, 60, 7.2, 40.0)
    small = filled_window(sampler, fr.y, fr.u, fr.v, 65, 45, 30, 30, 7.2, 40.0)
    np.testing.assert_array_equal(small, big[15:45, 15:45])


# --- detection -----------------------------------------------------------------------------

def test_find_marker_by_colour_and_not_when_absent():
    rng = np.random.default_rng(0)
    f = yuv_frame(scene(240, 320, 201.3, 77.6, 10.0, rng=rng))
    det = find_marker(f.y, f.u, f.v, parse_marker_colour("pink"))
    assert det is not None
    assert (det.x, det.y) == pytest.approx((201.3, 77.6), abs=0.1)
    assert det.radius == pytest.approx(10.0, abs=1.0) and det.contrast > 20
    empty = yuv_frame(scene(240, 320, None, None, rng=rng))
    assert find_marker(empty.y, empty.u, empty.v, parse_marker_colour("pink")) is None


def test_marker_in_roi_learns_a_dark_ball():
    rng = np.random.default_rng(1)
    f = yuv_frame(scene(120, 160, 80.4, 60.2, 8.0, colour=(40, 40, 40), wall=(200, 205, 210), rng=rng))
    det = marker_in_roi(f.y, f.u, f.v, (66, 46, 30, 30))
    assert det is not None and det.colour.wy < -0.9  # darker than the surroundings
    assert (det.x, det.y) == pytest.approx((80.4, 60.2), abs=0.1)
    assert marker_in_roi(f.y, f.u, f.v, (5, 5, 20, 20)) is None  # plain wall


# --- the tracker loop ----------------------------------------------------------------------

def swing(n, *, w=320, h=240, pivot=(160.0, 40.0), arm=150.0, amp=1.2, blur_frac=0.25, hide=(), jump=None,
          seed=0, r=9.0):
    """Frames of a pink spot on an arc (motion-blurred), and the true centres."""
    rng = np.random.default_rng(seed)
    frames, truth = [], []
    for i in range(n):
        th = amp * np.cos(2 * np.pi * i / 60)
        om = -amp * 2 * np.pi / 60 * np.sin(2 * np.pi * i / 60)  # rad/frame
        cx, cy = pivot[0] + arm * np.sin(th), pivot[1] + arm * np.cos(th)
        if jump is not None and i >= jump:
            cx, cy = cx + 60, cy - 20  # the marker jumps: prediction useless
        blur = (arm * np.cos(th) * om * blur_frac, -arm * np.sin(th) * om * blur_frac)
        visible = i not in hide
        img = scene(h, w, cx if visible else None, cy, r, rng=rng, blur=blur, nsub=6)
        frames.append(yuv_frame(img, i, i / 120))
        truth.append((cx, cy))
    return frames, np.array(truth)


def raw_sampler(w=320, h=240):
    return RawSampler(parse_marker_colour("pink"), width=w, height=h)


def test_tracks_a_blurred_swinging_spot_to_a_tenth_of_a_pixel():
    frames, truth = swing(90)
    res = track_frames(frames, sampler=raw_sampler(), params=TrackParams())
    assert res.ok.all() and (res.score > 0.9).all()
    err = np.hypot(res.x - truth[:, 0], res.y - truth[:, 1])
    # synthetic, uncompressed chroma: ~0.03 px rms; 0.1 px leaves room for 4:2:0 rounding
    assert np.sqrt(np.mean(err**2)) < 0.1 and err.max() < 0.25
    np.testing.assert_allclose(res.t, np.arange(90) / 120)
    assert res.searches["whole_frame"] == 0


@pytest.mark.parametrize("colour", ["pink", "dark", "#b4a0ff"])
def test_half_resolution_window_is_the_whole_half_feature_cut(colour):
    rng = np.random.default_rng(3)
    f = yuv_frame(scene(120, 160, 70.0, 50.0, 12.0, rng=rng))
    sam = RawSampler(parse_marker_colour(colour), width=160, height=120)
    whole = sam.whole_half(f.y, f.u, f.v)
    assert whole.shape == (sam.half_height, sam.half_width)
    # the same arithmetic on the same samples (2x2 luma blocks, chroma as is): equal to float32 rounding
    np.testing.assert_allclose(sam.window_half(f.y, f.u, f.v, 13, 7, 31, 22), whole[7:29, 13:44], atol=1e-4)


def test_a_large_marker_is_matched_at_half_resolution_as_well_as_at_full(monkeypatch):
    from pendtrack.track import templates

    frames, truth = swing(40, w=480, h=400, pivot=(240.0, 40.0), arm=280.0, amp=0.6, r=30.0)
    half = track_frames(frames, sampler=raw_sampler(480, 400), params=TrackParams())
    monkeypatch.setattr(templates, "HALF_RES_RADIUS_PX", np.inf)
    full = track_frames(frames, sampler=raw_sampler(480, 400), params=TrackParams())
    assert (half.match_scale, full.match_scale) == (2, 1)
    assert half.ok.all() and full.ok.all()
    rms = [np.sqrt(np.mean((r.x - truth[:, 0]) ** 2 + (r.y - truth[:, 1]) ** 2)) for r in (half, full)]
    # measured 0.084 px (half) and 0.080 px (full) rms, both from the motion blur and the lighting gradient:
    # the 30 px spot's broad score peak loses nothing on a 2 px grid (a wrong half-px offset would add 0.7 px)
    assert rms[0] < rms[1] + 0.02 and max(rms) < 0.15, rms


def test_hidden_marker_frames_are_not_ok_and_tracking_resumes():
    frames, truth = swing(60, hide=range(20, 30))
    res = track_frames(frames, sampler=raw_sampler(), params=TrackParams())
    hidden = np.zeros(60, bool)
    hidden[20:30] = True
    np.testing.assert_array_equal(res.ok, ~hidden)
    assert (res.score[hidden] < 0.6).all()
    err = np.hypot(res.x - truth[:, 0], res.y - truth[:, 1])[~hidden]
    assert err.max() < 0.25


def test_reacquires_after_a_jump_by_whole_frame_search():
    frames, truth = swing(40, jump=20)
    res = track_frames(frames, sampler=raw_sampler(), params=TrackParams(search_margin_px=10))
    assert res.ok[:20].all() and res.ok[21:].all()
    assert res.searches["whole_frame"] >= 1
    err = np.hypot(res.x - truth[:, 0], res.y - truth[:, 1])[res.ok]
    assert err.max() < 0.25


def test_evolution_rate_and_centroid_refinement_still_track():
    frames, truth = swing(40)
    for params in (TrackParams(evolution_rate=0.1), TrackParams(refine="centroid")):
        res = track_frames(frames, sampler=raw_sampler(), params=params)
        err = np.hypot(res.x - truth[:, 0], res.y - truth[:, 1])
        assert res.ok.all() and err.max() < 0.4


def test_corrected_sampler_tracks_in_corrected_coordinates():
    frames, truth = swing(30, amp=0.6)
    fe = Fisheye(width=320, height=240)
    res = track_frames(frames, sampler=CorrectedSampler(parse_marker_colour("pink"), fisheye=fe),
                       params=TrackParams())
    ex, ey = fe.undistort_points(truth[:, 0], truth[:, 1])
    # the synthetic spot is round in the raw frame, so its corrected image is slightly
    # egg-shaped: allow a few tenths of a pixel
    assert res.ok.all() and np.hypot(res.x - ex, res.y - ey).max() < 0.4


def test_warped_templates_are_computed_once_per_lens_jacobian():
    from pendtrack.track.templates import _Template, warp_template
    from pendtrack.track.tracker import MarkerTracker

    fe = Fisheye(width=320, height=240, projection="equidistant", fov_deg=150.0)
    sampler = WarpedRawSampler(parse_marker_colour("pink"), fisheye=fe)
    image = (disc(25, 25, 12.0, 12.0, 7.0) * 40).astype(np.float32)
    tracker = MarkerTracker(sampler, _Template(image, 7.0, 40.0), TrackParams())
    path = [(40.0 + 9.0 * k, 60.0 + 4.0 * k) for k in range(25)]
    first = [tracker._template_at(x, y) for x, y in path + path[::-1]]
    assert len(tracker._warps) < len(path)  # the swing back reuses the warps of the swing out
    for (img, std), (x, y) in zip(first, path + path[::-1]):
        if img is not image:
            assert std == pytest.approx(float(img.std()), rel=1e-5)
    np.testing.assert_array_equal(tracker._template_at(*path[-1])[0], warp_template(image, tracker._warp_jac))
    assert tracker._warp_jac in tracker._warps
    tracker._forget_warps()
    assert not tracker._warps and tracker._warp_key is None


def test_warped_template_in_raw_frames_matches_the_corrected_path():
    frames, truth = swing(30, amp=0.6)
    fe = Fisheye(width=320, height=240)
    pink = parse_marker_colour("pink")
    warped = track_frames(frames, sampler=WarpedRawSampler(pink, fisheye=fe), params=TrackParams())
    corrected = track_frames(frames, sampler=CorrectedSampler(pink, fisheye=fe), params=TrackParams())
    assert warped.ok.all() and corrected.ok.all()
    # raw path: tracks the raw blob (here a true disc in the raw frame) to a tenth of a pixel
    assert np.hypot(warped.x - truth[:, 0], warped.y - truth[:, 1]).max() < 0.15
    cx, cy = fe.undistort_points(warped.x, warped.y)
    assert np.hypot(cx - corrected.x, cy - corrected.y).max() < 0.4
    evolving = track_frames(frames, sampler=WarpedRawSampler(pink, fisheye=fe),
                            params=TrackParams(evolution_rate=0.2))
    assert evolving.ok.all() and np.hypot(evolving.x - truth[:, 0], evolving.y - truth[:, 1]).max() < 0.4


def lens_swing(n, *, fe, pivot, arm, amp, r=9.0, seed=0):
    """Frames of a pink disc swinging on an arc in corrected space, seen through the lens ``fe`` (round in
    corrected space, as a real marker through a real fisheye), and the true centres [corrected px]."""
    rng = np.random.default_rng(seed)
    gx, gy = np.meshgrid(np.arange(fe.width, dtype=float), np.arange(fe.height, dtype=float))
    cx, cy = fe.undistort_points(gx, gy)
    wall = np.array((150, 160, 165), float)
    frames, truth = [], []
    for i in range(n):
        th = amp * np.cos(2 * np.pi * i / 60)
        mx, my = pivot[0] + arm * np.sin(th), pivot[1] + arm * np.cos(th)
        cov = np.clip(r - np.hypot(cx - mx, cy - my) + 0.5, 0.0, 1.0)[..., None]
        img = wall * (1 - cov) + np.array(PINK, float) * cov + rng.normal(0, 2.0, (fe.height, fe.width, 3))
        frames.append(yuv_frame(np.clip(img, 0, 255).astype(np.uint8), i, i / 120))
        truth.append((mx, my))
    return frames, np.array(truth)


@pytest.mark.parametrize("amp", [0.9, 1.1])
def test_a_marker_whose_corrected_image_lies_past_the_frame_is_tracked_from_the_first_frame(amp):
    # A 16:9 frame under the paper's fisheye: the correction maps the raw frame's sides beyond the frame's
    # rectangle, here the marker's first position (raw x 294-302 of 320) to corrected x 317-338. Its template is
    # cut in corrected space from raw pixels that are all in view: tracked from frame 0 (it was acquired only
    # 5-8 frames later, once it had swung inwards; on a video of a ball held at the frame's side, a look-alike
    # was taken for it instead).
    fe = Fisheye(width=320, height=180)
    frames, truth = lens_swing(60, fe=fe, pivot=(160.0, -60.0), arm=200.0, amp=amp)
    assert truth[0, 0] + 9.0 > fe.width  # the marker's corrected disc reaches past the frame
    res = track_frames(frames, sampler=WarpedRawSampler(parse_marker_colour("pink"), fisheye=fe), params=TrackParams())
    assert res.acquisition["frame"] == 0 and res.ok.all()
    rx, ry = fe.distort_points(truth[:, 0], truth[:, 1])
    # the raw blob's centroid is off the image of the centre by the lens' second-order shift, largest at the
    # frame's side (0.31 px measured here), plus the 2-level noise's share
    assert np.hypot(res.x - rx, res.y - ry).max() < 0.5


def test_no_marker_and_no_frames_raise():
    rng = np.random.default_rng(0)
    frames = [yuv_frame(scene(120, 160, None, None, rng=rng))]
    with pytest.raises(TrackingError, match="no pink marker found in the first frame"):
        track_frames(frames, sampler=raw_sampler(160, 120), params=TrackParams())
    with pytest.raises(TrackingError, match="no frames"):
        track_frames([], sampler=raw_sampler(), params=TrackParams())
    with pytest.raises(TrackingError, match="roi"):
        track_frames(frames, sampler=raw_sampler(160, 120), params=TrackParams(), roi=(1, 2, 3))


def test_bad_params():
    for kw in ({"min_score": 2.0}, {"search_margin_px": 0}, {"evolution_rate": 1.0}, {"refine": "magic"}):
        with pytest.raises(ValueError):
            TrackParams(**kw)


def test_median_of_is_numpys_median():
    rng = np.random.default_rng(0)
    for n in (1, 2, 3, 4, 5, 88, 89, 1000):
        for a in (rng.normal(size=n).astype(np.float32), rng.integers(0, 4, n).astype(np.float32),
                  rng.normal(size=(n, 3))):
            assert median_of(a) == float(np.median(a))


def test_percentile_of_is_numpys_percentile():
    rng = np.random.default_rng(0)
    for n in (*range(1, 40), 88, 89, 200, 201, 1000, 4321):
        for a in (rng.normal(size=n).astype(np.float32), rng.integers(0, 4, n).astype(np.float32),
                  rng.normal(size=(n, 3))):
            for q in (0.0, 0.5, 50.0, 90.0, 99.0, 99.5, 100.0):
                assert percentile_of(a, q) == float(np.percentile(a, q)), (n, a.dtype, q)


def test_level_step_keeps_every_pixel_of_small_frames_and_20000_of_large_ones():
    assert level_step(64 * 48) == 1 and level_step(39_999) == 1
    for h, w in ((360, 640), (540, 960), (1080, 1920)):  # half-resolution grids of 720p, 1080p and 4K
        s = level_step(h * w)
        assert s > 1 and len(range(0, h, s)) * len(range(0, w, s)) >= 20_000


def test_chroma_feature_of_a_window_is_that_part_of_the_whole_planes():
    # OpenCV 5.1's addWeighted rounds a pixel differently in its vector loop and in a row's tail: a window's
    # feature then depended on where the window ended (1e-5), and the filled template and search windows disagreed
    from pendtrack.track.colour import chroma_feature

    rng = np.random.default_rng(11)
    u = rng.integers(0, 256, (60, 97), dtype=np.uint8)
    v = rng.integers(0, 256, (60, 97), dtype=np.uint8)
    colour = parse_marker_colour("pink")
    whole = chroma_feature(u, v, colour)
    assert whole.dtype == np.float32
    expected = (colour.wu * (u.astype(np.float64) - 128) + colour.wv * (v.astype(np.float64) - 128)).astype(np.float32)
    np.testing.assert_array_equal(whole, expected)
    for x0, y0, w, h in ((0, 0, 97, 60), (3, 5, 29, 17), (17, 2, 64, 40), (40, 30, 57, 30), (1, 1, 7, 3)):
        np.testing.assert_array_equal(chroma_feature(u[y0:y0 + h, x0:x0 + w], v[y0:y0 + h, x0:x0 + w], colour),
                                      whole[y0:y0 + h, x0:x0 + w])
