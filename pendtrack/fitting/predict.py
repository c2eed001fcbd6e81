"""Use a fit: the fitted model's curves on any times, and its cost on any (held-out) window.

Both simulate from the fitted initial state at ``result.window[0]`` on the data's uniform
grid, so a window after the fitted one is a genuine forecast (what a discovery step needs for
held-out validation).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from pendtrack.errors import FitError
from pendtrack.fitting.leastsq.cost import Observation
from pendtrack.fitting.leastsq.samples import GRID_TOL, interior
from pendtrack.fitting.leastsq.problem import STATE_NAMES, FitProblem, Simulator
from pendtrack.fitting.result import FitResult


def _grid_for(result: FitResult, t: np.ndarray, h: float | None) -> tuple[float, float, int]:
    t = np.asarray(t, dtype=float)
    finite = t[np.isfinite(t)]
    if finite.size < 2 and h is None:
        raise FitError("need at least two times (or the step h) to predict")
    step = float(np.median(np.diff(finite))) if h is None else float(h)
    t_start = float(result.window[0])
    n_grid = max(int(math.ceil((float(finite.max()) - t_start) / step - 1e-9)) + 1, 2)
    return t_start, step, n_grid


def _problem(result: FitResult, model: Any, t_start: float, h: float, n_grid: int, index: np.ndarray,
             theta: np.ndarray, omega: np.ndarray, observation: Observation, cost: str,
             simulator: Simulator | None, fixed_extra: Mapping[str, float] | None = None) -> FitProblem:
    values: dict[str, float] = dict(result.values)
    values.update({k: v.value for k, v in result.initial_state.items()})
    if fixed_extra:
        values.update(fixed_extra)
    names = tuple(model.param_names) + STATE_NAMES
    missing = [n for n in names if n not in values]
    if missing:
        raise FitError(f"fit of '{result.model}' has no value for parameter '{missing[0]}' of model '{model.name}'")
    return FitProblem(model=model, t_start=t_start, h=h, n_grid=n_grid, index=index, theta=theta, omega=omega,
                      cost=cost, omega_scale=1.0 / (2.0 * result.omega0_hat), observation=observation,
                      memory_s=result.memory_s, method="auto", lower=np.zeros(0), upper=np.zeros(0),
                      fixed={n: values[n] for n in names}, simulator=simulator, full_history=result.full_history,
                      max_step_s=result.max_step_s)


def predict(result: FitResult, model: Any, t: np.ndarray, *, h: float | None = None,
            observation: Observation | None = None,
            simulator: Simulator | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The fitted model's angle and angular velocity at times ``t``.

    Parameters
    ----------
    result : FitResult
        A fit (its parameters, initial state at ``window[0]`` and memory).
    model : Model
        The model that was fitted.
    t : ndarray
        Times [s]; those before ``result.window[0]`` get NaN.
    h : float, optional
        Simulation step [s]; default the median spacing of ``t``.
    observation : Observation, optional
        Pass the curves through the data's filter (default: the plain simulation).
    simulator : callable, optional
        As in :func:`~pendtrack.fitting.fit_model`.

    Returns
    -------
    theta, omega : ndarray
        [rad], [rad/s], same shape as ``t``.
    """
    t = np.asarray(t, dtype=float)
    t_start, step, n_grid = _grid_for(result, t, h)
    prob = _problem(result, model, t_start, step, n_grid, np.zeros(0, np.int64), np.zeros(0), np.zeros(0),
                    observation or Observation(), result.cost, simulator)
    th, om = prob.simulate(np.zeros(0))
    out_th = np.full(t.shape, np.nan)
    out_om = np.full(t.shape, np.nan)
    x = (t - t_start) / step
    inside = np.isfinite(x) & (x >= -GRID_TOL) & (x <= n_grid - 1 + GRID_TOL)
    k = np.rint(x[inside]).astype(np.int64)
    if np.all(np.abs(x[inside] - k) <= GRID_TOL):
        out_th[inside] = th[k]
        out_om[inside] = om[k]
    else:  # off-grid times: linear interpolation (callers with jittered clocks only)
        grid = t_start + step * np.arange(n_grid)
        out_th[inside] = np.interp(t[inside], grid, th)
        out_om[inside] = np.interp(t[inside], grid, om)
    return out_th, out_om


@dataclass(frozen=True)
class WindowScore:
    """The cost of a fitted model on a window of data.

    Attributes
    ----------
    cost : float
        Xi^2 [1] or mean squared angle residual [rad^2] (the fit's cost kind).
    rms : float
        Rms of ``theta - theta_model`` [rad].
    n : int
        Samples scored.
    window : (float, float)
        First and last scored time [s].
    """

    cost: float
    rms: float
    n: int
    window: tuple[float, float]

    def to_dict(self) -> dict[str, Any]:
        return {"cost": self.cost, "rms": self.rms, "n": self.n, "window": list(self.window)}


def score(result: FitResult, model: Any, t: np.ndarray, theta: np.ndarray, omega: np.ndarray, *,
          ok: np.ndarray | None = None, window: tuple[float, float] | None = None,
          observation: Observation | None = None, simulator: Simulator | None = None) -> WindowScore:
    """Cost of the fitted model on the samples of ``window`` (e.g. held out after the fit window).

    The model runs from the fit's initial state at ``result.window[0]``; only samples at or after
    it are scored. Same cost kind and A_omega scale as the fit.

    Parameters
    ----------
    result, model : FitResult, Model
    t, theta, omega : ndarray
        The record: times [s], angle [rad], angular velocity [rad/s].
    ok : ndarray of bool, optional
        Usable samples.
    window : (float, float), optional
        Scored times [s]; default every usable sample from ``result.window[0]``.
    observation : Observation, optional
        The data's filter (as given to the fit).
    simulator : callable, optional

    Returns
    -------
    WindowScore

    Raises
    ------
    FitError
        No usable sample in the window.
    """
    t = np.asarray(t, dtype=float)
    theta = np.asarray(theta, dtype=float)
    omega = np.asarray(omega, dtype=float)
    obs = observation or Observation()
    use = np.isfinite(t) & np.isfinite(theta) & np.isfinite(omega) & (t >= result.window[0] - 1e-9)
    if ok is not None:
        use &= np.asarray(ok, dtype=bool)
    if window is not None:
        use &= (t >= window[0]) & (t <= window[1])
    if not use.any():
        raise FitError("no usable sample to score in the window")
    t_start, step, _ = _grid_for(result, t, None)
    x = (t[use] - t_start) / step
    k = np.rint(x).astype(np.int64)
    if np.any(np.abs(x - k) > GRID_TOL):
        raise FitError("time stamps are not on the fit's uniform grid")
    n_grid = int(k.max()) + 1 + obs.trim
    keep = interior(k, n_grid, obs.trim) if obs.trim else np.ones(k.size, bool)
    if not keep.any():
        raise FitError("no sample left to score after the filter's edges")
    prob = _problem(result, model, t_start, step, n_grid, k[keep], theta[use][keep], omega[use][keep], obs,
                    result.cost, simulator)
    r = prob.residuals(np.zeros(0))
    th_m, _ = prob.model_at_data(np.zeros(0))
    rms = float(np.sqrt(np.mean((prob.theta - th_m) ** 2)))
    tk = prob.t
    return WindowScore(cost=float(r @ r), rms=rms, n=prob.n, window=(float(tk[0]), float(tk[-1])))
