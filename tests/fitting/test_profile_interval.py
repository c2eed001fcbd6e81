"""The 95 % intervals to quote: the sandwich's, widened for a memory model by profile scans -- each
parameter's likelihood-ratio set, and every parameter's set along beta's valley
(pendtrack.fitting.leastsq.profile_interval)."""

from __future__ import annotations

import numpy as np
import pytest
from stand_in_problem import StandInProblem

from pendtrack.fitting.leastsq import profile_interval
from pendtrack.fitting.leastsq.local_fits import StartOutcome
from pendtrack.fitting.leastsq.profile_interval import ProfileScan, lr_ends, one_se_rise, scan_intervals, scan_valley

Z95 = 1.959964
# a best fit of (beta, G2) on a valley: beta 0.6 +- 0.05, G2 3e-3 +- 4e-4, correlation 0.9; the sandwich is
# twice the textbook error (the residuals' autocorrelation), 10^4 residuals
X = np.array([0.6, 3e-3])
SE = np.array([0.05, 4e-4])
RHO = 0.9
COV = np.array([[SE[0] ** 2, RHO * SE[0] * SE[1]], [RHO * SE[0] * SE[1], SE[1] ** 2]])
NAIVE = SE / 2
COST, DOF = 1.0, 10_000 - 2
RISE = one_se_rise(COST, DOF, SE[0], NAIVE[0])


def floor(beta: float) -> np.ndarray:
    """The valley floor: G2 where the cost is lowest at ``beta`` (a linear model's)."""
    return np.array([beta, X[1] + COV[0, 1] / COV[0, 0] * (beta - X[0])])


def quadratic(beta: float) -> float:
    return COST + RISE * ((beta - X[0]) / SE[0]) ** 2


def g2_floor(g2: float) -> np.ndarray:
    """beta where the cost is lowest at ``g2``."""
    return np.array([X[0] + COV[0, 1] / COV[1, 1] * (g2 - X[1]), g2])


def test_on_a_quadratic_cost_the_intervals_are_the_sandwichs():
    # profiles read exactly where a linear model's lie (with the sandwich's geometry) add nothing: each
    # parameter's own likelihood-ratio set and its set along beta's valley are value +- z stderr
    k = np.array([-3.0, -2.0, -1.0, 1.0, 2.0, 3.0])
    beta_scan = ProfileScan(along=0, xs=np.array([floor(b) for b in X[0] + SE[0] * k]),
                            costs=COST + RISE * k**2)
    g2_scan = ProfileScan(along=1, xs=np.array([g2_floor(g) for g in X[1] + SE[1] * k]), costs=COST + RISE * k**2)
    for z in (1.0, Z95):
        low, high = scan_intervals({0: beta_scan, 1: g2_scan}, x=X, cost=COST, cov=COV, naive=NAIVE, dof=DOF, z=z,
                                   valley=0)
        # sqrt(D) is linear in the parameter on a quadratic: the crossings are exact; G2's set along the
        # valley is a minimum over beta read on a grid (401 points over 6 standard errors: 1e-4 relative)
        assert low == pytest.approx(X - z * SE, rel=1e-4)
        assert high == pytest.approx(X + z * SE, rel=1e-4)
        assert lr_ends(beta_scan, x=X, cost=COST, rise=RISE, z=z) == pytest.approx((X[0] - z * SE[0],
                                                                                  X[0] + z * SE[0]), rel=1e-12)


def test_a_near_equal_second_minimum_is_inside_the_interval():
    # a second minimum at beta = 0.42 (3.6 standard errors below), only 0.5 dc* above the best: the curvature
    # at 0.6 says nothing of it; beta's likelihood-ratio set holds it, and G2 (correlation 0.9) follows the
    # valley beyond its sandwich interval
    second, second_rise = 0.42, 0.5

    def cost(beta: float) -> float:
        return min(quadratic(beta), COST + RISE * (second_rise + ((beta - second) / SE[0]) ** 2))

    betas = X[0] + SE[0] * np.arange(-6.0, 3.0)
    betas = betas[betas != X[0]]
    scan = ProfileScan(along=0, xs=np.array([floor(b) for b in betas]), costs=np.array([cost(b) for b in betas]))
    low, high = scan_intervals({0: scan}, x=X, cost=COST, cov=COV, naive=NAIVE, dof=DOF, z=Z95, valley=0)
    assert low[0] < second - SE[0]  # sqrt(D) stays below 1 near the second minimum
    # G2 at the second minimum as the sandwich predicts it, and beyond: outside its own 1.96 stderr
    assert low[1] < X[1] + COV[0, 1] / COV[0, 0] * (second - X[0]) < X[1] - Z95 * SE[1]
    assert high == pytest.approx(X + Z95 * SE, rel=1e-4)  # the steep side: the sandwich's


def test_no_scan_or_no_finite_error_leaves_the_sandwich():
    low, high = scan_intervals({}, x=X, cost=COST, cov=COV, naive=NAIVE, dof=DOF, z=Z95)
    assert low == pytest.approx(X - Z95 * SE) and high == pytest.approx(X + Z95 * SE)
    scan = ProfileScan(along=0, xs=np.array([floor(0.3)]), costs=np.array([COST]))
    low, high = scan_intervals({0: scan}, x=X, cost=COST, cov=COV, naive=np.array([np.nan, NAIVE[1]]), dof=DOF,
                               z=Z95, valley=0)
    assert low == pytest.approx(X - Z95 * SE)


def _fitter(cost, slips_beyond=None):
    """A local fit at fixed beta that reaches the floor from a start near it, and slips a period -- ends
    far up, in another basin -- from a start more than 2 standard errors of G2 off it (or, with
    ``slips_beyond``, from any start beyond that beta)."""
    starts = []

    def local_fit(problem, x0, window_ends, *, index=0, max_nfev=None, central=False):
        beta = problem.fixed["beta"]
        starts.append((beta, float(x0[0])))
        off = abs(float(x0[0]) - floor(beta)[1]) > 2 * SE[1]
        if off or (slips_beyond is not None and beta < slips_beyond):
            return StartOutcome(index=index, x0=x0, x=np.array([0.5]), cost=COST * 3, success=True, nfev=5,
                                message="slipped")
        return StartOutcome(index=index, x0=x0, x=floor(beta)[1:], cost=cost(beta), success=True, nfev=5,
                            message="ok")

    return local_fit, starts


def test_the_scan_walks_the_floor_and_stops_past_the_95_percent_edge(monkeypatch):
    # flatter below the best fit than above (the fractional model's beta, estimated high): the scan reads
    # further on the flat side, each start on the floor, and stops once sqrt(D) passes 1.96
    def cost(beta):
        k = (beta - X[0]) / SE[0]
        return COST + RISE * (0.35 * k) ** 2 if k < 0 else quadratic(beta)

    fake, starts = _fitter(cost)
    monkeypatch.setattr(profile_interval, "local_fit", fake)
    scan = scan_valley(StandInProblem(), X, COST, COV, "beta", RISE)
    betas = np.round((scan.xs[:, 0] - X[0]) / SE[0], 9)
    assert sorted(betas) == [-6.0, -5.0, -4.0, -3.0, -2.0, -1.0, 1.0, 2.0]  # flat side: all 6 steps
    assert all(c <= COST * 1.5 for c in scan.costs)
    assert all(abs(g - floor(b)[1]) < 1e-12 for b, g in starts)  # every start on the floor: none slipped
    low, high = lr_ends(scan, x=X, cost=COST, rise=RISE, z=Z95)
    # sqrt(D) = 0.35 k crosses 1.96 between the 5th and 6th step, linearly interpolated: exact
    assert low == pytest.approx(X[0] - Z95 / 0.35 * SE[0], rel=1e-12)
    assert high == pytest.approx(X[0] + Z95 * SE[0], rel=1e-12)


def test_a_side_that_loses_the_valley_ends_there(monkeypatch):
    # below beta 0.42 every inner fit slips a period, even from the covariance's prediction: the scan keeps
    # the slipped point (its cost says it is outside) and reads no further on that side
    fake, starts = _fitter(lambda beta: COST + RISE * (0.35 * (beta - X[0]) / SE[0]) ** 2, slips_beyond=0.42)
    monkeypatch.setattr(profile_interval, "local_fit", fake)
    scan = scan_valley(StandInProblem(), X, COST, COV, "beta", RISE)
    below = sorted(scan.xs[scan.xs[:, 0] < X[0], 0])
    assert below == pytest.approx(X[0] - SE[0] * np.array([4.0, 3.0, 2.0, 1.0]))
    assert [b for b, _ in starts].count(below[0]) == 2  # tried again from the prediction
    low, _ = lr_ends(scan, x=X, cost=COST, rise=RISE, z=Z95)
    # sqrt(D) is 1.05 at the last point in the valley, 3 standard errors down: the set ends just past it
    assert X[0] - 3.05 * SE[0] < low < X[0] - 3 * SE[0]


def test_a_parameter_on_its_bound_is_not_scanned_past_it(monkeypatch):
    fake, _ = _fitter(quadratic)
    monkeypatch.setattr(profile_interval, "local_fit", fake)
    x = np.array([0.03, X[1]])
    scan = scan_valley(StandInProblem(), x, COST, COV, "beta", RISE)
    assert scan.xs[:, 0].min() == 0.0 and (scan.xs[:, 0] == 0.0).sum() == 1
    assert scan_valley(StandInProblem(), X, COST, COV, "p_f", RISE) is None  # not a fitted name
