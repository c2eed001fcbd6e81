"""The result of a joint fit: :class:`JointFit`, whose :meth:`~JointFit.to_dict` is ``fit_<model>.json``.

fit_<model>.json of a joint fit has the single fit's keys (:data:`pendtrack.artifacts.FIT_JSON_KEYS`),
over all runs pooled, plus::

    {"joint": true, "n_runs", "sharing": {name: scope}, "groups": {name: {group: {value, stderr, u_paper,
     "runs"}}}, "runs": {run: {"labels", "params", "initial_state", "columns", "xi2", "rms", "n", "window",
     "flags", "single": {"params", "initial_state", "xi2_min", "rms", "converged"}}}, "stderr_ratio",
     "n_starts", "n_accepted", "start_costs", "hac_lags", "covariance", "cost", "accept_ratio",
     "stderr_naive", "stderr_axle", "stderr_low", "stderr_high", "u_region", "message", "flags", "trustworthy", "quote": {label: "stderr" or null}}

``params`` holds the parameters shared by every run; ``groups`` the ones fitted per group of runs
(per tile, per tile and alley, ...); each run's entry every value it was simulated with (its
groups' and its own), with the joint standard errors, its own residual (``xi2`` its Xi^2 at the
joint optimum, ``rms`` [rad], ``n`` samples) and its own single-run fit for comparison.
``stderr_ratio``: per shared parameter, the joint standard error over the mean of the runs' own.
Every ``stderr`` includes the runs' axles' share (the angle's scale and zero, which the residuals
cannot show: :func:`pendtrack.fitting.joint.solve.axle_covariance`), and so does ``covariance``;
``stderr_axle`` is that share alone. ``stderr_low`` and ``stderr_high`` are the profile-likelihood
sigmas below and above each model parameter (``[fit] profile``; null when not computed), with the
axles' share.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from pendtrack.fitting.estimate import _floor
from pendtrack.fitting.joint.scopes import RUN, STATE_NAMES, Scope, scope_text
from pendtrack.fitting.result import (
    FitResult, ParamEstimate, _measurement_params, _num, plausibility_flags, plausible_limits, quote_method,
)

if TYPE_CHECKING:
    from pendtrack.config import FitConfig
    from pendtrack.fitting.joint.stacked import StackedProblem
    from pendtrack.fitting.leastsq.local_fits import StartOutcome


def _core(p: ParamEstimate) -> dict[str, float | None]:
    return {"value": _num(p.value), "stderr": _num(p.stderr)}


@dataclass(frozen=True)
class JointRun:
    """One run of a joint fit.

    Attributes
    ----------
    run : str
        Run id.
    labels : mapping
        Its run-code labels (empty without a run code).
    params, initial_state : mapping
        Every model parameter and the initial state at the joint optimum, with the joint standard
        errors [each parameter's unit].
    columns : mapping
        Fitted name -> the joint parameter it takes (``C0``, ``Omega0@tile=06``, ``theta0@06na5``).
    xi2 : float
        The run's own cost at the joint optimum [1].
    rms : float
        Rms of its angle residual [rad].
    n : int
        Its samples in the cost.
    window : tuple of float
        Its fitted times [s].
    single : FitResult
        The run fitted alone.
    flags : mapping
        Name -> why the value cannot be taken as a measurement (:func:`pendtrack.fitting.result.plausibility_flags`).
    """

    run: str
    labels: Mapping[str, str]
    params: Mapping[str, ParamEstimate]
    initial_state: Mapping[str, ParamEstimate]
    columns: Mapping[str, str]
    xi2: float
    rms: float
    n: int
    window: tuple[float, float]
    single: FitResult
    flags: Mapping[str, str] = field(default_factory=dict)

    @property
    def values(self) -> dict[str, float]:
        """Model parameter values by name (what :func:`pendtrack.models.simulate` takes)."""
        return {k: v.value for k, v in self.params.items()}

    def to_dict(self) -> dict[str, Any]:
        s = self.single
        return {"labels": dict(self.labels), "params": {k: _core(v) for k, v in self.params.items()},
                "initial_state": {k: _core(v) for k, v in self.initial_state.items()},
                "columns": dict(self.columns), "xi2": _num(self.xi2), "rms": _num(self.rms), "n": int(self.n),
                "window": [_num(w) for w in self.window], "flags": dict(self.flags),
                "single": {"params": {k: _core(v) for k, v in s.params.items()},
                           "initial_state": {k: _core(v) for k, v in s.initial_state.items()},
                           "xi2_min": _num(s.xi2_min), "rms": _num(s.rms), "converged": bool(s.converged),
                           "flags": dict(s.flags)}}


@dataclass(frozen=True)
class JointFit:
    """Best joint fit of one model to several runs.

    Attributes
    ----------
    model : str
        The fitted model's name.
    estimates : mapping
        Joint parameter label -> :class:`~pendtrack.fitting.result.ParamEstimate` (value, sandwich
        ``stderr``, ``u_paper`` over the starts, ``u_region``, ``stderr_naive``; ``estimate`` the
        pooled value of the runs' own fits).
    scopes : mapping
        Parameter name -> its scope (:mod:`pendtrack.fitting.joint.scopes`).
    runs : mapping
        Run id -> :class:`JointRun`.
    xi2_min : float
        The pooled cost (Xi^2 of every sample) [1].
    rms : float
        Rms of every angle residual [rad].
    aic, bic : float
        ``N ln(xi2_min) + 2k`` and ``N ln(xi2_min) + k ln(N)``, ``N`` all samples, ``k`` joint parameters.
    n : int
        All samples in the cost.
    converged : bool
        The best start ended on a convergence test, the covariance is finite and the model follows
        every run's oscillation.
    runtime_s : float
        Wall time, the runs' own fits included [s].
    seed : int
    cost : str
    n_starts, n_accepted : int
        Joint starts; starts within ``accept_ratio`` of the lowest cost.
    accept_ratio : float
    start_costs : ndarray
        Each joint start's final cost.
    covariance : ndarray
        Covariance of the joint vector (order of ``estimates``): the sandwich plus the runs' axles' share.
    hac_lags : tuple of int
        Each run's truncation lag of the sandwich's meat [samples].
    message : str
        The optimiser's last message, or why the fit did not converge.
    flags : mapping
        Joint parameter label -> why its value cannot be taken as a measurement.
    """

    model: str
    estimates: Mapping[str, ParamEstimate]
    scopes: Mapping[str, Scope]
    runs: Mapping[str, JointRun]
    xi2_min: float
    rms: float
    aic: float
    bic: float
    n: int
    converged: bool
    runtime_s: float
    seed: int
    cost: str = "xi2"
    n_starts: int = 0
    n_accepted: int = 0
    accept_ratio: float = 1.25
    start_costs: np.ndarray = field(default_factory=lambda: np.zeros(0))
    covariance: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    hac_lags: tuple[int, ...] = ()
    message: str = ""
    flags: Mapping[str, str] = field(default_factory=dict)

    @property
    def shared(self) -> dict[str, ParamEstimate]:
        """The parameters shared by every run, by name."""
        return {n: self.estimates[n] for n, s in self.scopes.items() if not s and n in self.estimates}

    @property
    def trustworthy(self) -> bool:
        """Converged and no parameter flagged."""
        return bool(self.converged and not self.flags)

    def stderr_ratio(self) -> dict[str, float]:
        """Per shared parameter: the joint standard error over the mean of the runs' own standard errors."""
        out = {}
        for name, est in self.shared.items():
            own = [r.single.params[name].stderr if name in r.single.params else r.single.initial_state[name].stderr
                   for r in self.runs.values()]
            mean = float(np.mean(own))
            out[name] = est.stderr / mean if math.isfinite(mean) and mean > 0 else math.nan
        return out

    def run_result(self, run: str) -> FitResult:
        """Run ``run`` at the joint optimum, as a single fit's :class:`~pendtrack.fitting.result.FitResult`.

        Its own fit with the joint values (model parameters, initial state at the start of its
        window), the joint verdict and its window, residual and samples: what
        :func:`pendtrack.fitting.predict.predict` takes to simulate the jointly fitted model on the
        run's times (its step, memory and filter settings are the run's own fit's).
        """
        r = self.runs[run]
        return replace(r.single, model=self.model, params=dict(r.params), initial_state=dict(r.initial_state),
                       window=r.window, rms=r.rms, n=r.n, converged=self.converged)

    def groups(self) -> dict[str, dict[str, dict[str, Any]]]:
        """Per parameter fitted per group of runs: group -> value, stderr, u_paper and its runs."""
        out: dict[str, dict[str, dict[str, Any]]] = {}
        for name, scope in self.scopes.items():
            if not scope or scope == (RUN,):
                continue
            for run in self.runs.values():
                label = run.columns.get(name)
                if label is None:
                    continue
                est = self.estimates[label]
                group = out.setdefault(name, {}).setdefault(label.split("@", 1)[1], {**est.core(), "runs": []})
                group["runs"].append(run.run)
        return out

    def to_dict(self) -> dict[str, Any]:
        """fit_<model>.json content (module docstring)."""
        cov = np.asarray(self.covariance, dtype=float)
        return {
            "model": self.model,
            "params": {k: v.core() for k, v in self.shared.items()},
            "xi2_min": _num(self.xi2_min), "rms": _num(self.rms), "aic": _num(self.aic), "bic": _num(self.bic),
            "n": int(self.n), "converged": bool(self.converged), "runtime_s": _num(self.runtime_s),
            "seed": int(self.seed),
            # extras
            "joint": True, "n_runs": len(self.runs),
            "sharing": {k: scope_text(v) for k, v in self.scopes.items()},
            "groups": self.groups(),
            "runs": {k: r.to_dict() for k, r in self.runs.items()},
            "stderr_ratio": {k: _num(v) for k, v in self.stderr_ratio().items()},
            "cost": self.cost, "n_params": len(self.estimates), "n_starts": int(self.n_starts),
            "n_accepted": int(self.n_accepted), "accept_ratio": float(self.accept_ratio),
            "start_costs": [_num(c) for c in np.asarray(self.start_costs, dtype=float)],
            "hac_lags": [int(v) for v in self.hac_lags],
            "stderr_naive": {k: _num(v.stderr_naive) for k, v in self.estimates.items()},
            "stderr_axle": {k: _num(v.stderr_scale) for k, v in self.estimates.items()},
            "stderr_low": {k: _num(v.stderr_low) for k, v in self.estimates.items()},
            "stderr_high": {k: _num(v.stderr_high) for k, v in self.estimates.items()},
            "u_region": {k: _num(v.u_region) for k, v in self.estimates.items()},
            "covariance": {"names": list(self.estimates), "matrix": [[_num(x) for x in row] for row in cov.tolist()]},
            "message": self.message, "flags": dict(self.flags), "trustworthy": self.trustworthy,
            "quote": {k: quote_method(v) for k, v in self.estimates.items()},
        }


def build_joint(model: Any, stacked: StackedProblem, best: StartOutcome, *, singles: Mapping[str, FitResult],
                scopes: Mapping[str, Scope], labels: Mapping[str, Mapping[str, str]], covariance: np.ndarray,
                axle_covariance: np.ndarray | None = None, hac_lags: list[int], u_paper: np.ndarray,
                stderr_naive: np.ndarray, u_region: np.ndarray, stderr_low: np.ndarray | None = None,
                stderr_high: np.ndarray | None = None,
                n_accepted: int, start_costs: np.ndarray, options: FitConfig, seed: int,
                runtime_s: float) -> JointFit:
    """The :class:`JointFit` of the refined best joint start (rms, AIC/BIC, verdict, flags)."""
    from pendtrack.fitting.uncertainty import stderr_from_cov

    x = best.x
    se = stderr_from_cov(covariance)
    se_axle = (np.sqrt(np.clip(np.diag(axle_covariance), 0.0, None)) if axle_covariance is not None
               else np.zeros(x.size))
    nan = np.full(x.size, np.nan)
    low = nan if stderr_low is None else stderr_low
    high = nan if stderr_high is None else stderr_high
    estimates = {label: ParamEstimate(value=float(x[j]), stderr=float(se[j]), u_paper=float(u_paper[j]),
                                      u_region=float(u_region[j]), stderr_naive=float(stderr_naive[j]),
                                      stderr_scale=float(se_axle[j]), stderr_low=float(low[j]),
                                      stderr_high=float(high[j]))
                 for j, label in enumerate(stacked.names)}
    runs: dict[str, JointRun] = {}
    flags: dict[str, str] = {}
    follows = True
    sq = 0.0
    for i, (run, p) in enumerate(zip(stacked.runs, stacked.problems)):
        xi = stacked.run_x(x, i)
        sei = se[stacked.columns[i]]
        theta_m, _ = p.model_at_data(xi)
        rms = float(np.sqrt(np.mean((p.theta - theta_m) ** 2)))
        follows &= rms <= 0.5 * float(np.std(p.theta))
        sq += rms ** 2 * p.n
        floors = {n: _floor(model, n, singles[run].omega0_hat) for n in p.names if n in model.param_names}
        run_flags = plausibility_flags(p.names, xi, sei, p.lower, p.upper, t_start=p.t_start, t_end=float(p.t[-1]),
                                       floors=floors, nuisance=_measurement_params(model),
                                       plausible=plausible_limits(model, p.names))
        columns = {n: stacked.names[j] for n, j in zip(p.names, stacked.columns[i])}
        for name, why in run_flags.items():
            flags.setdefault(columns[name], why)
        ests = {n: ParamEstimate(value=float(v), stderr=float(s)) for n, v, s in zip(p.names, xi, sei)}
        runs[run] = JointRun(run=run, labels=dict(labels.get(run) or {}),
                             params={n: ests[n] for n in model.param_names},
                             initial_state={n: ests[n] for n in STATE_NAMES}, columns=columns,
                             xi2=p.cost_value(xi), rms=rms, n=p.n, window=(p.t_start, float(p.t[-1])),
                             single=singles[run], flags=run_flags)
    n, k, xi2 = stacked.n, x.size, float(best.cost)
    cov_ok = bool(np.all(np.isfinite(se)))
    reasons = [] if best.success else [f"optimiser: {best.message}"]
    if not cov_ok:
        reasons.append("singular Jacobian (a parameter is not determined by the data)")
    if not follows:
        reasons.append("the model does not follow every run's oscillation")
    return JointFit(
        model=str(model.name), estimates=estimates, scopes=dict(scopes), runs=runs, xi2_min=xi2,
        rms=math.sqrt(sq / n), aic=n * math.log(xi2) + 2 * k if xi2 > 0 else -math.inf,
        bic=n * math.log(xi2) + k * math.log(n) if xi2 > 0 else -math.inf, n=n,
        converged=bool(best.success and cov_ok and follows), runtime_s=float(runtime_s), seed=int(seed),
        cost=options.cost, n_starts=len(start_costs), n_accepted=n_accepted, accept_ratio=float(options.accept_ratio),
        start_costs=np.asarray(start_costs, dtype=float), covariance=covariance, hac_lags=tuple(hac_lags),
        message="; ".join(reasons) if reasons else best.message, flags=flags)
