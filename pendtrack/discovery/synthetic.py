"""Synthetic runs with a hidden effect, for tests and benchmarks of discovery.

A run is the ``standard`` model (gravity, Coulomb, viscous and quadratic drag, damping in
realistic ranges) released near the top, plus none, one or two hidden effects of realistic
size, simulated with :func:`pendtrack.models.simulate`, observed through at most one
measurement artefact (theta's zero offset by 5-15 mrad, or an angle scale wrong by 5-15 % at
2.5 rad) and seeded white noise. The tool under test receives only ``t`` and ``theta``.

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
#: Every pair of hidden effects (a run may carry two).
HIDDEN_PAIRS = tuple((a, b) for i, a in enumerate(HIDDEN_EFFECTS) for b in HIDDEN_EFFECTS[i + 1:])
#: Measurement artefacts a clean run may carry (terms of :data:`pendtrack.models.MEASUREMENT_TERMS`).
ARTEFACTS = ("offset", "angle_scale")
MIN_EXCESS = 1.2  # the standard fit's residual RMS must exceed the noise by this factor
RATE_HZ = 120.0
OFFSET_MRAD = (5.0, 15.0)  # |theta_off| of an offset run [mrad]: a vertical misjudged by 0.3-0.9 degrees
SCALE_ERROR = (0.05, 0.15)  # |k_scale| (2.5 rad)^2 of an angle-scale run: theta wrong by 5-15 % at 2.5 rad
SCALE_AT = 2.5  # [rad]
SCALE_RELEASE = 2.6  # largest release of an angle-scale run [rad]
SIZE_CHECKED = ("memory", "time_varying_damping")  # effects redrawn until a standard fit cannot absorb them
#: Physics outside the catalogue, for controls: no catalogue effect is its cause.
#:
#: * ``drifting_omega0``: the natural frequency drifts linearly in time, as from a string that stretches;
#: * ``weak_drive``: a weak periodic torque off the pendulum's frequency, as from a shaking support;
#: * ``changing_length``: the length changes linearly in time (wound in or paid out), with the
#:   Coriolis-like term ``-2 (l'/l) dtheta/dt`` a varying length brings besides the frequency change.
OUTSIDE = ("drifting_omega0", "weak_drive", "changing_length")
OMEGA0_DRIFT = (-0.0048, -0.0024)  # relative change of Omega0 over DRIFT_SPAN_S: -0.24 to -0.48 % [1]
DRIFT_SPAN_S = 60.0  # [s]
# the drive's torque as the angle it would hold statically, A in Omega0^2 A sin(w_d t + phi): 3-6 mrad, whose
# forced response off resonance (w_d = 1.3-1.7 Omega0: |1 - (w_d/Omega0)^2|^-1 = 0.5-1.5) is 1.5-9 mrad,
# against 3-5 mrad noise: above it over a record, no visible feature of any one swing (2-4 mrad left a
# standard fit's residual within 6 % of the noise in 2 of 3 draws)
DRIVE_MRAD = (3.0, 6.0)  # [mrad]
DRIVE_RATIO = (1.3, 1.7)  # w_d / Omega0 [1]
LENGTH_CHANGE = (0.005, 0.01)  # |relative change of the length| over DRIFT_SPAN_S, either sign: 0.5-1 % [1]


@dataclass(frozen=True, eq=False)
class SyntheticRun:
    """A simulated record.

    Attributes
    ----------
    t, theta : ndarray
        Times [s] and noisy angle [rad] (what the tool gets).
    effect : str or None
        The (first) hidden effect (None for a control).
    params : dict
        True parameters of ``standard`` (+ effects, + measurement term).
    theta0 : float
        Release angle [rad].
    noise : float
        Noise standard deviation [rad].
    excess : float
        Standard-fit residual RMS over the noise (NaN if not checked).
    draws : int
        Draws needed to satisfy the size condition.
    effects : tuple of str
        Every hidden effect (one or two; empty for a control).
    measurement : str or None
        The measurement artefact the observation carries (``offset``, ``angle_scale``) or None.
    rate_hz : float
        Sampling rate [1/s].
    outside : str or None
        Physics outside the catalogue the run carries (:data:`OUTSIDE`), or None.
    """

    t: np.ndarray
    theta: np.ndarray
    effect: str | None
    params: dict[str, float] = field(default_factory=dict)
    theta0: float = 0.0
    noise: float = 0.0
    excess: float = float("nan")
    draws: int = 1
    effects: tuple[str, ...] = ()
    measurement: str | None = None
    rate_hz: float = RATE_HZ
    outside: str | None = None


#: The effect sizes a field trial used (a simulator written outside the project): added mass Ca
#: 0.018-0.03; time-varying damping C4 1.5-3 with t0 5-10 s before the release; memory G2
#: 0.003-0.004, beta 0.3-0.7, p_f 1.3-1.8. Narrower than the default draws and, for the
#: time-varying damping, stronger.
FIELD_SIZES = {"Ca": (0.018, 0.03), "C4": (1.5, 3.0), "t0": (-10.0, -5.0), "G2": (0.003, 0.004),
               "beta": (0.3, 0.7), "p_f": (1.3, 1.8)}
SIZES = ("catalogue", "field")  # draw_run's effect sizes: the default ranges (module docstring), FIELD_SIZES


def _draw_params(rng: np.random.Generator, effect: str | None | tuple[str, ...],
                 sizes: str = "catalogue") -> dict[str, float]:
    p = {"Omega0": rng.uniform(5.0, 6.5), "C1": rng.uniform(0.01, 0.03), "C0": rng.uniform(0.005, 0.02),
         "C2": rng.uniform(0.002, 0.006)}
    for e in _as_tuple(effect):
        p.update(_draw_field_effect(rng, e) if sizes == "field" else _draw_effect(rng, e))
    return p


def _draw_field_effect(rng: np.random.Generator, effect: str) -> dict[str, float]:
    names = {"added_mass": ("Ca",), "time_varying_damping": ("C4", "t0"), "memory": ("beta", "p_f", "G2")}
    return {n: rng.uniform(*FIELD_SIZES[n]) for n in names.get(effect, ())}


def _draw_effect(rng: np.random.Generator, effect: str) -> dict[str, float]:
    if effect == "added_mass":
        return {"Ca": rng.uniform(0.01, 0.03)}
    if effect == "time_varying_damping":
        return {"C4": rng.uniform(0.3, 1.5), "t0": -rng.uniform(3.0, 12.0)}
    if effect == "memory":
        return {"beta": rng.uniform(0.3, 0.7), "p_f": rng.uniform(1.0, 2.0),
                "G2": math.exp(rng.uniform(math.log(2e-3), math.log(1.5e-2)))}
    return {}


def _draw_artefact(rng: np.random.Generator, artefact: str | None) -> dict[str, float]:
    if artefact is None:
        return {}  # no draw: the runs without an artefact keep the random stream they always had
    sign = 1.0 if rng.uniform() < 0.5 else -1.0
    if artefact == "offset":
        return {"theta_off": sign * 1e-3 * rng.uniform(*OFFSET_MRAD)}
    if artefact == "angle_scale":
        return {"k_scale": sign * rng.uniform(*SCALE_ERROR) / SCALE_AT**2}
    return {}


def _as_tuple(effect: str | None | tuple[str, ...] | list[str]) -> tuple[str, ...]:
    if effect is None:
        return ()
    return (effect,) if isinstance(effect, str) else tuple(effect)


def simulate_run(params: dict[str, float], effect: str | None | tuple[str, ...], *, duration: float, theta0: float,
                 noise: float, rng: np.random.Generator, rate_hz: float = RATE_HZ,
                 measurement: str | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``standard`` (+ effects) from rest at ``theta0``, sampled at ``rate_hz``, observed through the
    measurement term (if any), plus white noise.

    Returns
    -------
    t, theta : ndarray
        [s], [rad].
    """
    from pendtrack.models import compose, get_model, simulate

    effects = _as_tuple(effect)
    model = compose("standard", list(effects)) if effects else get_model("standard")
    t = np.arange(int(round(duration * rate_hz))) / rate_hz
    physical = {k: v for k, v in params.items() if k in model.param_names}
    sim = simulate(model, physical, t, theta0=theta0, omega0=0.0)
    theta = np.asarray(sim.theta)
    if measurement:
        seen = compose(model, [measurement])
        theta = np.asarray(seen.observe(theta, {**physical, **{k: params[k] for k in seen.param_names
                                                               if k not in physical}}))
    return t, theta + rng.normal(0.0, noise, t.size)

RK4_STEP_S = 1.0 / 240.0  # the outside runs' RK4 step [s]: 25 urad from a 4x finer step on 60 s (noise 2-5 mrad)


def outside_acceleration(outside: str, params: dict[str, float]):
    """The angular acceleration [rad/s^2] that ``outside`` adds to ``standard``'s, as ``f(t, theta, omega)``.

    ``params`` holds ``Omega0`` [rad/s] and the outside physics' own parameters:

    * ``drifting_omega0``: ``omega0_drift``, the relative change of Omega0 over :data:`DRIFT_SPAN_S`;
      gravity's term ``-Omega0(t)^2 sin theta`` follows ``Omega0(t) = Omega0 (1 + drift t / span)``.
    * ``weak_drive``: ``drive_rad`` [rad], ``drive_ratio`` [1], ``drive_phase`` [rad]: the torque
      ``Omega0^2 drive_rad sin(drive_ratio Omega0 t + drive_phase)``.
    * ``changing_length``: ``length_change``, the relative change of the length over the span:
      ``l(t) = l (1 + change t / span)``, so gravity's term scales with ``l / l(t)`` and a term
      ``-2 (l'/l(t)) omega`` appears (a simple pendulum's angular momentum ``m l^2 omega`` changes
      only by gravity's torque and the damping).
    """
    w0 = float(params["Omega0"])
    if outside == "drifting_omega0":
        drift = float(params["omega0_drift"])

        def extra(time: float, th: float, om: float) -> float:
            w = w0 * (1.0 + drift * time / DRIFT_SPAN_S)
            return (w0 * w0 - w * w) * math.sin(th)
        return extra
    if outside == "weak_drive":
        amp, wd, phase = float(params["drive_rad"]), float(params["drive_ratio"]) * w0, float(params["drive_phase"])

        def extra(time: float, th: float, om: float) -> float:
            return w0 * w0 * amp * math.sin(wd * time + phase)
        return extra
    if outside == "changing_length":
        rate = float(params["length_change"]) / DRIFT_SPAN_S  # l'/l at t = 0 [1/s]

        def extra(time: float, th: float, om: float) -> float:
            grow = 1.0 + rate * time  # l(t) / l
            return w0 * w0 * (1.0 - 1.0 / grow) * math.sin(th) - 2.0 * (rate / grow) * om
        return extra
    raise ValueError(f"physics outside the catalogue is one of {OUTSIDE} (got {outside!r})")


def simulate_outside(params: dict[str, float], outside: str, *, duration: float, theta0: float, noise: float,
                     rng: np.random.Generator, rate_hz: float = RATE_HZ) -> tuple[np.ndarray, np.ndarray]:
    """``standard`` plus physics outside the catalogue (:func:`outside_acceleration`).

    The damping is the standard model's (:func:`pendtrack.models.kernels.accel_free`). Classic RK4
    with steps of at most :data:`RK4_STEP_S` (fixed steps: the Coulomb term's switch at every
    turning point stalls an adaptive integrator), from rest at ``theta0``.

    Returns
    -------
    t, theta : ndarray
        [s], [rad] with white noise of ``noise`` [rad].
    """
    from pendtrack.models import get_model
    from pendtrack.models.kernels import accel_free

    model = get_model("standard")
    physical = {k: v for k, v in params.items() if k in model.param_names}
    coeffs = model.pack(physical)  # validated once: the right-hand side is called ~1e5 times
    extra = outside_acceleration(outside, params)
    t = np.arange(int(round(duration * rate_hz))) / rate_hz

    def alpha(time: float, th: float, om: float) -> float:
        sgn = 1.0 if om >= 0.0 else -1.0  # sgn(0) = +1, as the kernels
        return float(accel_free(th, math.sin(th), om, time, sgn, coeffs)) + extra(time, th, om)

    sub = max(1, math.ceil(1.0 / (rate_hz * RK4_STEP_S)))
    h = 1.0 / (rate_hz * sub)
    out = np.empty(t.size)
    th, om, time = float(theta0), 0.0, 0.0
    out[0] = th
    for i in range(1, t.size):
        for _ in range(sub):
            a1 = alpha(time, th, om)
            a2 = alpha(time + 0.5 * h, th + 0.5 * h * om, om + 0.5 * h * a1)
            a3 = alpha(time + 0.5 * h, th + 0.5 * h * (om + 0.5 * h * a1), om + 0.5 * h * a2)
            a4 = alpha(time + h, th + h * (om + 0.5 * h * a2), om + h * a3)
            th += h * (6.0 * om + h * (a1 + a2 + a3)) / 6.0
            om += h * (a1 + 2.0 * a2 + 2.0 * a3 + a4) / 6.0
            time += h
        out[i] = th
    return t, out + rng.normal(0.0, noise, t.size)


def standard_excess(t: np.ndarray, theta: np.ndarray, noise: float) -> float:
    """Residual RMS of a whole-record output-error fit of ``standard``, over the noise [1]."""
    from pendtrack.config import Config
    from pendtrack.discovery.data import prepare
    from pendtrack.discovery.inputs import AngleSeries
    from pendtrack.discovery.candidate_fits import FitTask, fit_pair

    cfg = Config()
    data = prepare(AngleSeries(t, theta, source="synthetic", kind="table"),  # type: ignore[arg-type]
                   analysis_rate_hz=cfg.discover.analysis_rate_hz, train_fraction=cfg.discover.train_fraction,
                   savgol_window_s=cfg.kinematics.savgol_window_s, savgol_order=cfg.kinematics.savgol_order)
    pair = fit_pair(FitTask(data, "standard", (), None, 2, 0, cfg.fit.cost, cfg.models.memory_s, workers=1))
    if pair.full is None:
        return float("inf")
    r = data.theta - pair.trajectory
    return float(np.sqrt(np.mean(r * r)) / noise)


def draw_run(seed: int, effect: str | None | tuple[str, ...], *, check_size: bool = True, max_draws: int = 20,
             measurement: str | None = None, rate_hz: float = RATE_HZ,
             duration: tuple[float, float] = (60.0, 90.0),
             noise: tuple[float, float] = (0.002, 0.004), outside: str | None = None,
             sizes: str = "catalogue") -> SyntheticRun:
    """A synthetic run carrying ``effect`` (one, a pair, or none), drawn from ``seed``.

    Parameters
    ----------
    seed : int
        Everything (duration, release, noise, parameters) is drawn from it.
    effect : str, tuple of str or None
        One of :data:`HIDDEN_EFFECTS`, a pair of them (:data:`HIDDEN_PAIRS`), or None for a control.
    check_size : bool
        For memory and time-varying damping: redraw the effects' parameters until a standard
        fit's residual RMS exceeds the noise by :data:`MIN_EXCESS`, on the run and (for a pair)
        on the run with that effect alone: each effect of a pair must be a hidden effect on its own.
    max_draws : int
        Give up (``RuntimeError``) after this many draws.
    measurement : str, optional
        A measurement artefact (:data:`ARTEFACTS`) of the size :data:`OFFSET_MRAD` /
        :data:`SCALE_ERROR`, sign drawn.
    rate_hz : float
        Sampling rate [1/s].
    duration, noise : (float, float)
        Ranges the record's length [s] and noise standard deviation [rad] are drawn from.
    outside : str, optional
        Physics outside the catalogue (:data:`OUTSIDE`) instead of a hidden effect: a control
        on which no catalogue effect may be named as the cause.
    sizes : str
        The hidden effects' sizes (:data:`SIZES`): ``"catalogue"``, the ranges of the module
        docstring, or ``"field"``, :data:`FIELD_SIZES`.
    """
    effects = _as_tuple(effect)
    if sizes not in SIZES:
        raise ValueError(f"sizes is one of {SIZES}, got {sizes!r}")
    if outside is not None:
        if outside not in OUTSIDE or effects or measurement is not None:
            raise ValueError(f"physics outside the catalogue is one of {OUTSIDE}, alone (got {outside!r})")
        return _draw_outside(seed, outside, rate_hz=rate_hz, duration=duration, noise=noise,
                             check_size=check_size, max_draws=max_draws)
    for e in effects:
        if e not in HIDDEN_EFFECTS:
            raise ValueError(f"unknown hidden effect {e!r}")
    if measurement is not None and measurement not in ARTEFACTS:
        raise ValueError(f"unknown measurement artefact {measurement!r}")
    rng = np.random.default_rng(seed)
    dur = rng.uniform(*duration)
    theta0 = rng.uniform(2.6, 3.0)
    sd = rng.uniform(*noise)
    artefact = _draw_artefact(rng, measurement)
    if "k_scale" in artefact:
        # a camera measures angles within (-pi, pi]: released from SCALE_RELEASE at most, a swing stretched
        # by 15 % at 2.5 rad stays below 3.03 rad
        theta0 = min(theta0, SCALE_RELEASE)
    for draw in range(1, max_draws + 1):
        params = {**_draw_params(rng, effects, sizes), **artefact}
        # a pair's noise has its own seed, so that each effect alone can be simulated with the same noise;
        # the other runs draw it from the main stream (the single-effect cases as they always were)
        noise_seed = int(rng.integers(0, 2**31 - 1)) if len(effects) > 1 else None
        t, theta = simulate_run(params, effects, duration=dur, theta0=theta0, noise=sd,
                                rng=rng if noise_seed is None else np.random.default_rng(noise_seed),
                                rate_hz=rate_hz, measurement=measurement)
        excess = float("nan")
        if check_size and any(e in SIZE_CHECKED for e in effects):
            excess = standard_excess(t, theta, sd)
            if excess < MIN_EXCESS:
                continue
            if len(effects) > 1 and not all(
                    standard_excess(*simulate_run(params, (e,), duration=dur, theta0=theta0, noise=sd,
                                                  rng=np.random.default_rng(noise_seed), rate_hz=rate_hz,
                                                  measurement=measurement), sd) >= MIN_EXCESS
                    for e in effects if e in SIZE_CHECKED):
                continue
        return SyntheticRun(t, theta, effects[0] if effects else None, params, theta0, sd, excess, draw,
                            effects=effects, measurement=measurement, rate_hz=rate_hz)
    raise RuntimeError(f"no {effects} run of detectable size in {max_draws} draws (seed {seed})")


def _draw_outside_params(rng: np.random.Generator, outside: str) -> dict[str, float]:
    if outside == "drifting_omega0":
        return {"omega0_drift": rng.uniform(*OMEGA0_DRIFT)}
    if outside == "weak_drive":
        return {"drive_rad": 1e-3 * rng.uniform(*DRIVE_MRAD), "drive_ratio": rng.uniform(*DRIVE_RATIO),
                "drive_phase": rng.uniform(0.0, 2.0 * math.pi)}
    sign = 1.0 if rng.uniform() < 0.5 else -1.0  # changing_length: wound in or paid out
    return {"length_change": sign * rng.uniform(*LENGTH_CHANGE)}


def _draw_outside(seed: int, outside: str, *, rate_hz: float, duration: tuple[float, float],
                  noise: tuple[float, float], check_size: bool, max_draws: int) -> SyntheticRun:
    """A run of ``standard`` with physics outside the catalogue (:data:`OUTSIDE`).

    With ``check_size``, redrawn (parameters and noise) until a standard fit leaves a residual RMS
    :data:`MIN_EXCESS` times the noise: a control whose physics the data cannot show tests nothing.
    """
    rng = np.random.default_rng(seed)
    dur = rng.uniform(*duration)
    theta0 = rng.uniform(2.6, 3.0)
    sd = rng.uniform(*noise)
    for draw in range(1, max_draws + 1):
        params = {**_draw_params(rng, None), **_draw_outside_params(rng, outside)}
        t, theta = simulate_outside(params, outside, duration=dur, theta0=theta0, noise=sd, rng=rng,
                                    rate_hz=rate_hz)
        excess = standard_excess(t, theta, sd) if check_size else float("nan")
        if excess >= MIN_EXCESS or not check_size:
            return SyntheticRun(t, theta, None, params, theta0, sd, excess, draw, rate_hz=rate_hz, outside=outside)
    raise RuntimeError(f"no {outside} run of detectable size in {max_draws} draws (seed {seed})")


#: Release angles of a synthetic series [rad]: near the top, mid and low (the issue's example), so that
#: damping that weakens with time and damping that weakens with amplitude part.
SERIES_RELEASES = (math.pi - 0.1, 2.2, 1.2)
STRONG_C2 = (0.02, 0.04)  # a "strong" quadratic drag [1]: 4-20x the standard range's 0.002-0.006


@dataclass(frozen=True, eq=False)
class SyntheticSeries:
    """Several runs of one simulated pendulum, released from different angles.

    Attributes
    ----------
    runs : tuple of SyntheticRun
        One per release, in :data:`SERIES_RELEASES` order (each with its own noise).
    effects : tuple of str
        The hidden effects every run carries.
    params : dict
        The pendulum's true parameters, shared by every run.
    strong_drag : bool
        ``C2`` drawn from :data:`STRONG_C2`.
    """

    runs: tuple[SyntheticRun, ...]
    effects: tuple[str, ...]
    params: dict[str, float]
    strong_drag: bool = False


def draw_series(seed: int, effect: str | None | tuple[str, ...], *, releases: tuple[float, ...] = SERIES_RELEASES,
                duration: float = 60.0, rate_hz: float = RATE_HZ, noise: tuple[float, float] = (0.002, 0.003),
                strong_drag: bool = False, check_size: bool = True, max_draws: int = 20) -> SyntheticSeries:
    """A series of runs of one pendulum carrying ``effect`` (one, a pair, or none), drawn from ``seed``.

    Every run has the same physical parameters (``standard`` + the effects; a time-varying damping's
    ``t0`` on each run's own clock, the same launch each time) and is released from rest at one of
    ``releases`` with its own seeded noise.

    Parameters
    ----------
    seed : int
    effect : str, tuple of str or None
        As :func:`draw_run`.
    releases : tuple of float
        Release angles [rad].
    duration : float
        Each run's length [s].
    rate_hz : float
    noise : (float, float)
        Range of each run's noise standard deviation [rad].
    strong_drag : bool
        ``C2`` from :data:`STRONG_C2`: damping that weakens fast with the amplitude, which one record
        cannot tell from damping that weakens with time.
    check_size : bool
        Memory and time-varying damping redrawn until a standard fit of the first run (the largest
        swing) leaves a residual :data:`MIN_EXCESS` times its noise, with every effect together and
        with each alone (the same noise): each must be a hidden effect on its own.
    max_draws : int
    """
    effects = _as_tuple(effect)
    for e in effects:
        if e not in HIDDEN_EFFECTS:
            raise ValueError(f"unknown hidden effect {e!r}")
    rng = np.random.default_rng([seed, 7])
    sds = [rng.uniform(*noise) for _ in releases]
    noise_seeds = [int(rng.integers(0, 2**31 - 1)) for _ in releases]
    for draw in range(1, max_draws + 1):
        params = _draw_params(rng, effects)
        if strong_drag:
            params["C2"] = rng.uniform(*STRONG_C2)

        def one(i: int, which: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray]:
            return simulate_run(params, which, duration=duration, theta0=releases[i], noise=sds[i],
                                rng=np.random.default_rng(noise_seeds[i]), rate_hz=rate_hz)

        excess = float("nan")
        if check_size and any(e in SIZE_CHECKED for e in effects):
            excess = standard_excess(*one(0, effects), sds[0])
            if excess < MIN_EXCESS or (len(effects) > 1 and not all(
                    standard_excess(*one(0, (e,)), sds[0]) >= MIN_EXCESS for e in effects if e in SIZE_CHECKED)):
                continue
        runs = tuple(SyntheticRun(*one(i, effects), effects[0] if effects else None, params, releases[i], sds[i],
                                  excess if i == 0 else float("nan"), draw, effects=effects, rate_hz=rate_hz)
                     for i in range(len(releases)))
        return SyntheticSeries(runs=runs, effects=effects, params=params, strong_drag=strong_drag)
    raise RuntimeError(f"no {effects} series of detectable size in {max_draws} draws (seed {seed})")
