"""Step 3 of a fit, *refine*: finish the best start to the last digits the statistics need.

The starts run on a capped budget (``[fit] start_budget``) and Levenberg-Marquardt crawls along
the models' sloppy valleys, so the best start is finished here, in this order:

1. **continuation**: if its own budget ran out, Levenberg-Marquardt goes on from it with a
   larger budget (:data:`POLISH_ITERATIONS` Jacobians' worth) and central differences;
2. **profile polish** of a model with memory: the profile cost over ``beta`` is minimised
   (:func:`pendtrack.fitting.leastsq.profile.profile_polish`), then one free fit -- the fractional
   model's beta-G2 valley, where the "converged" point can sit standard errors up the valley;
3. **trust-region polish** (``[fit] trust_region_polish``, on in discovery): a trust-region
   least-squares run (:func:`scipy.optimize.least_squares`, ``trf``, Jacobian scaling) from the
   optimum; if it lowers the cost by more than :data:`TRUST_REGION_GAIN` (relative), a local
   fit from its point, finished by 1-2 again, replaces the best if it is no worse. A second
   optimiser with another step strategy guards against one that stopped short in a long valley.

Each stage only ever replaces the best by a point of lower (or equal) cost; each is capped in
evaluations, never in seconds, so the same record gives the same fit on any machine.
"""

from __future__ import annotations

import numpy as np

from pendtrack.config import FitConfig
from pendtrack.fitting.leastsq.local_fits import StartOutcome, local_fit
from pendtrack.fitting.leastsq.profile import profile_polish
from pendtrack.fitting.leastsq.problem import FitProblem

POLISH_ITERATIONS = 300  # budget (in Jacobians' worth) to finish the best start if its own budget ran out
PROFILE_ALONG = "beta"  # the best fit of a model with memory is finished by a profile over this
TRUST_REGION_TOL = 1e-10  # ftol/xtol of the trust-region polish: far below the statistical precision
TRUST_REGION_NFEV = 60  # its evaluation cap, per fitted parameter
TRUST_REGION_GAIN = 1e-6  # its optimum replaces the fit if its cost is lower by more than this fraction


def refine(problem: FitProblem, best: StartOutcome, *, options: FitConfig) -> StartOutcome:
    """The best start finished (step 3 of a fit; module docstring); never worse than ``best``.

    Parameters
    ----------
    problem : FitProblem
        The whole-window problem.
    best : StartOutcome
        The best start of the search (its ``index`` is kept).
    options : FitConfig
        Uses ``trust_region_polish`` and ``start_budget`` (the budget of the local fit after it).

    Returns
    -------
    StartOutcome
    """
    best = _finish(problem, best)
    if options.trust_region_polish:
        x = trust_region_polish(problem, best)
        if x is not None:
            again = _finish(problem, local_fit(problem, x, (problem.t_end,), index=best.index,
                                               max_nfev=options.start_budget))
            if again.cost <= best.cost:
                best = again
    return best


def _finish(problem: FitProblem, best: StartOutcome) -> StartOutcome:
    """Continuation of a budget-stopped start, then the profile polish of a model with memory."""
    if not best.success:  # only the winner needs the last digits: continue it with a larger budget
        more = local_fit(problem, best.x, (problem.t_end,), index=best.index, max_nfev=POLISH_ITERATIONS,
                         central=True)
        if more.cost <= best.cost:
            best = more
    if PROFILE_ALONG in problem.names and len(problem.names) > 1:  # memory's sloppy valley
        polished = profile_polish(problem, best, PROFILE_ALONG)
        if polished.cost < best.cost:
            best = polished
    return best


def trust_region_polish(problem: FitProblem, best: StartOutcome) -> np.ndarray | None:
    """A trust-region least-squares run from ``best.x``: its point if it gains, else None.

    Gains means a cost lower than ``best.cost`` by more than :data:`TRUST_REGION_GAIN` relative.
    """
    from scipy.optimize import least_squares

    residuals = problem.residuals
    x0 = np.clip(best.x, problem.lower, problem.upper)
    try:
        # scipy's bounded trf step warns on a non-finite intermediate (a column of J ~ 0 along a valley) and
        # rejects the step itself; the warning is numpy's, not the user's business
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            res = least_squares(residuals, x0, bounds=(problem.lower, problem.upper), method="trf",
                                x_scale="jac", ftol=TRUST_REGION_TOL, xtol=TRUST_REGION_TOL,
                                max_nfev=TRUST_REGION_NFEV * x0.size)
    except (ValueError, FloatingPointError, np.linalg.LinAlgError):
        return None
    if not (np.isfinite(res.cost) and 2.0 * res.cost < float(best.cost) * (1.0 - TRUST_REGION_GAIN)):
        return None
    return np.asarray(res.x, dtype=float)
