"""The catalogue of physical effects a model can gain, each with its signature.

Every effect is one named term of :mod:`pendtrack.models.terms` (so a model extended by it is
``compose(baseline, [..., effect])``). Its *signature* says which diagnostics of
:mod:`pendtrack.discovery.diagnostics` it would explain if it were the missing physics:

=========================  ===============================================================
added_mass                 an amplitude-dependent frequency shift beyond gravity's (the
                           "inertial redshift" of eq. nullmodel) and a (omega, Delta alpha)
                           loop opened by ``Ca omega^2 sin theta``; both accumulate into a
                           dephasing.
time_varying_damping       the envelope decaying faster early in the run than the baseline
                           allows (``C4 omega/(t - t0)``, eq. newDNHM), i.e. an amplitude
                           error that drifts over the first oscillations.
memory                     a persistent dephasing together with hysteresis and negative
                           damping near the turning points (the fractional derivative of
                           eq. ourfinalmodel stores and returns energy).
power_drag, viscous,       the envelope's shape: an amplitude error that follows the
coulomb, quadratic_drag    amplitude, without dephasing or hysteresis.
=========================  ===============================================================

Signatures only *rank* the candidates (which to try first, what the narrative says); the
decision to keep an effect is made by held-out error and BIC in
:mod:`pendtrack.discovery.rules`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from pendtrack.errors import ConfigError
from pendtrack.models import TERMS, get_model


@dataclass(frozen=True)
class Effect:
    """One physical effect of the catalogue.

    Attributes
    ----------
    name : str
        Term name in :data:`pendtrack.models.TERMS`.
    title : str
        Plain name ("added mass").
    physics : str
        One sentence of physics: what the term is and where it comes from.
    signature : str
        What it would explain, in words.
    weights : mapping
        Diagnosis evidence key -> weight of that diagnostic in the effect's signature score.
    early : bool
        The effect acts mostly early in the run and fades (time-varying damping: ``C4/(t - t0)``
        falls 5-8-fold over a minute): a prediction of the later times cannot show it, so it is
        also judged by refits on interleaved blocks (:func:`pendtrack.discovery.exchange.Context.refit_test`).
    """

    name: str
    title: str
    physics: str
    signature: str
    weights: Mapping[str, float]
    early: bool = False

    @property
    def params(self) -> tuple[str, ...]:
        """The parameters the term adds."""
        return TERMS[self.name].params

    @property
    def formula(self) -> str:
        """Its contribution to ``alpha + Omega0^2 sin(theta)`` [rad/s^2]."""
        return TERMS[self.name].formula

    def score(self, evidence: Mapping[str, float]) -> float:
        """Signature score: weighted ``log(1 + z)`` of the evidence it explains (0 for none) [1].

        The logarithm keeps one enormous z-score from drowning the others: a signature is a
        pattern across diagnostics.
        """
        return float(sum(w * math.log1p(max(float(evidence.get(k, 0.0)), 0.0)) for k, w in self.weights.items()))

    def explains(self, evidence: Mapping[str, float], *, z_min: float = 3.0) -> list[str]:
        """The diagnostics in this effect's signature whose evidence exceeds ``z_min``."""
        return [k for k in self.weights if float(evidence.get(k, 0.0)) > z_min]

    def to_dict(self) -> dict[str, object]:
        return {"name": self.name, "title": self.title, "params": list(self.params), "formula": self.formula,
                "physics": self.physics, "signature": self.signature, "weights": dict(self.weights),
                "early": self.early}


CATALOGUE: dict[str, Effect] = {
    e.name: e
    for e in (
        Effect("added_mass", "added mass",
               "air dragged along with the pendulum adds inertia that grows with speed: "
               "+Ca omega^2 sin(theta) (eq. ainerdef), an 'inertial redshift' of the frequency",
               "frequency shift with amplitude beyond gravity's; (omega, Delta alpha) loop; dephasing",
               {"frequency_amplitude": 1.0, "hysteresis": 1.0, "dephasing": 0.5}),
        Effect("time_varying_damping", "time-varying damping",
               "a laminar damping that weakens as the run goes on: -C4 omega/(t - t0) (eq. newDNHM, OPA model)",
               "envelope decays faster early in the run than the baseline allows",
               {"early_envelope": 1.0, "envelope": 0.5}, early=True),
        Effect("memory", "memory (fractional drag)",
               "a drag that remembers the recent motion: -4 Omega0^2 G2 D^beta(A_omega|A_omega|^(p_f-1)) "
               "(Grunwald-Letnikov derivative of order beta, eq. ourfinalmodel)",
               "persistent dephasing with hysteresis and negative damping near the turning points",
               {"dephasing": 1.0, "negative_damping": 1.0, "hysteresis": 0.5}),
        Effect("power_drag", "power-law drag",
               "a drag growing as a power of the speed: -C3 |omega/Omega0|^p sgn(omega) (eq. powerlawdiss)",
               "envelope shape (amplitude error following the amplitude)",
               {"envelope": 1.0, "early_envelope": 0.3}),
        Effect("viscous", "viscous drag", "Stokes drag -C1 omega (eq. standarddiss)",
               "envelope shape (exponential part of the decay)", {"envelope": 1.0}),
        Effect("coulomb", "dry friction", "Coulomb friction -C0 sgn(omega) (eq. standarddiss)",
               "envelope shape (linear part of the decay, late in the run)", {"envelope": 1.0}),
        Effect("quadratic_drag", "quadratic drag", "Newton drag -C2 omega|omega| (eq. standarddiss)",
               "envelope shape (fast decay at large amplitude)", {"envelope": 1.0, "early_envelope": 0.3}),
    )
}


def candidates(baseline: str, effects: Iterable[str] = ()) -> tuple[Effect, ...]:
    """The effects to try on top of ``baseline``.

    Parameters
    ----------
    baseline : str
        Registry model name.
    effects : iterable of str
        Restrict the catalogue to these (``--effects``); empty: every catalogue effect whose
        term the baseline does not already have.

    Raises
    ------
    ConfigError
        An unknown effect name.
    """
    base_terms = set(get_model(baseline).terms)
    names = tuple(effects)
    for n in names:
        if n not in CATALOGUE:
            raise ConfigError(f"unknown effect '{n}' (catalogue: {', '.join(CATALOGUE)})")
    chosen = names or tuple(CATALOGUE)
    return tuple(CATALOGUE[n] for n in chosen if n not in base_terms)


def rank(effects: Iterable[Effect], evidence: Mapping[str, float]) -> list[tuple[Effect, float]]:
    """Effects ordered by signature score, highest first (ties keep catalogue order)."""
    scored = [(e, e.score(evidence)) for e in effects]
    return sorted(scored, key=lambda es: -es[1])


@dataclass(frozen=True)
class Artefact:
    """One measurement term: how the record's angle may differ from the pendulum's.

    Attributes
    ----------
    name : str
        Term name in :data:`pendtrack.models.MEASUREMENT_TERMS`.
    title : str
        Plain name ("zero offset").
    meaning : str
        What it says about the measurement (a finding about the record, never a cause).
    """

    name: str
    title: str
    meaning: str

    @property
    def params(self) -> tuple[str, ...]:
        """The parameters the term adds."""
        from pendtrack.models import MEASUREMENT_TERMS

        return MEASUREMENT_TERMS[self.name].params

    @property
    def formula(self) -> str:
        from pendtrack.models import MEASUREMENT_TERMS

        return MEASUREMENT_TERMS[self.name].formula

    def to_dict(self) -> dict[str, object]:
        return {"name": self.name, "title": self.title, "params": list(self.params), "formula": self.formula,
                "meaning": self.meaning}


#: Measurement terms discovery tries before any physical effect. They enter the observation
#: (``Model.observe``), not the equation of motion.
MEASUREMENT: dict[str, Artefact] = {
    a.name: a
    for a in (
        Artefact("offset", "zero offset",
                 "theta's zero is not the rest position (the vertical was misjudged, or the tracked spot is "
                 "off the pendulum's axis): theta_obs = theta + theta_off"),
        Artefact("angle_scale", "angle-scale distortion",
                 "the measured angle is stretched or squeezed more at large angles (lens distortion, "
                 "perspective, a wrong pivot): theta_obs = theta (1 + k_scale theta^2)"),
    )
}


def measurement_candidates(baseline: str, names: Iterable[str]) -> tuple[Artefact, ...]:
    """The measurement terms to try on ``baseline`` (those it does not already have).

    Raises
    ------
    ConfigError
        An unknown measurement term.
    """
    base_terms = set(get_model(baseline).terms)
    out = []
    for n in names:
        if n not in MEASUREMENT:
            raise ConfigError(f"unknown measurement term '{n}' (known: {', '.join(MEASUREMENT)})")
        if n not in base_terms:
            out.append(MEASUREMENT[n])
    return tuple(out)
