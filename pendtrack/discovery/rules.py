"""The rules that decide whether a candidate earns its keep (:mod:`pendtrack.discovery.candidate_fits` fits it).

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

Every term it adds is present in that fit (:func:`absent_terms`)
    A term at the limit where it vanishes or becomes a simpler one (an amplitude at 0, ``beta``
    at 0: ``FitResult.findings``) is a finding that the data show no such term. A set of effects
    with one member absent is the others alone, and is not kept under its name.

A **measurement term** is judged by interleaved-block cross-validation instead of the
held-out extrapolation (:mod:`pendtrack.discovery.interleaved`), by the same z, gain and the
other rules. An effect that acts early in the run and fades (``Effect.early``: time-varying
damping) and fails the held-out test gets a second held-out test that looks where it acts:
the current model and the model with it are each refitted on two interleaved folds of the
record and predict the other fold (:meth:`pendtrack.discovery.exchange.Context.refit_test`);
its z and gain stand in for the held-out ones, and the other rules are unchanged. Every decision carries its margins (``z - 3``, ``-10 - dBIC``, ...) and its
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

import math
from collections.abc import Iterable, Sequence
from dataclasses import replace

from pendtrack.discovery.candidate_fits import FitPair
from pendtrack.discovery.data import AnalysisData
from pendtrack.discovery.interleaved import FoldTest
from pendtrack.discovery.residuals import heldout_test
from pendtrack.discovery.result import Candidate


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


def own_flags(pair: FitPair, current: FitPair, terms: Sequence[str], *, kind: str = "effect") -> dict[str, str]:
    """Flags of the candidate's whole-record fit that its terms brought.

    An effect: a flag on one of the new terms' parameters, or one the current model's fit does not
    carry (memory at ``beta`` = 1 flags ``Omega0``: the term is an added mass and Omega0 trades off
    against G2). A flag the current fit already carries (a baseline parameter the record does not
    determine) is not the new term's.

    A measurement term (theta's zero offset, an angle-scale error): a flag on its own parameters
    only. It does not enter the dynamics, so it can leave a physical parameter undetermined only by
    trading off with it -- and a trade-off leaves its own parameter undetermined too. A physical
    parameter that the corrected angle no longer determines (on lab1, the quadratic drag beside
    memory, once the 10-mrad offset no longer has to be absorbed by it) is the physics' flag, judged
    with the effects.
    """
    from pendtrack.models import CATALOGUE

    if pair.full is None:
        return {}
    mine = {p for t in terms if t in CATALOGUE for p in CATALOGUE[t].params}
    if kind == "measurement":
        return {k: v for k, v in pair.full.flags.items() if k in mine}
    before = current.full.flags if current.full is not None else {}
    return {k: v for k, v in pair.full.flags.items() if k in mine or k not in before}


def absent_terms(pair: FitPair, terms: Sequence[str]) -> dict[str, str]:
    """Findings of the candidate's whole-record fit on its new terms' parameters: a term it adds that sits
    at the limit where it vanishes or becomes a simpler term (:func:`pendtrack.fitting.result.split_findings`).

    Such a candidate is not the model it is named by: a pair whose added mass ends at ``Ca`` = 0 is its
    other member alone, perhaps in another minimum than that member's own fit, and the added mass
    must not be reported as kept.
    """
    from pendtrack.models import CATALOGUE

    if pair.full is None:
        return {}
    mine = {p for t in terms if t in CATALOGUE for p in CATALOGUE[t].params}
    return {k: v for k, v in pair.full.findings.items() if k in mine}


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
    ``test``: a measurement term's interleaved test, or an early effect's refit test
    (:mod:`pendtrack.discovery.interleaved`), which then stands in for the held-out test. Every candidate gets its margins against each
    rule and the stability of its decision (:mod:`pendtrack.discovery.stability`).
    """
    from pendtrack.discovery.stability import Rules, decision_stability

    names = terms or (effect,)
    which = test.name if test is not None else "heldout"
    if pair.error or pair.train is None or current.full is None:
        return Candidate(effect, step, score, pair.train, pair.full, math.inf, -math.inf, -math.inf, math.nan,
                         False, False, error=pair.error or "fit failed", terms=terms, kind=kind, test=which,
                         stability=1.0)
    if test is not None:
        gain, z = test.gain, test.z
        rms_ref, rms_test = test.rms_before, test.rms_after
        ref = test.reference if test.reference is not None else current.trajectory
        judged = test.mask if test.mask is not None else slice(None)
        samples = (data.theta[judged], ref[judged], test.prediction[judged])
    else:
        gain, z = judge_heldout(pair, current, data)
        rms_ref, rms_test = current.heldout_rms, pair.heldout_rms
        held = data.heldout
        samples = (data.theta[held], current.prediction[held], pair.prediction[held])
    dbic = pair.full.bic - current.full.bic if pair.full is not None else math.nan
    rms_change = current.full.rms - pair.full.rms if pair.full is not None else math.nan
    flags = own_flags(pair, current, names, kind=kind)
    absent = absent_terms(pair, names)
    passes_h = passes_heldout(gain, z, heldout_z_min, min_gain=min_gain, heldout_rms=rms_ref)
    lowers = bool(pair.full is None or rms_change > 0)
    cand = Candidate(effect=effect, step=step, signature_score=score, train=pair.train, full=pair.full,
                     heldout_rms=rms_test, heldout_gain=gain, heldout_z=z, delta_bic=dbic,
                     passes_bic=bool(dbic < delta_bic_max), passes_heldout=passes_h, terms=terms, kind=kind,
                     flags=flags, absent=absent, lowers_rms=lowers, test=which,
                     test_rms_before=rms_ref if test is not None else math.nan,
                     margins=rule_margins(z, gain, rms_ref, dbic, heldout_z_min=heldout_z_min, min_gain=min_gain,
                                      delta_bic_max=delta_bic_max, rms_change=rms_change))
    whole = (data.theta, current.trajectory, pair.trajectory) if pair.full is not None else None
    stab = decision_stability(kept=cand.earns_keep, test=samples, test_rms_ref=rms_ref, whole=whole,
                              delta_bic=dbic, n_bic=pair.full.n if pair.full is not None else 0,
                              rules=Rules(heldout_z_min, min_gain, delta_bic_max), fixed=bool(flags or absent),
                              seed=seed)
    return replace(cand, stability=stab)


def choose(cands: Iterable[Candidate]) -> Candidate | None:
    """The candidate that earns its keep with the lowest BIC, or None.

    Candidates of one call add the same number of terms (singles, or pairs): the simplest
    models are judged first (:func:`pendtrack.discovery.loop.discover`), so among nested
    alternatives that clear the rules the one with fewer terms is kept.
    """
    ok = [c for c in cands if c.earns_keep]
    return min(ok, key=lambda c: c.delta_bic) if ok else None
