"""Exchange steps of discovery: is a kept term still needed, would another do better in its place?

Forward selection (:func:`pendtrack.discovery.loop.discover`) keeps one term per round, the
one that earns its keep with the lowest BIC. A flexible term kept early can stand in for
others, so three exchange steps judge the kept set again, each by the held-out and BIC rules
of :mod:`pendtrack.discovery.rules`:

* :func:`recheck`: does a kept term still earn its keep in the current model?
* :func:`replace_earlier`: would another effect do better in the place of one kept earlier?
* :func:`swap_subset`: would a set of effects that shares at most all but two with the kept
  ones do better in their place (two effects that each stand in for one of the truth's), or,
  while structure remains, a set of one more (one effect that stands in for two)?

:meth:`Context.refit_test` judges an effect that acts early and fades by refits on interleaved
folds where the held-out test, a prediction of the later times, cannot see it.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from pendtrack.config import Config
from pendtrack.discovery.catalogue import CATALOGUE as EFFECTS
from pendtrack.discovery.data import AnalysisData
from pendtrack.discovery.interleaved import FoldTest, interleaved_test, out_of_fold_test, refit_folds
from pendtrack.discovery.result import Candidate
from pendtrack.discovery.candidate_fits import (
    FitPair, FitTask, fit_fold, fit_full, fit_pair, fit_train, full_start, run_tasks, warm_start,
)
from pendtrack.discovery.rules import judge, judge_heldout, passes_heldout, rule_margins
from pendtrack.discovery.starts import scaled_starts


@dataclass(frozen=True, eq=False)
class Context:
    """What every step of one discovery shares."""

    data: AnalysisData
    baseline: str
    config: Config
    executor: Any
    tick: Callable[[int], None]
    # id of a current model -> (that model, its out-of-fold prediction): refit_test fits it once per model
    refits: dict[int, tuple[FitPair, np.ndarray]] = field(default_factory=dict)
    # terms beyond the baseline -> the lowest whole-record fit of that model (its Xi^2; values, theta0,
    # omega0), for the nested starts of the models that extend it by one term (FitTask.sub_fulls)
    fulls: dict[frozenset[str], tuple[float, dict[str, float]]] = field(default_factory=dict)

    def sub_fulls(self, kept: Sequence[str], option: Sequence[str]) -> tuple[dict[str, float], ...]:
        """Whole-record fits of the models ``kept + option`` extends by one term, the current one
        (``kept``, the task's ``full_base``) apart, dropping each of its terms in turn."""
        terms = (*kept, *option)
        subs = [frozenset(t for j, t in enumerate(terms) if j != i) for i in range(len(terms))]
        return tuple(self.fulls[s][1] for s in subs if s != frozenset(kept) and s in self.fulls)

    def evaluate(self, current: FitPair, kept: Sequence[str], options: Sequence[tuple[str, ...]],
                 starts: Sequence[Sequence[dict[str, float]]], scores: Sequence[float], *, step: int, kind: str,
                 seed: int,
                 initials: Sequence[dict[str, float]] | None = None) -> tuple[list[Candidate], list[FitPair]]:
        """Fit ``baseline + kept + option`` for every option and judge it against ``current``.

        Every option is fitted on the training part and predicts the held-out part; only one
        that passes the held-out test earns a whole-record fit (for BIC; started at its training
        fit and at the current whole-record fit). ``initials[i]``: option i's warm start
        (default: the current model's training fit).
        """
        dc = self.config.discover
        data = self.data
        warm = warm_start(current)
        common = dict(cost=self.config.fit.cost, memory_s=self.config.models.memory_s)
        initials = list(initials) if initials is not None else [warm] * len(options)
        base = full_start(current)
        tasks = [FitTask(data, self.baseline, (*kept, *opt), ini, dc.n_starts, seed, extra_starts=tuple(st),
                         full_base=base, sub_fulls=self.sub_fulls(kept, opt), **common)
                 for opt, st, ini in zip(options, starts, initials)]
        pairs = run_tasks(fit_train, [(task,) for task in tasks], on_done=self.tick, executor=self.executor)
        again = [i for i, p in enumerate(pairs)
                 if passes_heldout(*judge_heldout(p, current, data), dc.heldout_z_min,
                                   min_gain=dc.heldout_min_gain, heldout_rms=current.heldout_rms)]
        # an early, fading effect that fails the held-out test: judged again where it acts
        early = [i for i, (opt, p) in enumerate(zip(options, pairs))
                 if i not in again and kind == "effect" and p.train is not None and not p.error and _has_early(opt)]
        tests: dict[int, FoldTest] = {}
        if early:
            folded = self.refit_test(current, [tasks[i] for i in early], [warm_start(pairs[i]) for i in early])
            for i, ft in zip(early, folded):
                if ft is None:
                    continue
                tests[i] = ft
                if passes_heldout(ft.gain, ft.z, dc.heldout_z_min, min_gain=dc.heldout_min_gain,
                                  heldout_rms=ft.rms_before):
                    again.append(i)
        refits = run_tasks(fit_full, [(tasks[i], pairs[i]) for i in again], executor=self.executor)
        for i, p in zip(again, refits):
            pairs[i] = p
            key = frozenset((*kept, *options[i]))
            if p.full is not None and p.full.xi2 < self.fulls.get(key, (math.inf, {}))[0]:
                self.fulls[key] = (p.full.xi2, full_start(p))
        judged = [judge(p, current, data, effect="+".join(opt), terms=tuple(opt), kind=kind, step=step, score=s,
                        delta_bic_max=dc.delta_bic_max, heldout_z_min=dc.heldout_z_min,
                        min_gain=dc.heldout_min_gain, test=tests.get(i), seed=seed)
                  for i, (p, opt, s) in enumerate(zip(pairs, options, scores))]
        return judged, pairs

    def refit_test(self, current: FitPair, tasks: Sequence[FitTask],
                   starts: Sequence[dict[str, float]]) -> list[FoldTest | None]:
        """Each task's model against ``current``, both refitted on interleaved folds of the record.

        The held-out test predicts the later times, where an effect that fades (time-varying
        damping, ``C4/(t - t0)``) no longer acts: measured at the field trial's sizes, the model
        with it at its true values predicted the last 40 % 0.12 mrad *worse* than the model
        without it, while it lowered the whole-record BIC by 450. Here the record is cut into
        blocks (:func:`~pendtrack.discovery.interleaved.refit_folds`: the first in both folds,
        the others alternating); the current model (from its whole-record fit) and each model
        with the effect (from ``starts[i]``, its training fit) are fitted on one fold and
        predict the other, and the pooled out-of-fold predictions are compared by the held-out
        test's gain and z. Returns a :class:`~pendtrack.discovery.interleaved.FoldTest` per
        task (None where a fit failed).
        """
        data = self.data
        fold_a, fold_b, judged = refit_folds(data.t.size, self.config.discover.cv_blocks)
        base = full_start(current)
        if base is None or current.full is None:
            return [None] * len(tasks)
        cached = self.refits.get(id(current))
        models = ([] if cached is not None else [(current.extra, base)]) + [
            (task.extra, start) for task, start in zip(tasks, starts)]
        proto = tasks[0]
        jobs = [(replace(proto, extra=tuple(extra), initial=dict(start), n_starts=1, extra_starts=(), fold=fold),)
                for extra, start in models for fold in (fold_a, fold_b)]
        preds = run_tasks(fit_fold, jobs, executor=self.executor)
        oof = []
        for k in range(len(models)):
            pa, pb = preds[2 * k], preds[2 * k + 1]
            oof.append(np.where(fold_a, pb, pa))  # fold A's samples predicted by fold B's fit and back
        if cached is None:
            self.refits[id(current)] = (current, oof.pop(0))  # the model is kept, so its id stays its own
        ref = self.refits[id(current)][1]
        out: list[FoldTest | None] = []
        for task, pred in zip(tasks, oof):
            ok = np.all(np.isfinite(ref[judged])) and np.all(np.isfinite(pred[judged]))
            out.append(out_of_fold_test(data.theta, ref, pred, judged, "+".join(task.extra)) if ok else None)
        return out

    def evaluate_measurement(self, current: FitPair, kept: Sequence[str], terms: Sequence[str],
                             starts: Sequence[Sequence[dict[str, float]]], *, step: int,
                             seed: int) -> tuple[list[Candidate], list[FitPair]]:
        """Judge measurement terms by interleaved-block cross-validation, not by extrapolation.

        Each term is tested on the current model's whole-record fit
        (:func:`~pendtrack.discovery.interleaved.interleaved_test`: physics held, the term
        estimated on one fold, predicting the other). Only a term that passes is fitted: on the
        training part (from ``starts``: it is the prediction the later effect steps are judged
        against) and on the whole record (for BIC and the residual; also started at the current
        whole-record fit). The same margins, BIC and residual rules as for an effect.
        """
        dc = self.config.discover
        data = self.data
        assert current.full is not None
        tests = [interleaved_test(data.theta, current.trajectory, term, n_blocks=dc.cv_blocks) for term in terms]
        nan = np.full(data.t.size, np.nan)
        pairs = [FitPair((*kept, term), None, None, nan, math.inf, nan, nan, error="no interleaved test")
                 for term in terms]
        go = [i for i, ft in enumerate(tests) if ft is not None and passes_heldout(
            ft.gain, ft.z, dc.heldout_z_min, min_gain=dc.heldout_min_gain, heldout_rms=ft.rms_before)]
        common = dict(cost=self.config.fit.cost, memory_s=self.config.models.memory_s)
        warm = warm_start(current)
        tasks = {i: FitTask(data, self.baseline, (*kept, terms[i]), warm, dc.n_starts, seed,
                            extra_starts=tuple(starts[i]), full_base=full_start(current), **common) for i in go}
        done = run_tasks(fit_pair, [(tasks[i],) for i in go], on_done=self.tick, executor=self.executor)
        for i, p in zip(go, done):
            pairs[i] = p
        judged = []
        for i, (term, ft) in enumerate(zip(terms, tests)):
            if i in tasks:
                judged.append(judge(pairs[i], current, data, effect=term, terms=(term,), kind="measurement",
                                    step=step, score=0.0, delta_bic_max=dc.delta_bic_max,
                                    heldout_z_min=dc.heldout_z_min, min_gain=dc.heldout_min_gain, test=ft, seed=seed))
            else:
                judged.append(_untested(term, ft, current, data, step=step, seed=seed, config=self.config))
        return judged, pairs


def _untested(term: str, ft: Any, current: FitPair, data: AnalysisData, *, step: int, seed: int,
              config: Config) -> Candidate:
    """A measurement term that failed its interleaved test (not fitted): its numbers and stability."""
    from pendtrack.discovery.stability import Rules, decision_stability

    dc = config.discover
    if ft is None:
        return Candidate(term, step, 0.0, None, None, math.inf, -math.inf, -math.inf, math.nan, False, False,
                         error="no interleaved test for this term", terms=(term,), kind="measurement",
                         test="interleaved", stability=1.0)
    stab = decision_stability(kept=False, test=(data.theta, current.trajectory, ft.prediction),
                              test_rms_ref=ft.rms_before, whole=None, delta_bic=math.nan, n_bic=0,
                              rules=Rules(dc.heldout_z_min, dc.heldout_min_gain, dc.delta_bic_max), seed=seed)
    margins = rule_margins(ft.z, ft.gain, ft.rms_before, math.nan, heldout_z_min=dc.heldout_z_min,
                           min_gain=dc.heldout_min_gain, delta_bic_max=dc.delta_bic_max, rms_change=math.nan)
    return Candidate(term, step, 0.0, None, None, ft.rms_after, ft.gain, ft.z, math.nan, False, False,
                     terms=(term,), kind="measurement", test="interleaved", test_rms_before=ft.rms_before,
                     margins=margins, stability=stab)


def without(warm: dict[str, float], term: str) -> dict[str, float]:
    """A warm start less one term's parameters."""
    from pendtrack.models import CATALOGUE

    drop = set(CATALOGUE[term].params)
    return {k: v for k, v in warm.items() if k not in drop}


def recheck(ctx: Context, current: FitPair, terms: Sequence[str], term: str, *, kind: str,
             step: int) -> tuple[Candidate, FitPair]:
    """Does ``term`` still earn its keep in the model ``baseline + terms``?

    The model without it is fitted (training part, then the whole record, warm-started from the
    current fit less the term's parameters) and the current model is judged against it as if
    the term were being added now, by the same held-out and BIC rules.
    """
    dc = ctx.config.discover
    reduced_terms = tuple(t for t in terms if t != term)
    base = full_start(current)
    task = FitTask(ctx.data, ctx.baseline, reduced_terms, without(warm_start(current), term), dc.n_starts,
                   dc.seed + 200 + step, cost=ctx.config.fit.cost, memory_s=ctx.config.models.memory_s,
                   full_base=without(base, term) if base is not None else None)
    reduced = fit_pair(task)
    ctx.tick(1)
    if reduced.error or reduced.full is None:  # the simpler model cannot be fitted: the term stays
        return Candidate(term, step, 0.0, current.train, current.full, current.heldout_rms, math.inf, math.inf,
                         -math.inf, True, True, terms=(term,), kind=kind, stability=1.0), reduced
    # a measurement term is judged as it was kept: interleaved folds on the model without it; an early
    # effect that fails the held-out test there, by refits on interleaved folds (Context.refit_test)
    test = interleaved_test(ctx.data.theta, reduced.trajectory, term, n_blocks=dc.cv_blocks) \
        if kind == "measurement" else None
    if kind == "effect" and _has_early((term,)) and not passes_heldout(
            *judge_heldout(current, reduced, ctx.data), dc.heldout_z_min, min_gain=dc.heldout_min_gain,
            heldout_rms=reduced.heldout_rms):
        test = ctx.refit_test(reduced, [replace(task, extra=tuple(terms))], [full_start(current) or warm_start(current)])[0]
    cand = judge(current, reduced, ctx.data, effect=term, terms=(term,), kind=kind, step=step, score=0.0,
                 delta_bic_max=dc.delta_bic_max, heldout_z_min=dc.heldout_z_min, min_gain=dc.heldout_min_gain,
                 test=test, seed=dc.seed + 200 + step)
    return cand, reduced


def _has_early(terms: Sequence[str]) -> bool:
    """Whether any of ``terms`` is an effect that acts early and fades (``Effect.early``)."""
    return any(EFFECTS[t].early for t in terms if t in EFFECTS)


def replace_earlier(ctx: Context, current: FitPair, meas_kept: Sequence[str], accepted: Sequence[str],
                     others: Sequence[str], *, step: int) -> tuple[list[Candidate], tuple | None]:
    """Sequential replacement: would another effect do better in the place of one kept earlier?

    Forward selection keeps the effect that earns its keep with the lowest BIC at each step, and
    a flexible effect kept first can stand in for another: memory with ``beta`` near 1 or 2 is a
    local, velocity-dependent inertia and absorbs most of an added mass, which then no longer
    earns its keep beside it (measured: added mass + time-varying damping at 120 Hz found as
    memory + time-varying damping). For every effect ``e`` kept *before* the last one, the model
    without ``e`` is fitted, and every catalogue effect ``f`` not in the model is added to it by the
    usual rules (held-out and BIC against the model without ``e``). A replacement that earns its
    keep there *and* gives a lower BIC than the current model is a better model of the same size
    or smaller. (The last effect kept needs no such test: its step already compared every
    alternative against the same model.)

    Returns
    -------
    judged : list of Candidate
        Every replacement tried (for the record).
    best : tuple or None
        ``(e, candidate, pair, reduced)`` of the lowest-BIC replacement that qualifies.
    """
    dc = ctx.config.discover
    judged_all: list[Candidate] = []
    best = None
    assert current.full is not None
    for e in accepted[:-1]:
        if not others:
            break
        _, reduced = recheck(ctx, current, (*meas_kept, *accepted), e, kind="effect", step=step)
        if reduced.error or reduced.full is None or reduced.train is None:
            continue
        kept = (*meas_kept, *(a for a in accepted if a != e))
        warm = warm_start(reduced)
        starts = [scaled_starts(ctx.baseline, kept, f, warm, ctx.data, memory_s=ctx.config.models.memory_s)
                  for f in others]
        judged, pairs = ctx.evaluate(reduced, kept, [(f,) for f in others], starts, [0.0] * len(others), step=step,
                                     kind="effect", seed=dc.seed + 300 + step)
        for c, p in zip(judged, pairs):
            better = bool(c.earns_keep and p.full is not None and p.full.bic < current.full.bic)
            judged_all.append(replace(c, note=f"tried in the place of {e}: " + (
                f"BIC {p.full.bic - current.full.bic:+.1f} against the current model" if p.full is not None
                else c.reason())))
            if better and (best is None or p.full.bic < best[2].full.bic):
                best = (e, c, p, reduced)
    return judged_all, best


def subset_starts(subset: Sequence[str], warm: Mapping[str, float], singles: Mapping[str, Mapping[str, float]],
                  accepted: Sequence[str]) -> list[dict[str, float]]:
    """Complete starts for ``baseline + measurement + subset`` from the current fit and single fits.

    Parameters
    ----------
    subset : sequence of str
        The effects of the model to fit.
    warm : mapping
        The current model's training fit (``warm_start``): physics, measurement terms, state.
    singles : mapping
        Effect -> its training fit alone on the first effect round (``warm_start`` of it).
    accepted : sequence of str
        The current model's effects: those not in ``subset`` leave the start with their parameters.

    Returns
    -------
    list of dict
        The current fit with each new effect's parameters from its single fit; then each new
        effect's single fit (its physics) with the others' parameters from theirs and the
        measurement terms' from the current fit. Empty when a new effect has no single fit.
    """
    from pendtrack.models import CATALOGUE

    new = [e for e in subset if e not in accepted]
    if any(e not in singles for e in new):
        return []
    gone = {p for e in accepted if e not in subset for p in CATALOGUE[e].params}
    base = {k: float(v) for k, v in warm.items() if k not in gone}
    for e in new:
        base.update({p: float(singles[e][p]) for p in CATALOGUE[e].params})
    out = [base]
    own = {p for e in subset for p in CATALOGUE[e].params}
    for a in new:
        start = {k: float(v) for k, v in singles[a].items() if k not in gone}
        start.update({k: v for k, v in base.items() if k in own or k not in start})
        start.update({p: float(singles[a][p]) for p in CATALOGUE[a].params})
        out.append(start)
    return out


def swap_subset(ctx: Context, current: FitPair, meas_kept: Sequence[str], accepted: Sequence[str],
                pool: Sequence[str], singles: Mapping[str, Mapping[str, float]], *,
                step: int, grow: bool = False) -> tuple[list[Candidate], tuple | None]:
    """Would another set of as many effects do better than the kept ones, changing two at once?

    Forward selection and :func:`replace_earlier` change one effect at a time. Two flexible
    effects kept may each stand in for one of the truth's, and then neither single exchange
    helps: measured at 120 Hz, added mass + time-varying damping found as memory (beta 1.4, a
    local inertia) + power drag (a damping that weakens as the swings shrink), while added mass
    alone in memory's place, beside power drag, predicted worse. Every set of
    ``len(accepted)`` catalogue effects that differs from the kept ones in two or more is fitted
    (its starts: the current fit with each new effect's first-round single fit,
    :func:`subset_starts`) and judged against the current model by the usual rules: it must
    predict the held-out part significantly better and lower the BIC. Each of its effects must
    then earn its keep in it (:func:`recheck`); the lowest-BIC set that does is returned.

    With ``grow`` (the loop sets it while the current model leaves structure and one more effect
    is allowed in a combination), the sets of ``len(accepted) + 1`` effects that bring two or
    more new ones are tried as well: one flexible effect kept first may stand in for a pair, and
    then neither adding one nor exchanging one helps (measured at the field trial's sizes:
    time-varying damping + memory found as an added mass at Ca 0.008 and nothing else, each
    single beside it predicting the later times no better).

    Returns
    -------
    judged : list of Candidate
        Every set tried (for the record).
    best : tuple or None
        ``(subset, candidate, pair)`` of the lowest-BIC set that qualifies.
    """
    dc = ctx.config.discover
    k = len(accepted)
    sizes = ([k] if k >= 2 else []) + ([k + 1] if grow and k >= 1 else [])
    subsets = [s for size in sizes for s in itertools.combinations(pool, size) if len(set(s) - set(accepted)) >= 2]
    if not subsets:
        return [], None
    warm = warm_start(current)
    starts = [[_within(st, ctx.baseline, (*meas_kept, *s)) for st in subset_starts(s, warm, singles, accepted)]
              for s in subsets]
    keep = [i for i, st in enumerate(starts) if st]
    subsets = [subsets[i] for i in keep]
    if not subsets:
        return [], None
    kept = tuple(meas_kept)
    judged, pairs = ctx.evaluate(current, kept, subsets, [starts[i] for i in keep], [0.0] * len(subsets),
                                 step=step, kind="effect", seed=dc.seed + 400 + step,
                                 initials=[_within(warm, ctx.baseline, (*kept, *s)) for s in subsets])
    out: list[Candidate] = []
    best = None
    assert current.full is not None
    for s, c, p in zip(subsets, judged, pairs):
        note = "tried in the place of " + "+".join(accepted)
        if c.earns_keep and p.full is not None:
            weak = []
            for e in s:
                cand, _ = recheck(ctx, p, (*kept, *s), e, kind="effect", step=step)
                if not cand.earns_keep:
                    weak.append(f"{e} ({cand.reason()})")
            note += ": " + (f"BIC {p.full.bic - current.full.bic:+.1f}, each effect earns its keep in it" if not weak
                            else "does not earn its keep in it: " + ", ".join(weak))
            if not weak and (best is None or p.full.bic < best[2].full.bic):
                best = (s, c, p)
        else:
            note += ": " + c.reason()
        out.append(replace(c, note=note))
    return out, best


def _within(start: Mapping[str, float], baseline: str, extra: Sequence[str]) -> dict[str, float]:
    """``start`` less the names that are not parameters (or the initial state) of ``baseline + extra``."""
    from pendtrack.models import compose

    names = {*compose(baseline, list(extra)).param_names, "theta0", "omega0"}
    return {k: v for k, v in start.items() if k in names}
