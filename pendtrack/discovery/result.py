"""Result objects of discovery: frozen dataclasses with ``to_dict()`` (discovery.json)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pendtrack.fitting.result import _num  # one JSON-safe float helper for every result


@dataclass(frozen=True)
class FitSummary:
    """What discovery keeps of one :class:`pendtrack.fitting.FitResult`.

    Attributes
    ----------
    model : str
        Model name (``baseline+term+...``).
    extra : tuple of str
        Terms added to the baseline.
    values, stderr, u_paper : mapping
        Parameter -> best value, sandwich standard error, the paper's spread uncertainty
        [each parameter's unit].
    theta0, omega0 : float
        Fitted initial state at the window's start [rad], [rad/s].
    xi2 : float
        Minimum cost (Xi^2, eq. leastsquarescostfunction, or the mean squared angle) [1].
    rms : float
        RMS of theta - theta_model over the fitted samples [rad].
    bic : float
        ``n ln(xi2) + k ln(n)`` as :mod:`pendtrack.fitting.result` defines it [1].
    n, k : int
        Samples in the cost; fitted parameters (initial state included).
    window : tuple of float
        Fitted time window [s].
    converged : bool
    message : str
    runtime_s : float
        Wall time of the fit [s].
    flags : mapping
        Parameter -> why its value is not a measurement (``FitResult.flags``,
        :func:`pendtrack.fitting.result.plausibility_flags`); empty for a trustworthy fit.
    findings : mapping
        Parameter -> the effect its fit shows absent (``FitResult.findings``,
        :func:`pendtrack.fitting.result.split_findings`: a term at the limit where it vanishes).
    """

    model: str
    extra: tuple[str, ...]
    values: Mapping[str, float]
    stderr: Mapping[str, float]
    u_paper: Mapping[str, float]
    theta0: float
    omega0: float
    xi2: float
    rms: float
    bic: float
    n: int
    k: int
    window: tuple[float, float]
    converged: bool
    message: str
    runtime_s: float
    flags: Mapping[str, str] = field(default_factory=dict)
    findings: Mapping[str, str] = field(default_factory=dict)

    @classmethod
    def from_fit(cls, fit: Any, extra: tuple[str, ...]) -> "FitSummary":
        return cls(model=fit.model, extra=tuple(extra), values=dict(fit.values),
                   stderr={k: float(v.stderr) for k, v in fit.params.items()},
                   # the paper's spread needs several accepted starts; one start has none
                   u_paper={k: float(v.u_paper) if fit.n_accepted > 1 else float("nan")
                            for k, v in fit.params.items()},
                   theta0=float(fit.theta0), omega0=float(fit.omega0), xi2=float(fit.xi2_min), rms=float(fit.rms),
                   bic=float(fit.bic), n=int(fit.n), k=int(fit.n_params),
                   window=(float(fit.window[0]), float(fit.window[1])), converged=bool(fit.converged),
                   message=str(fit.message), runtime_s=float(fit.runtime_s),
                   flags={str(k): str(v) for k, v in (getattr(fit, "flags", None) or {}).items()},
                   findings={str(k): str(v) for k, v in (getattr(fit, "findings", None) or {}).items()})

    def params(self, names: tuple[str, ...] | None = None) -> dict[str, dict[str, float | None]]:
        """``{name: {"value", "stderr", "u_paper"}}`` for the named (default all) parameters."""
        keys = self.values.keys() if names is None else names
        return {k: {"value": _num(self.values[k]), "stderr": _num(self.stderr.get(k)),
                    "u_paper": _num(self.u_paper.get(k))} for k in keys}

    def to_dict(self) -> dict[str, Any]:
        return {"model": self.model, "extra": list(self.extra), "params": self.params(),
                "initial_state": {"theta0": _num(self.theta0), "omega0": _num(self.omega0)},
                "xi2": _num(self.xi2), "rms": _num(self.rms), "bic": _num(self.bic), "n": self.n, "k": self.k,
                "window": [_num(self.window[0]), _num(self.window[1])], "converged": self.converged,
                "message": self.message, "runtime_s": _num(self.runtime_s), "flags": dict(self.flags),
                "findings": dict(self.findings)}


class _AddsTerms:
    """What a candidate and a step share: the terms they add."""

    effect: str
    terms: tuple[str, ...]

    @property
    def names(self) -> tuple[str, ...]:
        """The terms added (``terms``, or the one ``effect``)."""
        return self.terms or (self.effect,)


@dataclass(frozen=True)
class Candidate(_AddsTerms):
    """One candidate model judged against the current one.

    Attributes
    ----------
    effect : str
        The effect (term) tried.
    step : int
        Selection step (1 = first extension of the baseline).
    signature_score : float
        Its signature score on the current model's diagnosis (the order it was tried in); 0 for a
        measurement term.
    train, full : FitSummary
        Fit on the training part and on the whole record.
    heldout_rms : float
        RMS of the training fit's prediction over the held-out part [rad].
    heldout_gain : float
        Held-out RMS of the current model minus this one's [rad] (> 0: better).
    heldout_z : float
        That gain in mean squares over what noise alone would give (see :mod:`pendtrack.discovery.rules`) [1].
    delta_bic : float
        BIC of this model minus the current model's, whole record [1].
    passes_bic, passes_heldout : bool
        The two tests.
    error : str
        Why the candidate could not be fitted ("" when it could).
    terms : tuple of str
        The terms the candidate adds (several for a combination; default ``(effect,)``).
    kind : str
        ``"measurement"`` (a term of the observation) or ``"effect"`` (physics).
    note : str
        Why a term kept earlier was dropped (the final check), else "".
    flags : mapping
        Flags of its whole-record fit that the term brought (on its own parameters, or new
        against the current model's fit: memory at ``beta`` = 1 flags ``Omega0`` as an added
        mass): a term whose fit is flagged is not kept, its values are not measurements.
    absent : mapping
        Findings of its whole-record fit on the new terms' parameters: a term at the limit where it
        vanishes or becomes a simpler one (an amplitude at 0, ``beta`` at 0). Such a candidate is not
        the set it is named by, and is not kept: with added mass + memory at ``Ca`` = 0 it is memory
        alone, in another minimum.
    lowers_rms : bool
        Its whole-record fit's residual RMS is below the current model's (True when not refitted).
    test : str
        ``"heldout"`` (the training fit extrapolated into the held-out part: effects) or
        ``"interleaved"`` (interleaved-block cross-validation: measurement terms,
        :mod:`pendtrack.discovery.interleaved`).
    test_rms_before : float
        The current model's RMS on the test samples [rad] (NaN: its held-out RMS).
    margins : mapping
        Rule -> ``{"value", "threshold", "margin"}``; margin > 0 passes (z - 3, -10 - dBIC, ...).
    stability : float
        Share of block-bootstrap records on which the same decision is made
        (:mod:`pendtrack.discovery.stability`) [1]; NaN when not assessed.
    """

    effect: str
    step: int
    signature_score: float
    train: FitSummary | None
    full: FitSummary | None
    heldout_rms: float
    heldout_gain: float
    heldout_z: float
    delta_bic: float
    passes_bic: bool
    passes_heldout: bool
    error: str = ""
    terms: tuple[str, ...] = ()
    kind: str = "effect"
    note: str = ""
    flags: Mapping[str, str] = field(default_factory=dict)
    lowers_rms: bool = True
    test: str = "heldout"
    test_rms_before: float = math.nan
    margins: Mapping[str, Mapping[str, float]] = field(default_factory=dict)
    stability: float = math.nan
    absent: Mapping[str, str] = field(default_factory=dict)

    @property
    def earns_keep(self) -> bool:
        """Every rule passed: the test, BIC, a lower whole-record residual, an unflagged fit with every new
        term present."""
        return (self.passes_bic and self.passes_heldout and self.lowers_rms and not self.flags and not self.absent
                and not self.error)

    @property
    def borderline(self) -> bool:
        """Its decision is made on fewer than 80 % of resampled records (:data:`~pendtrack.discovery.stability.BORDERLINE`)."""
        from pendtrack.discovery.stability import BORDERLINE

        return bool(math.isfinite(self.stability) and self.stability < BORDERLINE)

    def reason(self) -> str:
        """One line: why it was (not) kept."""
        if self.note:
            return self.note
        if self.error:
            return f"could not be fitted: {self.error}"
        what = {"heldout": "held-out", "refit_folds": "refit on interleaved folds"}.get(
            self.test, "interleaved cross-validation")
        if not math.isfinite(self.delta_bic):
            return (f"{what} gain {1e3 * self.heldout_gain:+.3f} mrad, z {self.heldout_z:.1f} (not significant); "
                    "not refitted on the whole record, no dBIC")
        parts = [f"dBIC {self.delta_bic:+.1f}" + ("" if self.passes_bic else " (not < threshold)"),
                 f"{what} gain {1e3 * self.heldout_gain:+.3f} mrad, z {self.heldout_z:.1f}"
                 + ("" if self.passes_heldout else " (not significant)")]
        if not self.lowers_rms:
            parts.append("the whole-record residual RMS does not go down")
        if self.flags:
            parts.append("its fit is flagged (" + "; ".join(f"{k} {v}" for k, v in self.flags.items())
                         + "): its values are not measurements")
        if self.absent:
            parts.append("in its fit " + "; ".join(sorted(set(self.absent.values()))))
        return "; ".join(parts)

    def to_dict(self) -> dict[str, Any]:
        return {"effect": self.effect, "terms": list(self.names), "kind": self.kind, "step": self.step,
                "signature_score": _num(self.signature_score),
                "model": (self.full or self.train).model if (self.full or self.train) else None,
                "params": (self.full or self.train).params(_term_params(self.names)) if (self.full or self.train)
                else {},
                "params_from": "whole record" if self.full else ("training part" if self.train else None),
                "rms": _num(self.full.rms) if self.full else None, "xi2": _num(self.full.xi2) if self.full else None,
                "heldout_rms": _num(self.heldout_rms), "heldout_gain": _num(self.heldout_gain),
                "heldout_z": _num(self.heldout_z), "delta_bic": _num(self.delta_bic), "passes_bic": self.passes_bic,
                "passes_heldout": self.passes_heldout, "earns_keep": self.earns_keep and not self.note,
                "lowers_rms": self.lowers_rms, "flags": dict(self.flags), "absent": dict(self.absent),
                "test": self.test,
                "margins": _jsonable(self.margins), "stability": _num(self.stability), "borderline": self.borderline,
                "reason": self.reason(),
                "error": self.error}


def _term_params(terms: str | tuple[str, ...]) -> tuple[str, ...]:
    """The parameters the named term(s) add (physical or measurement terms)."""
    from pendtrack.models import CATALOGUE

    names = (terms,) if isinstance(terms, str) else tuple(terms)
    return tuple(p for n in names for p in CATALOGUE[n].params)


@dataclass(frozen=True)
class Step(_AddsTerms):
    """One accepted extension and what it gained.

    Attributes
    ----------
    effect : str
        The term added.
    before, after : FitSummary
        Whole-record fits of the model before and after.
    heldout_rms_before, heldout_rms_after : float
        Held-out RMS of the training fits' predictions [rad].
    heldout_z : float
        Significance of the held-out gain [1].
    delta_bic : float
        ``bic_after - bic_before`` [1].
    terms : tuple of str
        The terms added in this step (several when a combination was kept; default ``(effect,)``).
    kind : str
        ``"measurement"`` or ``"effect"``.
    step : int
        Its number within its kind (1 = first).
    test : str
        The candidate's test (``"heldout"`` or ``"interleaved"``; see :class:`Candidate`).
    margins : mapping
        Rule -> ``{"value", "threshold", "margin"}`` (:class:`Candidate`).
    stability : float
        Share of resampled records deciding alike [1] (:class:`Candidate`).
    """

    effect: str
    before: FitSummary
    after: FitSummary
    heldout_rms_before: float
    heldout_rms_after: float
    heldout_z: float
    delta_bic: float
    terms: tuple[str, ...] = ()
    kind: str = "effect"
    step: int = 0
    test: str = "heldout"
    margins: Mapping[str, Mapping[str, float]] = field(default_factory=dict)
    stability: float = math.nan

    @property
    def borderline(self) -> bool:
        """Kept on fewer than 80 % of resampled records (:class:`Candidate`)."""
        from pendtrack.discovery.stability import BORDERLINE

        return bool(math.isfinite(self.stability) and self.stability < BORDERLINE)

    def to_dict(self) -> dict[str, Any]:
        return {"effect": self.effect, "terms": list(self.names), "kind": self.kind, "step": self.step,
                "test": self.test, "margins": _jsonable(self.margins), "stability": _num(self.stability),
                "borderline": self.borderline, "flags": dict(self.after.flags),
                "model": self.after.model,
                "params": self.after.params(_term_params(self.names)),
                "rms_before": _num(self.before.rms), "rms_after": _num(self.after.rms),
                "xi2_before": _num(self.before.xi2), "xi2_after": _num(self.after.xi2),
                "heldout_rms_before": _num(self.heldout_rms_before), "heldout_rms_after": _num(self.heldout_rms_after),
                "heldout_z": _num(self.heldout_z), "delta_bic": _num(self.delta_bic),
                "model_params": self.after.params()}


@dataclass(frozen=True)
class DiscoveryResult:
    """Everything discovery found (``to_dict()`` is discovery.json without provenance).

    Attributes
    ----------
    baseline : str
        Baseline model name.
    effects : tuple of str
        The causes named: physical effects kept, in the order they were added, when the final
        model leaves no structure the catalogue cannot remove and none of their fits is
        flagged (measurement terms are not effects).
    steps : tuple of Step
        The physical steps.
    candidates : tuple of Candidate
        Every candidate judged, every step (the runners-up are those not kept).
    baseline_fit : FitSummary
        Whole-record baseline fit.
    baseline_heldout_rms : float
        Held-out RMS of the baseline's training fit [rad].
    final_fit : FitSummary
    final_heldout_rms : float
    diagnosis : mapping
        Baseline (and final) diagnosis, signature ranking, the cause named.
    thresholds : mapping
        The decision thresholds used.
    data : mapping
        Facts about the analysed record.
    runtime_s : float
    measurement : tuple of str
        Measurement terms kept (``offset``, ``angle_scale``): findings about the record, not
        causes; they stay in the model while the effects are searched.
    measurement_steps : tuple of Step
    order : tuple of str
        Every term of the final model beyond the baseline, in the order it was kept
        (measurement terms and effects interleaved).
    unexplained : tuple of str
        Diagnostics still off after the final model
        (:func:`~pendtrack.discovery.diagnostics.off_diagnostics`): structure no term removed.
    partial : tuple of str
        Physical effects kept in the model that are not named as causes: they lower the
        residual, but structure remains that the catalogue cannot remove (``unexplained``), or
        their parameters are flagged in the final fit. In the order kept.

    ``equivalents`` (a property, in discovery.json): models as large as the final one that the
    record does not tell apart from it.
    """

    baseline: str
    effects: tuple[str, ...]
    steps: tuple[Step, ...]
    candidates: tuple[Candidate, ...]
    baseline_fit: FitSummary
    baseline_heldout_rms: float
    final_fit: FitSummary
    final_heldout_rms: float
    diagnosis: Mapping[str, Any]
    thresholds: Mapping[str, float]
    data: Mapping[str, Any] = field(default_factory=dict)
    runtime_s: float = 0.0
    measurement: tuple[str, ...] = ()
    measurement_steps: tuple[Step, ...] = ()
    unexplained: tuple[str, ...] = ()
    order: tuple[str, ...] = ()
    partial: tuple[str, ...] = ()

    @property
    def kept(self) -> tuple[str, ...]:
        """Every physical effect of the final model: the causes, then the partial ones."""
        return (*self.effects, *self.partial)

    @property
    def runners_up(self) -> tuple[Candidate, ...]:
        """Candidates judged but not kept (measurement first), best held-out first within each step."""
        kept = {(s.kind, s.step or i + 1, s.effect) for steps in (self.measurement_steps, self.steps)
                for i, s in enumerate(steps)}
        rest = [c for c in self.candidates if (c.kind, c.step, c.effect) not in kept]
        return tuple(sorted(rest, key=lambda c: (c.kind != "measurement", c.step,
                                                 -(c.heldout_gain if math.isfinite(c.heldout_gain) else -1e9))))

    @property
    def equivalents(self) -> tuple[dict[str, Any], ...]:
        """Models fitted in the search that the record supports about as well as the final one.

        Each has as many physical effects as the final model but a different set, earned its
        keep where it was judged, and has a whole-record BIC within ``-delta_bic_max`` of the
        final model's: the evidence that the final model is better is weaker than the evidence
        an effect needs to be kept at all (Kass and Raftery's "very strong"), so the record does
        not tell them apart. (On a free decay, for one: a damping that weakens as the run goes
        on and a drag whose relative damping weakens as the swings shrink.) Lowest BIC first.
        """
        from pendtrack.models import MEASUREMENT_TERMS

        kept = self.kept
        if not kept:
            return ()
        margin = -float(self.thresholds.get("delta_bic_max", -10.0))
        best: dict[tuple[str, ...], Candidate] = {}
        for c in self.candidates:
            if c.step == 0 or c.kind != "effect" or c.full is None or not c.earns_keep:
                continue
            effects = tuple(sorted(t for t in c.full.extra if t not in MEASUREMENT_TERMS))
            if len(effects) != len(kept) or set(effects) == set(kept):
                continue
            if c.full.bic - self.final_fit.bic <= margin and (effects not in best
                                                               or c.full.bic < best[effects].full.bic):
                best[effects] = c
        rows = sorted(best.items(), key=lambda kv: kv[1].full.bic)
        return tuple({"effects": list(k), "model": c.full.model,
                      "delta_bic": _num(c.full.bic - self.final_fit.bic),
                      "heldout_rms": _num(c.heldout_rms)} for k, c in rows)

    def to_dict(self) -> dict[str, Any]:
        return {
            "baseline": self.baseline,
            "effects": list(self.effects),
            "partial": list(self.partial),
            "steps": [s.to_dict() for s in self.steps],
            "measurement": list(self.measurement),
            "measurement_steps": [s.to_dict() for s in self.measurement_steps],
            "unexplained": list(self.unexplained),
            "equivalents": list(self.equivalents),
            "order": list(self.order or (*self.measurement, *self.kept)),
            "diagnosis": _jsonable(self.diagnosis),
            "final_model": {**self.final_fit.to_dict(), "terms_added": list(self.kept),
                            "measurement_terms": list(self.measurement),
                            "heldout_rms": _num(self.final_heldout_rms)},
            "runners_up": [c.to_dict() for c in self.runners_up],
            "baseline_fit": {**self.baseline_fit.to_dict(), "heldout_rms": _num(self.baseline_heldout_rms)},
            "thresholds": dict(self.thresholds),
            "data": _jsonable(self.data),
            "runtime_s": _num(self.runtime_s),
        }


def _jsonable(obj: Any) -> Any:
    """Arrays to lists and non-finite floats to None, recursively."""
    if isinstance(obj, Mapping):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return [_jsonable(v) for v in obj.tolist()]
    if isinstance(obj, (np.bool_, bool)):
        return bool(obj)
    if isinstance(obj, (np.integer, int)):
        return int(obj)
    if isinstance(obj, (np.floating, float)):
        return _num(obj)
    return obj
