"""Forward selection: add the effect that earns its keep on data it was not fitted to.

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

Decision thresholds
-------------------
An effect is kept only if all hold:

``delta_bic < delta_bic_max`` (-10)
    BIC approximates ``-2 ln`` of the Bayes factor, so -10 means odds above e^5 ~ 150:1 for
    the extended model ("very strong" on Kass & Raftery's scale). For a *spurious* term
    fitted to white noise, ``n ln(Xi^2)`` drops by about a chi^2_1 variable while the
    penalty grows by ``ln n`` (~8 for a 60 s record at 60 Hz), so a spurious term reaches
    -10 with probability far below 1e-4.

``heldout_z > heldout_z_min`` (3)
    The held-out gain is judged against what noise alone gives. With the current model's
    prediction error ``e_a``, the candidate's ``e_b`` and ``Delta = theta_b - theta_a`` on the
    held-out samples, ``d = mean(e_a^2) - mean(e_b^2)``. If the candidate were no better in
    truth, ``d`` would be ``-mean(Delta^2) + 2 mean(n Delta)`` with ``n`` the noise: zero mean
    at best, standard deviation ``2 sqrt(s^2 mean(Delta^2) / n_eff)``, where ``s^2 =
    mean(e_b^2)`` (all that is left, noise or unmodelled physics) and ``n_eff`` is the
    number of independent held-out samples given the autocorrelation of ``e_b`` (which
    makes the test stricter on real data with coloured residuals). ``z = d / sd > 3`` is a
    one-sided p < 0.0014 per candidate, < 0.6 % for four candidates in a step.

``heldout_gain >= heldout_min_gain * heldout_rms`` (1 %)
    The z-test covers the noise, not the current model's own extrapolation bias: a new
    parameter can soak up a sliver of that bias on the training part and carry it
    consistently into the held-out part, a "significant" gain of a few micro-radians. A gain
    below 1 % of the held-out RMS changes no physical conclusion; a real missing effect of
    the size that matters (a baseline residual >= 1.2 x the noise) gains far more.

The whole-record residual RMS goes down
    An effect is kept only if it lowers the whole-record residual of the angle: the cost
    (Xi^2 weighs the angular velocity too) can fall while the angle's residual rises, and a
    term that makes the record's angle worse explains nothing of it.

The candidate's whole-record fit carries no flag of its own (:func:`own_flags`)
    ``FitResult.flags`` (:func:`pendtrack.fitting.result.plausibility_flags`): a parameter of
    the new term at an optimiser bound or not determined by the data, or a flag the term
    brings onto the others (memory with ``beta`` and ``p_f`` near 1 flags ``Omega0``: the term
    is an added mass). A flagged fit's values are not measurements, so the term is not named.

A **measurement term** is judged by interleaved-block cross-validation instead of the
held-out extrapolation (:mod:`pendtrack.discovery.interleaved`), by the same z, gain and the
other rules. Every decision carries its margins (``z - 3``, ``-10 - dBIC``, ...) and its
stability over block-bootstrap records (:mod:`pendtrack.discovery.stability`).

The whole-record fit of a candidate starts from its training fit and from the current
model's whole-record fit with the new terms at their training values (``FitTask.full_base``):
its minimum then does not hang on how one training fit extrapolated.

Among the candidates that pass all rules, the one with the lowest BIC is kept; the others are the
step's runners-up. The held-out test guards against terms that only fit; it is a poor
*ranker*: the held-out error of the true model is dominated by how its training-part
parameter errors extrapolate, and a more flexible wrong term (memory with beta ~ 1 mimics
added mass) can extrapolate a little better by chance, while BIC on the whole record
compares the models on all the data with the parameter count paid for (measured on
synthetic runs: ranking by held-out error named the wrong one of two passing candidates in
1 of 9 effect cases, ranking by BIC in none).
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, replace

import numpy as np

from pendtrack.config import FitConfig, ModelsConfig
from pendtrack.discovery.data import AnalysisData
from pendtrack.discovery.interleaved import FoldTest
from pendtrack.discovery.residuals import heldout_test
from pendtrack.discovery.result import Candidate, FitSummary
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
    if full:
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
    fit = fit_model(model, d.t, d.theta, d.omega, options=options, model_options=model_options, alpha=d.alpha,
                    window=None if full else d.train_window, observation=obs, initial=task.initial,
                    fixed=None if full else task.fixed,
                    extra_starts=task.extra_starts, seed=task.seed, workers=task.workers,
                    source=d.source)
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


def fit_full(task: FitTask, pair: FitPair) -> FitPair:
    """Refit a trained model on the whole record: from its training fit, and from ``task.full_base``
    (the current model's whole-record fit) with the new terms at their training values."""
    from pendtrack.errors import PendtrackError

    if pair.train is None:
        return pair
    full_task = replace(task, initial=warm_start(pair), extra_starts=())
    if task.full_base is not None:
        train = warm_start(pair)
        full_task = replace(full_task, extra_starts=({**train, **{k: v for k, v in task.full_base.items() if k in train}},))
    try:
        model, fit = _fit(full_task, full=True)
        full = FitSummary.from_fit(fit, task.extra)
        traj, traj_w = _simulate(model, full, task.data.t, task.memory_s)
    except (PendtrackError, *_FAILURES) as exc:
        return replace(pair, error=f"whole-record fit failed: {exc}")
    return replace(pair, full=full, trajectory=traj, trajectory_omega=traj_w)


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


def judge_heldout(pair: FitPair, current: FitPair, data: AnalysisData) -> tuple[float, float]:
    """Held-out gain [rad] and z of a trained candidate over the current model."""
    if pair.error or pair.train is None:
        return -math.inf, -math.inf
    held = data.heldout
    return heldout_test(data.theta[held], current.prediction[held], pair.prediction[held])


def passes_heldout(gain: float, z: float, heldout_z_min: float, *, min_gain: float = 0.0,
                   heldout_rms: float = 0.0) -> bool:
    """The held-out test of the module docstring: significant and not negligible."""
    return bool(gain > 0 and z > heldout_z_min and gain >= min_gain * heldout_rms)


def own_flags(pair: FitPair, current: FitPair, terms: Sequence[str]) -> dict[str, str]:
    """Flags of the candidate's whole-record fit that its terms brought.

    A flag on one of the new terms' parameters, or one the current model's fit does not carry
    (memory at ``beta`` = 1 flags ``Omega0``: the term is an added mass and Omega0 trades off
    against G2). A flag the current fit already carries (a baseline parameter the record does
    not determine) is not the new term's.
    """
    from pendtrack.models import CATALOGUE

    if pair.full is None:
        return {}
    mine = {p for t in terms if t in CATALOGUE for p in CATALOGUE[t].params}
    before = current.full.flags if current.full is not None else {}
    return {k: v for k, v in pair.full.flags.items() if k in mine or k not in before}


def rule_margins(z: float, gain: float, rms_ref: float, dbic: float, *, heldout_z_min: float, min_gain: float,
             delta_bic_max: float, rms_change: float) -> dict[str, dict[str, float]]:
    """Each rule's value, threshold and margin (> 0: passes); NaN for a rule not reached."""
    share = gain / rms_ref if rms_ref > 0 and math.isfinite(rms_ref) else math.nan
    return {"z": {"value": z, "threshold": heldout_z_min, "margin": z - heldout_z_min},
            "gain_share": {"value": share, "threshold": min_gain, "margin": share - min_gain},
            "delta_bic": {"value": dbic, "threshold": delta_bic_max, "margin": delta_bic_max - dbic},
            "rms_drop": {"value": rms_change, "threshold": 0.0, "margin": rms_change}}


def judge(pair: FitPair, current: FitPair, data: AnalysisData, *, effect: str, step: int, score: float,
          delta_bic_max: float, heldout_z_min: float, min_gain: float = 0.0, terms: tuple[str, ...] = (),
          kind: str = "effect", test: FoldTest | None = None, seed: int = 0) -> Candidate:
    """Compare a fitted candidate with the current model: the rules of the module docstring.

    The same rules judge a measurement term, a single effect and a combination of effects
    (``terms``; its parameters are all paid for in BIC). A candidate without a whole-record
    fit (it failed the held-out test, so it was not refitted) has ``delta_bic = NaN``.
    ``test``: a measurement term's interleaved test (:mod:`pendtrack.discovery.interleaved`),
    which then stands in for the held-out test. Every candidate gets its margins against each
    rule and the stability of its decision (:mod:`pendtrack.discovery.stability`).
    """
    from pendtrack.discovery.stability import Rules, decision_stability

    names = terms or (effect,)
    which = "interleaved" if test is not None else "heldout"
    if pair.error or pair.train is None or current.full is None:
        return Candidate(effect, step, score, pair.train, pair.full, math.inf, -math.inf, -math.inf, math.nan,
                         False, False, error=pair.error or "fit failed", terms=terms, kind=kind, test=which,
                         stability=1.0)
    if test is not None:
        gain, z = test.gain, test.z
        rms_ref, rms_test = test.rms_before, test.rms_after
        samples = (data.theta, current.trajectory, test.prediction)
    else:
        gain, z = judge_heldout(pair, current, data)
        rms_ref, rms_test = current.heldout_rms, pair.heldout_rms
        held = data.heldout
        samples = (data.theta[held], current.prediction[held], pair.prediction[held])
    dbic = pair.full.bic - current.full.bic if pair.full is not None else math.nan
    rms_change = current.full.rms - pair.full.rms if pair.full is not None else math.nan
    flags = own_flags(pair, current, names)
    passes_h = passes_heldout(gain, z, heldout_z_min, min_gain=min_gain, heldout_rms=rms_ref)
    lowers = bool(pair.full is None or rms_change > 0)
    cand = Candidate(effect=effect, step=step, signature_score=score, train=pair.train, full=pair.full,
                     heldout_rms=rms_test, heldout_gain=gain, heldout_z=z, delta_bic=dbic,
                     passes_bic=bool(dbic < delta_bic_max), passes_heldout=passes_h, terms=terms, kind=kind,
                     flags=flags, lowers_rms=lowers, test=which,
                     test_rms_before=rms_ref if test is not None else math.nan,
                     margins=rule_margins(z, gain, rms_ref, dbic, heldout_z_min=heldout_z_min, min_gain=min_gain,
                                      delta_bic_max=delta_bic_max, rms_change=rms_change))
    whole = (data.theta, current.trajectory, pair.trajectory) if pair.full is not None else None
    stab = decision_stability(kept=cand.earns_keep, test=samples, test_rms_ref=rms_ref, whole=whole,
                              delta_bic=dbic, n_bic=pair.full.n if pair.full is not None else 0,
                              rules=Rules(heldout_z_min, min_gain, delta_bic_max), fixed=bool(flags), seed=seed)
    return replace(cand, stability=stab)


def choose(cands: Iterable[Candidate]) -> Candidate | None:
    """The candidate that earns its keep with the lowest BIC, or None.

    Candidates of one call add the same number of terms (singles, or pairs): the simplest
    models are judged first (:func:`pendtrack.discovery.search.discover`), so among nested
    alternatives that clear the rules the one with fewer terms is kept.
    """
    ok = [c for c in cands if c.earns_keep]
    return min(ok, key=lambda c: c.delta_bic) if ok else None


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
