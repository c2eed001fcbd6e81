"""The search's starts run window by window, each start's fate decided after every shorter window.

:func:`run_ladder` runs :func:`pendtrack.fitting.leastsq.local_fits.local_fit`'s windows one task at a
time (a task = one start on one window of the growing-window ladder), so that between two
windows a start can end early in two ways that keep the search's meaning:

* **Hopeless**: after a shorter window (at least :data:`HOPELESS_FROM` of the record) its cost is
  more than ``hopeless_ratio`` times the lowest cost any start of lower number (or itself) reached
  on that window. Such a start has slipped
  by a period or sits in a far basin; it is stopped there, its cost taken on the whole window
  (far above the 5/4 rule's bar, so it is not an accepted start) and its point is its end point.
* **Merged**: after a shorter window its point coincides with that of a start of lower number
  still carried on (every fitted parameter within ``merge_tol`` of its start range's half-width,
  :func:`coincide`): from there its path would be the other's to that tolerance, so it takes that
  start's end point (point, cost, convergence) as its own. ``u_paper`` and ``n_accepted`` stay over
  every start's end point, a merged start counting with its representative's.

Each decision for start i after window k uses only starts of lower number on that window, and
waits until all of them have run it: the outcome does not depend on the number of workers or on
their timing. The best start is never stopped (its cost is the lowest on every window it ran
unless another's was lower, which then carries on) and is always finished by the refine step.

Tasks are handed to the workers lowest start first (a start's next window before a new start),
at most one per worker at a time; each worker holds the problem and its windows
(:func:`_init`), so a task pickles only a start vector. Every start runs: the search's work is
set by ``n_starts`` and each window's evaluation cap, never by a clock.
"""

from __future__ import annotations

import pickle
import uuid
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, wait
from dataclasses import dataclass, field

import numpy as np

from pendtrack.fitting.leastsq.local_fits import StartOutcome, WindowFit, _warm, finish, fit_window, inside_bounds, windows
from pendtrack.fitting.leastsq.problem import FitProblem
from pendtrack.parallel import ProcessPool, process_pool, worker_count


def coincide(a: np.ndarray, b: np.ndarray, scale: np.ndarray, tol: float) -> bool:
    """Every component of ``a - b`` within ``tol * scale`` (``scale`` > 0, same units as ``a``)."""
    return bool(np.all(np.abs(a - b) <= tol * scale))


@dataclass(frozen=True)
class LadderRules:
    """When a start ends before its last window (module docstring).

    Attributes
    ----------
    hopeless_ratio : float
        A start whose cost on a shorter window exceeds this many times the lowest cost of the
        starts up to it on that window stops there [1]; 0 = never.
    merge_tol : float
        A start within this share of the start ranges' half-widths of a lower start after a
        shorter window takes that start's end point [1]; 0 = never.
    scale : ndarray or None
        The start ranges' half-widths (parameter units); needed for ``merge_tol``.
    """

    hopeless_ratio: float = 0.0
    merge_tol: float = 0.0
    scale: np.ndarray | None = None


@dataclass
class _Start:
    index: int
    x0: np.ndarray
    x: np.ndarray
    next: int = 0  # window to fit next
    calls: int = 0
    fit: WindowFit | None = None
    costs: dict[int, float] = field(default_factory=dict)  # window -> cost at its end
    points: dict[int, np.ndarray] = field(default_factory=dict)  # window -> point at its end
    ended: bool = False
    rep: int = -1  # merged into this start
    note: str = ""  # why it ended early
    outcome: StartOutcome | None = None


HOPELESS_FROM = 0.25  # the hopeless rule judges windows of at least this share of the record: on shorter ones
# the starts that end accepted still spread widely (bench record: up to 23x the lowest cost on OPA's first
# window, 5.7 s); from 23 s on, at most 6.7x (classic) and 1.7x (OPA) on that window, 11x and 7.9x on the next

_W: dict[str, object] = {}  # in a worker: the token of the problem it holds and that problem's windows


def _hold(token: str, problem: FitProblem, ends: tuple[float, ...]) -> None:
    """Hold ``problem``'s windows under ``token`` in this process (a worker, or this one inline)."""
    _W.clear()
    _W.update(token=token, windows=windows(problem, ends))


def _init(token: str, problem: FitProblem, ends: tuple[float, ...], x: np.ndarray) -> None:
    """Initializer of a search's own pool: the problem's windows, held for every task; kernels warmed at ``x``."""
    _hold(token, problem, ends)
    _warm(problem, x)


def _load_kernels() -> None:
    """Initializer of a shared pool (:func:`search_pool`): the numba kernels loaded before any problem arrives."""
    from pendtrack.models.kernels import compile_kernels

    compile_kernels()


def _ready() -> None:
    """A no-op task: submitting one per worker makes a pool start them all now."""


def _window_task(token: str, held: bytes | None, k: int, x: np.ndarray, max_nfev: int | None) -> WindowFit:
    """Window ``k`` of the problem ``token`` from ``x``; ``held`` = the pickled ``(problem, ends)``, taken up by a
    worker that holds another problem (a shared pool), None where every worker holds it already."""
    if _W.get("token") != token:
        if held is None:
            raise RuntimeError("a ladder task reached a worker without its problem")  # programming error
        _hold(token, *pickle.loads(held))
    sub, last = _W["windows"][k]  # type: ignore[index]
    return fit_window(sub, x, last=last, max_nfev=max_nfev)


def search_pool(workers: int) -> ProcessPool | None:
    """Worker processes for several searches in a row (a fit stage's models), started now.

    Each worker loads the numba kernels as it starts, while the caller goes on (the first model's
    estimates); a search handed the pool (``run_ladder(pool=...)``) then sends its problem along with
    its tasks instead of starting processes of its own (~2 s each on this machine). None where
    ``workers`` resolves to one process (the searches then run inline). The caller shuts it down.
    """
    n = worker_count(workers)
    if n < 2:
        return None
    pool = process_pool(n, initializer=_load_kernels)
    for _ in range(n):
        pool.submit(_ready)
    return pool


class _Inline:
    """A one-process stand-in for the pool: each task runs when it is submitted."""

    def submit(self, fn: Callable[..., WindowFit], *args: object) -> Future:
        fut: Future = Future()
        fut.set_result(fn(*args))
        return fut


def run_ladder(problem: FitProblem, starts: np.ndarray, window_ends: Sequence[float], *,
               rules: LadderRules = LadderRules(), workers: int = 0, max_nfev: int | None = None,
               on_progress: Callable[[int], None] | None = None,
               pool: ProcessPool | None = None) -> list[StartOutcome]:
    """Every start over the growing-window ladder, window by window, with :class:`LadderRules`.

    Parameters
    ----------
    problem : FitProblem
        The whole-window problem.
    starts : ndarray, shape (n, p)
        Start vectors, row i = start i.
    window_ends : sequence of float
        Ends of the ladder's windows [s], the last ``problem.t_end``.
    rules : LadderRules
        When a start ends early; default never (each start is :func:`local_fit`'s path).
    workers : int
        Processes; 0 = the usable cores, 1 = this process. Never changes the outcomes.
    max_nfev : int, optional
        Cap on the whole window, in Jacobians' worth (``[fit] start_budget``).
    on_progress : callable, optional
        Called with 1 as each start ends.
    pool : ProcessPool, optional
        Worker processes to use (:func:`search_pool`, kept by the caller across searches) instead of
        ``workers`` new ones; its workers are sent the problem with the tasks.

    Returns
    -------
    list of StartOutcome
        One per start, in start order.
    """
    ends = tuple(float(e) for e in window_ends)
    wins = windows(problem, ends)
    n_win = len(wins)
    span = problem.t_end - problem.t_start
    judged = [sub.t_end - problem.t_start >= HOPELESS_FROM * span for sub, _ in wins]  # long enough to judge by
    todo = [_Start(i, np.asarray(s, dtype=float), inside_bounds(np.asarray(s, dtype=float), problem.lower,
                                                                 problem.upper)) for i, s in enumerate(starts)]
    began: list[_Start] = []
    waiting: list[_Start] = []  # ran a shorter window, fate not decided yet
    ready: list[_Start] = []  # to run their next window
    token = uuid.uuid4().hex
    held: bytes | None = None
    own = None
    if pool is not None:
        n_proc = min(pool.workers, len(todo))
        held = pickle.dumps((problem, ends), protocol=pickle.HIGHEST_PROTOCOL)
    else:
        n_proc = worker_count(workers, len(todo))
        if n_proc > 1:
            own = pool = process_pool(n_proc, initializer=_init, initargs=(token, problem, ends, todo[0].x))
    if pool is None:
        _hold(token, problem, ends)
    executor = pool if pool is not None else _Inline()
    in_flight: dict[Future, _Start] = {}

    def end(st: _Start, outcome: StartOutcome | None = None, note: str = "") -> None:
        st.ended, st.note = True, note or st.note
        if outcome is not None:
            st.outcome = outcome
        if on_progress:
            on_progress(1)

    def resolved(j: _Start, k: int) -> bool:
        return k in j.costs or j.ended

    def decide() -> None:
        """Decide, lowest start first, every waiting start whose lower starts have all run its window."""
        waiting.sort(key=lambda s: s.index)
        for st in list(waiting):
            k = st.next - 1
            lower = [j for j in began if j.index < st.index]
            if not all(resolved(j, k) for j in lower) or len(lower) < st.index:
                break  # a lower start has not run (or not begun) this window yet: wait for it
            waiting.remove(st)
            ran = [j for j in lower if k in j.costs]
            if rules.hopeless_ratio > 0 and judged[k]:
                floor = min([j.costs[k] for j in ran] + [st.costs[k]])
                if st.costs[k] > rules.hopeless_ratio * floor:
                    ratio = st.costs[k] / floor
                    end(st, finish(problem, st.index, st.x0, st.fit, st.calls, whole=False,
                                   message=f"stopped after window {k + 1} of {n_win}: cost {ratio:.3g} times the "
                                           "lowest there"), note="hopeless")
                    continue
            if rules.merge_tol > 0 and rules.scale is not None:
                rep = next((j for j in ran if j.rep < 0
                            and coincide(st.points[k], j.points[k], rules.scale, rules.merge_tol)), None)
                if rep is not None:
                    st.rep = rep.index
                    end(st, note="merged")
                    continue
            ready.append(st)

    def submit(st: _Start) -> None:
        in_flight[executor.submit(_window_task, token, held, st.next, st.x, max_nfev)] = st

    def collect(fut: Future) -> None:
        st = in_flight.pop(fut)
        fit: WindowFit = fut.result()
        k = st.next
        st.fit, st.calls, st.x, st.next = fit, st.calls + fit.calls, fit.x, k + 1
        st.costs[k], st.points[k] = fit.cost, fit.x
        if k == n_win - 1:
            end(st, finish(problem, st.index, st.x0, fit, st.calls, whole=True))
        else:
            waiting.append(st)

    try:
        while True:
            decide()
            while len(in_flight) < n_proc:
                ready.sort(key=lambda s: s.index)
                if ready:
                    st = ready.pop(0)
                elif todo:
                    st = todo.pop(0)
                    began.append(st)
                else:
                    break
                submit(st)
                if pool is None:  # inline: the result is there
                    for fut in list(in_flight):
                        collect(fut)
                    decide()
            if not in_flight:
                break
            done, _ = wait(list(in_flight), return_when=FIRST_COMPLETED)
            for fut in sorted(done, key=lambda f: in_flight[f].index):
                collect(fut)
    finally:
        if own is not None:
            own.shutdown(wait=True, cancel_futures=True)
        else:  # a shared pool outlives this search (an error left tasks queued): drop them
            for fut in in_flight:
                fut.cancel()
    by_index = {st.index: st for st in began}
    outcomes = []
    for st in began:
        if st.rep >= 0:
            rep = by_index[st.rep]
            while rep.rep >= 0:
                rep = by_index[rep.rep]
            o = rep.outcome
            assert o is not None
            st.outcome = StartOutcome(index=st.index, x0=st.x0, x=o.x, cost=o.cost, success=o.success,
                                      nfev=st.calls, message=f"merged with start {rep.index}: {o.message}")
        if st.outcome is not None:
            outcomes.append(st.outcome)
    return outcomes
