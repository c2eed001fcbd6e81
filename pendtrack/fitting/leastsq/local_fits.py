"""Multi-start local least squares over a growing time window (the paper's 150 starts).

The paper minimised Xi^2 with simulated annealing (``amebsa``) from 150 random initial
estimates. Here every start runs a bounded Levenberg-Marquardt fit with geodesic acceleration
(:mod:`pendtrack.fitting.leastsq.lm`) on the residual vector, which converges to the bottom of its
basin in a few dozen to a few hundred simulations; the 150 starts then play the
role annealing played: exploring basins, giving Xi^2_min and the paper's spread uncertainty.

Phase slips
-----------
Over a 60 s record (~50 periods) a 1 % error in Omega0 is half a period of phase: the Xi^2
landscape then has a local minimum every period. Each start therefore fits a *growing window*
(:func:`window_ladder`): the first ~3 periods, then a window twice as long warm-started from
the previous optimum, and so on up to the whole record. Omega0 is pinned to ~1e-3 by the
first window, to ~1e-4 by the next ones, before the long record is seen.

The search runs the ladder window by window (:func:`pendtrack.fitting.leastsq.ladder.run_ladder`:
duplicates merged between windows); :func:`run_tasks` runs whole :func:`local_fit` tasks (the
bootstrap's refits). Starts run in parallel in worker processes (:func:`pendtrack.parallel.process_pool`: ``spawn``
context, one BLAS/OpenMP/numba thread per worker); each task receives the pickled
:class:`~pendtrack.fitting.leastsq.problem.FitProblem` (plain arrays) and one start vector. Workers
warm the simulator once (numba kernels load from their ``cache=True`` cache or compile).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from concurrent.futures import as_completed
from dataclasses import dataclass

import numpy as np

from pendtrack.errors import PendtrackError
from pendtrack.fitting.leastsq.coordinates import BoundCoordinates
from pendtrack.fitting.leastsq.lm import levenberg_marquardt, sumsq
from pendtrack.fitting.leastsq.problem import FitProblem, SimState
from pendtrack.parallel import process_pool, worker_count

FINAL_TOL = 1e-8  # ftol/xtol on the whole window: a 0.01-0.03 standard-error change of a parameter
RUNG_TOL = 1e-5  # on the shorter windows only the basin matters
RUNG_ITERATIONS = 12  # Levenberg-Marquardt iterations per shorter window (enough to pin Omega0 and phase)
FINAL_ITERATIONS = 100  # cap on the whole window
SETTLED = 1e-6  # a budget-stopped fit counts as converged if its last 20 % gained less (relative cost):
# with N ~ 1e4 samples that is a move of ~0.1 standard error, well below the statistical precision


@dataclass(frozen=True)
class StartOutcome:
    """Where one start ended.

    Attributes
    ----------
    index : int
        Start number (0 is the data-derived estimate itself).
    x0, x : ndarray
        Initial and final fitted vectors (units of each parameter).
    cost : float
        Final cost on the whole window (Xi^2 [1] or mean squared angle residual [rad^2]).
    success : bool
        The final least-squares run ended on a convergence test (status > 0).
    nfev : int
        Residual evaluations over all windows, Jacobian ones included.
    message : str
        The final least-squares message.
    """

    index: int
    x0: np.ndarray
    x: np.ndarray
    cost: float
    success: bool
    nfev: int
    message: str


def window_ladder(t_start: float, t_end: float, first_end: float, *, growth: float = 2.0) -> tuple[float, ...]:
    """Ends of the growing windows: ``first_end``, then lengths ``growth`` times the last, then ``t_end`` [s].

    Parameters
    ----------
    t_start, t_end : float
        The whole fit window [s].
    first_end : float
        End of the first window, typically three periods after ``t_start`` [s].
    growth : float
        Ratio of each window's length to the one before (> 1; ``[fit] ladder_growth``).
    """
    ends: list[float] = []
    length = first_end - t_start
    while length > 0 and t_start + length < t_start + 0.95 * (t_end - t_start):
        ends.append(t_start + length)
        length *= growth
    ends.append(t_end)
    return tuple(ends)


def draw_starts(center: np.ndarray, half_width: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                n: int, seed: int) -> np.ndarray:
    """Seeded start vectors uniform in ``center +- half_width``, inside the bounds.

    Row 0 is ``center`` itself (the data-derived estimate), so one start always begins
    from the estimates.

    Returns
    -------
    ndarray, shape (n, p)
    """
    if n < 1:
        raise ValueError("n_starts must be >= 1")
    rng = np.random.default_rng(seed)
    lo = np.maximum(center - half_width, lower)
    hi = np.minimum(center + half_width, upper)
    u = rng.uniform(size=(n, center.size))
    starts = lo + u * (hi - lo)
    starts[0] = center
    return inside_bounds(starts, lower, upper)


def inside_bounds(x: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Move points a hair inside the bounds (``trf`` needs strictly feasible starts)."""
    span = np.where(np.isfinite(upper - lower), upper - lower, 1.0)
    eps = 1e-9 * np.maximum(span, 1.0)
    return np.clip(x, lower + eps, upper - eps)


class _Budget(Exception):
    """Raised inside the residual function when a window's evaluation budget is spent."""


class _Tracker:
    """Counts residual evaluations of a problem, remembers the best point, enforces a budget.

    Its :meth:`jac` is the forward- (or, with ``central``, central-) difference Jacobian with the
    problem's steps (:meth:`FitProblem.fd_steps`), evaluated through the same counter -- or, where
    the problem integrates sensitivities (:meth:`FitProblem.uses_sensitivities`, ``[fit] jacobian``),
    the sensitivity Jacobian, counted as the evaluations its finite differences would have made
    (p, or 2p with ``central``): the budgets, in Jacobians' worth, keep their meaning, so a start
    takes the same iterations with either Jacobian.
    """

    def __init__(self, problem: FitProblem, budget: int, *, central: bool = False,
                 coords: BoundCoordinates | None = None) -> None:
        self.problem = problem
        self.coords = coords  # the steps' coordinates y (None: the parameters x themselves)
        self.budget = budget
        self.central = central
        self.calls = 0
        self.best_x: np.ndarray | None = None
        self.best_r: np.ndarray | None = None
        self.best_cost = np.inf
        self.best_at_80 = np.inf  # best cost after 80 % of the budget
        # the finite-difference Jacobian's columns of measurement parameters observe the state at the point
        # again instead of simulating it (the state does not depend on them): the last two points' states are kept
        self._keeps_states = bool(getattr(problem, "measurement_columns", ())) and not problem.uses_sensitivities()
        self._states: tuple[tuple[np.ndarray, SimState | None], ...] = ()

    def __call__(self, y: np.ndarray) -> np.ndarray:
        """The residuals at the step point ``y`` (best point kept in the parameters ``x``)."""
        return self._residuals(y if self.coords is None else self.coords.to_natural(y), keep=self._keeps_states)

    def _residuals(self, x: np.ndarray, state: SimState | None = None, *,
                   keep: bool = False) -> np.ndarray:
        """The residuals at ``x`` through the counter; ``state``: the simulated state at a point differing from ``x``
        only in measurement parameters (:meth:`FitProblem.residuals_at_state`), else ``x`` is simulated
        (``keep``: and its state kept for a Jacobian there)."""
        if self.calls >= self.budget:
            raise _Budget
        self.calls += 1
        if state is not None:
            r = self.problem.residuals_at_state(state, x)
        elif keep:
            try:
                st = self.problem.simulate_state(x)
            except (PendtrackError, ValueError, ArithmeticError):
                st = None
            self._states = (*self._states[-1:], (x.copy(), st))
            r = self.problem.penalty() if st is None else self.problem.residuals_at_state(st)
        else:
            r = self.problem.residuals(x)
        c = sumsq(r)
        if c < self.best_cost:
            self.best_cost, self.best_x, self.best_r = c, x.copy(), r
        if self.calls == int(0.8 * self.budget):
            self.best_at_80 = self.best_cost
        return r

    def _sensitivity_jac(self, x: np.ndarray) -> np.ndarray | None:
        """The sensitivity Jacobian through the counter (its finite differences' worth of evaluations)."""
        worth = x.size * (2 if self.central else 1)
        if self.calls + worth > self.budget:  # where the finite differences would have run out
            raise _Budget
        mark = int(0.8 * self.budget)
        before = self.calls
        self.calls += worth
        if before < mark <= self.calls:
            self.best_at_80 = self.best_cost
        return self.problem.jacobian_sensitivity(x, steer=True)

    @property
    def settled(self) -> bool:
        """The last 20 % of the budget lowered the cost by less than ``SETTLED`` relative."""
        return self.best_at_80 - self.best_cost <= SETTLED * self.best_cost

    def jac(self, y: np.ndarray, r0: np.ndarray) -> np.ndarray:
        """The Jacobian by the step coordinates ``y`` at ``y`` (residuals ``r0`` there)."""
        if self.coords is None:
            return self._jac(y, r0)
        return self.coords.jacobian(self._jac(self.coords.to_natural(y), r0), y)

    def _jac(self, x: np.ndarray, r0: np.ndarray) -> np.ndarray:
        if self.problem.uses_sensitivities():
            jac = self._sensitivity_jac(x)
            if jac is not None:
                return jac
            self.calls -= x.size * (2 if self.central else 1)  # failed (a penalty point): differences below
        lo, hi = self.problem.lower, self.problem.upper
        steps = self.problem.fd_steps(x)
        jac = np.empty((r0.size, x.size), order="F")  # columns contiguous: LM's products with J run ~3x faster
        at_x = next((st for xs, st in self._states if np.array_equal(xs, x)), None)
        shifts = self.problem.measurement_columns if at_x is not None else ()
        for j in range(x.size):
            state = at_x if j in shifts else None
            if self.central:
                hp, hm = min(steps[j], hi[j] - x[j]), min(steps[j], x[j] - lo[j])
                xp, xm = x.copy(), x.copy()
                xp[j] += hp
                xm[j] -= hm
                np.subtract(self._residuals(xp, state), self._residuals(xm, state), out=jac[:, j])
                jac[:, j] /= hp + hm
                continue
            h = steps[j] if x[j] + steps[j] <= hi[j] else -min(steps[j], x[j] - lo[j])
            xp = x.copy()
            xp[j] += h
            np.subtract(self._residuals(xp, state), r0, out=jac[:, j])
            jac[:, j] /= h
        return jac


@dataclass(frozen=True)
class WindowFit:
    """One window of a start's ladder, fitted (:func:`fit_window`).

    Attributes
    ----------
    x : ndarray
        The best point found (units of each parameter).
    cost : float
        The window's cost there.
    calls : int
        Residual evaluations spent, Jacobians counted as their finite differences' worth.
    status : int
        Levenberg-Marquardt status (> 0 converged, 5 settled on its budget, 0 stopped).
    message : str
    """

    x: np.ndarray
    cost: float
    calls: int
    status: int
    message: str


def fit_window(sub: FitProblem, x: np.ndarray, *, last: bool, max_nfev: int | None = None,
               central: bool = False) -> WindowFit:
    """Least squares from ``x`` on one window ``sub`` of a start's ladder (:func:`local_fit`'s step).

    Parameters
    ----------
    sub : FitProblem
        The problem on this window (:meth:`FitProblem.restrict`); its bounds are the whole problem's.
    x : ndarray
        Start vector, inside the bounds.
    last : bool
        The whole window: tolerance ``FINAL_TOL`` and ``max_nfev`` (default ``FINAL_ITERATIONS``)
        Jacobians' worth; otherwise ``RUNG_TOL`` and ``RUNG_ITERATIONS``.
    max_nfev, central
        As in :func:`local_fit`.
    """
    p = x.size
    tol = FINAL_TOL if last else RUNG_TOL
    iters = (max_nfev or FINAL_ITERATIONS) if last else RUNG_ITERATIONS
    coords = sub.coordinates.bind(sub.names) if sub.coordinates is not None else None
    tracker = _Tracker(sub, iters * (p + 2) * (2 if central else 1), central=central, coords=coords)
    if coords is None:
        y, lower, upper = x, sub.lower, sub.upper
    else:
        y, (lower, upper) = coords.to_internal(x), coords.bounds(sub.lower, sub.upper)
    try:
        res = levenberg_marquardt(tracker, tracker.jac, y, lower=lower, upper=upper,
                                  ftol=tol, xtol=tol, max_iterations=10 * tracker.budget)
        status, message = res.status, res.message
    except _Budget:
        if tracker.settled:
            status, message = 5, f"cost settled (budget of {tracker.calls} evaluations spent)"
        else:
            status, message = 0, f"stopped after {tracker.calls} evaluations"
    if tracker.best_x is None:
        if tracker.calls == 0:
            raise ValueError("least squares made no evaluation")  # programming error
        # every evaluation was non-finite (the model blows up from this start, e.g. a drag exponent far
        # out): the start is kept where it was, at infinite cost, for the caller to rank or discard
        return WindowFit(x=np.array(x, dtype=float), cost=math.inf, calls=tracker.calls, status=0,
                         message=f"no finite cost in {tracker.calls} evaluations")
    return WindowFit(x=tracker.best_x, cost=tracker.best_cost, calls=tracker.calls, status=status, message=message)


def windows(problem: FitProblem, window_ends: Sequence[float]) -> list[tuple[FitProblem, bool]]:
    """The ladder's windows that hold enough samples (at least 3 per fitted parameter): ``(sub, last)``."""
    out = []
    for k, end in enumerate(window_ends):
        last = k == len(window_ends) - 1
        sub = problem if last else problem.rung(end)
        if sub.n >= 3 * problem.lower.size:
            out.append((sub, last))
    if not out:
        raise ValueError("every window is too short for the number of parameters")
    return out


def local_fit(problem: FitProblem, x0: np.ndarray, window_ends: Sequence[float], *, index: int = 0,
              max_nfev: int | None = None, central: bool = False) -> StartOutcome:
    """Least squares from ``x0`` over each window of the ladder, warm-starting each from the last.

    Levenberg-Marquardt (:func:`pendtrack.fitting.leastsq.lm.levenberg_marquardt`), bounds by
    projection, one :func:`fit_window` per window. The shorter windows only have to pin Omega0
    and the phase, so their evaluations are capped (``RUNG_ITERATIONS`` Jacobians' worth) and
    their tolerance is loose; the whole window is fitted to ``FINAL_TOL``.

    Parameters
    ----------
    problem : FitProblem
        The problem on the whole window.
    x0 : ndarray
        Start vector.
    window_ends : sequence of float
        Ends of the successive windows [s]; the last should be ``problem.t_end``.
    index : int
        Start number, copied into the outcome.
    max_nfev : int, optional
        Cap on the whole window, in Jacobians' worth of evaluations (default ``FINAL_ITERATIONS``).
    central : bool
        Central-difference Jacobians (twice the simulations, more accurate slopes).

    Returns
    -------
    StartOutcome
    """
    x = inside_bounds(np.asarray(x0, dtype=float), problem.lower, problem.upper)
    calls = 0
    fit, whole = None, False
    for sub, last in windows(problem, window_ends):
        fit = fit_window(sub, x, last=last, max_nfev=max_nfev, central=central)
        calls, x, whole = calls + fit.calls, fit.x, last
    assert fit is not None
    return finish(problem, index, x0, fit, calls, whole=whole)


def finish(problem: FitProblem, index: int, x0: np.ndarray, fit: WindowFit, calls: int, *, whole: bool,
           message: str | None = None) -> StartOutcome:
    """The outcome of a start whose last fitted window was ``fit``; its cost on the whole window.

    ``whole``: that window was the whole one (else one more evaluation gives the whole window's cost:
    a start stopped early on a shorter window).
    """
    if whole:
        cost = fit.cost
    else:
        cost = sumsq(problem.residuals(fit.x))
        calls += 1
    return StartOutcome(index=index, x0=np.asarray(x0, dtype=float), x=fit.x, cost=cost,
                        success=fit.status > 0 and whole, nfev=calls,
                        message=fit.message if message is None else message)


def _warm(problem: FitProblem, x: np.ndarray) -> None:
    """Worker initializer: one short simulation (and sensitivity Jacobian, if the problem uses
    them) so the numba kernels are loaded or compiled."""
    short = problem.restrict(problem.t_start + (20 + 2 * problem.observation.trim) * problem.h)
    try:
        short.residuals(x)
        if short.uses_sensitivities():
            short.jacobian_sensitivity(x)
    except Exception:  # noqa: BLE001 - warming is best effort; the real call reports errors
        pass


def _task(problem: FitProblem, x0: np.ndarray, window_ends: tuple[float, ...], index: int,
          max_nfev: int | None) -> StartOutcome:
    return local_fit(problem, x0, window_ends, index=index, max_nfev=max_nfev)


Task = tuple[FitProblem, np.ndarray, Sequence[float]]


def run_tasks(tasks: Sequence[Task], *, workers: int = 0, max_nfev: int | None = None,
              on_progress: Callable[[int], None] | None = None) -> list[StartOutcome]:
    """Run :func:`local_fit` on ``(problem, x0, window_ends)`` tasks, in parallel when ``workers != 1``.

    Parameters
    ----------
    tasks : sequence of (FitProblem, ndarray, sequence of float)
        Each a problem (pickled to a worker: plain arrays only), a start vector and the
        growing-window ladder [s].
    workers : int
        Processes; 0 = the usable cores (:func:`pendtrack.parallel.worker_count`), 1 = in this process.
    max_nfev : int, optional
        Cap on iterations per window.
    on_progress : callable, optional
        Called with 1 after each finished task.

    Returns
    -------
    list of StartOutcome, in task order (``index`` = task number).
    """
    n_proc = worker_count(workers, len(tasks))
    outcomes: list[StartOutcome] = []
    if n_proc <= 1:
        for i, (prob, x0, ends) in enumerate(tasks):
            outcomes.append(local_fit(prob, x0, tuple(ends), index=i, max_nfev=max_nfev))
            if on_progress:
                on_progress(1)
        return outcomes
    with process_pool(n_proc, initializer=_warm, initargs=(tasks[0][0], tasks[0][1])) as pool:
        futures = [pool.submit(_task, prob, x0, tuple(float(e) for e in ends), i, max_nfev)
                   for i, (prob, x0, ends) in enumerate(tasks)]
        for fut in as_completed(futures):
            outcomes.append(fut.result())
            if on_progress:
                on_progress(1)
    return sorted(outcomes, key=lambda o: o.index)
