"""Fit a model to a record: :func:`fit_model` (arrays in, :class:`FitResult` out).

Procedure (an output-error fit, see :mod:`pendtrack.fitting.cost` for the cost):

1. keep the usable samples (``ok``, finite, inside ``window``) and map them onto the uniform
   simulation grid;
2. model-free facts and the data-derived estimates (:mod:`pendtrack.fitting.estimates`);
3. ``n_starts`` seeded starts around the estimates, each a growing-window least-squares fit
   (:mod:`pendtrack.fitting.multistart`), in parallel;
4. Xi^2_min, the paper's accepted set and ``u_paper``; the sandwich standard errors at the
   best fit (:mod:`pendtrack.fitting.uncertainty`); optionally a block bootstrap.

The paper used simulated annealing (``amebsa``); multi-start bounded Levenberg-Marquardt least
squares on the residual vector (:mod:`pendtrack.fitting.lm`) is the modern equivalent: each start
descends to the bottom of its basin with far fewer model evaluations, and the many starts search
for the global minimum.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from pendtrack.errors import FitError, PendtrackError
from pendtrack.fitting import uncertainty as U
from pendtrack.fitting.cost import COSTS, Observation
from pendtrack.fitting.estimates import DataSummary, Estimates, equation_error_estimates, summarize
from pendtrack.fitting.multistart import draw_starts, local_fit, run_starts, run_tasks, window_ladder
from pendtrack.fitting.polish import profile_polish, profile_sigmas
from pendtrack.fitting.problem import FD_REL, STATE_NAMES, FitProblem, Simulator, parameter_bounds
from pendtrack.fitting.result import FitResult, ParamEstimate

THETA0_SPREAD = 0.02  # start half-width of the initial angle [rad] (~7x the tracking noise)
OMEGA0_STATE_SPREAD = 0.1  # start half-width of the initial angular velocity [rad/s]
GRID_TOL = 1e-3  # data times may deviate from the uniform grid by this fraction of a step
FIRST_WINDOW_HALF_SWINGS = 6  # the ladder's first window: three periods
POLISH_ITERATIONS = 300  # budget (in Jacobians' worth) to finish the best start if its own budget ran out
PROFILE_ALONG = "beta"  # the best fit of a model with memory is finished by a profile over this (fitting/polish.py)


def _usable(t: np.ndarray, theta: np.ndarray, omega: np.ndarray, ok: np.ndarray | None,
            window: tuple[float, float] | None, source: str) -> np.ndarray:
    if not (t.shape == theta.shape == omega.shape) or t.ndim != 1:
        raise FitError(f"t, theta and omega must be 1-D arrays of one length, got {t.shape}, {theta.shape}, "
                       f"{omega.shape}", path=source)
    mask = np.isfinite(t) & np.isfinite(theta) & np.isfinite(omega)
    if ok is not None:
        ok = np.asarray(ok, dtype=bool)
        if ok.shape != t.shape:
            raise FitError(f"ok has shape {ok.shape}, expected {t.shape}", path=source)
        if not ok.any():
            raise FitError("no usable samples: every sample is flagged not ok", path=source)
        mask &= ok
    if window is not None:
        a, b = window
        mask &= (t >= a) & (t <= b)
    if not mask.any():
        raise FitError("no usable samples in the fit window", path=source)
    return mask


def _grid_index(t: np.ndarray, h: float, source: str) -> np.ndarray:
    k = np.rint((t - t[0]) / h).astype(np.int64)
    dev = np.max(np.abs(t - t[0] - k * h)) if t.size else 0.0
    if dev > GRID_TOL * h or np.any(np.diff(k) <= 0):
        raise FitError(f"time stamps are not on a uniform grid (off by up to {dev:.3g} s with step {h:.6g} s)",
                       path=source)
    return k


def _interior(index: np.ndarray, n_grid: int, trim: int) -> np.ndarray:
    """Samples whose filter window lies on present samples only (no gap, no window edge)."""
    if trim == 0:
        return np.ones(index.size, bool)
    present = np.zeros(n_grid, np.int64)
    present[index] = 1
    csum = np.concatenate(([0], np.cumsum(present)))
    lo = index - trim
    hi = index + trim + 1
    inside = (lo >= 0) & (hi <= n_grid)
    full = np.zeros(index.size, bool)
    full[inside] = (csum[hi[inside]] - csum[lo[inside]]) == 2 * trim + 1
    return full


UNIT_SCALE = {"rad/s^2": 2, "1/s": 1}  # a unit's natural scale is Omega0_hat**power times 1e-3


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


def build_problem(model: Any, t: np.ndarray, theta: np.ndarray, omega: np.ndarray, *, ok: np.ndarray | None = None,
                  window: tuple[float, float] | None = None, cost: str = "xi2", omega0_hat: float,
                  observation: Observation | None = None, memory_s: float = 100 / 120,
                  full_history: bool = False, simulator: Simulator | None = None, method: str = "auto",
                  source: str = "the data") -> FitProblem:
    """The :class:`FitProblem` of a record (usable samples mapped onto the simulation grid).

    Parameters are as in :func:`fit_model`; ``omega0_hat`` [rad/s] fixes the A_omega scale.
    """
    t = np.asarray(t, dtype=float)
    theta = np.asarray(theta, dtype=float)
    omega = np.asarray(omega, dtype=float)
    mask = _usable(t, theta, omega, ok, window, source)
    obs = observation or Observation()
    h = float(np.median(np.diff(t[np.isfinite(t)])))
    tu = t[mask]
    index = _grid_index(tu, h, source)
    n_grid = int(index[-1]) + 1
    keep = _interior(index, n_grid, obs.trim)
    lower, upper = parameter_bounds(model, float(tu[0]))
    th_init = float(theta[mask][0])
    om_init = float(omega[mask][0])
    lower = np.concatenate((lower, [th_init - 1.0, om_init - 2.0 * omega0_hat]))
    upper = np.concatenate((upper, [th_init + 1.0, om_init + 2.0 * omega0_hat]))
    return FitProblem(model=model, t_start=float(tu[0]), h=h, n_grid=n_grid, index=index[keep],
                      theta=theta[mask][keep], omega=omega[mask][keep], cost=cost,
                      omega_scale=1.0 / (2.0 * omega0_hat), observation=obs, memory_s=float(memory_s),
                      method=method, lower=lower, upper=upper, simulator=simulator, full_history=full_history)


def _uniform_series(problem: FitProblem, t: np.ndarray, series: list[np.ndarray],
                    mask: np.ndarray) -> tuple[np.ndarray, list[np.ndarray], np.ndarray]:
    """Series on the whole simulation grid, gaps filled by linear interpolation."""
    grid = problem.grid()
    tu = t[mask]
    filled = [np.interp(grid, tu, s[mask]) for s in series]
    present = np.zeros(grid.size, bool)
    present[_grid_index(tu, problem.h, "the data")] = True
    return grid, filled, present


def check_record(t: np.ndarray, theta: np.ndarray, omega: np.ndarray, *, alpha: np.ndarray | None = None,
                 ok: np.ndarray | None = None, window: tuple[float, float] | None = None,
                 source: str = "the data") -> DataSummary:
    """The checks :func:`fit_model` makes before any fitting, alone (cheap): FitError if the
    record cannot support a fit (no usable sample, too few, no oscillation)."""
    t = np.asarray(t, dtype=float)
    theta = np.asarray(theta, dtype=float)
    omega = np.asarray(omega, dtype=float)
    mask = _usable(t, theta, omega, ok, window, source)
    alpha = np.gradient(omega, t) if alpha is None else np.asarray(alpha, dtype=float)
    mask &= np.isfinite(alpha)
    return summarize(t[mask], theta[mask], omega[mask], alpha[mask], source=source)


def fit_model(model: Any, t: np.ndarray, theta: np.ndarray, omega: np.ndarray, *,
              alpha: np.ndarray | None = None, ok: np.ndarray | None = None,
              window: tuple[float, float] | None = None, cost: str = "xi2", n_starts: int = 150,
              accept_ratio: float = 1.25, start_spread: float = 0.5, omega0_spread: float = 0.01,
              seed: int = 0, workers: int = 0, memory_s: float = 100 / 120, full_history: bool = False,
              observation: Observation | None = None, fixed: Mapping[str, float] | None = None,
              initial: Mapping[str, float] | None = None, ladder: bool = True, bootstrap: int = 0,
              profile: bool = False, start_budget: int | None = None,
              simulator: Simulator | None = None, method: str = "auto",
              on_progress: Callable[[int], None] | None = None, source: str = "the data") -> FitResult:
    """Fit ``model`` to a record by output error, with the paper's uncertainties and better ones.

    Parameters
    ----------
    model : Model
        From :func:`pendtrack.models.get_model` or :func:`pendtrack.models.compose`.
    t : ndarray
        Sample times [s], uniformly spaced (samples may be missing or flagged).
    theta : ndarray
        Measured angle [rad] (in ``kinematics.parquet``: Savitzky-Golay smoothed).
    omega : ndarray
        Measured angular velocity [rad/s] (Savitzky-Golay derivative).
    alpha : ndarray, optional
        Measured angular acceleration [rad/s^2], used only for the initial estimates;
        default ``gradient(omega, t)``.
    ok : ndarray of bool, optional
        Usable samples (default: every finite one).
    window : (float, float), optional
        Only samples with ``window[0] <= t <= window[1]`` enter the fit [s] (held-out tests);
        the initial state is fitted at the first of them.
    cost : {"xi2", "theta"}
        The paper's Xi^2 (eq. leastsquarescostfunction) or the mean squared angle residual.
    n_starts : int
        Starts (paper: 150); start 0 is the data-derived estimate itself.
    accept_ratio : float
        Starts with cost <= accept_ratio * min enter ``u_paper`` (paper: 5/4).
    start_spread : float
        Relative half-width of the start ranges of the damping parameters [1].
    omega0_spread : float
        Relative half-width of the start range of Omega0 [1].
    seed : int
        Seed of the start draws (and of the bootstrap).
    workers : int
        Processes for the starts; 0 = all cores, 1 = this process.
    memory_s : float
        Grunwald-Letnikov memory of models with the memory term [s].
    full_history : bool
        The Grunwald-Letnikov sum runs over the whole record instead (``ModelsConfig.full_history``).
    observation : Observation, optional
        How the data were filtered (so the model is filtered alike); default none.
    fixed : mapping, optional
        Parameters held at given values (not fitted), e.g. ``{"Ca": 0.0}``.
    initial : mapping, optional
        Start centre overriding the data-derived estimates for the named parameters (a warm
        start from an earlier fit -- never a truth in a test).
    ladder : bool
        Fit a growing window in every start (robust against phase slips); False fits the whole
        window at once.
    bootstrap : int
        Moving-block bootstrap refits (0 = none).
    start_budget : int, optional
        Cap on each start's fit of the whole window, in Jacobians' worth of simulations
        (default :data:`pendtrack.fitting.multistart.FINAL_ITERATIONS`). The best start is
        always finished afterwards (a larger budget, and the profile polish for memory models),
        so a smaller cap only makes the starts that are still crawling stop earlier: fewer of
        them reach the paper's 5/4 acceptance, none changes the best fit.
    profile : bool
        Profile-likelihood standard errors below and above each model parameter (the fit
        stage turns this on, ``[fit] profile``)
        (``stderr_low``, ``stderr_high``; :func:`pendtrack.fitting.polish.profile_sigmas`), two
        constrained refits per side; they show where the cost is not quadratic.
    simulator : callable, optional
        ``simulate(model, params, t, *, theta0, omega0, memory_s, method)``; default the models
        package's numba hot path.
    method : str
        Simulator method (only used with a custom ``simulator``).
    on_progress : callable, optional
        Called with 1 after each start (and each bootstrap refit).
    source : str
        Name of the data in error messages.

    Returns
    -------
    FitResult

    Raises
    ------
    FitError
        Too few samples, none usable, no oscillation, time stamps not uniform, bad options.
    """
    t0_wall = time.perf_counter()
    if cost not in COSTS:
        raise FitError(f"unknown cost '{cost}' (use {' or '.join(COSTS)})", path=source)
    if n_starts < 1:
        raise FitError(f"n_starts must be >= 1, got {n_starts}", path=source)
    if accept_ratio < 1:
        raise FitError(f"accept_ratio must be >= 1, got {accept_ratio}", path=source)
    t = np.asarray(t, dtype=float)
    theta = np.asarray(theta, dtype=float)
    omega = np.asarray(omega, dtype=float)
    mask = _usable(t, theta, omega, ok, window, source)
    if alpha is None:
        alpha = np.gradient(omega, t)
    alpha = np.asarray(alpha, dtype=float)
    mask &= np.isfinite(alpha)
    obs = observation or Observation()
    moments = None
    if obs.savgol_window:
        from pendtrack.kinematics.analysis import savgol_bias_moments

        h_data = float(np.median(np.diff(t[mask]))) if mask.sum() > 1 else 1.0
        moments = savgol_bias_moments(obs.savgol_window, obs.savgol_order, h_data)
    summary = summarize(t[mask], theta[mask], omega[mask], alpha[mask], sg_moments=moments, source=source)
    problem = build_problem(model, t, theta, omega, ok=mask, cost=cost, omega0_hat=summary.omega0_hat,
                            observation=obs, memory_s=memory_s, full_history=full_history, simulator=simulator,
                            method=method, source=source)
    n_fit = len(problem.all_names) - len(fixed or {})
    if problem.n < max(3 * n_fit, 60):
        raise FitError(f"too few usable samples to fit model '{model.name}' ({problem.n})", path=source)

    grid, (th_g, om_g), present = _uniform_series(problem, t, [theta, omega], mask)
    est = equation_error_estimates(model, grid, th_g, om_g, omega0_hat=summary.omega0_hat,
                                   memory_s=memory_s, full_history=full_history, use=present)
    center = _center(model, est, summary, initial)
    if fixed:
        problem = problem.with_fixed(fixed)
    names = problem.names
    x_center = np.array([center[n] for n in names])
    floors = {n: _floor(model, n, summary.omega0_hat) for n in model.param_names}
    half = _half_widths(names, x_center, est.scales, problem.t_start, start_spread=start_spread,
                        omega0_spread=omega0_spread, floors=floors)
    typical = np.array([max(abs(c), h, floors.get(n, 0.0)) for n, c, h in zip(names, x_center, half)])
    problem = replace(problem, typical=typical)
    starts = draw_starts(x_center, half, problem.lower, problem.upper, n_starts, seed)
    first_end = summary.first_window_end(problem.t_start, FIRST_WINDOW_HALF_SWINGS)
    ends = window_ladder(problem.t_start, problem.t_end, first_end) if ladder else (problem.t_end,)

    outcomes = run_starts(problem, starts, ends, workers=workers, max_nfev=start_budget, on_progress=on_progress)
    xs = np.array([o.x for o in outcomes])
    costs = np.array([o.cost if np.isfinite(o.cost) else np.inf for o in outcomes])
    best_i = int(np.argmin(costs))
    best = outcomes[best_i]
    u_paper, accepted = U.paper_uncertainty(xs, costs, accept_ratio)
    if not best.success:  # only the winner needs the last digits: continue it with a larger budget
        more = local_fit(problem, best.x, (problem.t_end,), index=best.index, max_nfev=POLISH_ITERATIONS,
                         central=True)
        if more.cost <= best.cost:
            best = more
            costs[best_i] = more.cost

    if PROFILE_ALONG in names and len(names) > 1:  # the memory term's sloppy valley: finish along it
        polished = profile_polish(problem, best, PROFILE_ALONG)
        if polished.cost < best.cost:
            best = polished
            costs[best_i] = polished.cost

    x = best.x
    r = problem.residuals(x)
    jac = problem.jacobian(x, central=True)
    cov, lag = U.hac_covariance(jac, r, problem.n)
    se = U.stderr_from_cov(cov)
    # smoothness check: the sandwich of the parameters inside their bounds, with 10x larger steps,
    # must agree (it does for smooth solvers; the fractional model's quarter-power friction makes
    # the trajectories rough in the parameters, and then local standard errors mean little)
    inner = (x > problem.lower) & (x < problem.upper)
    step_spread = 0.0
    if inner.any():
        se_in, _ = U.hac_covariance(jac[:, inner], r, problem.n, lag=lag)
        wide = problem.jacobian(x, central=True, rel=10 * FD_REL)
        se_wide, _ = U.hac_covariance(wide[:, inner], r, problem.n, lag=lag)
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = np.abs(np.log(U.stderr_from_cov(se_wide) / U.stderr_from_cov(se_in)))
        step_spread = float(np.max(ratio)) if np.all(np.isfinite(ratio)) else math.inf
    rough = not (step_spread <= math.log(1.3))
    se_naive = U.stderr_from_cov(U.naive_covariance(jac, r))
    u_region = U.region_halfwidth(jac, best.cost, accept_ratio)
    se_low = np.full(x.size, np.nan)
    se_high = np.full(x.size, np.nan)
    if profile:
        se_low, se_high = profile_sigmas(problem, x, float(best.cost), cov, se_naive,
                                         [nm for nm in names if nm not in STATE_NAMES])
    se_boot = np.full(x.size, np.nan)
    if bootstrap > 0:
        se_boot = _bootstrap(problem, x, bootstrap, max(lag, obs.savgol_window, 1), seed, workers, on_progress)

    theta_m, _ = problem.model_at_data(x)
    rms = float(np.sqrt(np.mean((problem.theta - theta_m) ** 2)))
    n = problem.n
    k = x.size
    xi2 = float(best.cost)
    aic = n * math.log(xi2) + 2 * k if xi2 > 0 else -math.inf
    bic = n * math.log(xi2) + k * math.log(n) if xi2 > 0 else -math.inf
    follows = rms <= 0.5 * float(np.std(problem.theta))
    cov_ok = bool(np.all(np.isfinite(se)))
    converged = bool(best.success and cov_ok and follows)
    reasons = []
    if not best.success:
        reasons.append(f"optimiser: {best.message}")
    if not cov_ok:
        reasons.append("singular Jacobian (a parameter is not determined by the data)")
    if not follows:
        reasons.append(f"the model does not follow the oscillation (rms {rms:.3g} rad)")
    notes = []
    if rough and cov_ok:
        notes.append(f"standard errors unreliable: they change by a factor {math.exp(step_spread):.2g} with the "
                     "finite-difference step (the solver is not smooth in the parameters)")

    values = problem.full(x)
    fitted = dict(zip(names, range(k)))
    estimates_full = {**est.values, "theta0": summary.theta_init, "omega0": summary.omega_init}

    def pe(name: str) -> ParamEstimate:
        if name not in fitted:
            return ParamEstimate(value=values[name], stderr=0.0, u_paper=0.0, u_region=0.0, stderr_naive=0.0,
                                 estimate=estimates_full.get(name, math.nan), fixed=True)
        j = fitted[name]
        return ParamEstimate(value=float(x[j]), stderr=float(se[j]), u_paper=float(u_paper[j]),
                             u_region=float(u_region[j]), stderr_naive=float(se_naive[j]),
                             stderr_bootstrap=float(se_boot[j]), stderr_low=float(se_low[j]),
                             stderr_high=float(se_high[j]), estimate=float(estimates_full.get(name, math.nan)))

    return FitResult(
        model=str(model.name),
        params={nm: pe(nm) for nm in model.param_names},
        initial_state={nm: pe(nm) for nm in STATE_NAMES},
        xi2_min=xi2, rms=rms, aic=aic, bic=bic, n=n, converged=converged,
        runtime_s=time.perf_counter() - t0_wall, seed=int(seed), cost=cost,
        window=(problem.t_start, float(problem.t[-1])), omega0_hat=summary.omega0_hat,
        n_starts=len(outcomes), n_accepted=int(accepted.sum()), accept_ratio=float(accept_ratio),
        hac_lag=int(lag), covariance=cov, fitted_names=names, start_costs=costs, memory_s=float(memory_s),
        full_history=bool(full_history),
        message="; ".join(reasons + notes) if reasons else "; ".join([best.message] + notes),
        stderr_reliable=not rough,
    )


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


def _bootstrap(problem: FitProblem, x: np.ndarray, n_boot: int, block: int, seed: int, workers: int,
               on_progress: Callable[[int], None] | None) -> np.ndarray:
    """Standard deviation of block-bootstrap refits started at the best fit."""
    problems = U.bootstrap_problems(problem, x, n_boot, block, seed + 1)
    tasks = [(p, x, (problem.t_end,)) for p in problems]
    outs = run_tasks(tasks, workers=workers, on_progress=on_progress)
    xb = np.array([o.x for o in outs if np.isfinite(o.cost)])
    if xb.shape[0] < 2:
        return np.full(x.size, np.nan)
    return xb.std(axis=0, ddof=1)


__all__ = ["build_problem", "check_record", "fit_model"]
