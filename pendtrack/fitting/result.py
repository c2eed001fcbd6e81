"""The result of a fit: a frozen :class:`FitResult` whose :meth:`~FitResult.to_dict` is fit.json.

fit.json of one model has exactly the issue's keys::

    {"model", "params": {name: {"value", "stderr", "u_paper"}}, "xi2_min", "rms", "aic", "bic",
     "n", "converged", "runtime_s", "seed"}

plus extra keys: ``initial_state`` (theta0, omega0 in the same {value, stderr, u_paper} form),
``cost``, ``n_params``, ``n_starts``, ``n_accepted``, ``accept_ratio``, ``window``, ``omega0_hat``,
``memory_s``, ``full_history``, ``hac_lag``, ``stderr_reliable``, ``u_region``, ``stderr_naive``,
``stderr_bootstrap``, ``stderr_low``, ``stderr_high``, ``stderr_scale``, ``estimates``, ``covariance``,
``start_costs``, ``message``, ``flags``, ``findings``, ``trustworthy``,
``measurement`` (the model's measurement terms, e.g. ``["offset"]``; their parameters, e.g.
``theta_off``, are in ``params`` like any other), ``interval68`` and ``interval95`` (per parameter
``[low, high]``), ``quote`` (:func:`quote_method`: per parameter the uncertainty a user should quote,
``"interval"`` -- ``interval68`` and ``interval95`` --, ``"stderr"``, or null where there is none).
Non-finite numbers are written as ``null``.

Flags and findings
------------------
``flags`` maps a parameter to why its value cannot be taken as a measurement
(:func:`plausibility_flags`: at an optimiser bound, not determined by the data, the memory term
acting as an added mass). ``findings`` maps a parameter to what the fit found when a term sits at
a limit where it vanishes or becomes a simpler one (:func:`split_findings`, the terms'
:class:`~pendtrack.models.declare.Limit` declarations): "the data show no memory; the model
reduces to ..." -- a result about the pendulum, never a flag. ``converged`` keeps its meaning
(the optimiser's verdict); ``trustworthy`` is ``converged`` and no flag: what the CLI and the
report call a good fit.

Information criteria
--------------------
``aic = n ln(xi2_min) + 2k`` and ``bic = n ln(xi2_min) + k ln(n)``, ``n`` samples and ``k`` fitted
parameters (the initial state included): the Gaussian log-likelihood of the cost up to a
constant. They compare models fitted to the *same* data with the *same* cost only, and, since the
residuals are autocorrelated, their differences overstate the evidence by about ``n/n_eff``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from pendtrack.errors import FitError
from pendtrack.fitting.estimate import _floor
from pendtrack.models import PARAMS

if TYPE_CHECKING:
    from pendtrack.config import FitConfig, ModelsConfig
    from pendtrack.fitting.estimate import Setup
    from pendtrack.fitting.leastsq.local_fits import StartOutcome
    from pendtrack.fitting.search import Search
    from pendtrack.fitting.uncertainty import Uncertainty

STATE_NAMES = ("theta0", "omega0")

# --- plausibility flags (plausibility_flags) ---
AT_BOUND_REL = 1e-6  # a value this close (relative to max(1, |bound|)) to an optimiser bound sits on it
# t0 of the C4 omega/(t - t0) damping: 1/(t - t0) changes over a record of length T by the factor
# 1 + T/(t_start - t0); with t0 more than this many record lengths before the start that is < 10 %,
# the term is a constant linear damping over the record and t0 is not measured (OPA's t0 = -1154 s
# on a 60 s record: a damping that fell off at the time of the apparatus's set-up, not of the swing)
T0_MAX_RECORDS = 10.0
# a standard error above this times the value's magnitude (for t0: its distance before the record):
# the value lies within half a standard error of 0, as close to 0 as to three times itself, so the
# data do not measure the parameter (fractional G2 = 150 +- 2776 lies 0.05 sigma from 0: any value
# fits as well). Between 0.5 and 1 sigma a weak effect is still a (poor) measurement: on a 6 s
# record the standard model's C0 comes out 0.08 +- 0.12 for a true 0.02. Judged only for values above the
# parameter's visibility floor (``floors``: 1e-3 Omega0^k, below which a term has no visible
# effect on a record of minutes): a coefficient below it is "absent", a valid result with its
# error bar as an upper limit (e.g. Ca = 0.0007 +- 0.001), not a claimed effect the data cannot carry.
UNDETERMINED_RATIO = 2.0
# the memory term -G2 D^beta(A |A|^(p_f - 1)) with beta = 1 and p_f = 1 is G2 dA/dt*: an added
# mass, which the pendulum's own inertia cannot be told from, so Omega0 trades off against G2
# (correlation 0.9998 on a 12-s field render, where Omega0 came out 7 % above the frequency of
# the swing at beta = 0.99995 +- 0.007, p_f = 0.994 +- 0.005). Flagged where the data cannot
# tell beta and p_f from 1: both within this many standard errors of it.
INERTIA_SIGMAS = 2.0
# ... and measured there: a standard error of beta and of p_f at most this. beta = 0.45 +- 0.61 (a 30-fps
# memory record) is within 2 standard errors of 1 only because it is not measured at all; the interval
# then spans velocity-like (0) and acceleration-like (1) drag alike, and the fit is no added mass
INERTIA_RESOLUTION = 0.25
# a value above its parameter's physical range (ParamSpec.plausible_high) is flagged when it lies more than
# this many standard errors above it: lab2_trial1_rawdata.txt's classic p = 3.1 +- 2.0 is no such claim
PLAUSIBLE_SIGMAS = 2.0


def plausibility_flags(names: tuple[str, ...], x: np.ndarray, stderr: np.ndarray, lower: np.ndarray,
                       upper: np.ndarray, *, t_start: float, t_end: float,
                       floors: Mapping[str, float], nuisance: tuple[str, ...] = (),
                       plausible: Mapping[str, tuple[float, str]] | None = None) -> dict[str, str]:
    """Why a fitted model parameter's value cannot be taken as a measurement, by name.

    Rules (constants above, the physics reason next to each):

    * **at an optimiser bound**: the limit of an exponent, of ``beta`` in (0, 1], of ``t0``'s
      search range (1e4 s before the record, or 1 ms before it) -- the optimum lies beyond or on
      the edge of the model's domain, and its standard error means nothing. A coefficient at its
      physical lower bound 0 is not flagged: 0 is a physical value (the term is absent from the
      data), not an artefact of the optimiser;
    * **t0 far before the record**: more than :data:`T0_MAX_RECORDS` record lengths;
    * **not determined**: a non-finite standard error, or, for a value above its visibility
      floor, one above :data:`UNDETERMINED_RATIO` times the magnitude of the value (for ``t0``:
      of ``t_start - t0``);
    * **above its physics**: more than :data:`PLAUSIBLE_SIGMAS` standard errors above the largest
      value the physics it stands for takes (``plausible``: a drag's speed exponent above 3, no
      drag law): the term is then fitting something else the model lacks;
    * **the memory term an added mass** (``Omega0`` flagged): ``G2 > 0`` with ``beta`` and
      ``p_f`` both measured (standard errors at most :data:`INERTIA_RESOLUTION`) and within
      :data:`INERTIA_SIGMAS` standard errors of 1, where the term is
      indistinguishable from ``G2 dA_omega/dt*``: Omega0 is then the frequency without that
      mass and trades off against G2, not the frequency of the swing.

    The initial state (``theta0``, ``omega0``) is not judged: a release from rest has
    ``omega0`` ~ 0 with any relative error. Nor is a measurement parameter (``nuisance``, e.g.
    ``theta_off``) judged by its relative error: it corrects the observation, and a value
    consistent with 0 (``theta_off = 0.2 +- 0.5 mrad``: the camera's zero was right) is a
    result, not a failure; it is flagged only for a non-finite standard error.

    Parameters
    ----------
    names : tuple of str
        Fitted names (``x``, ``stderr``, ``lower``, ``upper`` in this order).
    x, stderr, lower, upper : ndarray
        Values, sandwich standard errors and optimiser bounds [each parameter's unit].
    t_start, t_end : float
        The fitted window [s].
    floors : mapping
        Name -> visibility floor of the value [its unit] (missing: 0).
    nuisance : tuple of str
        Measurement parameters (judged only for a finite standard error and the bounds).
    plausible : mapping, optional
        Name -> (largest physical value [its unit], why): :func:`plausible_limits`.
    """
    flags: dict[str, str] = {}
    plausible = plausible or {}
    duration = max(t_end - t_start, 0.0)
    for j, name in enumerate(names):
        if name in STATE_NAMES:
            continue
        v, se, lo, hi = float(x[j]), float(stderr[j]), float(lower[j]), float(upper[j])
        for bound, side in ((lo, "lower"), (hi, "upper")):
            if math.isfinite(bound) and bound != 0.0 and abs(v - bound) <= AT_BOUND_REL * max(1.0, abs(bound)):
                flags[name] = f"at its {side} bound {bound:.6g} (the optimum lies on the edge of the model's range)"
        if name in flags:
            continue
        if name == "t0":
            before = t_start - v
            if before > T0_MAX_RECORDS * duration:
                flags[name] = (f"far before the record: {before:.4g} s before its start, > {T0_MAX_RECORDS:g} record "
                               f"lengths ({duration:.3g} s): 1/(t - t0) is constant over the record")
                continue
            scale = before
        else:
            scale = abs(v)
        if not math.isfinite(se):
            flags[name] = "not determined by the data (no finite standard error)"
        elif name in nuisance:
            continue
        elif scale > floors.get(name, 0.0) and se > UNDETERMINED_RATIO * scale:
            flags[name] = (f"not determined by the data: standard error {se:.3g} > "
                           f"{'its distance before the record' if name == 't0' else '|value|'} {scale:.3g}")
        elif name in plausible and v - PLAUSIBLE_SIGMAS * se > plausible[name][0]:
            high, why = plausible[name]
            flags[name] = (f"above any physical value: {v:.3g} +- {se:.2g}, more than {PLAUSIBLE_SIGMAS:g} standard "
                           f"errors above {high:g} ({why}): the term stands in for something the model lacks")
    inertia = _memory_as_inertia(names, x, stderr)
    if inertia and "Omega0" not in flags:
        flags["Omega0"] = inertia
    return flags


def plausible_limits(model: Any, names: tuple[str, ...]) -> dict[str, tuple[float, str]]:
    """Name -> (largest physical value, why) of the fitted ``names`` whose declaration has one
    (:attr:`pendtrack.models.declare.ParamSpec.plausible_high`): :func:`plausibility_flags`'s ``plausible``."""
    out: dict[str, tuple[float, str]] = {}
    spec_of = getattr(model, "param_spec", None)  # a caller's own model (a toy) may declare no ranges
    if spec_of is None:
        return out
    for name in names:
        if name in model.param_names:
            spec = spec_of(name)
            if math.isfinite(spec.plausible_high):
                out[name] = (float(spec.plausible_high), spec.plausible_why)
    return out


def split_findings(terms: tuple[str, ...], names: tuple[str, ...], x: np.ndarray, stderr: np.ndarray,
                   lower: np.ndarray, flags: Mapping[str, str], *, t_start: float,
                   t_end: float) -> tuple[dict[str, str], dict[str, str]]:
    """Split ``flags`` into what is wrong and what is a finding: an effect the data do not show.

    A physical term whose parameter sits at one of its limits (:class:`pendtrack.models.declare.Limit`:
    its amplitude at 0, ``beta`` at 0, ``t0`` more than :data:`T0_MAX_RECORDS` record lengths before the
    record or on its optimiser bound there) is absent, or is the simpler term it becomes there. That
    parameter and the ones the data then cannot measure get a finding in place of a flag. An amplitude
    or order is at its limit 0 when on its optimiser bound there; an order whose limit makes the term a
    simpler one (``beta``) also when within one standard error of it. An amplitude merely consistent with
    the limit, or small, is not at it: correlated dampings (C1, C0, C2) can each lie within
    two standard errors of 0 while together they are far from it.

    Parameters
    ----------
    terms : tuple of str
        The model's physical terms (catalogue names).
    names, x, stderr, lower
        Fitted names, values, standard errors and lower optimiser bounds (as :func:`plausibility_flags`).
    flags : mapping
        :func:`plausibility_flags` of the same fit.
    t_start, t_end : float
        The fitted window [s].

    Returns
    -------
    flags, findings : dict
        The flags left, and parameter name -> the finding (one sentence).
    """
    from pendtrack.models.declare import Limit
    from pendtrack.models.terms import CATALOGUE

    pos = {n: j for j, n in enumerate(names)}
    duration = max(t_end - t_start, 0.0)

    def reached(lim: Limit) -> str:
        """How ``lim`` is reached (the parameter's value in words), or ""."""
        j = pos[lim.param]
        v, se, lo = float(x[j]), float(stderr[j]), float(lower[j])
        on_bound = math.isfinite(lo) and abs(v - lo) <= AT_BOUND_REL * max(1.0, abs(lo))
        if lim.value == -math.inf:
            before = t_start - v
            if before > T0_MAX_RECORDS * duration or on_bound:
                return f"{lim.param} = {v:.4g} s, {before:.3g} s before the record"
            return ""
        if on_bound:
            err = f" +- {se:.2g}" if math.isfinite(se) else ""
            return f"{lim.param} = {v:.3g}{err}"
        if lim.becomes and lim.value == 0.0 and math.isfinite(se) and abs(v) <= se:
            # an order whose limit makes the term a simpler one (beta -> 0: a plain power-law drag) and whose value
            # is within one standard error of it: what "not determined" (se > |value|) means there. On its bound
            # or a hair inside it, the same verdict
            return f"{lim.param} = {v:.3g} +- {se:.2g}, within one standard error of 0"
        return ""

    absent: dict[str, tuple[Limit, str]] = {}  # term -> the limit it reached, and how
    for term in terms:
        decl = CATALOGUE[term]
        limits = decl.limits
        if decl.amplitude and all(lim.param != decl.amplitude for lim in limits):
            limits = (Limit(decl.amplitude, 0.0),) + limits
        for lim in limits:
            how = reached(lim) if lim.param in pos else ""
            if how:
                absent[term] = (lim, how)
                break
    reduced = [t for t in terms if t not in absent]
    for lim, _ in absent.values():
        if lim.nested and lim.nested not in reduced:
            reduced.append(lim.nested)
    reduced = [t for t in CATALOGUE if t in reduced]  # catalogue order, as model names are
    left, findings = dict(flags), {}
    for term, (lim, how) in absent.items():
        what = f" (there the term is {lim.becomes})" if lim.becomes else ""
        text = (f"the data show no {term.replace('_', ' ')}: {how}{what}; the model reduces to "
                f"{'+'.join(['gravity', *reduced])}")
        for name in (lim.param, *lim.unmeasured):
            if name in pos:
                findings[name] = text
                left.pop(name, None)
    return left, findings


def _memory_as_inertia(names: tuple[str, ...], x: np.ndarray, stderr: np.ndarray) -> str:
    """Why the memory term is an added mass here (``beta``, ``p_f`` within INERTIA_SIGMAS of 1), or ""."""
    if not {"Omega0", "G2", "beta", "p_f"} <= set(names):
        return ""
    at = {n: (float(x[names.index(n)]), float(stderr[names.index(n)])) for n in ("G2", "beta", "p_f")}
    if not at["G2"][0] > 0.0:
        return ""
    for n in ("beta", "p_f"):
        v, se = at[n]
        if not (math.isfinite(se) and se <= INERTIA_RESOLUTION and abs(v - 1.0) <= INERTIA_SIGMAS * se):
            return ""
    (b, sb), (pf, spf) = at["beta"], at["p_f"]
    return (f"not the frequency of the swing: the memory term is an added mass (beta = {b:.4g} +- {sb:.2g} and "
            f"p_f = {pf:.4g} +- {spf:.2g} within {INERTIA_SIGMAS:g} standard errors of 1), whose inertia Omega0 "
            f"trades off against G2")


#: The uncertainty fit.json tells a user to quote (:func:`quote_method`), from benchmarks/bench_coverage.py (400
#: seeded records per model with the render's tracking noise): the sandwich's intervals cover the truth as they
#: should for classic and OPA (20-s records); for the fractional model its 95 % intervals cover 88-95 % (60-s
#: records), the scans' widened ones 93-97.5 % (:func:`pendtrack.fitting.leastsq.profile_interval.scan_intervals`).
#: The profile sigmas come out 9-40x below the sandwich where another parameter sits on its optimiser bound (C0
#: at 0: a constrained profile), and u_paper, the spread of the starts, covers 0-33 % for classic and OPA (their
#: starts meet at one minimum).
QUOTE = "interval"


def in_range(name: str, interval: tuple[float, float]) -> tuple[float, float]:
    """``interval`` cut to the physical range of the parameter ``name`` (its :class:`ParamSpec`'s bounds).

    An interval about a value at or near a bound reaches past it by symmetry (beta = 0 +- 0.047 reads
    [-0.047, 0.047]); the values beyond cannot be the parameter's, so they are no part of its interval.
    A parameter without a declared range (the initial state) keeps its interval.
    """
    lo, hi = float(interval[0]), float(interval[1])
    spec = PARAMS.get(name)
    if spec is None:
        return lo, hi
    # NaN stays NaN: np.clip would keep it, min/max would not
    return float(np.clip(lo, spec.low, spec.high)), float(np.clip(hi, spec.low, spec.high))


def quote_method(p: "ParamEstimate") -> str | None:
    """Which uncertainty of ``p`` a user should quote: :data:`QUOTE` (``interval68`` and ``interval95``) where
    they are finite, else ``"stderr"`` where that is finite and positive (a joint fit), else None.

    A fixed parameter (not fitted) has none.
    """
    if p.fixed or not (math.isfinite(p.stderr) and p.stderr > 0):
        return None
    if all(math.isfinite(v) for v in (*p.interval68, *p.interval95)):
        return QUOTE
    return "stderr"


def _num(x: Any) -> float | None:
    """A JSON-safe float: None for NaN/inf/None."""
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


@dataclass(frozen=True)
class ParamEstimate:
    """One fitted parameter.

    Attributes
    ----------
    value : float
        Best-fit value [the parameter's unit].
    stderr : float
        Statistical standard error (autocorrelation-consistent sandwich) [same unit]; NaN if
        unavailable.
    u_paper : float
        The paper's eq. paramuncertain over the accepted starts [same unit].
    u_region : float
        Half-width of the region Xi^2 <= accept_ratio Xi^2_min (quadratic model) [same unit].
    stderr_naive : float
        Textbook ``s^2 (J^T J)^-1`` standard error, for comparison [same unit].
    stderr_bootstrap : float
        Block-bootstrap standard error [same unit]; NaN if not computed.
    stderr_low, stderr_high : float
        Profile-likelihood standard errors below and above ``value`` [same unit] (equal to
        ``stderr`` where the cost is quadratic); NaN if not computed or on a bound on that side,
        inf if the profile is flat.
    estimate : float
        The data-derived initial estimate [same unit].
    fixed : bool
        Held at ``value`` (not fitted).
    stderr_scale : float
        The shift of ``value`` under theta's scale uncertainty (the axle's radius uncertainty,
        :func:`pendtrack.fitting.uncertainty.scale_shift`) [same unit]; 0 when none was given.
        The fit stage adds it to ``stderr`` in quadrature.
    interval68, interval95 : tuple of float
        ``(low, high)``: the intervals that hold the truth 68 % and 95 % of the time, the ones to
        quote (:data:`QUOTE`; :func:`pendtrack.fitting.leastsq.profile_interval.scan_intervals`)
        [same unit]; NaN where not computed (a fixed parameter, a joint fit).
    """

    value: float
    stderr: float = math.nan
    u_paper: float = math.nan
    u_region: float = math.nan
    stderr_naive: float = math.nan
    stderr_bootstrap: float = math.nan
    stderr_low: float = math.nan
    stderr_high: float = math.nan
    estimate: float = math.nan
    fixed: bool = False
    stderr_scale: float = 0.0
    interval68: tuple[float, float] = (math.nan, math.nan)
    interval95: tuple[float, float] = (math.nan, math.nan)

    def core(self) -> dict[str, float | None]:
        return {"value": _num(self.value), "stderr": _num(self.stderr), "u_paper": _num(self.u_paper)}


@dataclass(frozen=True)
class FitResult:
    """Best fit of one model to one record, with uncertainties.

    Attributes
    ----------
    model : str
        Model name.
    params : mapping
        Model parameter name -> :class:`ParamEstimate` (``model.param_names`` order).
    initial_state : mapping
        ``theta0`` [rad] and ``omega0`` [rad/s] at ``window[0]`` -> :class:`ParamEstimate`.
    xi2_min : float
        Minimum cost (Xi^2 [1] for ``cost="xi2"``, mean squared angle residual [rad^2] for ``"theta"``).
    rms : float
        Rms of ``theta - theta_model`` over the fitted samples [rad].
    aic, bic : float
        Information criteria (module docstring).
    n : int
        Samples in the cost.
    converged : bool
        Best start ended on a convergence test, covariance finite and the fit follows the
        oscillation (rms below half the angle's standard deviation).
    runtime_s : float
        Wall time of the fit [s].
    seed : int
        Seed of the start draws.
    cost : str
        ``"xi2"`` or ``"theta"``.
    window : tuple of float
        ``(t_start, t_end)`` of the fitted samples [s].
    omega0_hat : float
        Model-free Omega0 that scales A_omega in Xi^2 [rad/s].
    n_starts, n_accepted : int
        Starts run; starts with cost <= accept_ratio * xi2_min.
    accept_ratio : float
        5/4 in the paper.
    hac_lag : int
        Truncation lag of the sandwich covariance's meat [samples].
    covariance : ndarray
        Sandwich covariance of the fitted vector, order ``fitted_names``.
    fitted_names : tuple of str
        Names of the fitted vector (model parameters then theta0, omega0, fixed ones left out).
    start_costs : ndarray
        Final cost of every start (start order).
    memory_s : float
        GL memory used [s].
    full_history : bool
        The GL sum ran over the whole record.
    stderr_reliable : bool
        False if the sandwich standard errors change by more than 30 % when the finite-difference
        step grows 100-fold (a solver that is not smooth in the parameters): then prefer
        ``u_paper`` or a bootstrap.
    message : str
        Why the fit did not converge, or the optimiser's last message, plus notes.
    flags : mapping
        Parameter name -> why its value is not a measurement (:func:`plausibility_flags`).
    findings : mapping
        Parameter name -> an effect the data do not show (:func:`split_findings`).
    measurement : tuple of str
        The model's measurement terms (e.g. ``("offset",)``: ``params`` has ``theta_off``).
    max_step_s : float or None
        The predictor-corrector's largest step used [s] (``[models] max_step_s``; None: its
        default); :func:`~pendtrack.fitting.predict` simulates with it. Not in ``to_dict``: the
        stage records ``[models]`` in the provenance.
    """

    model: str
    params: Mapping[str, ParamEstimate]
    initial_state: Mapping[str, ParamEstimate]
    xi2_min: float
    rms: float
    aic: float
    bic: float
    n: int
    converged: bool
    runtime_s: float
    seed: int
    cost: str = "xi2"
    window: tuple[float, float] = (math.nan, math.nan)
    omega0_hat: float = math.nan
    n_starts: int = 0
    n_accepted: int = 0
    accept_ratio: float = 1.25
    hac_lag: int = 0
    covariance: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    fitted_names: tuple[str, ...] = ()
    start_costs: np.ndarray = field(default_factory=lambda: np.zeros(0))
    memory_s: float = math.nan
    full_history: bool = False
    stderr_reliable: bool = True
    message: str = ""
    flags: Mapping[str, str] = field(default_factory=dict)
    findings: Mapping[str, str] = field(default_factory=dict)
    measurement: tuple[str, ...] = ()
    max_step_s: float | None = None

    # ---- access --------------------------------------------------------------------------
    @property
    def values(self) -> dict[str, float]:
        """Model parameter values by name (what :func:`pendtrack.models.simulate` takes)."""
        return {k: v.value for k, v in self.params.items()}

    @property
    def theta0(self) -> float:
        """Fitted initial angle at ``window[0]`` [rad]."""
        return self.initial_state["theta0"].value

    @property
    def omega0(self) -> float:
        """Fitted initial angular velocity at ``window[0]`` [rad/s]."""
        return self.initial_state["omega0"].value

    @property
    def trustworthy(self) -> bool:
        """Converged and no parameter flagged: a fit whose values can be quoted."""
        return bool(self.converged and not self.flags)

    @property
    def n_params(self) -> int:
        """Number of fitted parameters, initial state included."""
        return len(self.fitted_names)

    def quote(self) -> dict[str, str | None]:
        """Parameter name -> the uncertainty to quote (:func:`quote_method`), model parameters and initial state."""
        return {k: quote_method(v) for k, v in {**self.params, **self.initial_state}.items()}

    def require_converged(self) -> "FitResult":
        """Return self, or raise :class:`FitError` if the fit did not converge."""
        if not self.converged:
            raise FitError(f"fit of model '{self.model}' did not converge: {self.message}")
        return self

    # ---- serialisation -------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """fit.json content (see the module docstring)."""
        all_params = {**self.params, **self.initial_state}
        cov = np.asarray(self.covariance, dtype=float)
        return {
            "model": self.model,
            "params": {k: v.core() for k, v in self.params.items()},
            "xi2_min": _num(self.xi2_min),
            "rms": _num(self.rms),
            "aic": _num(self.aic),
            "bic": _num(self.bic),
            "n": int(self.n),
            "converged": bool(self.converged),
            "runtime_s": _num(self.runtime_s),
            "seed": int(self.seed),
            # extras
            "initial_state": {k: v.core() for k, v in self.initial_state.items()},
            "cost": self.cost,
            "n_params": self.n_params,
            "n_starts": int(self.n_starts),
            "n_accepted": int(self.n_accepted),
            "accept_ratio": float(self.accept_ratio),
            "window": [_num(self.window[0]), _num(self.window[1])],
            "omega0_hat": _num(self.omega0_hat),
            "memory_s": _num(self.memory_s),
            "full_history": bool(self.full_history),
            "hac_lag": int(self.hac_lag),
            "stderr_reliable": bool(self.stderr_reliable),
            "u_region": {k: _num(v.u_region) for k, v in all_params.items()},
            "stderr_naive": {k: _num(v.stderr_naive) for k, v in all_params.items()},
            "stderr_bootstrap": {k: _num(v.stderr_bootstrap) for k, v in all_params.items()},
            "stderr_low": {k: _num(v.stderr_low) for k, v in all_params.items()},
            "stderr_high": {k: _num(v.stderr_high) for k, v in all_params.items()},
            "stderr_scale": {k: _num(v.stderr_scale) for k, v in all_params.items()},
            "interval68": {k: [_num(x) for x in v.interval68] for k, v in all_params.items()},
            "interval95": {k: [_num(x) for x in v.interval95] for k, v in all_params.items()},
            "estimates": {k: _num(v.estimate) for k, v in all_params.items()},
            "fixed": [k for k, v in all_params.items() if v.fixed],
            "covariance": {"names": list(self.fitted_names),
                           "matrix": [[_num(x) for x in row] for row in cov.tolist()]},
            "start_costs": [_num(c) for c in np.asarray(self.start_costs, dtype=float)],
            "message": self.message,
            "flags": dict(self.flags),
            "findings": dict(self.findings),
            "trustworthy": self.trustworthy,
            "measurement": list(self.measurement),
            "quote": self.quote(),
        }


def build_result(setup: Setup, found: Search, best: StartOutcome, unc: Uncertainty, *, options: FitConfig,
                 model_options: ModelsConfig, seed: int, runtime_s: float,
                 scale: np.ndarray | None = None) -> FitResult:
    """The :class:`FitResult` of the refined best fit (step 5 of a fit).

    Adds what the steps before did not compute: rms, AIC/BIC (module docstring) and the
    convergence verdict -- the best start ended on a convergence test, the covariance is finite
    and the model follows the oscillation (rms below half the angle's standard deviation).

    Parameters
    ----------
    setup, found, best, unc
        The outputs of the estimate, search, refine and uncertainty steps.
    options : FitConfig
        Uses ``cost`` and ``accept_ratio`` (recorded).
    model_options : ModelsConfig
        The memory used (recorded).
    seed : int
        Seed of the start draws (recorded).
    runtime_s : float
        Wall time of the fit [s].
    scale : ndarray, optional
        Each fitted parameter's shift under theta's scale uncertainty
        (:func:`pendtrack.fitting.uncertainty.scale_shift`): ``ParamEstimate.stderr_scale``.
    """
    problem = setup.problem
    model = problem.model
    names = problem.names
    x = best.x
    theta_m, _ = problem.model_at_data(x)
    rms = float(np.sqrt(np.mean((problem.theta - theta_m) ** 2)))
    n = problem.n
    k = x.size
    xi2 = float(best.cost)
    aic = n * math.log(xi2) + 2 * k if xi2 > 0 else -math.inf
    bic = n * math.log(xi2) + k * math.log(n) if xi2 > 0 else -math.inf
    follows = rms <= 0.5 * float(np.std(problem.theta))
    floors = {n: _floor(model, n, setup.summary.omega0_hat) for n in names if n in model.param_names}
    t_end = float(problem.t[-1])
    flags, findings = split_findings(
        tuple(getattr(model, "physical_terms", ())), names, x, unc.stderr, problem.lower,
        plausibility_flags(names, x, unc.stderr_judged, problem.lower, problem.upper, t_start=problem.t_start,
                           t_end=t_end,
                           floors=floors, nuisance=_measurement_params(model), plausible=plausible_limits(model, names)),
        t_start=problem.t_start, t_end=t_end)
    # a parameter of an absent term (a finding) may have no standard error (the exponent of a power drag
    # at C3 = 0 changes nothing): the fit is judged on the others
    cov_ok = bool(all(math.isfinite(float(se)) for nm, se in zip(names, unc.stderr) if nm not in findings))
    converged = bool(best.success and cov_ok and follows)
    reasons = []
    if not best.success:
        reasons.append(f"optimiser: {best.message}")
    if not cov_ok:
        reasons.append("singular Jacobian (a parameter is not determined by the data)")
    if not follows:
        reasons.append(f"the model does not follow the oscillation (rms {rms:.3g} rad)")
    notes = []
    if not unc.reliable and cov_ok:
        notes.append(f"standard errors unreliable: they change by a factor {math.exp(unc.step_spread):.2g} with the "
                     "finite-difference step (the solver is not smooth in the parameters)")
    start_costs = found.costs.copy()
    start_costs[found.best_position] = best.cost if np.isfinite(best.cost) else np.inf  # the refined best

    values = problem.full(x)
    fitted = dict(zip(names, range(k)))

    def pe(name: str) -> ParamEstimate:
        if name not in fitted:
            return ParamEstimate(value=values[name], stderr=0.0, u_paper=0.0, u_region=0.0, stderr_naive=0.0,
                                 estimate=setup.estimates.get(name, math.nan), fixed=True)
        j = fitted[name]
        return ParamEstimate(value=float(x[j]), stderr=float(unc.stderr[j]), u_paper=float(unc.u_paper[j]),
                             u_region=float(unc.u_region[j]), stderr_naive=float(unc.stderr_naive[j]),
                             stderr_bootstrap=float(unc.stderr_bootstrap[j]), stderr_low=float(unc.stderr_low[j]),
                             stderr_high=float(unc.stderr_high[j]),
                             interval68=in_range(name, (unc.interval68[0][j], unc.interval68[1][j])),
                             interval95=in_range(name, (unc.interval95[0][j], unc.interval95[1][j])),
                             estimate=float(setup.estimates.get(name, math.nan)),
                             stderr_scale=float(scale[j]) if scale is not None else 0.0)

    return FitResult(
        model=str(model.name),
        params={nm: pe(nm) for nm in model.param_names},
        initial_state={nm: pe(nm) for nm in STATE_NAMES},
        xi2_min=xi2, rms=rms, aic=aic, bic=bic, n=n, converged=converged,
        runtime_s=float(runtime_s), seed=int(seed), cost=options.cost,
        window=(problem.t_start, float(problem.t[-1])), omega0_hat=setup.summary.omega0_hat,
        n_starts=len(found.outcomes), n_accepted=unc.n_accepted, accept_ratio=float(options.accept_ratio),
        hac_lag=unc.hac_lag, covariance=unc.covariance, fitted_names=names, start_costs=start_costs,
        memory_s=float(model_options.memory_s), full_history=bool(model_options.full_history),
        message="; ".join(reasons + notes) if reasons else "; ".join([best.message] + notes),
        stderr_reliable=unc.reliable,
        flags=flags, findings=findings,
        measurement=tuple(getattr(model, "measurement_terms", ())),
        max_step_s=getattr(model_options, "max_step_s", None),
    )


def _measurement_params(model: Any) -> tuple[str, ...]:
    """The parameters of a model's measurement terms."""
    from pendtrack.models.terms import CATALOGUE

    return tuple(p for t in getattr(model, "measurement_terms", ()) for p in CATALOGUE[t].params)
