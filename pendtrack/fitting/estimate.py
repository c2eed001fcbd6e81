"""Step 1 of a fit, *estimate*: the problem, model-free facts and the start ranges, from the data only.

:func:`estimate` maps the record's usable samples onto the simulation grid
(:func:`pendtrack.fitting.record.build_problem`), takes the model-free facts (Omega0 from the
turning points, Savitzky-Golay-bias corrected; the initial state from the first usable sample)
and the equation-error estimates of every model parameter
(:func:`pendtrack.fitting.estimates.equation_error_estimates`), and sets the centre and
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
from pendtrack.fitting.estimates import DataSummary, Estimates, equation_error_estimates
from pendtrack.fitting.problem import FitProblem, Simulator
from pendtrack.fitting.record import Record, build_problem, uniform_series

THETA0_SPREAD = 0.02  # start half-width of the initial angle [rad] (~7x the tracking noise)
OMEGA0_STATE_SPREAD = 0.1  # start half-width of the initial angular velocity [rad/s]
FIRST_WINDOW_HALF_SWINGS = 6  # the ladder's first window: three periods
UNIT_SCALE = {"rad/s^2": 2, "1/s": 1}  # a unit's natural scale is Omega0_hat**power times 1e-3


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
        Uses ``cost``, ``start_spread`` and ``omega0_spread``.
    model_options : ModelsConfig
        Memory of the models with the memory term (``memory_s`` [s], ``full_history``).
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
    problem = build_problem(model, record.t, record.theta, record.omega, ok=mask, cost=options.cost,
                            omega0_hat=summary.omega0_hat, observation=record.observation, memory_s=memory_s,
                            full_history=full_history, simulator=simulator, method=method, source=record.source)
    n_fit = len(problem.all_names) - len(fixed or {})
    if problem.n < max(3 * n_fit, 60):
        raise FitError(f"too few usable samples to fit model '{model.name}' ({problem.n})", path=record.source)

    grid, (th_g, om_g), present = uniform_series(problem, record.t, [record.theta, record.omega], mask)
    est = equation_error_estimates(model, grid, th_g, om_g, omega0_hat=summary.omega0_hat,
                                   memory_s=memory_s, full_history=full_history, use=present)
    center = _center(model, est, summary, initial)
    if fixed:
        problem = problem.with_fixed(fixed)
    names = problem.names
    x_center = np.array([center[n] for n in names])
    floors = {n: _floor(model, n, summary.omega0_hat) for n in model.param_names}
    half = _half_widths(names, x_center, est.scales, problem.t_start, start_spread=options.start_spread,
                        omega0_spread=options.omega0_spread, floors=floors)
    typical = np.array([max(abs(c), h, floors.get(n, 0.0)) for n, c, h in zip(names, x_center, half)])
    return Setup(problem=replace(problem, typical=typical), summary=summary,
                 estimates={**est.values, "theta0": summary.theta_init, "omega0": summary.omega_init},
                 center=x_center, half_widths=half,
                 first_window_end=summary.first_window_end(problem.t_start, FIRST_WINDOW_HALF_SWINGS))


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
                 start_spread: float, omega0_spread: float, floors: Mapping[str, float]) -> np.ndarray:
    out = []
    for name, x in zip(names, center):
        if name == "Omega0":
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


def _center(model: Any, est: Estimates, summary: DataSummary, initial: Mapping[str, float] | None) -> dict[str, float]:
    """Centre of the start ranges: equation-error estimates, model-free Omega0, first-sample state."""
    center = dict(est.values)
    w_eq = center.get("Omega0", math.nan)
    if not (math.isfinite(w_eq) and abs(w_eq / summary.omega0_hat - 1.0) < 0.02):
        center["Omega0"] = summary.omega0_hat
    center["theta0"] = summary.theta_init
    center["omega0"] = summary.omega_init
    if initial:
        unknown = [k for k in initial if k not in center]
        if unknown:
            raise FitError(f"initial value for unknown parameter '{unknown[0]}' of model '{model.name}'")
        center.update({k: float(v) for k, v in initial.items()})
    return center
