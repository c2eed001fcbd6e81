"""The profile polish of a model with memory: the profile over beta is read on a fixed grid before
Brent's method, so that the basin it ends in does not hang on where the best start stopped."""

from __future__ import annotations

import numpy as np
import pytest
from stand_in_problem import StandInProblem

from pendtrack.fitting.leastsq import profile
from pendtrack.fitting.leastsq.local_fits import StartOutcome

# Two basins of the profile cost c(beta), as on a 40-s 30-fps memory record (beta 0.09 and 0.71, the
# deeper one at 0.71, 3.5e-4 apart relative): a descent from beta = 0.3 alone ends at 0.09.
SHALLOW, DEEP = (0.09, 1.0 + 3.5e-4), (0.71, 1.0)


def profile_cost(beta: float) -> float:
    return min(SHALLOW[1] + (beta - SHALLOW[0]) ** 2, DEEP[1] + (beta - DEEP[0]) ** 2)


def _fake_local_fit(problem: StandInProblem, x0: np.ndarray, window_ends, *, index: int = 0, max_nfev=None,
                    central: bool = False) -> StartOutcome:
    """The inner fits at fixed beta reach the profile exactly; the free fit descends in its basin."""
    if "beta" in problem.fixed:
        cost, x = profile_cost(problem.fixed["beta"]), np.array([0.5])
    else:
        beta = float(x0[0])
        centre = DEEP[0] if abs(beta - DEEP[0]) < abs(beta - SHALLOW[0]) else SHALLOW[0]
        x = np.array([centre, x0[1]])
        cost = profile_cost(centre)
    return StartOutcome(index=index, x0=np.asarray(x0), x=x, cost=cost, success=True, nfev=1, message="ok")


@pytest.mark.parametrize("beta_start", [0.3, 0.05, 0.95])
def test_the_polish_ends_in_the_deeper_basin_from_any_start(monkeypatch, beta_start):
    monkeypatch.setattr(profile, "local_fit", _fake_local_fit)
    x = np.array([beta_start, 0.5])
    best = StartOutcome(index=3, x0=x, x=x, cost=profile_cost(beta_start), success=True, nfev=10, message="start")
    out = profile.profile_polish(StandInProblem(), best, "beta")
    # Brent's tolerance is PROFILE_XTOL on beta; the fake free fit lands on the basin's centre
    assert out.x[0] == pytest.approx(DEEP[0], abs=1e-9)
    assert out.cost == pytest.approx(DEEP[1], rel=1e-12)
    assert out.index == 3 and out.cost <= best.cost


def test_the_polish_is_never_worse_than_its_start(monkeypatch):
    monkeypatch.setattr(profile, "local_fit", _fake_local_fit)
    x = np.array([DEEP[0], 0.5])
    best = StartOutcome(index=0, x0=x, x=x, cost=DEEP[1] - 1e-3, success=True, nfev=10, message="start")
    out = profile.profile_polish(StandInProblem(), best, "beta")
    assert out.cost == best.cost and np.array_equal(out.x, best.x)
