"""Exchange steps of discovery: is a kept term still needed, would another do better in its place?

Forward selection (:func:`pendtrack.discovery.loop.discover`) keeps one term per round, the
one that earns its keep with the lowest BIC. A flexible term kept early can stand in for
others, so three exchange steps judge the kept set again, each by the held-out and BIC rules
of :mod:`pendtrack.discovery.rules`:

* :func:`recheck`: does a kept term still earn its keep in the current model?
* :func:`replace_earlier`: would another effect do better in the place of one kept earlier?
* :func:`swap_subset`: would a set of effects that shares at most all but two with the kept
  ones do better in their place (two effects that each stand in for one of the truth's)?
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from pendtrack.config import Config
from pendtrack.discovery.data import AnalysisData
from pendtrack.discovery.interleaved import interleaved_test
from pendtrack.discovery.result import Candidate
from pendtrack.discovery.candidate_fits import (
    FitPair, FitTask, fit_full, fit_pair, fit_train, full_start, run_tasks, warm_start,
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
                         full_base=base, **common)
                 for opt, st, ini in zip(options, starts, initials)]
        pairs = run_tasks(fit_train, [(task,) for task in tasks], on_done=self.tick, executor=self.executor)
        again = [i for i, p in enumerate(pairs)
                 if passes_heldout(*judge_heldout(p, current, data), dc.heldout_z_min,
                                   min_gain=dc.heldout_min_gain, heldout_rms=current.heldout_rms)]
        refits = run_tasks(fit_full, [(tasks[i], pairs[i]) for i in again], executor=self.executor)
        for i, p in zip(again, refits):
            pairs[i] = p
        judged = [judge(p, current, data, effect="+".join(opt), terms=tuple(opt), kind=kind, step=step, score=s,
                        delta_bic_max=dc.delta_bic_max, heldout_z_min=dc.heldout_z_min,
                        min_gain=dc.heldout_min_gain, seed=seed)
                  for p, opt, s in zip(pairs, options, scores)]
        return judged, pairs

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
    # a measurement term is judged as it was kept: interleaved folds on the model without it
    test = interleaved_test(ctx.data.theta, reduced.trajectory, term, n_blocks=dc.cv_blocks) \
        if kind == "measurement" else None
    cand = judge(current, reduced, ctx.data, effect=term, terms=(term,), kind=kind, step=step, score=0.0,
                 delta_bic_max=dc.delta_bic_max, heldout_z_min=dc.heldout_z_min, min_gain=dc.heldout_min_gain,
                 test=test, seed=dc.seed + 200 + step)
    return cand, reduced


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
                step: int) -> tuple[list[Candidate], tuple | None]:
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

    Returns
    -------
    judged : list of Candidate
        Every set tried (for the record).
    best : tuple or None
        ``(subset, candidate, pair)`` of the lowest-BIC set that qualifies.
    """
    dc = ctx.config.discover
    k = len(accepted)
    subsets = [s for s in itertools.combinations(pool, k) if len(set(s) - set(accepted)) >= 2]
    if k < 2 or not subsets:
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
