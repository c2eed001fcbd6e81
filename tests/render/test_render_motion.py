"""Raster kernel vs its Python twin; motion sampling, blur density, model parameters, run codes."""

from __future__ import annotations

import numpy as np
import pytest

from pendtrack.apparatus import two_cuboid_omega0
from pendtrack.config import RenderConfig
from pendtrack.errors import ConfigError, ModelError
from pendtrack.render import plan_render
from pendtrack.render.motion import run_code, sample_motion, subsample_counts
from pendtrack.render.physics import DEFAULT_PARAMS, parse_params, resolve_params
from pendtrack.render.raster import _raster_nb, _raster_py
from pendtrack.render.scene import Scene


@pytest.mark.parametrize("thetas, centre", [
    (np.array([0.30]), "spot"),
    (np.linspace(0.28, 0.31, 4), "spot"),
    (np.linspace(-1.00, -1.02, 3), "axle"),
])
def test_raster_kernel_matches_python_twin(thetas, centre):
    scene = Scene(width=320, height=180, tile_length_m=0.12)
    xw, yw, size = scene.pixel_world_maps()
    rng = np.random.default_rng(1)
    light = rng.uniform(100, 255, (180, 320, 1)).astype(np.float32)
    back = rng.uniform(0, 255, (180, 320, 3)).astype(np.float32)
    u, v = scene.spot_centre_px(thetas[0]) if centre == "spot" else scene.axle_px
    x0, y0 = int(u) - 12, int(v) - 12
    outs = []
    for kernel in (_raster_py, _raster_nb):
        bgr = np.full((25, 25, 3), np.nan, np.float32)
        alpha = np.full((25, 25), np.nan, np.float32)
        kernel(xw, yw, size, light, back, x0, y0, np.sin(thetas), np.cos(thetas), scene.parts(), bgr, alpha)
        outs.append((bgr, alpha))
    (b_py, a_py), (b_nb, a_nb) = outs
    assert np.isfinite(b_py).all() and 0.05 < a_py.mean() < 0.95  # the box holds edges
    # float32 outputs from float64 arithmetic: the two agree to float32 rounding
    np.testing.assert_allclose(b_nb, b_py, rtol=0, atol=1e-3)
    np.testing.assert_allclose(a_nb, a_py, rtol=0, atol=1e-6)


def test_subsample_counts():
    counts = subsample_counts(np.array([0.0, 1.0, 10.0, 1e6]), exposure_s=1 / 480, px_per_rad=330.0, step_px=0.4)
    assert counts[0] == 1 and counts[1] == 3 and counts[2] == 22 and counts[3] == 64
    assert (subsample_counts(np.array([10.0]), exposure_s=0.0, px_per_rad=330.0, step_px=0.4) == 1).all()


def test_sample_motion_with_an_exact_simulator():
    # uniform rotation: theta = 1 + 2 t; every sub-sample must be on it
    def uniform(t):
        return 1.0 + 2.0 * t, np.full_like(t, 2.0)

    m = sample_motion(uniform, n_frames=5, fps=100.0, exposure_s=0.004, theta0=1.0, omega0=2.0,
                      px_per_rad=1000.0, step_px=1.0)
    np.testing.assert_allclose(m.t, np.arange(5) / 100.0)
    np.testing.assert_allclose(m.theta, 1.0 + 2.0 * m.t)
    for k in range(5):
        th = m.frame_thetas(k)
        assert th.size == 10  # ceil(1.25 * 2 * 0.004 * 1000 / 1)
        np.testing.assert_allclose(th.mean(), m.theta[k], atol=1e-12)  # centred on mid-exposure
        np.testing.assert_allclose(np.ptp(th), 2.0 * 0.004 * (1 - 1 / 10), atol=1e-12)


def test_blur_subsamples_move_the_spot_less_than_half_a_pixel():
    cfg = RenderConfig(seconds=1.2, theta0=3.1, omega0=-1.0)  # passes the bottom fast
    plan = plan_render(cfg)
    scene = plan.scene
    worst = 0.0
    for k in range(plan.n_frames):
        u, v = scene.spot_centre_px(plan.motion.frame_thetas(k))
        if u.size > 1:
            worst = max(worst, float(np.hypot(np.diff(u), np.diff(v)).max()))
    assert worst < 0.5
    u, v = scene.spot_centre_px(plan.motion.theta)
    assert np.hypot(np.diff(u), np.diff(v)).max() > 15  # it does move fast near the bottom


def test_truth_starts_at_initial_conditions():
    plan = plan_render(RenderConfig(seconds=0.5, theta0=2.0, omega0=-1.5))
    assert plan.motion.t[0] == 0.0 and plan.motion.theta[0] == 2.0 and plan.motion.omega[0] == -1.5
    assert np.diff(plan.motion.t) == pytest.approx(1 / 120)


@pytest.mark.parametrize("model", ["opa", "classic", "inertial"])
def test_other_models_drive_the_pendulum(model):
    plan = plan_render(RenderConfig(seconds=0.3, model=model, theta0=1.0))
    assert plan.model == model and np.isfinite(plan.motion.theta).all() and plan.motion.theta[-1] < 1.0


@pytest.mark.slow  # the first call compiles the models' numba predictor-corrector (~20 s cold)
def test_model_with_memory_renders_truth():
    plan = plan_render(RenderConfig(seconds=0.5, model="fractional", theta0=1.0))
    assert np.isfinite(plan.motion.theta).all() and plan.motion.theta[-1] < 1.0
    # frame times lie on the integration grid, sub-samples are interpolated between them
    counts = np.diff(plan.motion.sub_start)
    assert counts.max() > 1


def test_parse_params():
    assert parse_params(["C0=0.02", " Omega0 = 5 "]) == {"C0": 0.02, "Omega0": 5.0}
    for bad in (["C0"], ["=1"], ["C0=abc"], ["C0=1", "C0=2"]):
        with pytest.raises(ConfigError):
            parse_params(bad)


def test_omega0_defaults_to_the_two_cuboid_formula_and_explicit_wins():
    kw = dict(x=1.48, l0_m=0.54, gravity=9.81)
    _, p = resolve_params("standard", {}, tile_length_m=0.06, **kw)
    assert p["Omega0"] == pytest.approx(float(two_cuboid_omega0(0.06, x=1.48, l0=0.54, g=9.81)))
    assert p["C0"] > 0 and p["C1"] > 0 and p["C2"] > 0
    _, p = resolve_params("standard", {"Omega0": 4.0, "C2": 0.0}, tile_length_m=0.06, **kw)
    assert p["Omega0"] == 4.0 and p["C2"] == 0.0


def test_composed_model_gets_baseline_and_term_defaults():
    model, p = resolve_params("standard+memory", {"G2": 0.01}, tile_length_m=0.0, x=1.48, l0_m=0.54, gravity=9.81)
    assert model.name == "standard+memory"
    assert set(p) == set(model.param_names)
    assert p["C1"] == DEFAULT_PARAMS["standard"]["C1"] and p["beta"] == DEFAULT_PARAMS["fractional"]["beta"]
    assert p["G2"] == 0.01


@pytest.mark.parametrize("model, given, fragment", [
    ("nope", {}, "unknown model 'nope'"),
    ("standard+magic", {}, "unknown term 'magic'"),
    ("standard+viscous", {}, "already in model 'standard'"),
    ("standard", {"G1": 1.0}, "no parameter 'G1'"),
    ("standard", {"C0": -1.0}, "'C0'"),
])
def test_bad_model_or_parameter(model, given, fragment):
    with pytest.raises(ModelError, match=fragment):
        resolve_params(model, given, tile_length_m=0.0, x=1.48, l0_m=0.54, gravity=9.81)


def test_run_code():
    assert run_code(tile_length_m=0.06, omega0=0.0, alley=True, trial=1) == "06na1"
    assert run_code(tile_length_m=0.24, omega0=-2.0, alley=True, trial=3) == "24la3"
    assert run_code(tile_length_m=0.0, omega0=-1.0, alley=False, trial=1) == "00ln1"
    assert run_code(tile_length_m=0.045, omega0=0.0, alley=False, trial=1) is None
