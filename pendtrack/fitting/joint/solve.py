"""A joint fit of one model over several runs: estimate -> search -> refine -> uncertainty -> result.

1. **estimate**: each run is fitted alone (:func:`pendtrack.fitting.fitter.fit_setup`, the whole
   single-run fit with its own data-derived estimates and starts); its problem and values are kept.
2. **search**: starts from those fits, never from a truth -- start 0 the pooled values (each joint
   parameter the inverse-variance weighted mean of its runs' own values), then one start per run
   (each group's parameters at that run's own values), then ``[fit] joint_starts`` seeded draws
   within the spread of the runs' values; from each the single-run Levenberg-Marquardt ladder
   (:func:`pendtrack.fitting.leastsq.local_fits.local_fit`) on the stacked problem
   (:class:`~pendtrack.fitting.joint.stacked.StackedProblem`), windows grown over every run at once.
3. **refine**: the best start continued with a larger budget and central differences if its own
   budget ran out.
4. **uncertainty**: the sandwich covariance ``B^-1 (S_1 + ... + S_R) B^-1`` with ``B = J^T J`` of
   the stacked residuals and ``S_i`` run ``i``'s Newey-West meat (:func:`pendtrack.fitting.
   uncertainty.hac_meat`: autocorrelated within a run, independent between runs); the paper's 5/4
   spread over the starts.
5. **result**: :class:`~pendtrack.fitting.joint.outcome.JointFit`.
"""

from __future__ import annotations

import math
import time
from dataclasses import replace
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from pendtrack.config import FitConfig, ModelsConfig
from pendtrack.errors import FitError
from pendtrack.fitting.estimate import estimate
from pendtrack.fitting.fitter import check_options, fit_setup
from pendtrack.fitting.joint.outcome import JointFit, build_joint
from pendtrack.fitting.joint.scopes import STATE_NAMES, column_label, group_of, resolve_scopes
from pendtrack.fitting.joint.stacked import StackedProblem, stack
from pendtrack.fitting.leastsq.local_fits import StartOutcome, inside_bounds, local_fit, run_tasks, window_ladder
from pendtrack.fitting.leastsq.samples import Record
from pendtrack.fitting.refine import POLISH_ITERATIONS
from pendtrack.fitting.result import FitResult
from pendtrack.fitting.search import ladder_growth
from pendtrack.fitting.uncertainty import (filter_support, hac_meat, naive_covariance, paper_uncertainty,
                                           region_halfwidth, sandwich)
from pendtrack.fitting.uncertainty import stderr_from_cov
from pendtrack.parallel import ProcessPool

SPREAD_SE = 2.0  # a random start's half-width is at least this many of the runs' own standard errors


def fit_joint(model: Any, records: Mapping[str, Record], *, sharing: Mapping[str, str] | None = None,
              labels: Mapping[str, Mapping[str, str]] | None = None, options: FitConfig | None = None,
              model_options: ModelsConfig | None = None, seed: int | None = None, workers: int | None = None,
              pool: ProcessPool | None = None, initial: Mapping[str, Mapping[str, float]] | None = None,
              extra_starts: Mapping[str, Sequence[Mapping[str, float]]] | None = None,
              singles: Mapping[str, FitResult] | None = None) -> JointFit:
    """Fit ``model`` to several runs of one pendulum at once (module docstring).

    Parameters
    ----------
    model : Model
        From :func:`pendtrack.models.get_model` or :func:`~pendtrack.models.compose`.
    records : mapping
        Run id -> its :class:`~pendtrack.fitting.leastsq.samples.Record` (times [s], angle [rad],
        angular velocity [rad/s], filter, usable samples); at least two.
    sharing : mapping, optional
        Parameter name -> scope (``"shared"``, ``"run"``, ``"tile+alley"``, ...), overriding the
        defaults (:mod:`pendtrack.fitting.joint.scopes`).
    labels : mapping, optional
        Run id -> its run-code labels (``tile``, ``launched``, ``alley``); the defaults follow the
        paper's run codes when every run has them.
    options : FitConfig, optional
        ``[fit]``: each run's own fit (``n_starts``, ...), ``joint_starts``, ``start_budget``,
        ``ladder``, ``accept_ratio``; default ``FitConfig()``.
    model_options : ModelsConfig, optional
        ``[models]`` (memory); default ``ModelsConfig()``.
    seed, workers : int, optional
        Seed of the start draws and processes (0 = all cores); default the options'.
    pool : ProcessPool, optional
        Worker processes for the runs' own fits, kept by the caller.
    initial, extra_starts : mapping, optional
        Run id -> a warm start of that run's own fit (parameters and ``theta0``/``omega0``), and
        further complete starts of it (:func:`pendtrack.fitting.fit_model`'s ``initial`` and
        ``extra_starts``): discovery across runs starts a candidate from the current model's fits.
    singles : mapping, optional
        Run id -> that run already fitted alone with this model on this record (a
        :class:`~pendtrack.fitting.result.FitResult`): its own fit is not repeated.

    Returns
    -------
    JointFit

    Raises
    ------
    FitError
        Fewer than two runs, a run the single fit refuses (named), a bad sharing declaration.
    """
    t_wall = time.monotonic()
    options = FitConfig() if options is None else options
    model_options = ModelsConfig() if model_options is None else model_options
    seed = options.seed if seed is None else seed
    workers = options.workers if workers is None else workers
    check_options(options, source="the joint fit")
    # the runs in the order of their ids, not of the arguments: the starts, the joint vector and so the
    # search's path follow this order (given in another order, a 12-run series once stopped on its refine
    # budget where the sorted order converged, at the same minimum)
    runs = tuple(sorted(records))
    if len(runs) < 2:
        raise FitError(f"a joint fit needs at least two records, got {len(runs)}")
    labels = {r: dict((labels or {}).get(r) or {}) for r in runs}
    scopes = resolve_scopes(model, sharing, labels=labels)

    given, singles = singles, {}
    problems = []
    for run in runs:
        setup = estimate(model, records[run], options=options, model_options=model_options,
                         initial=(initial or {}).get(run))
        if given and run in given:
            singles[run] = given[run]
        else:
            singles[run] = fit_setup(setup, options=options, model_options=model_options, seed=seed,
                                     workers=workers, pool=pool, extra_starts=tuple((extra_starts or {}).get(run, ())))
        problems.append(setup.problem)
    labels_of = [{n: column_label(n, group_of(scopes[n], run, labels[run])) for n in p.names}
                 for run, p in zip(runs, problems)]
    stacked = stack(runs, tuple(problems), labels_of)

    starts = joint_starts(stacked, [singles[r] for r in runs], n_random=options.joint_starts, seed=seed)
    first = max(_first_window(singles[r]) for r in runs)
    ends = (window_ladder(0.0, stacked.t_end, first, growth=ladder_growth(model, options)) if options.ladder
            else (stacked.t_end,))
    outcomes = run_tasks([(stacked, x0, ends) for x0 in starts], workers=workers, max_nfev=options.start_budget)
    costs = np.array([o.cost if np.isfinite(o.cost) else np.inf for o in outcomes])
    best = outcomes[int(np.argmin(costs))]
    if not best.success:  # continued with a larger budget (the single fit's refine step, continuation)
        more = local_fit(stacked, best.x, (stacked.t_end,), index=best.index, max_nfev=POLISH_ITERATIONS,
                         central=True)
        if more.cost <= best.cost:
            best = more
    xs = np.array([o.x for o in outcomes])
    costs[int(np.argmin(costs))] = best.cost  # the refined best
    u_paper, accepted = paper_uncertainty(xs, costs, options.accept_ratio)
    axle = [(records[r].theta_scale_rel, records[r].zero_sigma_rad) for r in runs]
    cov, lags, se_naive, u_region, axle_cov = joint_covariance(stacked, best, accept_ratio=options.accept_ratio,
                                                               axle=axle)
    low = high = None
    if options.profile:
        low, high = joint_profile_sigmas(stacked, best, cov - axle_cov, se_naive, axle_cov, pool=pool)
    return build_joint(model, stacked, best, singles=singles, scopes=scopes, labels=labels, covariance=cov,
                       axle_covariance=axle_cov, hac_lags=lags, u_paper=u_paper, stderr_naive=se_naive,
                       u_region=u_region, stderr_low=low, stderr_high=high,
                       n_accepted=int(accepted.sum()), start_costs=costs, options=options, seed=seed,
                       runtime_s=time.monotonic() - t_wall)


def _first_window(single: FitResult) -> float:
    """The first window of the joint ladder for a run: three of its periods [s]."""
    return 3.0 * 2.0 * math.pi / max(single.omega0_hat, 1e-9)


def _run_value(single: FitResult, name: str) -> tuple[float, float]:
    """A run's own value and standard error of a fitted name."""
    est = single.params.get(name) or single.initial_state[name]
    return float(est.value), float(est.stderr)


def joint_starts(stacked: StackedProblem, singles: Sequence[FitResult], *, n_random: int, seed: int) -> np.ndarray:
    """The joint starts, from the runs' own fits only (module docstring, step 2).

    Returns
    -------
    ndarray, shape (1 + n_runs + n_random, p)
        The pooled values; then per run, the pooled values with every column of that run at its own
        values; then the seeded draws, uniform within each column's half-width (half the range of its
        runs' values, at least :data:`SPREAD_SE` of their smallest standard error).
    """
    p = len(stacked.names)
    values: list[list[float]] = [[] for _ in range(p)]
    errors: list[list[float]] = [[] for _ in range(p)]
    for i, single in enumerate(singles):
        for name, j in zip(stacked.problems[i].names, stacked.columns[i]):
            v, se = _run_value(single, name)
            values[j].append(v)
            errors[j].append(se)
    center = np.empty(p)
    half = np.empty(p)
    for j in range(p):
        v, se = np.array(values[j]), np.array(errors[j])
        good = np.isfinite(se) & (se > 0)
        center[j] = float(np.sum(v[good] / se[good] ** 2) / np.sum(1.0 / se[good] ** 2)) if good.any() \
            else float(np.median(v))
        floor = SPREAD_SE * float(se[good].min()) if good.any() else 0.0
        half[j] = max(0.5 * float(v.max() - v.min()), floor)
    rows = [center]
    for i, single in enumerate(singles):
        x = center.copy()
        for name, j in zip(stacked.problems[i].names, stacked.columns[i]):
            x[j] = _run_value(single, name)[0]
        rows.append(x)
    rng = np.random.default_rng(seed)
    for _ in range(n_random):
        rows.append(center + half * rng.uniform(-1.0, 1.0, p))
    return inside_bounds(np.array(rows), stacked.lower, stacked.upper)


def joint_covariance(stacked: StackedProblem, best: StartOutcome, *, accept_ratio: float,
                     axle: Sequence[tuple[float, float]] | None = None
                     ) -> tuple[np.ndarray, list[int], np.ndarray, np.ndarray, np.ndarray]:
    """Covariance of the joint vector: the sandwich with one Newey-West meat per run (module docstring, step 4)
    plus the share of every run's axle (:func:`axle_covariance`).

    Parameters
    ----------
    axle : sequence of (float, float), optional
        Per run (``stacked.runs`` order), the relative uncertainty of theta's scale [1] and of its
        zero [rad] (:class:`~pendtrack.fitting.leastsq.samples.Record`'s ``theta_scale_rel``,
        ``zero_sigma_rad``); None: none.

    Returns
    -------
    covariance : ndarray, shape (p, p)
        The sandwich plus ``axle_covariance``.
    lags : list of int
        Each run's truncation lag of the sandwich's meat [samples].
    stderr_naive, u_region : ndarray
        The textbook standard errors and the 5/4 region's half-widths (comparison only).
    axle_covariance : ndarray, shape (p, p)
        The axles' share alone.
    """
    x = best.x
    r = stacked.residuals(x)
    jac = stacked.jacobian(x, central=True, method="fd")  # as the single fit's sandwich: central differences
    meat = np.zeros((x.size, x.size))
    lags = []
    for i, p in enumerate(stacked.problems):
        rows = stacked.rows[i]
        m, lag = hac_meat(jac[rows], r[rows], p.n, min_flat=filter_support(p))
        meat += m
        lags.append(int(lag))
    cov = sandwich(jac.T @ jac, meat)
    axle_cov = axle_covariance(stacked, x, jac, axle or [(0.0, 0.0)] * len(stacked.problems))
    return (cov + axle_cov, lags, stderr_from_cov(naive_covariance(jac, r)),
            region_halfwidth(jac, best.cost, accept_ratio), axle_cov)


def joint_profile_sigmas(stacked: StackedProblem, best: StartOutcome, sandwich: np.ndarray, naive: np.ndarray,
                         axle_cov: np.ndarray, *, pool: ProcessPool | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The profile-likelihood sigmas below and above each joint model parameter (the single fit's ``[fit] profile``).

    :func:`pendtrack.fitting.leastsq.profile.profile_sigmas` on the stacked problem (each inner fit
    holds one joint column, in every run using it: :meth:`StackedProblem.with_fixed`), from the
    sandwich alone; the axles' share (:func:`axle_covariance`) is then added in quadrature, as to
    ``stderr``. The runs' initial states and offsets are not profiled (NaN).

    Returns
    -------
    low, high : ndarray
        In the joint vector's order [parameter units].
    """
    from pendtrack.fitting.leastsq.profile import profile_sigmas

    profiled = [label for label in stacked.names if label.split("@", 1)[0] not in (*STATE_NAMES, "theta_off")]
    low, high = profile_sigmas(stacked, best.x, float(best.cost), sandwich, naive, profiled,  # type: ignore[arg-type]
                               executor=pool)
    share = np.sqrt(np.clip(np.diag(axle_cov), 0.0, None))
    return np.hypot(low, share), np.hypot(high, share)


def axle_covariance(stacked: StackedProblem, x: np.ndarray, jac: np.ndarray,
                    axle: Sequence[tuple[float, float]]) -> np.ndarray:
    """The joint vector's covariance from the runs' axles, which the residuals cannot show.

    Each run's angle is measured about its own fitted axle, so its error is one number for every
    sample of the run: a scale (the axle off along the radius) and, for a run whose zero is fitted
    (``theta_off``), a zero (the axle off sideways). Independent between runs (each video's axle
    is fitted alone), each moves the joint minimum by the Gauss-Newton step of the data's change,
    ``dx_i = -(J^T J)^-1 J^T dr_i`` (:func:`pendtrack.fitting.uncertainty.scale_shift`, the single
    fit's twin), and the covariance is the sum of ``dx_i dx_i^T`` over the runs and both errors.
    Shared values gather the shifts of every run; a run's own values mostly its own.

    Parameters
    ----------
    stacked : StackedProblem
    x : ndarray
        The fitted joint vector.
    jac : ndarray
        :meth:`StackedProblem.jacobian` at ``x``.
    axle : sequence of (float, float)
        Per run, theta's relative scale uncertainty [1] and its zero's [rad].

    Returns
    -------
    ndarray, shape (p, p)
        Zero where no run's axle is uncertain; a parameter on a bound gets none (a refit could not
        leave the bound either).
    """
    p = x.size
    out = np.zeros((p, p))
    free = (x > stacked.lower) & (x < stacked.upper)
    if not free.any():
        return out
    pinv: np.ndarray | None = None
    for i, (prob, (scale, zero)) in enumerate(zip(stacked.problems, axle)):
        changed = []
        if math.isfinite(scale) and scale > 0:
            changed.append(replace(prob, theta=prob.theta * (1.0 + scale), omega=prob.omega * (1.0 + scale)))
        if math.isfinite(zero) and zero > 0 and "theta_off" in prob.names:
            changed.append(replace(prob, theta=prob.theta + zero))
        if not changed:
            continue
        xi = stacked.run_x(x, i)
        base = prob.residuals(xi)
        if pinv is None:
            if not np.all(np.isfinite(jac[:, free])):
                return np.full((p, p), np.nan)
            pinv = np.linalg.pinv(jac[:, free])
        for moved in changed:
            dr = np.zeros(jac.shape[0])
            dr[stacked.rows[i]] = stacked.weights[i] * (moved.residuals(xi) - base)
            dx = np.zeros(p)
            dx[free] = -(pinv @ dr)
            out += np.outer(dx, dx)
    return out
