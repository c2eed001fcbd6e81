"""Discovery end to end on one record: fit the baseline, diagnose it, extend it, measure.

:func:`discover` is the pure core of ``pendtrack discover`` (arrays in, a
:class:`~pendtrack.discovery.result.DiscoveryResult` out, no files); :class:`DiscoveryLoop` holds
its state, one method per round. See
:mod:`pendtrack.discovery.rules` for the decision rule and
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
from pendtrack.discovery.candidate_fits import FitPair, FitTask, fit_pair, make_executor, warm_start
from pendtrack.discovery.rules import choose
from pendtrack.errors import ConfigError, FitError, ModelError
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
        # its values: the fit of the model it was kept in (the candidate's fit has no parameters of it)
        judged_all.append(replace(cand, step=0, effect=gone, terms=(gone,), train=current.train, full=current.full, note=(
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


class DiscoveryLoop:
    """The state of one discovery, one method per round (:func:`discover` runs them).

    Rounds: :meth:`measurement` (a measurement term), :meth:`effects` (a catalogue effect,
    alone or, via :meth:`combinations`, with others), :meth:`exchanges` (a kept effect
    replaced), :meth:`simplify` (terms that no longer earn their keep dropped) and
    :meth:`result`. The candidate fits are made by :class:`~pendtrack.discovery.exchange.Context`
    and :mod:`~pendtrack.discovery.candidate_fits`; the rules that judge them are
    :func:`~pendtrack.discovery.rules.choose` and the candidates' ``earns_keep``.

    Attributes
    ----------
    current : FitPair
        The model kept so far (the baseline with every term kept), fitted.
    accepted, meas_kept, order : list of str
        Effects kept, measurement terms kept, every term kept in the order it was kept.
    steps, meas_steps : list of Step
        The kept effects' and measurement terms' steps.
    judged : list of Candidate
        Every candidate judged, kept or not.
    banned : set of str
        Terms dropped by the final check, not tried again.
    """

    def __init__(self, series: AngleSeries, *, config: Config, baseline: str, pool: Sequence[C.Effect],
                 meas_pool: Sequence[C.Artefact], on_progress: Callable[[int], None] | None = None) -> None:
        self.t_wall = time.perf_counter()
        self.series, self.config, self.baseline = series, config, baseline
        self.pool, self.meas_pool = tuple(pool), tuple(meas_pool)
        dc = self.dc = config.discover
        self.data = prepare(series, analysis_rate_hz=dc.analysis_rate_hz, train_fraction=dc.train_fraction,
                            savgol_window_s=config.kinematics.savgol_window_s,
                            savgol_order=config.kinematics.savgol_order,
                            slow_motion_px=config.fit.slow_motion_px)
        self.workers = worker_count(max(dc.workers, 0))
        self.tick = on_progress or (lambda n: None)
        base = fit_pair(FitTask(self.data, baseline, (), None, dc.n_starts_baseline, dc.seed, workers=self.workers,
                                cost=config.fit.cost, memory_s=config.models.memory_s))
        self.tick(1)
        if base.error or base.full is None:
            raise FitError(f"baseline model '{baseline}' could not be fitted: {base.error}", path=series.source)
        self.base = self.current = base
        self.diag_base = self.diag_current = diagnose_pair(base, self.data, config)
        self.diag_measured: Diagnosis | None = None
        self.timing: dict[str, Any] = {"baseline_s": time.perf_counter() - self.t_wall, "measurement_s": 0.0,
                                       "steps_s": []}
        self.rankings: list[list[dict[str, Any]]] = []
        self.accepted: list[str] = []
        self.meas_kept: list[str] = []
        self.order: list[str] = []  # every term kept, in the order it was kept
        self.steps: list[Step] = []
        self.meas_steps: list[Step] = []
        self.judged: list[Candidate] = []
        self.step = self.mstep = 0
        self.banned: set[str] = set()  # terms dropped by the final check: not tried again
        self.first_singles: dict[str, dict[str, float]] = {}  # each effect's fit alone on the first effect round
        self.subset_tried = False
        self.confirmed: dict[str, tuple[str, ...]] = {}  # term -> the model (its terms) the final check kept it in
        self.executor = None
        self.ctx: Context | None = None

    def run(self) -> DiscoveryResult:
        """Every round until nothing changes; then :meth:`result`."""
        self.executor = make_executor(worker_count(self.workers, max(len(self.pool), len(self.meas_pool), 1)))
        self.ctx = Context(self.data, self.baseline, self.config, self.executor, self.tick)
        try:
            while True:
                while True:
                    # the measurement first, at every round: what the record's angle is, before what the
                    # pendulum does (a term the baseline's own errors hid may show once the physics is better)
                    if self.measurement():
                        continue
                    remaining = [e for e in self.pool if e.name not in self.accepted and e.name not in self.banned]
                    if not remaining:
                        break
                    if len(self.accepted) < self.dc.max_effects and self.effects(remaining):
                        continue
                    # no effect to add: would one kept earlier do better replaced by another?
                    if not self.exchanges(remaining):
                        break
                dropped = self.simplify()
                if not dropped:
                    break
                self.banned.update(dropped)  # the search goes on without them (each round bans one more: it ends)
            if not self.meas_kept:
                self.diag_measured = None
        finally:
            if self.executor is not None:
                self.executor.shutdown()
        return self.result()

    def _adopt(self, best: Candidate, pair: FitPair, *, measurement: bool) -> None:
        """Keep ``best`` (fitted as ``pair``) in the current model."""
        (self.meas_steps if measurement else self.steps).append(_step(best, self.current, pair))
        (self.meas_kept if measurement else self.accepted).extend(best.names)
        self.order.extend(best.names)
        self.current = pair
        self.diag_current = diagnose_pair(pair, self.data, self.config)

    def measurement(self) -> bool:
        """One measurement round: the terms not yet kept, judged on the current whole-record fit.

        Judged by interleaved-block cross-validation, not by extrapolation: a term that shifts every
        sample must not hang on a held-out part that the baseline's dephasing dominates (on lab1 the
        offset's held-out z came out 0.7 or 4 by the rounding of the physics fits; its interleaved z
        is tens). Only a term that passes is fitted. Returns whether a term was kept.
        """
        assert self.ctx is not None
        t_meas = time.perf_counter()
        remaining = [a for a in self.meas_pool if a.name not in self.meas_kept and a.name not in self.banned]
        best = None
        if remaining:
            self.mstep += 1
            starts = [measurement_starts(a.name, warm_start(self.current), self.data, self.current.prediction)
                      for a in remaining]
            judged, pairs = self.ctx.evaluate_measurement(self.current, (*self.meas_kept, *self.accepted),
                                                          [a.name for a in remaining], starts, step=self.mstep,
                                                          seed=self.dc.seed + 100 + self.mstep)
            self.judged.extend(judged)
            best = choose(judged)
            if best is not None:
                self._adopt(best, pairs[judged.index(best)], measurement=True)
                if not self.accepted:
                    self.diag_measured = self.diag_current
        self.timing["measurement_s"] += time.perf_counter() - t_meas
        return best is not None

    def effects(self, remaining: Sequence[C.Effect]) -> bool:
        """One effect round: every remaining effect alone, ranked by its signature; when none earns
        its keep, :meth:`combinations`. Returns whether an effect (or a combination) was kept."""
        assert self.ctx is not None
        self.step += 1
        t_step = time.perf_counter()
        kept = (*self.meas_kept, *self.accepted)
        ranked = C.rank(remaining, self.diag_current.evidence)
        self.rankings.append([{"effect": e.name, "score": s, "explains": e.explains(self.diag_current.evidence)}
                              for e, s in ranked])
        warm = warm_start(self.current)
        scaled = {e.name: scaled_starts(self.baseline, kept, e.name, warm, self.data,
                                        memory_s=self.config.models.memory_s) for e, _ in ranked}
        judged, pairs = self.ctx.evaluate(self.current, kept, [(e.name,) for e, _ in ranked],
                                          [scaled[e.name] for e, _ in ranked], [s for _, s in ranked],
                                          step=self.step, kind="effect", seed=self.dc.seed + self.step)
        self.judged.extend(judged)
        if not self.first_singles:
            self.first_singles = {c.effect: warm_start(p) for c, p in zip(judged, pairs) if p.train is not None}
        best = choose(judged)
        chosen = (best, pairs[judged.index(best)]) if best is not None else None
        if chosen is None:
            chosen = self.combinations(judged, pairs, ranked, scaled, kept, n_remaining=len(remaining))
        self.timing["steps_s"].append(time.perf_counter() - t_step)
        if chosen is None:
            return False
        self._adopt(*chosen, measurement=False)
        return True

    def combinations(self, judged: Sequence[Candidate], pairs: Sequence[FitPair], ranked: Sequence[tuple[C.Effect, float]],
                     scaled: dict[str, Any], kept: tuple[str, ...], *, n_remaining: int
                     ) -> tuple[Candidate, FitPair] | None:
        """Effects in combination, when none alone earns its keep yet the residual has structure:
        pairs, then triples (up to ``max_combination``) among the best singles. The kept one, or None."""
        assert self.ctx is not None
        dc = self.dc
        size = 2
        while (size <= dc.max_combination and size <= n_remaining and len(self.accepted) + size <= dc.max_effects
               and off_diagnostics(self.diag_current.evidence)):
            combos = _combinations(judged, pairs, size, dc.combination_pool)
            if not combos:
                break
            singles = {c.effect: warm_start(p) for c, p in zip(judged, pairs) if p.train is not None}
            starts = [combination_starts(combo, singles, scaled) for combo in combos]
            scores = [sum(s for e, s in ranked if e.name in combo) for combo in combos]
            chosen_judged, chosen_pairs = self.ctx.evaluate(self.current, kept, combos, starts, scores,
                                                            step=self.step, kind="effect",
                                                            seed=dc.seed + 10 * self.step + size)
            self.judged.extend(chosen_judged)
            best = choose(chosen_judged)
            if best is not None:
                return best, chosen_pairs[chosen_judged.index(best)]
            size += 1
        return None

    def exchanges(self, remaining: Sequence[C.Effect]) -> bool:
        """A kept effect replaced by another (:func:`~pendtrack.discovery.exchange.replace_earlier`), or, once
        per discovery, the kept set by a set of its size (:func:`~pendtrack.discovery.exchange.swap_subset`).
        Returns whether the model changed."""
        assert self.ctx is not None and self.current.full is not None
        tried, swap = replace_earlier(self.ctx, self.current, self.meas_kept, self.accepted,
                                      [e.name for e in remaining], step=self.step)
        self.judged.extend(tried)
        if swap is None and not self.subset_tried:
            self.subset_tried = True
            pool_names = [e.name for e in self.pool if e.name not in self.banned]
            # one more effect than kept, while structure remains and a combination that size is allowed
            grow = bool(len(self.accepted) + 1 <= min(self.dc.max_combination, self.dc.max_effects)
                        and off_diagnostics(self.diag_current.evidence))
            tried, subset = swap_subset(self.ctx, self.current, self.meas_kept, self.accepted, pool_names,
                                        self.first_singles, step=self.step, grow=grow)
            self.judged.extend(tried)
            if subset is not None:
                self.current, self.diag_current, self.steps = _adopt_subset(
                    subset, self.current, self.accepted, self.order, self.banned, self.steps, self.judged,
                    self.data, self.config)
                return True
        if swap is None:
            return False
        gone, cand, pair, reduced = swap
        self.judged.append(replace(cand, step=0, effect=gone, terms=(gone,), train=self.current.train,
                                   full=self.current.full, note=(
            f"kept first, replaced by {cand.effect} (BIC {pair.full.bic - self.current.full.bic:+.1f}): "
            "the model with it in its place is better")))
        self.steps = [s for s in self.steps if gone not in s.names] + [_step(cand, reduced, pair)]
        self.accepted.remove(gone)
        self.accepted.append(cand.effect)
        self.order.remove(gone)
        self.order.append(cand.effect)
        self.banned.add(gone)
        self.current = pair
        self.diag_current = diagnose_pair(pair, self.data, self.config)
        return True

    def simplify(self) -> list[str]:
        """The simplest model: every term kept before a term of the other kind is judged again in the
        final model, and dropped if it no longer earns its keep. Returns the terms dropped.

        A measurement term kept against a poor fit (a baseline that slipped a phase) may have absorbed
        what an effect explains; an effect kept while theta's zero was wrong may have bent to absorb
        the offset.
        """
        assert self.ctx is not None
        dropped = []
        order = self.order
        for term in [t for i, t in enumerate(order)
                     if any((u in self.meas_kept) != (t in self.meas_kept) for u in order[i + 1:])][::-1]:
            kind = "measurement" if term in self.meas_kept else "effect"
            model_terms = tuple(sorted(self.order))
            if self.confirmed.get(term) == model_terms:  # already judged in this very model
                continue
            cand, reduced = recheck(self.ctx, self.current, (*self.meas_kept, *self.accepted), term, kind=kind,
                                    step=(len(self.meas_steps) if kind == "measurement" else len(self.steps)) + 1)
            if cand.earns_keep:
                self.confirmed[term] = model_terms
                continue
            self.judged.append(replace(cand, step=0, note="kept first, dropped at the end: in the final model "
                                       "it no longer earns its keep (" + cand.reason() + ")"))
            if kind == "measurement":
                self.meas_kept.remove(term)
                self.meas_steps = [s for s in self.meas_steps if term not in s.names]
            else:
                self.accepted.remove(term)
                self.steps = [s for s in self.steps if term not in s.names]
            self.order.remove(term)
            self.current = reduced
            self.diag_current = diagnose_pair(reduced, self.data, self.config)
            dropped.append(term)
        return dropped

    def result(self) -> DiscoveryResult:
        """What stays unexplained, the causes named (or ``partial``), and the whole record."""
        dc = self.dc
        diag_final = self.diag_current if (self.steps or self.meas_steps) else None
        unexplained = tuple(off_diagnostics(self.diag_current.evidence))
        causes, partial = _causes(self.accepted, unexplained, self.current, self.base)
        diagnosis = _diagnosis_record(self.baseline, self.pool, self.diag_base, diag_final, self.rankings, causes,
                                      measured=self.diag_measured, meas_pool=self.meas_pool)
        thresholds = {"delta_bic_max": dc.delta_bic_max, "heldout_z_min": dc.heldout_z_min,
                      "heldout_min_gain": dc.heldout_min_gain, "cv_blocks": dc.cv_blocks,
                      "train_fraction": dc.train_fraction, "max_combination": dc.max_combination,
                      "combination_pool": dc.combination_pool}
        return DiscoveryResult(baseline=self.baseline, effects=causes, partial=partial, steps=tuple(self.steps),
                               candidates=tuple(self.judged), baseline_fit=self.base.full,
                               baseline_heldout_rms=self.base.heldout_rms, final_fit=self.current.full,
                               final_heldout_rms=self.current.heldout_rms, diagnosis=diagnosis,
                               thresholds=thresholds,
                               data={**self.series.to_dict(), "analysis": self.data.to_dict(), "timing": self.timing},
                               runtime_s=time.perf_counter() - self.t_wall, measurement=tuple(self.meas_kept),
                               measurement_steps=tuple(self.meas_steps), unexplained=unexplained,
                               order=tuple(self.order))


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
       flag rules of :mod:`~pendtrack.discovery.rules`. A kept term enters the
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
    dc = config.discover
    baseline = baseline or dc.baseline
    try:
        pool = C.candidates(baseline, tuple(dc.effects if effects is None else effects))
        meas_pool = C.measurement_candidates(baseline, tuple(dc.measurement if measurement is None else measurement))
    except ModelError as exc:
        raise ConfigError(str(exc)) from None
    return DiscoveryLoop(series.centred(), config=config, baseline=baseline, pool=pool, meas_pool=meas_pool,
                         on_progress=on_progress).run()


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
