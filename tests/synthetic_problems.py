"""Fit problems on synthetic records: a model simulated from known values, noise, the pipeline's filter."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from pendtrack.fitting import Observation, build_problem
from pendtrack.kinematics import savgol_kinematics
from pendtrack.models import get_model, simulate

FS = 120.0  # [Hz]


def synthetic_problem(name: str, truth: Mapping[str, float], seconds: float = 10.0, *, cost: str = "xi2",
                      seed: int = 0):
    """A FitProblem on a noisy (3 mrad), Savitzky-Golay-filtered record of model ``name`` released
    from 2.8 rad at rest, and a generic point: 1 % off ``truth`` on every parameter, with some speed."""
    m = get_model(name)
    t = np.arange(int(seconds * FS)) / FS
    phys = {k: v for k, v in truth.items() if k in m.physics().param_names}
    sim = simulate(m.physics(), phys, t, theta0=2.8, omega0=0.0)
    theta = m.observe(sim.theta, truth) + np.random.default_rng(seed).normal(0.0, 3e-3, t.size)
    kin = savgol_kinematics(t, theta, window_s=25 / FS, order=3)
    obs = Observation(savgol_window=int(kin.info["window_points"]), savgol_order=3)
    prob = build_problem(m, kin.t, kin.theta, kin.omega, ok=kin.ok, omega0_hat=truth["Omega0"], observation=obs,
                         cost=cost, jacobian_method="sensitivity")
    x = np.array([truth[n] * 1.01 for n in m.param_names] + [2.79, 0.05])
    return prob, x
