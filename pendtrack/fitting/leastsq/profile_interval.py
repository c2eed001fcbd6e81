"""The 95 % intervals of a model with memory: the sandwich's, widened by profile scans.

The fractional model's estimates have tails along its beta-G2-p_f valley that the curvature at
the best fit does not show (benchmarks/bench_coverage.py, 800 seeded 60-s records: the sandwich's
95 % intervals hold the truth 88-95 % of the time; beta estimated high carries G1 and p_f high
with it, beta estimated low carries G2 low; the valley's profile is flatter on one side than the
other and can hold a second, near-equal minimum).

:func:`scan_valley` reads a parameter's profile cost ``c(v) = min over the others`` outwards from
the best fit, one sandwich standard error at a time, into a :class:`ProfileScan`. With
``D = (c(v) - c_min) / dc*``, ``dc* = s^2 (stderr / naive)^2`` the rise of a quadratic cost at one
standard error (as for the profile sigmas: ``s^2`` the residual variance, ``(stderr / naive)^2``
the sandwich's autocorrelation inflation), :func:`scan_intervals` takes the hull of

* ``value +- z stderr``;
* each scanned parameter's own likelihood-ratio set ``{v : D(v) <= z^2}`` (:func:`lr_ends`);
* every parameter's set along beta's valley (:func:`valley_ends`): the profile of a
  two-parameter quadratic in beta and the parameter, beta's part replaced by beta's scan.

On a quadratic cost all three are ``value +- z stderr``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from pendtrack.fitting.leastsq.local_fits import local_fit
from pendtrack.fitting.leastsq.problem import FitProblem

SCAN_ALONG = "beta"  # the memory models' sloppy valley is scanned along this (as refine's profile polish)
SCAN_STEPS = 6  # inner fits per side at most, one sandwich standard error apart (a flat side: most stop at 2-3)
SCAN_ITERATIONS = 30  # budget of each inner fit, in Jacobians' worth (a warm start on the valley floor)
SCAN_SLIP = 1.5  # an inner fit ending above this times the best cost has slipped a period: tried again
SCAN_BEYOND = 1.959964  # a side stops once sqrt(D) passes this (the 95 % set's edge is then bracketed)
VALLEY_GRID = 401  # points on which beta's D is read between scanned values for the sets along its valley


@dataclass(frozen=True, eq=False)
class ProfileScan:
    """The profile cost over one parameter, as an inner fit at each value left it.

    Attributes
    ----------
    along : int
        Index of the profiled parameter in the fitted vector.
    xs : ndarray
        ``(k, p)``: the fitted vector at each scanned value (the profiled one at column ``along``).
    costs : ndarray
        ``(k,)``: the cost of each inner fit (``inf`` where it failed).
    """

    along: int
    xs: np.ndarray
    costs: np.ndarray


def lr_ends(scan: ProfileScan, *, x: np.ndarray, cost: float, rise: float, z: float) -> tuple[float, float]:
    """The ends of the scanned parameter's likelihood-ratio set ``{v : D(v) <= z^2}`` (its hull where it is
    not one piece), ``sqrt(D)`` followed linearly between scanned values to where it crosses ``z``.

    ``rise``: ``dc*`` of the scanned parameter (:func:`one_se_rise`); ``x``, ``cost``: the best fit.
    """
    j = scan.along
    v = np.append(scan.xs[:, j], x[j])
    root = _root_d(np.append(scan.costs, cost), cost, rise)
    order = np.argsort(v, kind="stable")
    v, root = v[order], root[order]
    inside = root <= z
    ends = list(v[inside])
    for a in range(len(v) - 1):
        if inside[a] != inside[a + 1]:  # the set's edge between two scanned values
            i, o = (a, a + 1) if inside[a] else (a + 1, a)
            f = (z - root[i]) / (root[o] - root[i]) if math.isfinite(root[o]) else 0.0
            ends.append(v[i] + f * (v[o] - v[i]))
    return float(min(ends)), float(max(ends))


def valley_ends(scan: ProfileScan, k: int, *, x: np.ndarray, cost: float, cov: np.ndarray, rise: float,
                z: float) -> tuple[float, float]:
    """Parameter ``k``'s set along the valley of the scanned one (beta): ``{g : min over beta of D(beta) +
    (g - P(beta))^2 / s_k|beta^2 <= z^2}``.

    ``P(beta) = x_k + cov[k, j] / cov[j, j] (beta - x_j)`` is the sandwich's prediction of ``k`` at
    ``beta`` and ``s_k|beta`` its conditional standard error: the profile of a two-parameter
    quadratic cost, with beta's part replaced by the scanned ``D``. On a quadratic ``D`` it is
    ``x_k +- z stderr_k``; where beta's set reaches further, ``k``'s reaches along the valley in
    proportion to its correlation with beta. ``D`` between scanned values: ``sqrt(D)`` linear
    in beta, read on :data:`VALLEY_GRID` points.
    """
    j = scan.along
    v = np.append(scan.xs[:, j], x[j])
    root = _root_d(np.append(scan.costs, cost), cost, rise)
    keep = np.isfinite(root)
    order = np.argsort(v[keep], kind="stable")
    v, root = v[keep][order], root[keep][order]
    grid = np.union1d(np.linspace(v[0], v[-1], VALLEY_GRID), [x[j]])
    d = np.interp(grid, v, root) ** 2
    se_k, se_j = math.sqrt(cov[k, k]), math.sqrt(cov[j, j])
    rho = float(np.clip(cov[k, j] / (se_k * se_j), -1.0, 1.0))
    centre = x[k] + rho * se_k / se_j * (grid - x[j])
    inside = d <= z * z
    half = se_k * math.sqrt(max(1.0 - rho * rho, 0.0)) * np.sqrt(z * z - d[inside])
    return float(np.min(centre[inside] - half)), float(np.max(centre[inside] + half))


def _root_d(costs: np.ndarray, cost: float, rise: float) -> np.ndarray:
    """``sqrt(D)`` of each cost: ``sqrt((c - cost) / rise)``, 0 below the best, inf where not finite."""
    up = np.where(np.isfinite(costs), np.maximum(costs - cost, 0.0), np.inf)
    return np.sqrt(up / rise)


def scan_intervals(scans: Mapping[int, ProfileScan], *, x: np.ndarray, cost: float, cov: np.ndarray,
                   naive: np.ndarray, dof: int, z: float, valley: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Every fitted parameter's interval at ``z`` standard errors (module docstring): the hull of
    ``x +- z stderr``, each scanned parameter's own likelihood-ratio set (:func:`lr_ends`) and, with
    ``valley`` (the index of beta, scanned), every parameter's set along beta's valley
    (:func:`valley_ends`).

    Parameters
    ----------
    scans : mapping
        Parameter index -> its :class:`ProfileScan` (empty: the sandwich's interval alone).
    x : ndarray
        The best fit; ``cost`` its cost.
    cov : ndarray
        Sandwich covariance of the fitted vector.
    naive : ndarray
        Textbook standard errors of every fitted parameter.
    dof : int
        Residuals minus fitted parameters (``s^2 = cost / dof``).
    z : float
        Half-width in standard errors (1.96 for 95 %).
    valley : int, optional
        The parameter whose scan is the valley every other parameter follows.

    Returns
    -------
    low, high : ndarray
        The interval's ends [parameter units]; NaN where the standard error is not finite.
    """
    d = np.diag(cov)
    with np.errstate(invalid="ignore"):
        stderr = np.where(d > 0, np.sqrt(np.abs(d)), np.nan)  # as the fit's own stderr
    low, high = x - z * stderr, x + z * stderr
    rises = {k: one_se_rise(cost, dof, float(stderr[k]), float(naive[k])) for k in scans}
    ends = [(k, lr_ends(scan, x=x, cost=cost, rise=rises[k], z=z)) for k, scan in scans.items()
            if math.isfinite(rises[k])]
    if valley is not None and valley in scans and math.isfinite(rises[valley]):
        ends += [(k, valley_ends(scans[valley], k, x=x, cost=cost, cov=cov, rise=rises[valley], z=z))
                 for k in range(x.size) if k != valley and np.isfinite(stderr[k]) and stderr[k] > 0]
    for k, (lo, hi) in ends:
        if np.isfinite(low[k]):
            low[k], high[k] = min(low[k], lo), max(high[k], hi)
    return low, high


def one_se_rise(cost: float, dof: int, stderr: float, naive: float) -> float:
    """``dc*``: the rise of a quadratic cost at one sandwich standard error from its minimum
    (``s^2 (stderr / naive)^2``, ``s^2 = cost / dof``); NaN where the errors are not finite."""
    if not (math.isfinite(stderr) and math.isfinite(naive) and stderr > 0 and naive > 0 and cost > 0):
        return math.nan
    return cost / max(dof, 1) * (stderr / naive) ** 2


def scan_valley(problem: FitProblem, x: np.ndarray, cost: float, cov: np.ndarray, along: str,
                rise: float) -> ProfileScan | None:
    """The profile cost over ``along`` read outwards from the best fit, one standard error at a time.

    Each side takes up to :data:`SCAN_STEPS` steps of the sandwich standard error and stops once
    ``sqrt(D)`` passes :data:`SCAN_BEYOND`, the valley is lost or the parameter's bound is
    reached. Each inner fit starts on the valley floor: the first as the covariance predicts it
    (the others moved by ``cov[:, j] / cov[j, j]`` times the step), the next ones extrapolated
    through the last two points of the side -- over a 60-s record a start off the floor slips a
    period and its fit ends in another basin.

    Parameters
    ----------
    problem : FitProblem
        The whole-window problem; ``x`` its best fit, ``cost`` there.
    cov : ndarray
        Sandwich covariance of the fitted vector.
    along : str
        The parameter to scan (a fitted name).
    rise : float
        ``dc*`` of ``along`` (:func:`one_se_rise`).

    Returns
    -------
    ProfileScan or None
        None where ``along`` is not fitted or ``rise`` or its standard error is not finite.
    """
    names = list(problem.names)
    if along not in names:
        return None
    j = names.index(along)
    se = math.sqrt(abs(float(cov[j, j])))
    if not (math.isfinite(se) and se > 0 and math.isfinite(rise) and rise > 0):
        return None
    rest = np.arange(len(names)) != j
    slope = cov[:, j] / cov[j, j]
    xs, costs = [], []
    for side in (-1.0, 1.0):
        trail = [x]
        for k in range(1, SCAN_STEPS + 1):
            v = min(max(float(x[j] + side * k * se), float(problem.lower[j])), float(problem.upper[j]))
            if v == trail[-1][j]:
                break  # on the bound
            predicted = np.clip(x + slope * (v - x[j]), problem.lower, problem.upper)
            if len(trail) >= 2:  # along the floor through the last two points
                a, b = trail[-2], trail[-1]
                x0 = np.clip(b + (b - a) * (v - b[j]) / (b[j] - a[j]), problem.lower, problem.upper)
            else:
                x0 = predicted
            sub = problem.with_fixed({along: v})
            inner = local_fit(sub, x0[rest], (problem.t_end,), max_nfev=SCAN_ITERATIONS)
            if not inner.cost <= SCAN_SLIP * cost and len(trail) >= 2:  # slipped: once more from the prediction
                again = local_fit(sub, predicted[rest], (problem.t_end,), max_nfev=SCAN_ITERATIONS)
                inner = again if again.cost < inner.cost else inner
            point = np.empty_like(x)
            point[j] = v
            point[rest] = inner.x
            c = float(inner.cost) if np.isfinite(inner.cost) else math.inf
            xs.append(point)
            costs.append(c)
            if not c <= SCAN_SLIP * cost:
                break  # the valley is lost: the set ends before this point
            trail.append(point)
            if c - cost > SCAN_BEYOND ** 2 * rise:
                break  # the 95 % set's edge is bracketed
    if not xs:
        return None
    return ProfileScan(along=j, xs=np.array(xs), costs=np.array(costs))
