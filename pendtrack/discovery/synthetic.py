"""Synthetic runs with a hidden effect, for tests and benchmarks of discovery.

A run is the ``standard`` model (gravity, Coulomb, viscous and quadratic drag, damping in
realistic ranges) released near the top, plus at most one hidden effect of realistic size,
simulated with :func:`pendtrack.models.simulate` and observed with seeded white noise. The
tool under test receives only ``t`` and ``theta``.

Effect sizes: ``Ca`` in [0.01, 0.03] (the paper's classic fits); memory with ``beta`` in
[0.3, 0.7]; time-varying damping with ``C4`` and ``t0`` around the paper's OPA fit
(C4 = 3.25, t0 = -8.85 s) scaled down. Memory and time-varying damping are redrawn until a
fit of the standard model leaves a residual RMS at least 20 % above the noise
(:data:`MIN_EXCESS`): an effect the baseline can absorb is not a hidden effect.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

HIDDEN_EFFECTS = ("added_mass", "time_varying_damping", "memory")
MIN_EXCESS = 1.2  # the standard fit's residual RMS must exceed the noise by this factor
RATE_HZ = 120.0


@dataclass(frozen=True, eq=False)
class SyntheticRun:
    """A simulated record.

    Attributes
    ----------
    t, theta : ndarray
        Times [s] and noisy angle [rad] (what the tool gets).
    effect : str or None
        The hidden effect (None for a control).
    params : dict
        True parameters of ``standard`` (+ effect).
    theta0 : float
        Release angle [rad].
    noise : float
        Noise standard deviation [rad].
    excess : float
        Standard-fit residual RMS over the noise (NaN if not checked).
    draws : int
        Draws needed to satisfy the size condition.
    """

    t: np.ndarray
    theta: np.ndarray
    effect: str | None
    params: dict[str, float] = field(default_factory=dict)
    theta0: float = 0.0
    noise: float = 0.0
    excess: float = float("nan")
    draws: int = 1


def _draw_params(rng: np.random.Generator, effect: str | None) -> dict[str, float]:
    p = {"Omega0": rng.uniform(5.0, 6.5), "C1": rng.uniform(0.01, 0.03), "C0": rng.uniform(0.005, 0.02),
         "C2": rng.uniform(0.002, 0.006)}
    if effect == "added_mass":
        p["Ca"] = rng.uniform(0.01, 0.03)
    elif effect == "time_varying_damping":
        p["C4"] = rng.uniform(0.3, 1.5)
        p["t0"] = -rng.uniform(3.0, 12.0)
    elif effect == "memory":
        p["beta"] = rng.uniform(0.3, 0.7)
        p["p_f"] = rng.uniform(1.0, 2.0)
        p["G2"] = math.exp(rng.uniform(math.log(2e-3), math.log(1.5e-2)))
    return p


def simulate_run(params: dict[str, float], effect: str | None, *, duration: float, theta0: float, noise: float,
                 rng: np.random.Generator, rate_hz: float = RATE_HZ) -> tuple[np.ndarray, np.ndarray]:
    """``standard`` (+ effect) from rest at ``theta0``, sampled at ``rate_hz``, plus white noise.

    Returns
    -------
    t, theta : ndarray
        [s], [rad].
    """
    from pendtrack.models import compose, get_model, simulate

    model = compose("standard", [effect]) if effect else get_model("standard")
    t = np.arange(int(round(duration * rate_hz))) / rate_hz
    sim = simulate(model, params, t, theta0=theta0, omega0=0.0)
    return t, np.asarray(sim.theta) + rng.normal(0.0, noise, t.size)


def standard_excess(t: np.ndarray, theta: np.ndarray, noise: float) -> float:
    """Residual RMS of a whole-record output-error fit of ``standard``, over the noise [1]."""
    from pendtrack.config import Config
    from pendtrack.discovery.data import prepare
    from pendtrack.discovery.inputs import AngleSeries
    from pendtrack.discovery.selection import FitTask, fit_pair

    cfg = Config()
    data = prepare(AngleSeries(t, theta, source="synthetic", kind="table"),  # type: ignore[arg-type]
                   analysis_rate_hz=cfg.discover.analysis_rate_hz, train_fraction=cfg.discover.train_fraction,
                   savgol_window_s=cfg.kinematics.savgol_window_s, savgol_order=cfg.kinematics.savgol_order)
    pair = fit_pair(FitTask(data, "standard", (), None, 2, 0, cfg.fit.cost, cfg.models.memory_s, workers=1))
    if pair.full is None:
        return float("inf")
    r = data.theta - pair.trajectory
    return float(np.sqrt(np.mean(r * r)) / noise)


def draw_run(seed: int, effect: str | None, *, check_size: bool = True, max_draws: int = 20) -> SyntheticRun:
    """A synthetic run carrying ``effect`` (or none), drawn from ``seed``.

    Parameters
    ----------
    seed : int
        Everything (duration, release, noise, parameters) is drawn from it.
    effect : str or None
        One of :data:`HIDDEN_EFFECTS`, or None for a control.
    check_size : bool
        For memory and time-varying damping: redraw the effect's parameters until a
        standard fit's residual RMS exceeds the noise by :data:`MIN_EXCESS`.
    max_draws : int
        Give up (``RuntimeError``) after this many draws.
    """
    if effect is not None and effect not in HIDDEN_EFFECTS:
        raise ValueError(f"unknown hidden effect {effect!r}")
    rng = np.random.default_rng(seed)
    duration = rng.uniform(60.0, 90.0)
    theta0 = rng.uniform(2.6, 3.0)
    noise = rng.uniform(0.002, 0.004)
    for draw in range(1, max_draws + 1):
        params = _draw_params(rng, effect)
        t, theta = simulate_run(params, effect, duration=duration, theta0=theta0, noise=noise, rng=rng)
        excess = float("nan")
        if check_size and effect in ("memory", "time_varying_damping"):
            excess = standard_excess(t, theta, noise)
            if excess < MIN_EXCESS:
                continue
        return SyntheticRun(t, theta, effect, params, theta0, noise, excess, draw)
    raise RuntimeError(f"no {effect} run of detectable size in {max_draws} draws (seed {seed})")
