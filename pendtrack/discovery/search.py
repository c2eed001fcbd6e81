"""Discovery end to end on one record: fit the baseline, diagnose it, extend it, measure.

:func:`discover` is the pure core of ``pendtrack discover`` (arrays in, a
:class:`~pendtrack.discovery.result.DiscoveryResult` out, no files): see
:mod:`pendtrack.discovery.selection` for the decision rule and
:mod:`pendtrack.discovery.catalogue` for the signatures.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any

from pendtrack.config import Config
from pendtrack.discovery import catalogue as C
from pendtrack.discovery.data import AnalysisData, prepare
from pendtrack.discovery.diagnostics import Diagnosis, diagnose
from pendtrack.discovery.inputs import AngleSeries
from pendtrack.discovery.starts import scaled_starts
from pendtrack.discovery.result import Candidate, DiscoveryResult, Step
from pendtrack.discovery.selection import (
    FitPair, FitTask, choose, fit_full, fit_pair, fit_train, judge, judge_heldout, make_executor, passes_heldout,
    run_tasks, warm_start,
)
from pendtrack.errors import FitError
from pendtrack.parallel import worker_count


def diagnose_pair(pair: FitPair, data: AnalysisData, config: Config) -> Diagnosis:
    """Diagnose a whole-record fit against the data."""
    assert pair.full is not None
    dc = config.discover
    return diagnose(data.t, data.theta, pair.trajectory, pair.trajectory_omega, pair.full.values["Omega0"],
                    model=pair.full.model, savgol_window_s=data.savgol_window * data.dt,
                    savgol_order=data.savgol_order, n_replicas=dc.n_replicas, seed=dc.seed,
                    near_fraction=dc.near_turning_fraction)


def discover(series: AngleSeries, *, config: Config, baseline: str | None = None,
             effects: Sequence[str] | None = None,
             on_progress: Callable[[int], None] | None = None) -> DiscoveryResult:
    """Find what the baseline gets wrong, name the cause, extend the model, measure the gain.

    Parameters
    ----------
    series : AngleSeries
        The record (``t`` [s], ``theta`` [rad]).
    config : Config
        Uses the [discover], [kinematics], [models] and [fit] (cost) sections.
    baseline : str, optional
        Baseline model; default ``config.discover.baseline``.
    effects : sequence of str, optional
        Restrict the catalogue; default ``config.discover.effects`` (empty: all).
    on_progress : callable, optional
        Called with 1 after each fit pair (baseline, then every candidate).

    Returns
    -------
    DiscoveryResult

    Raises
    ------
    ConfigError
        Unknown baseline or effect.
    FitError
        The record cannot support the analysis, or the baseline cannot be fitted.
    """
    t_wall = time.perf_counter()
    dc = config.discover
    baseline = baseline or dc.baseline
    effects = tuple(dc.effects if effects is None else effects)
    from pendtrack.errors import ModelError

    try:
        pool = C.candidates(baseline, effects)
    except ModelError as exc:
        from pendtrack.errors import ConfigError

        raise ConfigError(str(exc)) from None
    data = prepare(series, analysis_rate_hz=dc.analysis_rate_hz, train_fraction=dc.train_fraction,
                   savgol_window_s=config.kinematics.savgol_window_s, savgol_order=config.kinematics.savgol_order)
    workers = worker_count(max(dc.workers, 0))
    common = dict(cost=config.fit.cost, memory_s=config.models.memory_s)
    tick = on_progress or (lambda n: None)

    base = fit_pair(FitTask(data, baseline, (), None, dc.n_starts_baseline, dc.seed, workers=workers, **common))
    tick(1)
    if base.error or base.full is None:
        raise FitError(f"baseline model '{baseline}' could not be fitted: {base.error}", path=series.source)
    diag_base = diagnose_pair(base, data, config)
    timing = {"baseline_s": time.perf_counter() - t_wall, "steps_s": []}
    diag_current = diag_base
    rankings: list[list[dict[str, Any]]] = []
    current, accepted = base, []
    steps: list[Step] = []
    judged_all: list[Candidate] = []
    executor = make_executor(worker_count(workers, len(pool)))
    try:
        for step in range(1, dc.max_effects + 1):
            remaining = [e for e in pool if e.name not in accepted]
            if not remaining:
                break
            t_step = time.perf_counter()
            ranked = C.rank(remaining, diag_current.evidence)
            rankings.append([{"effect": e.name, "score": s, "explains": e.explains(diag_current.evidence)}
                             for e, s in ranked])
            warm = warm_start(current)
            tasks = [FitTask(data, baseline, (*accepted, e.name), warm, dc.n_starts, dc.seed + step,
                             extra_starts=tuple(scaled_starts(baseline, accepted, e.name, warm, data,
                                                              memory_s=config.models.memory_s)), **common)
                     for e, _ in ranked]
            pairs = run_tasks(fit_train, [(task,) for task in tasks], on_done=tick, executor=executor)
            # only a candidate that predicts the held-out part better earns a whole-record fit (for BIC)
            again = [i for i, p in enumerate(pairs)
                     if passes_heldout(*judge_heldout(p, current, data), dc.heldout_z_min,
                                       min_gain=dc.heldout_min_gain, heldout_rms=current.heldout_rms)]
            refits = run_tasks(fit_full, [(tasks[i], pairs[i]) for i in again], executor=executor)
            for i, p in zip(again, refits):
                pairs[i] = p
            judged = [judge(p, current, data, effect=e.name, step=step, score=s, delta_bic_max=dc.delta_bic_max,
                            heldout_z_min=dc.heldout_z_min, min_gain=dc.heldout_min_gain)
                      for p, (e, s) in zip(pairs, ranked)]
            judged_all.extend(judged)
            timing["steps_s"].append(time.perf_counter() - t_step)
            best = choose(judged)
            if best is None:
                break
            pair = pairs[judged.index(best)]
            steps.append(Step(effect=best.effect, before=current.full, after=pair.full,
                              heldout_rms_before=current.heldout_rms, heldout_rms_after=pair.heldout_rms,
                              heldout_z=best.heldout_z, delta_bic=best.delta_bic))
            accepted.append(best.effect)
            current = pair
            diag_current = diagnose_pair(current, data, config)
    finally:
        if executor is not None:
            executor.shutdown()

    diagnosis = _diagnosis_record(baseline, pool, diag_base, diag_current if steps else None, rankings, accepted)
    thresholds = {"delta_bic_max": dc.delta_bic_max, "heldout_z_min": dc.heldout_z_min,
                  "heldout_min_gain": dc.heldout_min_gain,
                  "train_fraction": dc.train_fraction}
    return DiscoveryResult(baseline=baseline, effects=tuple(accepted), steps=tuple(steps),
                           candidates=tuple(judged_all), baseline_fit=base.full,
                           baseline_heldout_rms=base.heldout_rms, final_fit=current.full,
                           final_heldout_rms=current.heldout_rms, diagnosis=diagnosis, thresholds=thresholds,
                           data={**series.to_dict(), "analysis": data.to_dict(), "timing": timing},
                           runtime_s=time.perf_counter() - t_wall)


def _diagnosis_record(baseline: str, pool: Sequence[C.Effect], diag_base: Diagnosis, diag_final: Diagnosis | None,
                      rankings: list[list[dict[str, Any]]], accepted: list[str]) -> dict[str, Any]:
    first = rankings[0] if rankings else []
    top = first[0]["effect"] if first else None
    cause = accepted[0] if accepted else None
    return {
        "baseline": diag_base.to_dict(),
        "final": diag_final.to_dict() if diag_final is not None else None,
        "evidence": dict(diag_base.evidence),
        "ranking": first,
        "rankings_by_step": rankings,
        "catalogue": {e.name: e.to_dict() for e in pool},
        "signature_top": top,
        "cause": cause,
        "cause_matches_signature": bool(cause is not None and cause == top),
    }
