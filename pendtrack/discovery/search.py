"""Discovery end to end on one record: fit the baseline, diagnose it, extend it, measure.

:func:`discover` is the pure core of ``pendtrack discover`` (arrays in, a
:class:`~pendtrack.discovery.result.DiscoveryResult` out, no files): see
:mod:`pendtrack.discovery.selection` for the decision rule and
:mod:`pendtrack.discovery.catalogue` for the signatures.
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any

from pendtrack.config import Config
from pendtrack.discovery import catalogue as C
from pendtrack.discovery.data import AnalysisData, prepare
from pendtrack.discovery.diagnostics import Diagnosis, diagnose, off_diagnostics
from pendtrack.discovery.exchange import Context, recheck, replace_earlier, swap_subset
from pendtrack.discovery.inputs import AngleSeries
from pendtrack.discovery.starts import combination_starts, measurement_starts, scaled_starts
from pendtrack.discovery.result import Candidate, DiscoveryResult, Step
from pendtrack.discovery.selection import FitPair, FitTask, choose, fit_pair, make_executor, warm_start
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


def _adopt_subset(subset: tuple, current: FitPair, accepted: list[str], order: list[str], banned: set[str],
                  steps: list[Step], judged_all: list[Candidate], data: AnalysisData,
                  config: Config) -> tuple[FitPair, Diagnosis, list[Step]]:
    """Put the effects of :func:`~pendtrack.discovery.exchange.swap_subset`'s set in the place of the
    kept ones (``accepted``, ``order``, ``banned`` and ``judged_all`` updated in place); returns the
    new current fit, its diagnosis and the steps."""
    new, cand, pair = subset
    assert current.full is not None and pair.full is not None
    for gone in [e for e in accepted if e not in new]:
        judged_all.append(replace(cand, step=0, effect=gone, terms=(gone,), note=(
            f"kept, replaced with {'+'.join(e for e in new if e not in accepted)} by {cand.effect} "
            f"(BIC {pair.full.bic - current.full.bic:+.1f}): the model with them in its place is better")))
        accepted.remove(gone)
        order.remove(gone)
        banned.add(gone)
    added = [e for e in new if e not in accepted]
    accepted.extend(added)
    order.extend(added)
    steps = [s for s in steps if all(n in accepted for n in s.names)] + [_step(cand, current, pair)]
    return pair, diagnose_pair(pair, data, config), steps


def _step(best: Candidate, current: FitPair, pair: FitPair) -> Step:
    """The step of a kept candidate; its test's RMS before and after (held-out, or interleaved folds)."""
    assert current.full is not None and pair.full is not None
    before = best.test_rms_before if math.isfinite(best.test_rms_before) else current.heldout_rms
    return Step(effect=best.effect, before=current.full, after=pair.full, heldout_rms_before=before,
                heldout_rms_after=best.heldout_rms, heldout_z=best.heldout_z, delta_bic=best.delta_bic,
                terms=best.names, kind=best.kind, step=best.step, test=best.test, margins=best.margins,
                stability=best.stability)


def _combinations(singles: Sequence[Candidate], single_pairs: Sequence[FitPair], size: int,
                  pool_size: int) -> list[tuple[str, ...]]:
    """Combinations of ``size`` effects among the ``pool_size`` singles with the best held-out gain.

    A single that could not be fitted does not enter. The order is that of the gains, so the
    most promising combination is fitted first.
    """
    usable = [(c, p) for c, p in zip(singles, single_pairs) if p.train is not None and not c.error]
    usable.sort(key=lambda cp: -(cp[0].heldout_gain if math.isfinite(cp[0].heldout_gain) else -1e9))
    names = [c.effect for c, _ in usable[:pool_size]]
    return [tuple(combo) for combo in itertools.combinations(names, size)]


def discover(series: AngleSeries, *, config: Config, baseline: str | None = None,
             effects: Sequence[str] | None = None, measurement: Sequence[str] | None = None,
             on_progress: Callable[[int], None] | None = None) -> DiscoveryResult:
    """Find what the baseline gets wrong, name the cause, extend the model, measure the gain.

    1. Fit the baseline and diagnose it.
    2. **Measurement** (``[discover] measurement``): at every round the measurement terms
       (theta's zero offset, an angle-scale error) not yet kept are tried first, by
       interleaved-block cross-validation on the current whole-record fit
       (:mod:`~pendtrack.discovery.interleaved`: a term that shifts every sample is not judged
       by an extrapolation that the baseline's dephasing dominates) and the BIC, residual and
       flag rules of :mod:`~pendtrack.discovery.selection`. A kept term enters the
       observation, stays in every later model and is reported as a measurement finding, never
       as a cause. (Tried again after each effect: a better physics leaves a cleaner residual.)
    3. **Effects**: when no measurement term earns its keep, forward selection over the
       catalogue, one effect per round. When no single
       effect earns its keep but the current model's residual still has structure
       (:func:`~pendtrack.discovery.diagnostics.off_diagnostics`), combinations of
       ``max_combination`` effects among the ``combination_pool`` singles with the best
       held-out gain are fitted and judged by the same rules (pairs first, then triples):
       two effects that each alone cannot show their worth may do so together. Singles are
       judged before pairs, so among nested alternatives the simplest that clears the rules
       is kept.
       **Replacement**: when no effect can be added (none earns its keep, or ``max_effects``
       are kept), each effect kept before the last is tried replaced by every other catalogue
       effect (:func:`_replace_earlier`); a replacement that earns its keep in the model without
       the replaced effect and lowers the BIC is kept in its place (a flexible term kept first,
       memory standing in for an added mass, gives way to the right one).
    4. **The simplest model**: every term kept before a term of the other kind (a measurement
       term before an effect, an effect before a measurement term) is judged again in the
       final model (the model without it against the model with it, same rules) and dropped if
       it no longer earns its keep.
    5. **What stays unexplained**: the final model's diagnostics still off. While any is,
       or the final fit carries a flag the baseline's does not, no cause is named: the
       effects kept go to ``partial`` (they improve the fit without explaining the record).

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
    measurement : sequence of str, optional
        Measurement terms to try; default ``config.discover.measurement`` (empty: none).
    on_progress : callable, optional
        Called with 1 after each candidate's training fit (and the baseline).

    Returns
    -------
    DiscoveryResult

    Raises
    ------
    ConfigError
        Unknown baseline, effect or measurement term.
    FitError
        The record cannot support the analysis, or the baseline cannot be fitted.
    """
    t_wall = time.perf_counter()
    dc = config.discover
    baseline = baseline or dc.baseline
    effects = tuple(dc.effects if effects is None else effects)
    measurement = tuple(dc.measurement if measurement is None else measurement)
    from pendtrack.errors import ModelError

    try:
        pool = C.candidates(baseline, effects)
        meas_pool = C.measurement_candidates(baseline, measurement)
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
    timing: dict[str, Any] = {"baseline_s": time.perf_counter() - t_wall, "measurement_s": 0.0, "steps_s": []}
    diag_current = diag_base
    rankings: list[list[dict[str, Any]]] = []
    current = base
    accepted: list[str] = []
    meas_kept: list[str] = []
    steps: list[Step] = []
    meas_steps: list[Step] = []
    judged_all: list[Candidate] = []
    diag_measured: Diagnosis | None = None
    order: list[str] = []  # every term kept, in the order it was kept
    executor = make_executor(worker_count(workers, max(len(pool), len(meas_pool), 1)))
    ctx = Context(data, baseline, config, executor, tick)
    try:
        step = mstep = 0
        banned: set[str] = set()  # terms dropped by the final check: not tried again
        first_singles: dict[str, dict[str, float]] = {}  # each effect's fit alone on the first effect round
        subset_tried = False
        confirmed: dict[str, tuple[str, ...]] = {}  # term -> the model (its terms) the final check kept it in
        while True:
            while True:
                # 1. the measurement first, at every round: what the record's angle is, before what the
                # pendulum does (a term the baseline's own errors hid may show once the physics is better)
                t_meas = time.perf_counter()
                remaining_m = [a for a in meas_pool if a.name not in meas_kept and a.name not in banned]
                best = None
                if remaining_m:
                    mstep += 1
                    # judged by interleaved-block cross-validation on the current whole-record fit, not by
                    # extrapolation: a term that shifts every sample must not hang on a held-out part that the
                    # baseline's dephasing dominates (on lab1 the offset's held-out z came out 0.7 or 4 by the
                    # rounding of the physics fits; its interleaved z is tens). Only a term that passes is fitted.
                    starts = [measurement_starts(a.name, warm_start(current), data, current.prediction)
                              for a in remaining_m]
                    judged, pairs = ctx.evaluate_measurement(current, (*meas_kept, *accepted),
                                                             [a.name for a in remaining_m], starts, step=mstep,
                                                             seed=dc.seed + 100 + mstep)
                    judged_all.extend(judged)
                    best = choose(judged)
                    if best is not None:
                        pair = pairs[judged.index(best)]
                        meas_steps.append(_step(best, current, pair))
                        meas_kept.extend(best.names)
                        order.extend(best.names)
                        current = pair
                        diag_current = diagnose_pair(current, data, config)
                        if not accepted:
                            diag_measured = diag_current
                timing["measurement_s"] += time.perf_counter() - t_meas
                if best is not None:
                    continue

                # 2. the physics, the measurement terms kept in every model
                remaining = [e for e in pool if e.name not in accepted and e.name not in banned]
                if not remaining:
                    break
                best = None
                if len(accepted) < dc.max_effects:
                    step += 1
                    t_step = time.perf_counter()
                    kept = (*meas_kept, *accepted)
                    ranked = C.rank(remaining, diag_current.evidence)
                    rankings.append([{"effect": e.name, "score": s, "explains": e.explains(diag_current.evidence)}
                                     for e, s in ranked])
                    warm = warm_start(current)
                    scaled = {e.name: scaled_starts(baseline, kept, e.name, warm, data, memory_s=config.models.memory_s)
                              for e, _ in ranked}
                    judged, pairs = ctx.evaluate(current, kept, [(e.name,) for e, _ in ranked],
                                                 [scaled[e.name] for e, _ in ranked], [s for _, s in ranked],
                                                 step=step, kind="effect", seed=dc.seed + step)
                    judged_all.extend(judged)
                    best = choose(judged)
                    chosen_pairs, chosen_judged = pairs, judged
                    if not first_singles:
                        first_singles = {c.effect: warm_start(p) for c, p in zip(judged, pairs) if p.train is not None}
                    # effects in combination: none alone earns its keep, yet the residual has structure
                    size = 2
                    while (best is None and size <= dc.max_combination and size <= len(remaining)
                           and len(accepted) + size <= dc.max_effects and off_diagnostics(diag_current.evidence)):
                        combos = _combinations(judged, pairs, size, dc.combination_pool)
                        if not combos:
                            break
                        singles = {c.effect: warm_start(p) for c, p in zip(judged, pairs) if p.train is not None}
                        starts = [combination_starts(combo, singles, scaled) for combo in combos]
                        scores = [sum(s for e, s in ranked if e.name in combo) for combo in combos]
                        chosen_judged, chosen_pairs = ctx.evaluate(current, kept, combos, starts, scores, step=step,
                                                                   kind="effect", seed=dc.seed + 10 * step + size)
                        judged_all.extend(chosen_judged)
                        best = choose(chosen_judged)
                        size += 1
                    timing["steps_s"].append(time.perf_counter() - t_step)
                if best is None:
                    # no effect to add: would one kept earlier do better replaced by another?
                    others = [e.name for e in remaining]
                    tried, swap = replace_earlier(ctx, current, meas_kept, accepted, others, step=step)
                    judged_all.extend(tried)
                    if swap is None and not subset_tried:
                        # ... or two at once (once per discovery: each set of that size is fitted then)
                        subset_tried = True
                        pool_names = [e.name for e in pool if e.name not in banned]
                        tried, subset = swap_subset(ctx, current, meas_kept, accepted, pool_names, first_singles,
                                                    step=step)
                        judged_all.extend(tried)
                        if subset is not None:
                            current, diag_current, steps = _adopt_subset(
                                subset, current, accepted, order, banned, steps, judged_all, data, config)
                            continue
                    if swap is None:
                        break
                    gone, cand, pair, reduced = swap
                    judged_all.append(replace(cand, step=0, effect=gone, terms=(gone,), note=(
                        f"kept first, replaced by {cand.effect} (BIC {pair.full.bic - current.full.bic:+.1f}): "
                        "the model with it in its place is better")))
                    steps = [s for s in steps if gone not in s.names] + [_step(cand, reduced, pair)]
                    accepted.remove(gone)
                    accepted.append(cand.effect)
                    order.remove(gone)
                    order.append(cand.effect)
                    banned.add(gone)
                    current = pair
                    diag_current = diagnose_pair(current, data, config)
                    continue
                pair = chosen_pairs[chosen_judged.index(best)]
                steps.append(_step(best, current, pair))
                accepted.extend(best.names)
                order.extend(best.names)
                current = pair
                diag_current = diagnose_pair(current, data, config)

            # 3. the simplest model: a term kept before a term of the other kind must still earn its keep
            # in the final model -- a measurement term kept against a poor fit (a baseline that slipped a
            # phase) may have absorbed what an effect explains, an effect kept while theta's zero was
            # wrong may have bent to absorb the offset. One that does not is dropped, by the same rules.
            dropped = []
            for term in [t for i, t in enumerate(order)
                         if any((u in meas_kept) != (t in meas_kept) for u in order[i + 1:])][::-1]:
                kind = "measurement" if term in meas_kept else "effect"
                model_terms = tuple(sorted(order))
                if confirmed.get(term) == model_terms:  # already judged in this very model
                    continue
                cand, reduced = recheck(ctx, current, (*meas_kept, *accepted), term, kind=kind,
                                         step=(len(meas_steps) if kind == "measurement" else len(steps)) + 1)
                if cand.earns_keep:
                    confirmed[term] = model_terms
                    continue
                judged_all.append(replace(cand, step=0, note="kept first, dropped at the end: in the final model "
                                          "it no longer earns its keep (" + cand.reason() + ")"))
                if kind == "measurement":
                    meas_kept.remove(term)
                    meas_steps = [s for s in meas_steps if term not in s.names]
                else:
                    accepted.remove(term)
                    steps = [s for s in steps if term not in s.names]
                order.remove(term)
                current = reduced
                diag_current = diagnose_pair(current, data, config)
                dropped.append(term)
            if not dropped:
                break
            banned.update(dropped)  # the search goes on without them (each round bans one more: it ends)
        if not meas_kept:
            diag_measured = None
    finally:
        if executor is not None:
            executor.shutdown()

    diag_final = diag_current if (steps or meas_steps) else None
    unexplained = tuple(off_diagnostics(diag_current.evidence))
    causes, partial = _causes(accepted, unexplained, current, base)
    diagnosis = _diagnosis_record(baseline, pool, diag_base, diag_final, rankings, causes,
                                  measured=diag_measured, meas_pool=meas_pool)
    thresholds = {"delta_bic_max": dc.delta_bic_max, "heldout_z_min": dc.heldout_z_min,
                  "heldout_min_gain": dc.heldout_min_gain, "cv_blocks": dc.cv_blocks,
                  "train_fraction": dc.train_fraction, "max_combination": dc.max_combination,
                  "combination_pool": dc.combination_pool}
    return DiscoveryResult(baseline=baseline, effects=causes, partial=partial, steps=tuple(steps),
                           candidates=tuple(judged_all), baseline_fit=base.full,
                           baseline_heldout_rms=base.heldout_rms, final_fit=current.full,
                           final_heldout_rms=current.heldout_rms, diagnosis=diagnosis, thresholds=thresholds,
                           data={**series.to_dict(), "analysis": data.to_dict(), "timing": timing},
                           runtime_s=time.perf_counter() - t_wall, measurement=tuple(meas_kept),
                           measurement_steps=tuple(meas_steps), unexplained=unexplained, order=tuple(order))


def _causes(accepted: Sequence[str], unexplained: Sequence[str], final: FitPair,
            base: FitPair) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The kept effects named as causes, and those that only improve the fit (``partial``).

    No cause is named while the final model leaves structure the catalogue cannot remove
    (``unexplained``): the terms kept lower the residual but do not explain it. Nor while the
    final fit carries a flag the baseline's does not (a parameter of a kept term, or one a
    kept term made undetermined, as memory at ``beta`` = 1 does Omega0): its values are not
    measurements.
    """
    assert final.full is not None and base.full is not None
    new_flags = [k for k in final.full.flags if k not in base.full.flags]
    if unexplained or new_flags:
        return (), tuple(accepted)
    return tuple(accepted), ()


def _diagnosis_record(baseline: str, pool: Sequence[C.Effect], diag_base: Diagnosis, diag_final: Diagnosis | None,
                      rankings: list[list[dict[str, Any]]], accepted: list[str], *,
                      measured: Diagnosis | None = None, meas_pool: Sequence[C.Artefact] = ()) -> dict[str, Any]:
    first = rankings[0] if rankings else []
    top = first[0]["effect"] if first else None
    cause = accepted[0] if accepted else None
    return {
        "baseline": diag_base.to_dict(),
        "final": diag_final.to_dict() if diag_final is not None else None,
        "measured": measured.to_dict() if measured is not None else None,
        "measurement_catalogue": {a.name: a.to_dict() for a in meas_pool},
        "evidence": dict(diag_base.evidence),
        "ranking": first,
        "rankings_by_step": rankings,
        "catalogue": {e.name: e.to_dict() for e in pool},
        "signature_top": top,
        "cause": cause,
        "cause_matches_signature": bool(cause is not None and cause == top),
    }
