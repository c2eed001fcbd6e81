"""Step 2 of a fit, *search*: seeded starts around the estimates, each a growing-window local fit.

:func:`search` draws ``n_starts`` starts (:func:`pendtrack.fitting.leastsq.local_fits.draw_starts`;
start 0 is the estimate itself), adds any complete start vectors the caller gives (a warm
start from an earlier model, say), and runs a local least-squares fit from each over the
growing-window ladder (:func:`pendtrack.fitting.leastsq.local_fits.window_ladder`: Omega0 and the
phase are pinned on three periods before the long record is seen), in worker processes.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from pendtrack.config import FitConfig
from pendtrack.errors import FitError
from pendtrack.fitting.estimate import Setup
from pendtrack.fitting.leastsq.ladder import LadderRules, run_ladder
from pendtrack.fitting.leastsq.local_fits import StartOutcome, draw_starts, inside_bounds, window_ladder
from pendtrack.parallel import ProcessPool


@dataclass(frozen=True, eq=False)
class Search:
    """Where every start ended.

    Attributes
    ----------
    outcomes : list of StartOutcome
        One per start, in start order.
    xs : ndarray, shape (n_starts, p)
        Final fitted vectors.
    costs : ndarray
        Final costs on the whole window (non-finite ones as inf).
    best : StartOutcome
        The start with the lowest cost.
    """

    outcomes: list[StartOutcome]
    xs: np.ndarray
    costs: np.ndarray
    best: StartOutcome

    @property
    def best_position(self) -> int:
        """Position of :attr:`best` in :attr:`outcomes` (its ``index`` is the start number)."""
        return next(i for i, o in enumerate(self.outcomes) if o.index == self.best.index)


def hopeless_ratio(model: Any, options: FitConfig) -> float:
    """The ladder's hopeless ratio for ``model``: ``hopeless_ratio_memory`` if it has memory, else ``hopeless_ratio``.

    A window of a quarter of the record pins a model without memory (its accepted starts are
    within ~10x of the lowest cost there), but not the memory of one with it.
    """
    return options.hopeless_ratio_memory if model.has_memory else options.hopeless_ratio


def ladder_growth(model: Any, options: FitConfig) -> float:
    """The ladder's growth for ``model``: ``ladder_growth_memory`` if it has memory, else ``ladder_growth``.

    The shorter windows pin Omega0 and the phase; a model without memory also converges on them,
    and its starts that meet there merge (the doubling windows pay for themselves). A model with
    memory does not converge on them (the memory is not pinned by a short window): its starts
    only need Omega0 and the phase carried over, which a window four times longer keeps.
    """
    return options.ladder_growth_memory if model.has_memory else options.ladder_growth


def search(setup: Setup, *, options: FitConfig, seed: int, workers: int,
           extra_starts: Sequence[Mapping[str, float]] = (),
           on_progress: Callable[[int], None] | None = None,
           pool: ProcessPool | None = None) -> Search:
    """Multi-start growing-window least squares from the start ranges of ``setup`` (step 2 of a fit).

    Parameters
    ----------
    setup : Setup
        From :func:`pendtrack.fitting.estimate.estimate`.
    options : FitConfig
        Uses ``n_starts``, ``ladder``, ``ladder_growth`` (or ``ladder_growth_memory`` for a model with
        memory), ``start_budget``, ``hopeless_ratio`` (or ``hopeless_ratio_memory``) and ``merge_tol``
        (:class:`pendtrack.fitting.leastsq.ladder.LadderRules`: which starts end before the whole window).
    seed : int
        Seed of the start draws.
    workers : int
        Processes; 0 = all cores, 1 = this process.
    extra_starts : sequence of mapping
        Further starts after the drawn ones, each a mapping of fitted names to values (names
        left out take the centre's value).
    on_progress : callable, optional
        Called with 1 after each start.
    pool : ProcessPool, optional
        Worker processes kept across searches (:func:`pendtrack.fitting.leastsq.ladder.search_pool`); used
        instead of ``workers`` new ones.
    """
    problem = setup.problem
    names = problem.names
    starts = draw_starts(setup.center, setup.half_widths, problem.lower, problem.upper, options.n_starts, seed)
    if extra_starts:
        rows = []
        for start in extra_starts:
            unknown = [k for k in start if k not in names and k not in problem.fixed]
            if unknown:
                raise FitError(f"start value for unknown parameter '{unknown[0]}' of model '{problem.model.name}'")
            rows.append([float(start.get(n, c)) for n, c in zip(names, setup.center)])
        starts = np.vstack((starts, inside_bounds(np.array(rows), problem.lower, problem.upper)))
    ends = (window_ladder(problem.t_start, problem.t_end, setup.first_window_end,
                          growth=ladder_growth(problem.model, options)) if options.ladder
            else (problem.t_end,))
    rules = LadderRules(hopeless_ratio=hopeless_ratio(problem.model, options), merge_tol=options.merge_tol, scale=setup.half_widths)
    outcomes = run_ladder(problem, starts, ends, rules=rules, workers=workers, max_nfev=options.start_budget,
                          on_progress=on_progress, pool=pool)
    xs = np.array([o.x for o in outcomes])
    costs = np.array([o.cost if np.isfinite(o.cost) else np.inf for o in outcomes])
    return Search(outcomes=outcomes, xs=xs, costs=costs, best=outcomes[int(np.argmin(costs))])
