"""The candidate fits of discovery: a model fitted on the training part and on the whole record.

Forward selection adds the effect that earns its keep on data it was not fitted to
(:mod:`pendtrack.discovery.rules` judges).

Each step fits every remaining candidate ``current + effect`` twice, by output error
(:func:`pendtrack.fitting.fit_model`, its refine step with the trust-region polish on:
:func:`fit_options`):

* on the **training part** (the first ``train_fraction`` of the record), warm-started from the
  current model's training fit (its parameters and initial state); the new term's parameters
  start from the fitting package's equation-error estimates on the data -- data-derived,
  never a truth. The fitted model is then simulated over the *whole* record from its fitted
  initial state, and its RMS over the held-out part is the held-out error;
* on the **whole record**, warm-started from that training fit, for BIC, Xi^2, RMS and the
  parameters with their uncertainties.

Candidates of one step are independent, so they run in parallel worker processes
(:func:`pendtrack.parallel.process_pool`: ``spawn``, one BLAS/numba thread per worker).
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, replace

import numpy as np

from pendtrack.config import FitConfig, ModelsConfig
from pendtrack.discovery.data import AnalysisData
from pendtrack.discovery.result import FitSummary
from pendtrack.discovery.starts import COEFFICIENT, TINY
from pendtrack.parallel import process_pool

log = logging.getLogger(__name__)

TRAIN_START_SPREAD = 0.2  # random starts within +-20 % of the warm start (it is already close)


@dataclass(frozen=True, eq=False)
class FitTask:
    """Everything a worker needs to fit one model twice (training part, whole record).

    Attributes
    ----------
    data : AnalysisData
    baseline : str
        Baseline model name.
    extra : tuple of str
        Terms added to it.
    initial : mapping or None
        Warm start of the training fit (parameter values and ``theta0``/``omega0``); the new
        term's parameters, when absent, come from the fitting package's equation-error
        estimates.
    n_starts : int
        Random starts around ``initial`` in the training fit.
    seed : int
    cost : str
        ``"xi2"`` or ``"theta"``.
    memory_s : float
        Grunwald-Letnikov memory [s].
    workers : int
        Processes inside ``fit_model`` (1 inside a worker).
    """

    data: AnalysisData
    baseline: str
    extra: tuple[str, ...]
    initial: dict[str, float] | None
    n_starts: int
    seed: int
    cost: str
    memory_s: float
    workers: int = 1
    extra_starts: tuple[dict[str, float], ...] = ()  # further complete starts (best training cost wins)
    fixed: dict[str, float] | None = None  # parameters held in the training fit (a measurement term's physics)
    # the current model's whole-record fit (values, theta0, omega0): the whole-record fit also starts there,
    # the new terms at their training values, so that its minimum does not hang on the training fit alone
    full_base: dict[str, float] | None = None
    # whole-record fits of models this one extends by one term (values, theta0, omega0): the whole-record fit
    # also starts at each with the missing term's coefficient at TINY of its training value
    sub_fulls: tuple[dict[str, float], ...] = ()
    # training samples of a refit test's fold (interleaved.refit_folds): one start at ``initial``, no ladder
    fold: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class FitPair:
    """A model fitted on the training part and on the whole record.

    Attributes
    ----------
    extra : tuple of str
    train, full : FitSummary or None
    prediction : ndarray
        The training fit simulated over the whole record [rad] (NaN if it failed).
    heldout_rms : float
        RMS of ``theta - prediction`` over the held-out part [rad].
    trajectory : ndarray
        The whole-record fit simulated over the record: angle [rad].
    trajectory_omega : ndarray
        ... and angular velocity [rad/s].
    error : str
    """

    extra: tuple[str, ...]
    train: FitSummary | None
    full: FitSummary | None
    prediction: np.ndarray
    heldout_rms: float
    trajectory: np.ndarray
    trajectory_omega: np.ndarray
    error: str = ""


def _model(baseline: str, extra: Sequence[str]):  # noqa: ANN202
    from pendtrack.models import compose, get_model

    return compose(baseline, list(extra)) if extra else get_model(baseline)


def _simulate(model, summary: FitSummary, t: np.ndarray,  # noqa: ANN001
              memory_s: float) -> tuple[np.ndarray, np.ndarray]:
    """The fitted model as the camera sees it: angle [rad] and angular velocity [rad/s] through its
    measurement terms (:meth:`pendtrack.models.Model.observe_state`; the identity without them)."""
    from pendtrack.models import simulate

    sim = simulate(model, summary.values, t, theta0=summary.theta0, omega0=summary.omega0, memory_s=memory_s)
    theta, omega = model.observe_state(np.asarray(sim.theta), np.asarray(sim.omega), summary.values)
    return np.asarray(theta), np.asarray(omega)


def fit_options(task: FitTask, *, full: bool) -> tuple[FitConfig, ModelsConfig]:
    """The options of discovery's fits (:func:`pendtrack.fitting.fit_model`).

    Every start may take :data:`~pendtrack.fitting.leastsq.local_fits.FINAL_ITERATIONS` Jacobians' worth
    (discovery runs few starts), no profile sigmas (not reported), and the refine step's
    trust-region polish (the fitted models are sloppy: a second optimiser guards against one
    that stopped short in a long valley). The training fit starts within
    :data:`TRAIN_START_SPREAD` of a warm start; the whole-record fit, warm-started at a
    training fit whose basin is known, runs that one start without the growing windows.
    """
    from pendtrack.fitting.leastsq.local_fits import FINAL_ITERATIONS

    fit = FitConfig(cost=task.cost, n_starts=task.n_starts, start_budget=FINAL_ITERATIONS, profile=False,
                    trust_region_polish=True)
    if full or task.fold is not None:
        fit = replace(fit, n_starts=1, ladder=False)
    elif task.initial:
        fit = replace(fit, start_spread=TRAIN_START_SPREAD)
    return fit, ModelsConfig(memory_s=task.memory_s)


def _fit(task: FitTask, *, full: bool):  # noqa: ANN202
    """One fit by :func:`pendtrack.fitting.fit_model` with :func:`fit_options`: training part or whole record."""
    from pendtrack.fitting import Observation, fit_model

    t_wall = time.perf_counter()
    d = task.data
    model = _model(task.baseline, task.extra)
    obs = Observation(savgol_window=d.savgol_window, savgol_order=d.savgol_order, smooth_theta=d.smoothed)
    options, model_options = fit_options(task, full=full)
    fold = None if full else task.fold
    fit = fit_model(model, d.t, d.theta, d.omega, options=options, model_options=model_options, alpha=d.alpha,
                    ok=fold, window=None if full or fold is not None else d.train_window, observation=obs,
                    initial=task.initial,
                    fixed=None if full else task.fixed,
                    extra_starts=task.extra_starts, seed=task.seed, workers=task.workers,
                    source=d.source, cost_out=d.cost_out)
    log.debug("fit %s (%s): xi2 %.6g rms %.6g in %.1f s", model.name, "whole" if full else "train",
              fit.xi2_min, fit.rms, time.perf_counter() - t_wall)
    return model, fit


_FAILURES = (FloatingPointError, ValueError, ArithmeticError, np.linalg.LinAlgError)


def fit_train(task: FitTask) -> FitPair:
    """Fit ``baseline + extra`` on the training part and predict the whole record.

    The starts are ``task.n_starts`` around ``task.initial`` and ``task.extra_starts``; the
    training cost alone picks the best (the held-out part is not seen). Runs in a worker
    process; every failure becomes ``FitPair.error`` (a candidate that cannot be fitted is
    simply not kept).
    """
    from pendtrack.errors import PendtrackError

    d = task.data
    nan = np.full(d.t.size, np.nan)
    try:
        model, fit = _fit(task, full=False)
    except (PendtrackError, *_FAILURES) as exc:
        return FitPair(task.extra, None, None, nan, math.inf, nan, nan, error=str(exc) or type(exc).__name__)
    train = FitSummary.from_fit(fit, task.extra)
    try:
        pred, _ = _simulate(model, train, d.t, task.memory_s)
        if not np.all(np.isfinite(pred)):
            raise FloatingPointError
        held = d.heldout
        heldout_rms = float(np.sqrt(np.mean((d.theta[held] - pred[held]) ** 2)))
    except (PendtrackError, *_FAILURES):
        pred, heldout_rms = nan, math.inf
    return FitPair(task.extra, train, None, pred, heldout_rms, nan, nan)


def fit_fold(task: FitTask) -> np.ndarray:
    """Fit ``baseline + extra`` on the samples of ``task.fold`` from ``task.initial`` and simulate it
    over the whole record: its prediction [rad] (NaN where the fit or the simulation failed)."""
    from pendtrack.errors import PendtrackError

    try:
        model, fit = _fit(task, full=False)
        pred, _ = _simulate(model, FitSummary.from_fit(fit, task.extra), task.data.t, task.memory_s)
    except (PendtrackError, *_FAILURES):
        return np.full(task.data.t.size, np.nan)
    return pred


# the whole-record fit of a model with memory also starts at these orders (the others at the training fit): on a
# 40-s 30-fps memory record (seed 1369428722) two basins 3e-4 apart in cost (beta 0.10, a drag that leaves the
# quadratic drag undetermined, and beta 0.68) were reached as the rounding of the starts' descent decided
MEMORY_ORDER_STARTS = (0.2, 0.5, 0.8)


def fit_full(task: FitTask, pair: FitPair) -> FitPair:
    """Refit a trained model on the whole record: from its training fit, from ``task.full_base``
    (the current model's whole-record fit) with the new terms at their training values, and from
    that start with each new term's coefficient at :data:`~pendtrack.discovery.starts.TINY` of it:
    the current whole-record optimum itself (the models are nested), so the extended fit cannot
    end far above it. Without that start, memory on a drifting-Omega0 control ended its
    whole-record fit 603 in BIC above the model without it under one code generation and below
    it under the other, and the two kept different terms. Likewise from every other model it extends
    by one term that has a whole-record fit (``task.sub_fulls``, :func:`nested_start`): without it,
    power drag + memory on a changing-length control ended 52 in BIC above power drag alone under
    the host's code and 44 below it under the generic code, and the two kept different terms."""
    from pendtrack.errors import PendtrackError

    if pair.train is None:
        return pair
    full_task = replace(task, initial=warm_start(pair), extra_starts=())
    if task.full_base is not None:
        train = warm_start(pair)
        beside = {**train, **{k: v for k, v in task.full_base.items() if k in train}}
        new = [COEFFICIENT[e] for e in task.extra if COEFFICIENT.get(e) in train and COEFFICIENT[e] not in task.full_base]
        nested = nested_start(train, task.full_base, task.extra)
        full_task = replace(full_task, extra_starts=(beside, nested) if new else (beside,))
    if task.sub_fulls:
        train = warm_start(pair)
        full_task = replace(full_task, extra_starts=(*full_task.extra_starts,
                                                     *(nested_start(train, sub, task.extra) for sub in task.sub_fulls)))
    train = warm_start(pair)
    if "beta" in train:  # the memory term's order: its whole-record cost can have a basin far from the training fit's
        full_task = replace(full_task, extra_starts=(*full_task.extra_starts,
                                                     *({**train, "beta": b} for b in MEMORY_ORDER_STARTS)))
    try:
        model, fit = _fit(full_task, full=True)
        full = FitSummary.from_fit(fit, task.extra)
        traj, traj_w = _simulate(model, full, task.data.t, task.memory_s)
    except (PendtrackError, *_FAILURES) as exc:
        return replace(pair, error=f"whole-record fit failed: {exc}")
    return replace(pair, full=full, trajectory=traj, trajectory_omega=traj_w)


def nested_start(train: Mapping[str, float], sub: Mapping[str, float], extra: Sequence[str]) -> dict[str, float]:
    """A start of the whole-record fit at a sub-model's whole-record optimum ``sub``: its values, and every
    parameter it lacks at its training value ``train``, the missing terms' coefficients at
    :data:`~pendtrack.discovery.starts.TINY` of it (the models are nested, so the fit from there cannot end
    far above ``sub``)."""
    start = {**train, **{k: v for k, v in sub.items() if k in train}}
    for c in (COEFFICIENT.get(e) for e in extra):
        if c is not None and c in train and c not in sub:
            start[c] = TINY * train[c]
    return start


def fit_pair(task: FitTask) -> FitPair:
    """:func:`fit_train` then :func:`fit_full` (the baseline, and the synthetic-run check)."""
    pair = fit_train(task)
    return fit_full(task, pair) if not pair.error else pair


def run_tasks(fn: Callable[..., FitPair], args: Sequence[tuple], *, on_done: Callable[[int], None] | None = None,
              executor: ProcessPoolExecutor | None = None) -> list[FitPair]:
    """``[fn(*a) for a in args]``, in parallel worker processes when an executor is given."""
    if executor is None or len(args) <= 1:
        out = []
        for a in args:
            out.append(fn(*a))
            if on_done:
                on_done(1)
        return out
    futures = [executor.submit(fn, *a) for a in args]
    out = []
    for f in futures:
        out.append(f.result())
        if on_done:
            on_done(1)
    return out


def make_executor(workers: int) -> ProcessPoolExecutor | None:
    """A process pool (:func:`pendtrack.parallel.process_pool`: spawn, one thread per worker), or
    None for ``workers <= 1``."""
    if workers <= 1:
        return None
    return process_pool(workers)


def warm_start(pair: FitPair) -> dict[str, float]:
    """Parameters and initial state of a training fit, to start the next fits from."""
    assert pair.train is not None
    return {**pair.train.values, "theta0": pair.train.theta0, "omega0": pair.train.omega0}


def full_start(pair: FitPair) -> dict[str, float] | None:
    """Parameters and initial state of a whole-record fit (None without one)."""
    if pair.full is None:
        return None
    return {**pair.full.values, "theta0": pair.full.theta0, "omega0": pair.full.omega0}


def elapsed(t0: float) -> float:
    """Seconds since ``t0`` (``time.perf_counter``)."""
    return time.perf_counter() - t0
