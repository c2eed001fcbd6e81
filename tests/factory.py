"""Synthetic records for the tests, drawn in one place (in the style of ``trackpy.artificial``).

Every test that needs a record imports it from here:

* :func:`swing` -- a model simulated from known values, sampled like a camera, with seeded
  Gaussian tracking noise: ``(t, theta)``;
* :func:`filtered` -- the pipeline's Savitzky-Golay filter on such a record, and the
  :class:`~pendtrack.fitting.Observation` a fit needs to filter the model alike;
* :func:`synthetic_problem` -- a fit problem on a filtered record, and a point near its truth;
* :func:`angle_file` -- a record written as the angle stage writes it (``angle.parquet``);
* videos with their truth: :func:`write_swing_video` (a small synthetic swing, no renderer;
  the committed ones are in :data:`TEST_DATA`), :func:`field_video` (field conditions painted
  over the renderer's frames), :func:`lens_video` (a chosen camera lens), :func:`render_condition`
  and :func:`run_and_score` (``pendtrack run`` on the field conditions of issue 15, its targets
  :data:`OK_MIN`, :data:`THETA_RMS_MAX`, :data:`OMEGA0_REL_MAX`);
* closed-form and reference solutions: :func:`damped_linear`, :func:`inertial_speed`,
  :func:`mittag_leffler`, :func:`solve_gl_fde`.

The same arguments give the same arrays, bit for bit (fixed seeds, no clock).
"""

from __future__ import annotations

import importlib.util
from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np
import pandas as pd

from field_run import (CONDITIONS, OK_MIN, OMEGA0_REL_MAX, THETA_RMS_MAX, Score, flags_for, render_condition,
                       run_and_score)
from field_videos import FieldVideo, field_video
from lens_videos import lens_video
from pendtrack.artifacts import Provenance, write_artifact
from pendtrack.fitting import Observation, build_problem
from pendtrack.kinematics import savgol_kinematics
from pendtrack.models import Model, get_model, simulate
from reference_solutions import damped_linear, inertial_speed, mittag_leffler, solve_gl_fde

__all__ = ["CONDITIONS", "FS", "OK_MIN", "OMEGA0_REL_MAX", "TEST_DATA", "THETA_RMS_MAX", "FieldVideo", "Score",
           "angle_file", "damped_linear", "field_video", "filtered", "flags_for", "inertial_speed", "lens_video",
           "mittag_leffler", "render_condition", "run_and_score", "solve_gl_fde", "swing", "synthetic_problem",
           "write_swing_video"]

FS = 120.0  # [Hz], the paper's frame rate
PAPER_WINDOW = 25  # [frames], the paper's Savitzky-Golay window
TEST_DATA = Path(__file__).resolve().parent / "data"  # the committed test videos, their truth and their script


def _test_videos_script():
    """``data/make_test_videos.py`` as a module (a script beside the files it wrote, not a package)."""
    spec = importlib.util.spec_from_file_location("make_test_videos", TEST_DATA / "make_test_videos.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


write_swing_video = _test_videos_script().write_swing_video


def swing(model: Model | str, params: Mapping[str, float], *, seconds: float, theta0: float, fps: float = FS,
          omega0: float = 0.0, noise: float = 0.0, seed: int = 0,
          measured: Callable[[np.ndarray], np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """A swing of ``model`` as a camera records it: ``t = k / fps`` and ``measured(theta) + noise``.

    Parameters
    ----------
    model : Model or str
        The pendulum's model (a registered or composed name).
    params : mapping of str to float
        Its parameters.
    seconds : float
        Record length [s]: ``int(seconds * fps)`` samples from ``t = 0``.
    theta0, omega0 : float
        Initial angle [rad] and angular speed [rad/s].
    fps : float
        Sample rate [Hz].
    noise : float
        Standard deviation of the white Gaussian tracking noise [rad] (0: none).
    seed : int
        Seed of the noise (``numpy.random.default_rng``).
    measured : callable, optional
        The measurement applied to the true angle before the noise (e.g. a camera's zero).

    Returns
    -------
    t, theta : ndarray
        Sample times [s] and measured angles [rad].
    """
    t = np.arange(int(seconds * fps)) / fps
    theta = simulate(get_model(model) if isinstance(model, str) else model, params, t, theta0=theta0,
                     omega0=omega0).theta
    if measured is not None:
        theta = measured(theta)
    if noise:
        theta = theta + np.random.default_rng(seed).normal(0.0, noise, t.size)
    return t, theta


def filtered(t: np.ndarray, theta: np.ndarray, *, fps: float = FS, window_frames: int = PAPER_WINDOW,
             order: int = 3):
    """The pipeline's Savitzky-Golay kinematics of ``(t, theta)`` and the fit's matching observation.

    Parameters
    ----------
    t, theta : ndarray
        Sample times [s] and angles [rad].
    fps : float
        The record's sample rate [Hz].
    window_frames : int
        Filter window [samples at ``fps``] (the paper's 25 by default).
    order : int
        Polynomial order.

    Returns
    -------
    kin : KinematicsResult
        ``t``, ``theta``, ``omega``, ``alpha``, ``ok`` and ``info``.
    observation : Observation
        The filter, for :func:`pendtrack.fitting.fit_model`.
    """
    kin = savgol_kinematics(t, theta, window_s=window_frames / fps, order=order)
    obs = Observation(savgol_window=int(kin.info["window_points"]), savgol_order=int(kin.info["order"]))
    return kin, obs


def synthetic_problem(name: str, truth: Mapping[str, float], seconds: float = 10.0, *, cost: str = "xi2",
                      seed: int = 0):
    """A FitProblem on a noisy (3 mrad), Savitzky-Golay-filtered record of model ``name`` released
    from 2.8 rad at rest, and a generic point: 1 % off ``truth`` on every parameter, with some speed."""
    m = get_model(name)
    phys = {k: v for k, v in truth.items() if k in m.physics().param_names}
    t, theta = swing(m.physics(), phys, seconds=seconds, theta0=2.8, noise=3e-3, seed=seed,
                     measured=lambda th: m.observe(th, truth))
    kin, obs = filtered(t, theta)
    prob = build_problem(m, kin.t, kin.theta, kin.omega, ok=kin.ok, omega0_hat=truth["Omega0"], observation=obs,
                         cost=cost, jacobian_method="sensitivity")
    x = np.array([truth[n] * 1.01 for n in m.param_names] + [2.79, 0.05])
    return prob, x


def angle_file(path: Path, t: np.ndarray, theta: np.ndarray, ok: np.ndarray | None = None) -> Path:
    """Write ``(t, theta, ok)`` as an angle artifact (all ok unless ``ok`` says otherwise); returns ``path``."""
    ok = np.ones(t.size, bool) if ok is None else ok
    write_artifact(pd.DataFrame({"t": t, "theta": theta, "ok": ok}), path, "angle",
                   provenance=Provenance(stage="test"))
    return Path(path)
