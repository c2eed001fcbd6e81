"""Discovery over several runs of one pendulum: effects judged on whole runs held out and on later times.

:func:`discover_runs` is the pure core of ``pendtrack discover A B C`` (several records): arrays in,
a :class:`RunsDiscovery` out, no files. The runs are fitted jointly
(:func:`pendtrack.fitting.joint.fit_joint`): the physical parameters shared, or per group of runs
by their run codes (:mod:`pendtrack.fitting.joint.scopes`), the initial state, theta's offset and a
time-varying damping's ``t0`` per run.

Forward selection over the catalogue, one effect per round (pairs when no single earns its keep
and a run's residual still has structure). A candidate ``current + effect`` is fitted three ways:

* on the **whole runs**, jointly: its BIC against the current model's (``delta_bic``), its angle
  residual (it must go down) and its flags (none of its own);
* on the **first** ``train_fraction`` **of every run**, jointly, then simulated over each whole
  run: its error on the **later times** against the current model's, pooled over the runs (the
  z and gain of :func:`pendtrack.discovery.residuals.heldout_test`);
* **each run held out whole**: fitted jointly to the other runs, then the held-out run fitted
  with every parameter the others determine held at their values (only its own initial state,
  offset and ``t0`` free), and its whole-run error compared with the current model's, pooled
  over the runs. This is the test one record cannot make: an effect that only bends one run to
  its noise does not carry to another run released from another amplitude, and damping that
  weakens with time predicts a low release wrongly where damping that weakens with amplitude
  does not.

An effect is kept when it passes every rule of :mod:`pendtrack.discovery.rules` on both tests. The
runs are held out (the costliest test: one joint fit per run) only for a candidate that passes
every other rule.
Each kept effect is then fitted, in the final model, with its parameters per run as well; it is
reported as **per run** when that lowers the BIC by more than ``-delta_bic_max``, else as
**shared** (judged in the final model: before memory was kept, a time-varying damping per run
absorbed part of the missing memory, dBIC -108 on a series whose damping is one). As on one record,
no cause is named while a run's final residual still has structure (its diagnostics off): the
terms kept then go to ``partial``.

Measurement terms are not judged across runs: with ``offset`` in ``[discover] measurement``,
every model carries theta's zero offset per run.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from pendtrack.config import Config, FitConfig, ModelsConfig
from pendtrack.discovery import catalogue as C
from pendtrack.discovery.data import AnalysisData, prepare
from pendtrack.discovery.diagnostics import diagnose, off_diagnostics
from pendtrack.discovery.inputs import AngleSeries
from pendtrack.discovery.residuals import heldout_test
from pendtrack.discovery.rules import passes_heldout, rule_margins
from pendtrack.discovery.starts import scaled_starts
from pendtrack.errors import ConfigError, FitError, ModelError, PendtrackError

TRAIN_START_SPREAD = 0.2  # random starts within +-20 % of a warm start (as one record's candidate fits)


@dataclass(frozen=True, eq=False)
class RunsTask:
    """Everything a worker needs to fit one model to the runs three ways (module docstring).

    Attributes
    ----------
    data : mapping
        Run id -> its :class:`~pendtrack.discovery.data.AnalysisData`.
    labels : mapping
        Run id -> its run-code labels (empty: none).
    baseline : str
    terms : tuple of str
        Terms added to the baseline (``offset`` first when carried).
    sharing : mapping
        Parameter -> scope text, over the defaults.
    initial : mapping or None
        Run id -> a warm start of the training fits; the new terms' parameters from the data.
    extra : mapping
        Run id -> further starts of the training fits (the scaled new term).
    full_base : mapping or None
        Run id -> the current model's whole-run values: a further start of the whole-run fit.
    n_starts : int
    seed : int
    cost : str
    memory_s : float
    heldout_runs : bool
        Also hold out each run whole.
    """

    data: Mapping[str, AnalysisData]
    labels: Mapping[str, Mapping[str, str]]
    baseline: str
    terms: tuple[str, ...]
    sharing: Mapping[str, str]
    initial: Mapping[str, Mapping[str, float]] | None
    extra: Mapping[str, Sequence[Mapping[str, float]]]
    full_base: Mapping[str, Mapping[str, float]] | None
    n_starts: int
    seed: int
    cost: str
    memory_s: float
    heldout_runs: bool = True


@dataclass(frozen=True, eq=False)
class RunsFit:
    """A model fitted to the runs three ways.

    Attributes
    ----------
    terms : tuple of str
    full, train : JointFit or None
        The joint fits on the whole runs and on their training parts.
    later : mapping
        Run id -> the training fit simulated over the whole run [rad].
    whole : mapping
        Run id -> the run predicted with it held out [rad].
    curves : mapping
        Run id -> the whole-run fit's angle and angular velocity ([rad], [rad/s]).
    warm_train, warm_full : mapping
        Run id -> the training and whole-run fits' values and initial state.
    error : str
    runtime_s : float
    """

    terms: tuple[str, ...]
    full: Any = None
    train: Any = None
    later: Mapping[str, np.ndarray] = field(default_factory=dict)
    whole: Mapping[str, np.ndarray] = field(default_factory=dict)
    curves: Mapping[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    warm_train: Mapping[str, dict[str, float]] = field(default_factory=dict)
    warm_full: Mapping[str, dict[str, float]] = field(default_factory=dict)
    error: str = ""
    runtime_s: float = 0.0


def _model(baseline: str, terms: Sequence[str]):  # noqa: ANN202
    from pendtrack.models import compose, get_model

    return compose(baseline, list(terms)) if terms else get_model(baseline)


def _records(data: Mapping[str, AnalysisData], *, train: bool) -> dict[str, Any]:
    from pendtrack.fitting import Observation
    from pendtrack.fitting.leastsq.samples import Record

    return {run: Record(t=d.t, theta=d.theta, omega=d.omega, alpha=d.alpha,
                        window=d.train_window if train else None, source=d.source, cost_out=d.cost_out,
                        observation=Observation(savgol_window=d.savgol_window, savgol_order=d.savgol_order,
                                                smooth_theta=d.smoothed))
            for run, d in data.items()}


def _options(task: RunsTask, *, warm: bool) -> tuple[FitConfig, ModelsConfig]:
    """As one record's candidate fits (:func:`pendtrack.discovery.candidate_fits.fit_options`): few
    starts, each with the final budget, the trust-region polish, no profile sigmas."""
    from pendtrack.fitting.leastsq.local_fits import FINAL_ITERATIONS

    fit = FitConfig(cost=task.cost, n_starts=task.n_starts, start_budget=FINAL_ITERATIONS, profile=False,
                    trust_region_polish=True, joint_starts=1, workers=1)
    if warm:
        fit = replace(fit, start_spread=TRAIN_START_SPREAD)
    return fit, ModelsConfig(memory_s=task.memory_s)


def _values(fit: Any, run: str) -> dict[str, float]:
    """A run's values and initial state at a joint optimum (a warm start)."""
    res = fit.run_result(run)
    return {**{k: float(v.value) for k, v in res.params.items()},
            **{k: float(v.value) for k, v in res.initial_state.items()}}


def _curve(fit: Any, model: Any, run: str, d: AnalysisData) -> tuple[np.ndarray, np.ndarray]:
    from pendtrack.fitting.predict import predict

    th, om = predict(fit.run_result(run), model, d.t)
    return np.asarray(th, dtype=float), np.asarray(om, dtype=float)


def _fit_joint(task: RunsTask, runs: Sequence[str], *, train: bool, initial: Mapping[str, Mapping[str, float]] | None,
               extra: Mapping[str, Sequence[Mapping[str, float]]] | None, singles: Mapping[str, Any] | None = None
               ) -> Any:
    from pendtrack.fitting.joint import fit_joint

    model = _model(task.baseline, task.terms)
    fit, mopt = _options(task, warm=initial is not None)
    records = _records({r: task.data[r] for r in runs}, train=train)
    init = {r: {k: v for k, v in initial[r].items() if k in (*model.param_names, "theta0", "omega0")}
            for r in runs} if initial else None
    return fit_joint(model, records, sharing=dict(task.sharing), labels={r: task.labels.get(r, {}) for r in runs},
                     options=fit, model_options=mopt, seed=task.seed, workers=1, initial=init,
                     extra_starts={r: list(extra.get(r, ())) for r in runs} if extra else None, singles=singles)


def _predict_heldout_run(task: RunsTask, run: str, others: Any, warm: Mapping[str, float]) -> np.ndarray:
    """Run ``run`` predicted by the joint fit of the others: every parameter they determine held."""
    from pendtrack.fitting import Observation, fit_model
    from pendtrack.fitting.joint.scopes import RUN, column_label, group_of
    from pendtrack.fitting.predict import predict

    model = _model(task.baseline, task.terms)
    d = task.data[run]
    known = {lab: others.estimates[lab].value for lab in others.estimates}
    fixed = {}
    for name in model.param_names:
        scope = others.scopes[name]
        if scope == (RUN,):
            continue
        label = column_label(name, group_of(scope, run, task.labels.get(run, {})))
        if label in known:
            fixed[name] = float(known[label])
    opts, mopt = _options(task, warm=True)
    free = {k: v for k, v in warm.items() if k not in fixed and k in (*model.param_names, "theta0", "omega0")}
    fit = fit_model(model, d.t, d.theta, d.omega, options=opts, model_options=mopt, alpha=d.alpha,
                    observation=Observation(savgol_window=d.savgol_window, savgol_order=d.savgol_order,
                                            smooth_theta=d.smoothed),
                    fixed=fixed, initial=free, seed=task.seed, workers=1, source=d.source, cost_out=d.cost_out)
    th, _ = predict(fit, model, d.t)
    return np.asarray(th, dtype=float)


_FAILURES = (PendtrackError, FloatingPointError, ValueError, ArithmeticError, np.linalg.LinAlgError)


def fit_runs(task: RunsTask) -> RunsFit:
    """Fit ``baseline + terms`` to the training parts and to the whole runs (module docstring); with
    ``task.heldout_runs``, also hold out each run (:func:`hold_out_runs`). Runs in a worker process;
    every failure becomes ``RunsFit.error`` (a candidate that cannot be fitted is not kept)."""
    t_wall = time.perf_counter()
    runs = tuple(task.data)
    model = _model(task.baseline, task.terms)
    try:
        train = _fit_joint(task, runs, train=True, initial=task.initial, extra=task.extra)
        warm_train = {r: _values(train, r) for r in runs}
        later = {r: _curve(train, model, r, task.data[r])[0] for r in runs}
        extra_full = ({r: [{**warm_train[r], **{k: v for k, v in task.full_base[r].items() if k in warm_train[r]}}]
                       for r in runs} if task.full_base else None)
        full = _fit_joint(task, runs, train=False, initial=warm_train, extra=extra_full)
        warm_full = {r: _values(full, r) for r in runs}
        curves = {r: _curve(full, model, r, task.data[r]) for r in runs}
    except _FAILURES as exc:
        return RunsFit(task.terms, error=str(exc) or type(exc).__name__, runtime_s=time.perf_counter() - t_wall)
    fit = RunsFit(task.terms, full=full, train=train, later=later, curves=curves, warm_train=warm_train,
                  warm_full=warm_full, runtime_s=time.perf_counter() - t_wall)
    return hold_out_runs(task, fit) if task.heldout_runs else fit


def hold_out_runs(task: RunsTask, fit: RunsFit) -> RunsFit:
    """``fit`` with each run predicted while held out: the joint fit of the other runs (their own fits
    are the whole-run fit's: same model, same records), then the held-out run with every parameter
    they determine held (:func:`_predict_heldout_run`). A failure becomes ``RunsFit.error``."""
    t_wall = time.perf_counter()
    runs = tuple(task.data)
    full = fit.full
    whole: dict[str, np.ndarray] = {}
    try:
        for r in runs:
            rest = [o for o in runs if o != r]
            others = (_fit_joint(task, rest, train=False, initial={o: fit.warm_full[o] for o in rest}, extra=None,
                                 singles={o: full.runs[o].single for o in rest}) if len(rest) > 1
                      else _single_as_joint(task, rest[0], full.runs[rest[0]].single))
            whole[r] = _predict_heldout_run(task, r, others, fit.warm_full[r])
    except _FAILURES as exc:
        return replace(fit, error=f"runs held out: {exc or type(exc).__name__}",
                       runtime_s=fit.runtime_s + time.perf_counter() - t_wall)
    return replace(fit, whole=whole, runtime_s=fit.runtime_s + time.perf_counter() - t_wall)


@dataclass(frozen=True)
class _OneRun:
    """A single run's fit seen as a joint fit (its ``estimates`` and ``scopes``): two runs, one held out."""

    estimates: Mapping[str, Any]
    scopes: Mapping[str, tuple[str, ...]]


def _single_as_joint(task: RunsTask, run: str, fit: Any) -> _OneRun:
    """Run ``run``'s own fit (a :class:`~pendtrack.fitting.result.FitResult`) seen as a joint fit of one run."""
    from pendtrack.fitting.joint.scopes import column_label, group_of, resolve_scopes

    model = _model(task.baseline, task.terms)
    labels = {run: task.labels.get(run, {})}
    scopes = resolve_scopes(model, dict(task.sharing), labels=labels)
    return _OneRun(estimates={column_label(n, group_of(scopes[n], run, labels[run])): fit.params[n]
                              for n in model.param_names}, scopes=scopes)


@dataclass(frozen=True)
class RunsCandidate:
    """One candidate judged across runs.

    Attributes
    ----------
    effect : str
        The effect (a pair: ``a+b``).
    terms : tuple of str
    step : int
    delta_bic : float
        Its joint BIC minus the current model's [1].
    rms_drop : float
        The current model's angle RMS minus its, over every run [rad].
    later_gain, later_z : float
        Later times: RMS gain [rad] and z over the current model.
    runs_gain, runs_z : float
        Whole runs held out: RMS gain [rad] and z.
    flags : mapping
        Flags of its whole-run fit its terms brought.
    margins : mapping
        Each rule's value, threshold and margin, per test (``later``, ``runs``).
    kept : bool
    error : str
    runtime_s : float
        Wall time of its fits [s].
    """

    effect: str
    terms: tuple[str, ...]
    step: int
    delta_bic: float
    rms_drop: float
    later_gain: float
    later_z: float
    runs_gain: float
    runs_z: float
    flags: Mapping[str, str]
    margins: Mapping[str, Any]
    kept: bool
    error: str = ""
    runtime_s: float = math.nan

    def reason(self) -> str:
        """Why it was not kept, in words ("" when kept)."""
        if self.kept:
            return ""
        if self.error:
            return f"could not be fitted ({self.error})"
        why = []
        for test in ("later", "runs"):
            m = self.margins.get(test, {})
            if m and not (m["z"]["margin"] > 0 and m["gain_share"]["margin"] >= 0):
                what = "later times" if test == "later" else "runs held out"
                why.append(f"{what}: z {m['z']['value']:.1f}")
        if not self.delta_bic < self.margins.get("later", {}).get("delta_bic", {}).get("threshold", -10.0):
            why.append(f"dBIC {self.delta_bic:+.1f}")
        if not self.rms_drop > 0:
            why.append("the residual does not go down")
        if self.flags:
            why.append("flagged: " + ", ".join(sorted(self.flags)))
        return "; ".join(why)

    def to_dict(self) -> dict[str, Any]:
        return {"effect": self.effect, "terms": list(self.terms), "step": self.step, "delta_bic": _num(self.delta_bic),
                "rms_drop": _num(self.rms_drop), "later": {"gain": _num(self.later_gain), "z": _num(self.later_z)},
                "runs_held_out": {"gain": _num(self.runs_gain), "z": _num(self.runs_z)}, "flags": dict(self.flags),
                "margins": _clean(self.margins), "kept": self.kept, "error": self.error, "reason": self.reason(),
                "runtime_s": _num(self.runtime_s)}


def _num(x: float) -> float | None:
    return float(x) if x is not None and math.isfinite(float(x)) else None


def _clean(obj: Any) -> Any:
    if isinstance(obj, Mapping):
        return {k: _clean(v) for k, v in obj.items()}
    if isinstance(obj, float):
        return _num(obj)
    return obj


def _pooled(parts: Mapping[str, AnalysisData], theta_of: Callable[[str], np.ndarray],
            a: Mapping[str, np.ndarray], b: Mapping[str, np.ndarray]) -> tuple[float, float, float]:
    """Gain [rad], z and the current model's RMS [rad] of predictions ``b`` over ``a``, pooled over the runs."""
    runs = list(parts)
    th = np.concatenate([theta_of(r) for r in runs])
    pa = np.concatenate([a[r] for r in runs])
    pb = np.concatenate([b[r] for r in runs])
    gain, z = heldout_test(th, pa, pb)
    return gain, z, float(np.sqrt(np.mean((th - pa) ** 2))) if np.all(np.isfinite(pa)) else math.inf


def _base_name(label: str) -> str:
    return label.split("@", 1)[0]


def judge_runs(cand: RunsFit, current: RunsFit, data: Mapping[str, AnalysisData], *, effect: str, step: int,
               config: Config, new_terms: Sequence[str]) -> RunsCandidate:
    """The rules of :mod:`pendtrack.discovery.rules` on both tests of the module docstring."""
    from pendtrack.models import CATALOGUE

    dc = config.discover
    nan = math.nan
    if cand.error or cand.full is None or current.full is None:
        return RunsCandidate(effect, tuple(new_terms), step, nan, nan, -math.inf, -math.inf, -math.inf, -math.inf,
                             {}, {}, False, error=cand.error or "fit failed", runtime_s=cand.runtime_s)
    held = {r: d.heldout for r, d in data.items()}
    lg, lz, l_ref = _pooled(data, lambda r: data[r].theta[held[r]], {r: current.later[r][held[r]] for r in data},
                            {r: cand.later[r][held[r]] for r in data})
    if cand.whole and current.whole:
        rg, rz, r_ref = _pooled(data, lambda r: data[r].theta, current.whole, cand.whole)
    else:  # not held out (yet): only a candidate that passes every other rule is
        rg, rz, r_ref = nan, nan, nan
    dbic = float(cand.full.bic - current.full.bic)
    drop = float(current.full.rms - cand.full.rms)
    mine = {p for t in new_terms if t in CATALOGUE for p in CATALOGUE[t].params}
    before = {_base_name(k) for k in current.full.flags}
    flags = {k: v for k, v in cand.full.flags.items() if _base_name(k) in mine or _base_name(k) not in before}
    rules = {"heldout_z_min": dc.heldout_z_min, "min_gain": dc.heldout_min_gain, "delta_bic_max": dc.delta_bic_max}
    margins = {"later": rule_margins(lz, lg, l_ref, dbic, rms_change=drop, **rules)}
    ok_later = passes_heldout(lg, lz, dc.heldout_z_min, min_gain=dc.heldout_min_gain, heldout_rms=l_ref)
    ok_runs = True  # before the runs are held out: whether it is worth holding them out
    if cand.whole:
        margins["runs"] = rule_margins(rz, rg, r_ref, dbic, rms_change=drop, **rules)
        ok_runs = passes_heldout(rg, rz, dc.heldout_z_min, min_gain=dc.heldout_min_gain, heldout_rms=r_ref)
    kept = bool(ok_later and ok_runs and dbic < dc.delta_bic_max and drop > 0 and not flags)
    return RunsCandidate(effect, tuple(new_terms), step, dbic, drop, lg, lz, rg, rz, flags, margins, kept,
                         runtime_s=cand.runtime_s)


@dataclass(frozen=True, eq=False)
class RunsDiscovery:
    """What discovery across runs found.

    Attributes
    ----------
    runs : tuple of str
    baseline : str
    effects : tuple of str
        The causes named (empty while a run's residual keeps structure the catalogue cannot remove).
    partial : tuple of str
        Effects kept that improve the fit without explaining the runs.
    scopes : mapping
        Kept effect -> ``"shared"`` or ``"per run"``, with the BIC of its per-run fit against the shared one.
    candidates : tuple of RunsCandidate
        Every candidate judged, in order.
    baseline_fit, final_fit : JointFit
    unexplained : mapping
        Run id -> the final model's diagnostics still off there.
    carried : tuple of str
        Measurement terms every model carries per run.
    thresholds : mapping
        The rules' thresholds (``delta_bic_max``, ``heldout_z_min``, ``heldout_min_gain``, ``train_fraction``).
    runtime_s : float
    """

    runs: tuple[str, ...]
    baseline: str
    effects: tuple[str, ...]
    partial: tuple[str, ...]
    scopes: Mapping[str, Mapping[str, Any]]
    candidates: tuple[RunsCandidate, ...]
    baseline_fit: Any
    final_fit: Any
    unexplained: Mapping[str, tuple[str, ...]]
    carried: tuple[str, ...]
    thresholds: Mapping[str, float]
    runtime_s: float

    def to_dict(self) -> dict[str, Any]:
        """discovery.json's content across runs."""
        def fit_dict(f: Any) -> dict[str, Any]:
            return {"model": f.model, "bic": _num(f.bic), "rms": _num(f.rms), "converged": bool(f.converged),
                    "flags": dict(f.flags),
                    "values": {k: {"value": _num(v.value), "stderr": _num(v.stderr)} for k, v in f.estimates.items()},
                    "runs_rms": {r: _num(jr.rms) for r, jr in f.runs.items()}}

        return {"kind": "discovery_runs", "runs": list(self.runs), "baseline": self.baseline,
                "effects": list(self.effects), "partial": list(self.partial),
                "scopes": _clean({k: dict(v) for k, v in self.scopes.items()}),
                "carried": list(self.carried), "unexplained": {r: list(v) for r, v in self.unexplained.items()},
                "candidates": [c.to_dict() for c in self.candidates], "baseline_fit": fit_dict(self.baseline_fit),
                "final_fit": fit_dict(self.final_fit), "thresholds": dict(self.thresholds),
                "runtime_s": self.runtime_s}

    def summary(self) -> str:
        """discovery.md across runs: what was found, in words that match the numbers."""
        lines = [f"# Discovery across {len(self.runs)} runs: {', '.join(self.runs)}", "",
                 f"Baseline `{self.baseline}` fitted jointly"
                 + (f", with {', '.join(self.carried)} per run" if self.carried else "")
                 + "; each effect judged on the later times of every run and on every run held out whole.", "",
                 "## Verdict", ""]
        kept = [c for c in self.candidates if c.kept]
        if self.effects:
            lines.append("The causes named are " + " together with ".join(
                f"{e} ({self.scopes[e]['scope']})" for e in self.effects) + ".")
        elif self.partial:
            lines.append("No cause is named: the runs keep structure the catalogue cannot remove "
                         f"({'; '.join(f'{r}: ' + ', '.join(v) for r, v in self.unexplained.items() if v)}). "
                         f"Kept because they improve the fit, not as its cause: {', '.join(self.partial)}.")
        else:
            lines.append("No effect earns its keep: the baseline explains the runs.")
        lines += ["", "## Candidates", "", "| step | effect | dBIC | later times z | runs held out z | kept | why not |",
                  "|---|---|---|---|---|---|---|"]
        for c in self.candidates:
            runs_z = f"{c.runs_z:.1f}" if math.isfinite(c.runs_z) else "not held out"
            lines.append(f"| {c.step} | {c.effect} | {c.delta_bic:+.1f} | {c.later_z:.1f} | {runs_z} | "
                         f"{'yes' if c.kept else 'no'} | {c.reason()} |")
        if kept:
            lines += ["", "## Shared or per run", "", "Each kept effect's parameters fitted per run against shared:"]
            for e, s in self.scopes.items():
                lines.append(f"- {e}: {s['scope']} (per-run dBIC {s['delta_bic_per_run']:+.1f})"
                             if s.get("delta_bic_per_run") is not None else f"- {e}: {s['scope']}")
        return "\n".join(lines) + "\n"


class RunsLoop:
    """The state of one discovery across runs (:func:`discover_runs` runs it)."""

    def __init__(self, series: Mapping[str, AngleSeries], *, config: Config, baseline: str, pool: Sequence[C.Effect],
                 labels: Mapping[str, Mapping[str, str]] | None, sharing: Mapping[str, str] | None,
                 on_progress: Callable[[int], None] | None) -> None:
        from pendtrack.discovery.candidate_fits import make_executor
        from pendtrack.parallel import worker_count

        self.t_wall = time.perf_counter()
        self.config, self.baseline, self.pool = config, baseline, tuple(pool)
        dc = self.dc = config.discover
        if len(series) < 2:
            raise FitError(f"discovery across runs needs at least two records, got {len(series)}")
        self.data = {r: prepare(s, analysis_rate_hz=dc.analysis_rate_hz, train_fraction=dc.train_fraction,
                                savgol_window_s=config.kinematics.savgol_window_s,
                                savgol_order=config.kinematics.savgol_order,
                                slow_motion_px=config.fit.slow_motion_px) for r, s in series.items()}
        self.labels = {r: dict((labels or {}).get(r) or {}) for r in series}
        self.sharing = dict(sharing or {})
        self.carried = ("offset",) if "offset" in dc.measurement else ()
        self.tick = on_progress or (lambda n: None)
        self.workers = worker_count(max(dc.workers, 0))
        self.executor = make_executor(worker_count(self.workers, max(len(self.pool), 1)))
        self.accepted: list[str] = []
        self.candidates: list[RunsCandidate] = []
        self.scopes: dict[str, dict[str, Any]] = {}
        self.step = 0

    def _task(self, terms: Sequence[str], **kw: Any) -> RunsTask:
        return RunsTask(data=self.data, labels=self.labels, baseline=self.baseline, terms=(*self.carried, *terms),
                        cost=self.config.fit.cost, memory_s=self.config.models.memory_s,
                        **{"initial": None, "extra": {}, "full_base": None, "n_starts": self.dc.n_starts,
                           "seed": self.dc.seed, "sharing": self.sharing, **kw})

    def _fit_many(self, tasks: Sequence[RunsTask], fits: Sequence[RunsFit] | None = None) -> list[RunsFit]:
        """:func:`fit_runs` of each task, or (``fits`` given) :func:`hold_out_runs` of each, in the workers."""
        args = [(t,) for t in tasks] if fits is None else list(zip(tasks, fits))
        fn = fit_runs if fits is None else hold_out_runs
        if self.executor is None or len(args) <= 1:
            out = [fn(*a) for a in args]
        else:
            out = [f.result() for f in [self.executor.submit(fn, *a) for a in args]]
        self.tick(len(args))
        return out

    def _candidates(self, combos: Sequence[tuple[str, ...]]) -> list[tuple[RunsCandidate, RunsFit]]:
        cur = self.current
        tasks = []
        for combo in combos:
            extra: dict[str, list[dict[str, float]]] = {}
            if len(combo) == 1:
                extra = {r: scaled_starts(self.baseline, [*self.carried, *self.accepted], combo[0], cur.warm_train[r],
                                          self.data[r], memory_s=self.config.models.memory_s) for r in self.data}
            tasks.append(self._task((*self.accepted, *combo), initial=cur.warm_train, extra=extra,
                                    full_base=cur.warm_full, seed=self.dc.seed + self.step))
        fits = self._fit_many([replace(t, heldout_runs=False) for t in tasks])
        judge = lambda combo, fit: judge_runs(fit, cur, self.data, effect="+".join(combo),  # noqa: E731
                                              step=self.step, config=self.config, new_terms=combo)
        out = [(judge(combo, fit), fit) for combo, fit in zip(combos, fits)]
        # each run held out (the costliest test) only for the candidates that pass every other rule
        passing = [i for i, (c, _) in enumerate(out) if c.kept]
        held = self._fit_many([tasks[i] for i in passing], [out[i][1] for i in passing]) if passing else []
        for i, fit in zip(passing, held):
            out[i] = (judge(combos[i], fit), fit)
        self.candidates.extend(c for c, _ in out)
        return out

    def run(self) -> RunsDiscovery:
        try:
            (base,) = self._fit_many([self._task((), n_starts=self.dc.n_starts_baseline)])
            if base.error or base.full is None:
                raise FitError(f"baseline model '{self.baseline}' could not be fitted jointly: {base.error}")
            self.base = self.current = base
            while len(self.accepted) < self.dc.max_effects:
                remaining = [e.name for e in self.pool if e.name not in self.accepted]
                if not remaining:
                    break
                self.step += 1
                judged = self._candidates([(e,) for e in remaining])
                best = _best(judged)
                if best is None and self._structure_left() and len(remaining) >= 2 and self.dc.max_combination >= 2 \
                        and len(self.accepted) + 2 <= self.dc.max_effects:
                    singles = sorted((c for c, _ in judged if not c.error),
                                     key=lambda c: -(c.later_gain if math.isfinite(c.later_gain) else -1e9))
                    names = [c.effect for c in singles[:self.dc.combination_pool]]
                    pairs = [(a, b) for i, a in enumerate(names) for b in names[i + 1:]]
                    best = _best(self._candidates(pairs)) if pairs else None
                if best is None:
                    break
                cand, fit = best
                self.accepted.extend(cand.terms)
                self.current = fit
            for term in self.accepted:  # in the final model: an effect missing beside it would bend the scopes
                self._scope(term)
            return self._result()
        finally:
            if self.executor is not None:
                self.executor.shutdown()

    def _scope(self, term: str) -> None:
        """Shared or per run: the term's parameters per run against shared, by the BIC of the whole runs."""
        from pendtrack.fitting.joint.scopes import PER_RUN_PARAMS
        from pendtrack.models import CATALOGUE

        params = [p for p in CATALOGUE[term].params if p not in PER_RUN_PARAMS and p not in self.sharing]
        if not params:
            self.scopes[term] = {"scope": "per run", "delta_bic_per_run": None}
            return
        cur = self.current
        task = self._task(self.accepted, sharing={**self.sharing, **{p: "run" for p in params}},
                          initial=cur.warm_full, heldout_runs=False)
        try:
            per_run = _fit_joint(task, list(self.data), train=False, initial=cur.warm_full, extra=None,
                                 singles={r: cur.full.runs[r].single for r in self.data})
            dbic = float(per_run.bic - cur.full.bic)
        except (PendtrackError, FloatingPointError, ValueError, ArithmeticError, np.linalg.LinAlgError):
            dbic = math.nan
        self.tick(1)
        self.scopes[term] = {"scope": "per run" if dbic < self.dc.delta_bic_max else "shared",
                             "delta_bic_per_run": dbic, "params": params}

    def _structure_left(self) -> dict[str, tuple[str, ...]]:
        """Run id -> the current model's diagnostics still off there (only runs with any)."""
        dc = self.dc
        out = {}
        for r, d in self.data.items():
            th, om = self.current.curves[r]
            omega0 = float(self.current.full.run_result(r).params["Omega0"].value)
            diag = diagnose(d.t, d.theta, th, om, omega0, model=self.current.full.model,
                            savgol_window_s=d.savgol_window * d.dt, savgol_order=d.savgol_order,
                            n_replicas=dc.n_replicas, seed=dc.seed, near_fraction=dc.near_turning_fraction)
            off = tuple(off_diagnostics(diag.evidence))
            if off:
                out[r] = off
        return out

    def _result(self) -> RunsDiscovery:
        dc = self.dc
        unexplained = self._structure_left()
        base_flags = {_base_name(k) for k in self.base.full.flags}
        new_flags = [k for k in self.current.full.flags if _base_name(k) not in base_flags]
        named = () if (unexplained or new_flags) else tuple(self.accepted)
        partial = tuple(self.accepted) if not named else ()
        thresholds = {"delta_bic_max": dc.delta_bic_max, "heldout_z_min": dc.heldout_z_min,
                      "heldout_min_gain": dc.heldout_min_gain, "train_fraction": dc.train_fraction}
        return RunsDiscovery(runs=tuple(self.data), baseline=self.baseline, effects=named, partial=partial,
                             scopes=self.scopes, candidates=tuple(self.candidates), baseline_fit=self.base.full,
                             final_fit=self.current.full, unexplained=unexplained, carried=self.carried,
                             thresholds=thresholds, runtime_s=time.perf_counter() - self.t_wall)


def _best(judged: Sequence[tuple[RunsCandidate, RunsFit]]) -> tuple[RunsCandidate, RunsFit] | None:
    """The kept candidate with the lowest BIC (as :func:`pendtrack.discovery.rules.choose`)."""
    ok = [cf for cf in judged if cf[0].kept]
    return min(ok, key=lambda cf: cf[0].delta_bic) if ok else None


def discover_runs(series: Mapping[str, AngleSeries], *, config: Config, baseline: str | None = None,
                  effects: Sequence[str] | None = None, labels: Mapping[str, Mapping[str, str]] | None = None,
                  sharing: Mapping[str, str] | None = None,
                  on_progress: Callable[[int], None] | None = None) -> RunsDiscovery:
    """Find what the baseline gets wrong across several runs of one pendulum (module docstring).

    Parameters
    ----------
    series : mapping
        Run id -> its record (``t`` [s], ``theta`` [rad]); at least two.
    config : Config
        Uses [discover], [kinematics], [models] and [fit] (cost).
    baseline : str, optional
        Default ``config.discover.baseline``.
    effects : sequence of str, optional
        Restrict the catalogue; default ``config.discover.effects`` (empty: all).
    labels : mapping, optional
        Run id -> its run-code labels (``tile``, ``launched``, ``alley``): the default scopes follow them.
    sharing : mapping, optional
        Parameter -> scope text (``shared``, ``run``, ``tile+alley``) over the defaults.
    on_progress : callable, optional
        Called with the number of fits done.

    Returns
    -------
    RunsDiscovery

    Raises
    ------
    ConfigError
        Unknown baseline or effect.
    FitError
        Fewer than two runs, a run too short, or a baseline that cannot be fitted.
    """
    dc = config.discover
    baseline = baseline or dc.baseline
    try:
        pool = C.candidates(baseline, tuple(dc.effects if effects is None else effects))
    except ModelError as exc:
        raise ConfigError(str(exc)) from None
    return RunsLoop(series, config=config, baseline=baseline, pool=pool, labels=labels, sharing=sharing,
                    on_progress=on_progress).run()
