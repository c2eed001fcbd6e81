"""Finish the best fit along a sloppy valley: minimise the profile cost over one parameter.

The fractional model's cost has one very weak direction, mostly G2 and beta (the memory
term's amplitude and order trade off; with Omega0 and G1 following). The Jacobian's scaled
singular values span 1.6e5, so a Levenberg-Marquardt run crawls along the curved valley
floor and its "converged" point can sit 2-5 standard errors up the valley, with a cost only
~1e-4 relative above the minimum. Holding beta fixed the rest is ~50x better conditioned
and converges in a few steps, so the minimum is found as a one-dimensional problem: the
profile cost ``c(beta) = min over the others`` is minimised by Brent's method
(:func:`scipy.optimize.minimize_scalar`), each inner fit warm-started from the nearest one
already done, and a last free fit starts from the profile minimum.
"""

from __future__ import annotations

import math
from concurrent.futures import Executor

import numpy as np
from scipy.optimize import minimize_scalar

from pendtrack.fitting.leastsq.local_fits import StartOutcome, local_fit
from pendtrack.fitting.leastsq.problem import FitProblem

PROFILE_XTOL = 2e-4  # Brent's tolerance on the profiled parameter (beta's standard error is ~3e-2)
PROFILE_BRACKET = 0.02  # first bracket half-width; Brent's bracketing walks downhill from it
# the profile cost is first read on this fixed grid (fractions of the parameter's range), walking out from
# the best start: Brent's method then starts in the basin of the lowest point. The profile over beta can
# have two minima (a 40-s 30-fps memory record: beta 0.09 and 0.71, 3.5e-4 apart in cost), and a descent
# from the best start alone ended in either, as the rounding of the start's own fit decided
PROFILE_GRID = (0.1, 0.3, 0.5, 0.7, 0.9)
PROFILE_MAX_INNER = 45  # inner fits at most (the grid's 5, Brent ~15-25)
INNER_ITERATIONS = 30  # budget of each inner fit, in Jacobians' worth
SLIP_RATIO = 1.5  # an inner fit ending above this times the best cost has slipped a period


def profile_polish(problem: FitProblem, best: StartOutcome, along: str) -> StartOutcome:
    """The best of ``best`` and a fit finished by minimising the profile cost over ``along``.

    Parameters
    ----------
    problem : FitProblem
        The whole-window problem.
    best : StartOutcome
        The best start so far (its ``x`` in ``problem.names`` order).
    along : str
        The parameter to profile over (a fitted name with finite bounds, e.g. ``"beta"``).

    Returns
    -------
    StartOutcome
        Never worse than ``best`` (same ``index``); ``nfev`` counts every evaluation.
    """
    names = list(problem.names)
    if along not in names:
        return best
    j = names.index(along)
    lo, hi = float(problem.lower[j]), float(problem.upper[j])
    rest = [i for i in range(len(names)) if i != j]
    done: dict[float, tuple[float, np.ndarray]] = {}
    calls = [0]

    def warm_start(value: float) -> np.ndarray:
        """The others at ``value``: interpolated along the valley floor through the two nearest
        good inner fits (extrapolated beyond them), or the nearest one, or the best start."""
        good = sorted((v for v, (c, _) in done.items() if c <= SLIP_RATIO * best.cost), key=lambda v: abs(v - value))
        if len(good) >= 2 and good[0] != good[1]:
            (va, xa), (vb, xb) = ((v, done[v][1]) for v in good[:2])
            return np.clip(xa + (xb - xa) * (value - va) / (vb - va), problem.lower[rest], problem.upper[rest])
        return done[good[0]][1] if good else best.x[rest]

    def profile(value: float) -> float:
        value = min(max(float(value), lo), hi)
        if value in done:
            return done[value][0]
        if len(done) >= PROFILE_MAX_INNER:
            return math.inf
        sub = problem.with_fixed({along: value})
        out = local_fit(sub, warm_start(value), (problem.t_end,), max_nfev=INNER_ITERATIONS)
        calls[0] += out.nfev
        if not out.cost <= SLIP_RATIO * best.cost:  # a phase slip: once more from the best start
            again = local_fit(sub, best.x[rest], (problem.t_end,), max_nfev=INNER_ITERATIONS)
            calls[0] += again.nfev
            out = again if again.cost < out.cost else out
        cost = out.cost if np.isfinite(out.cost) else math.inf
        done[value] = (cost, out.x)
        return cost

    b0 = min(max(float(best.x[j]), lo), hi)
    profile(b0)
    grid = [lo + f * (hi - lo) for f in PROFILE_GRID] if math.isfinite(hi - lo) else []
    for g in [g for g in grid if g > b0] + sorted((g for g in grid if g < b0), reverse=True):
        profile(g)  # outwards from b0 on each side: each inner fit warm-started along the valley
    b0 = min(done, key=lambda v: done[v][0])
    b1 = b0 + PROFILE_BRACKET if b0 + PROFILE_BRACKET <= hi else b0 - PROFILE_BRACKET
    try:  # two starting points: Brent's bracketing walks downhill from them
        res = minimize_scalar(profile, bracket=(b0, b1),
                              options={"xtol": PROFILE_XTOL / max(abs(b0), 1.0), "maxiter": PROFILE_MAX_INNER})
        b_star = min(max(float(res.x), lo), hi)
    except (ValueError, FloatingPointError, ArithmeticError):
        return best
    if b_star not in done:
        profile(b_star)
    if not done:
        return best
    b_star = min(done, key=lambda v: done[v][0])
    x_star = np.empty_like(best.x)
    x_star[j] = b_star
    x_star[rest] = done[b_star][1]
    final = local_fit(problem, x_star, (problem.t_end,), index=best.index)
    nfev = best.nfev + calls[0] + final.nfev
    if not final.cost <= best.cost:
        return StartOutcome(index=best.index, x0=best.x0, x=best.x, cost=best.cost, success=best.success,
                            nfev=nfev, message=best.message)
    return StartOutcome(index=best.index, x0=best.x0, x=final.x, cost=final.cost, success=final.success,
                        nfev=nfev, message=f"{final.message} (after a profile over {along})")


PROFILE_STEPS = 2  # inner fits per side of each parameter: at +-stderr, then at the refined point


def profile_sigmas(problem: FitProblem, x: np.ndarray, cost: float, cov: np.ndarray, naive: np.ndarray,
                   params: list[str], *, executor: Executor | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Profile-likelihood standard errors below and above the best fit, per parameter.

    For parameter j the profile cost ``c_j(v) = min over the others`` is compared with the
    one-standard-error rise a quadratic cost would show, ``dc* = s^2 (stderr_j / naive_j)^2``:
    ``s^2 = cost / (m - p)`` is the residual variance and ``(stderr/naive)^2`` the
    autocorrelation inflation of the sandwich (in a linear model ``c_j(x_j +- stderr_j) - cost
    = dc*`` exactly). The sigma on each side is where ``sqrt(c_j - cost)`` reaches
    ``sqrt(dc*)``, found by the secant through the best fit (where it is 0) and the last inner
    fit; :data:`PROFILE_STEPS` inner fits per side, the first at ``x_j +- stderr_j``. Each
    inner fit starts on the valley floor as the covariance predicts it (the others moved by
    ``cov[:, j] / cov[j, j]`` times the change of x_j), so it does not have to crawl there. On
    a curved valley the two sides differ, and both differ from ``stderr``.

    Parameters
    ----------
    problem : FitProblem
        The whole-window problem; ``x`` its best fit (``problem.names`` order), ``cost`` there.
    cov : ndarray
        Sandwich covariance of the fitted vector (its diagonal: the squared ``stderr``).
    naive : ndarray
        Textbook standard errors of every fitted parameter.
    params : list of str
        The names to profile (others get NaN).
    executor : Executor, optional
        Worker processes (a fit stage's search pool) to run the sides in (:func:`profile_side`
        each); the same sigmas as in this process.

    Returns
    -------
    low, high : ndarray
        Standard-error equivalents below and above the value [parameter units]; ``inf`` where
        the profile stays flat, NaN where not computed or where the value sits on its bound
        on that side.
    """
    names = list(problem.names)
    m = problem.residuals(x).size
    s2 = cost / max(m - len(names), 1)
    stderr = np.sqrt(np.abs(np.diag(cov)))
    low = np.full(len(names), np.nan)
    high = np.full(len(names), np.nan)
    sides = []
    for name in params:
        if name not in names:
            continue
        j = names.index(name)
        if not (np.isfinite(stderr[j]) and np.isfinite(naive[j]) and stderr[j] > 0 and naive[j] > 0):
            continue
        target = math.sqrt(s2) * stderr[j] / naive[j]  # sqrt(dc*)
        for side, out in ((-1.0, low), (1.0, high)):
            sides.append((out, j, (problem, x, cost, cov[:, j] / cov[j, j], j, side, float(stderr[j]), target)))
    if executor is not None and len(sides) > 1:  # each side's inner fits are independent of the others'
        futures = [executor.submit(profile_side, *args) for _, _, args in sides]
        sigmas = [f.result() for f in futures]
    else:
        sigmas = [profile_side(*args) for _, _, args in sides]
    for (out, j, _), sigma in zip(sides, sigmas):
        out[j] = sigma
    return low, high


def profile_side(problem: FitProblem, x: np.ndarray, cost: float, shift: np.ndarray, j: int, side: float,
                 stderr: float, target: float) -> float:
    """The profile sigma of parameter ``j`` on one side (``side`` -1 below, +1 above): :func:`profile_sigmas`'s
    inner fits for it (a module-level function, so a worker process can run it).

    ``shift``: ``cov[:, j] / cov[j, j]``, the valley floor's slope; ``target``: ``sqrt(dc*)``.
    """
    names = list(problem.names)
    name = names[j]
    rest = [i for i in range(len(names)) if i != j]
    room = (x[j] - problem.lower[j]) if side < 0 else (problem.upper[j] - x[j])
    delta = min(stderr, 0.999 * float(room))
    sigma = math.nan
    for _ in range(PROFILE_STEPS):
        if not delta > 0:
            sigma = math.nan if room <= 0 else sigma  # on its bound: no interval that side
            break
        v = float(x[j] + side * delta)
        x0 = np.clip(x + shift * (side * delta), problem.lower, problem.upper)[rest]
        inner = local_fit(problem.with_fixed({name: v}), x0, (problem.t_end,), max_nfev=INNER_ITERATIONS)
        rise = math.sqrt(max(float(inner.cost) - cost, 0.0))
        if not (np.isfinite(inner.cost) and rise > 0):
            return math.inf
        sigma = delta * target / rise  # secant of sqrt(rise) through the best fit
        if abs(sigma / delta - 1.0) < 0.1:
            break
        delta = min(sigma, 0.999 * float(room))
    return sigma
