"""Step 1 of a fit, *estimate*: the problem, model-free facts and the start ranges, from the data only.

:func:`estimate` maps the record's usable samples onto the simulation grid
(:func:`pendtrack.fitting.leastsq.samples.build_problem`), takes the model-free facts (Omega0 from the
turning points, Savitzky-Golay-bias corrected; the initial state from the first usable sample)
and the equation-error estimates of every model parameter
(:func:`pendtrack.fitting.leastsq.equation_error.equation_error_estimates`), and sets the centre and
half-widths of the start ranges and the typical magnitude of each fitted parameter (the
finite-difference steps). Nothing is simulated.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from pendtrack.config import FitConfig, ModelsConfig
from pendtrack.errors import FitError, PendtrackError
from pendtrack.fitting.leastsq.equation_error import DataSummary, Estimates, equation_error_estimates
from pendtrack.fitting.leastsq.problem import FitProblem, Simulator
from pendtrack.fitting.leastsq.coordinates import fit_coordinates
from pendtrack.fitting.leastsq.samples import Record, build_problem, uniform_series

THETA0_SPREAD = 0.02  # start half-width of the initial angle [rad] (~7x the tracking noise)
OMEGA0_STATE_SPREAD = 0.1  # start half-width of the initial angular velocity [rad/s]
FIRST_WINDOW_HALF_SWINGS = 6  # the ladder's first window: three periods
UNIT_SCALE = {"rad/s^2": 2, "1/s": 1}  # a unit's natural scale is Omega0_hat**power times 1e-3
# measurement terms (models.terms, kind "measurement"): their start values and ranges
THETA_OFF_SPREAD = 0.005  # start half-width of theta_off [rad], at least: a few times the spread of the
# oscillation centre over a record (~1 mrad); theta_off enters the residuals almost linearly, so one
# Levenberg-Marquardt step finds it from anywhere in the range
K_SCALE_THETA_ERROR = 0.03  # start half-width of k_scale: a 3 % error of theta at the record's amplitude A
# (k A^2 = 0.03), the size of a lens or projection error a calibration would have caught beyond that
THETA_GAIN_SCALE = 1e-3  # scale of theta_gain: an axle 0.1 % of the radius off along it, or a codec's smoothing
# (renders at crf 20 read theta 1-3e-4 small); its starts lie within +-3 times this about 0


@dataclass(frozen=True, eq=False)
class Setup:
    """What the search starts from.

    Attributes
    ----------
    problem : FitProblem
        The whole-window problem (fixed parameters removed, typical magnitudes set).
    summary : DataSummary
        Model-free facts of the usable samples (``omega0_hat`` [rad/s], turning points, ...).
    estimates : mapping
        Data-derived estimate of every model parameter and of ``theta0`` [rad], ``omega0`` [rad/s].
    center : ndarray
        Centre of the start ranges, ``problem.names`` order (the estimates, or ``initial``).
    half_widths : ndarray
        Half-widths of the start ranges, same order and units.
    first_window_end : float
        End of the growing-window ladder's first window [s] (inf: too few turning points).
    """

    problem: FitProblem
    summary: DataSummary
    estimates: Mapping[str, float]
    center: np.ndarray
    half_widths: np.ndarray
    first_window_end: float


def estimate(model: Any, record: Record, *, options: FitConfig, model_options: ModelsConfig,
             fixed: Mapping[str, float] | None = None, initial: Mapping[str, float] | None = None,
             simulator: Simulator | None = None, method: str = "auto") -> Setup:
    """The problem and the start ranges of ``model`` on ``record`` (step 1 of a fit).

    Parameters
    ----------
    model : Model
    record : Record
    options : FitConfig
        Uses ``cost``, ``start_spread``, ``omega0_spread`` and ``coordinates`` (the steps' coordinates
        from the data: :func:`pendtrack.fitting.leastsq.coordinates.fit_coordinates`).
    model_options : ModelsConfig
        Memory of the models with the memory term (``memory_s`` [s], ``full_history``) and the
        predictor-corrector's largest step (``max_step_s`` [s]).
    fixed : mapping, optional
        Parameters held at given values (not fitted).
    initial : mapping, optional
        Start centre overriding the estimates for the named parameters (a warm start).
    simulator, method
        As in :func:`pendtrack.fitting.fit_model`.

    Raises
    ------
    FitError
        No usable sample, too few for the model, no oscillation, time stamps not uniform, an
        ``initial`` value for an unknown parameter.
    """
    mask = record.usable()
    summary = record.summary()
    memory_s, full_history = model_options.memory_s, model_options.full_history
    meas_start, meas_scale = measurement_estimates(model, summary)
    theta_off_hat = meas_start.get("theta_off", 0.0)
    for given in (initial, fixed):  # a warm start's or a held zero offset is the model's (fixed wins)
        if "theta_off" in meas_start and given and "theta_off" in given:
            theta_off_hat = float(given["theta_off"])
    problem = build_problem(model, record.t, record.theta, record.omega, ok=record.cost_mask(), cost=options.cost,
                            omega0_hat=summary.omega0_hat, observation=record.observation, memory_s=memory_s,
                            full_history=full_history, simulator=simulator, method=method, source=record.source,
                            max_step_s=model_options.max_step_s, jacobian_method=options.jacobian,
                            substep_phase=options.substep_phase, steer_phase=options.steer_phase,
                            rung_phase=options.rung_phase, theta_zero=theta_off_hat)
    n_fit = len(problem.all_names) - len(fixed or {})
    if problem.n < max(3 * n_fit, 60):
        raise FitError(f"too few usable samples to fit model '{model.name}' ({problem.n})", path=record.source)

    grid, (th_g, om_g), present = uniform_series(problem, record.t, [record.theta, record.omega], mask)
    # the physics on the model's angle: the data's angle less the estimated zero offset
    est = equation_error_estimates(model.physics() if meas_start else model, grid, th_g - theta_off_hat, om_g,
                                   omega0_hat=summary.omega0_hat, memory_s=memory_s, full_history=full_history,
                                   use=present)
    if meas_start:
        est = Estimates(values={**est.values, **meas_start}, scales={**est.scales, **meas_scale}, rms=est.rms)
    center = _center(model, est, summary, initial, theta_off_hat=theta_off_hat)
    if fixed:
        problem = problem.with_fixed(fixed)
    names = problem.names
    x_center = np.array([center[n] for n in names])
    floors = {n: _floor(model, n, summary.omega0_hat) for n in model.param_names}
    half = _half_widths(names, x_center, est.scales, problem.t_start, start_spread=options.start_spread,
                        omega0_spread=options.omega0_spread, floors=floors, amplitude=summary.amplitude)
    typical = np.array([max(abs(c), h, floors.get(n, 0.0)) for n, c, h in zip(names, x_center, half)])
    coords = None
    if options.coordinates == "decorrelated":
        coords = fit_coordinates(model.param_names, problem.t, problem.omega, omega0_hat=summary.omega0_hat,
                                 center=center)
    return Setup(problem=replace(problem, typical=typical, coordinates=coords), summary=summary,
                 estimates={**est.values, "theta0": summary.theta_init - theta_off_hat, "omega0": summary.omega_init},
                 center=x_center, half_widths=half,
                 first_window_end=summary.first_window_end(problem.t_start, FIRST_WINDOW_HALF_SWINGS))


def measurement_estimates(model: Any, summary: DataSummary) -> tuple[dict[str, float], dict[str, float]]:
    """Data-derived start values and scales of a model's measurement parameters (empty without them).

    ``theta_off`` [rad]: the centre of the oscillation (:attr:`DataSummary.theta_center`, from
    the turning points), its standard error as the scale; ``theta_gain`` [1]: 0, its scale
    :data:`THETA_GAIN_SCALE`; ``k_scale`` [1/rad^2]: 0 (no scale
    error), its scale a 1 % angle error at the record's amplitude (a third of the start half-width).
    """
    values: dict[str, float] = {}
    scales: dict[str, float] = {}
    names = getattr(model, "param_names", ())
    if "theta_off" in names:
        values["theta_off"] = float(summary.theta_center)
        scales["theta_off"] = float(summary.theta_center_se)
    if "theta_gain" in names:
        values["theta_gain"] = 0.0
        scales["theta_gain"] = THETA_GAIN_SCALE
    if "k_scale" in names:
        values["k_scale"] = 0.0
        scales["k_scale"] = K_SCALE_THETA_ERROR / 3.0 / max(summary.amplitude, 1e-3) ** 2
    return values, scales


def _floor(model: Any, name: str, omega0_hat: float) -> float:
    """A small but physically meaningful magnitude of a parameter whose estimate may be 0.

    ``1e-3 * Omega0_hat**k`` for a unit ``rad/s^2`` (k = 2), ``1/s`` (k = 1) or dimensionless
    (k = 0): below it a damping term has no visible effect on a record of a few minutes.
    """
    try:
        unit = model.param_spec(name).unit
    except (AttributeError, PendtrackError):
        return 1e-6
    return 1e-3 * omega0_hat ** UNIT_SCALE.get(unit, 0)


def _half_widths(names: tuple[str, ...], center: np.ndarray, scales: Mapping[str, float], t_start: float, *,
                 start_spread: float, omega0_spread: float, floors: Mapping[str, float],
                 amplitude: float = 1.0) -> np.ndarray:
    out = []
    for name, x in zip(names, center):
        if name == "theta_off":
            s = scales.get(name, math.nan)
            w = max(THETA_OFF_SPREAD, 3.0 * s if math.isfinite(s) else 0.0)
        elif name == "k_scale":
            w = K_SCALE_THETA_ERROR / max(amplitude, 1e-3) ** 2
        elif name == "Omega0":
            w = omega0_spread * x
        elif name == "theta0":
            w = THETA0_SPREAD
        elif name == "omega0":
            w = OMEGA0_STATE_SPREAD
        elif name == "t0":
            w = start_spread * (t_start - x)
        else:
            s = scales.get(name, math.nan)
            w = max(start_spread * abs(x), 3.0 * s if math.isfinite(s) else 0.0, start_spread * floors.get(name, 1e-6))
        out.append(w)
    return np.array(out)


def _center(model: Any, est: Estimates, summary: DataSummary, initial: Mapping[str, float] | None, *,
            theta_off_hat: float = 0.0) -> dict[str, float]:
    """Centre of the start ranges: equation-error estimates, model-free Omega0, first-sample state
    (the model's angle: the measured one less the estimated zero offset)."""
    center = dict(est.values)
    w_eq = center.get("Omega0", math.nan)
    if not (math.isfinite(w_eq) and abs(w_eq / summary.omega0_hat - 1.0) < 0.02):
        center["Omega0"] = summary.omega0_hat
    center["theta0"] = summary.theta_init - theta_off_hat
    center["omega0"] = summary.omega_init
    if initial:
        unknown = [k for k in initial if k not in center]
        if unknown:
            raise FitError(f"initial value for unknown parameter '{unknown[0]}' of model '{model.name}'")
        center.update({k: float(v) for k, v in initial.items()})
    return center
