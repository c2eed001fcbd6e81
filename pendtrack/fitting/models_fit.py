"""Several models fitted to one record, and every decision about what the fit stage writes.

:func:`fit_models` is the one core function behind ``pendtrack fit`` and ``pt.fit``: it takes the
record's arrays and what its kinematics provenance says (the Savitzky-Golay filter, the zero of
theta), fits each model with :func:`~pendtrack.fitting.fitter.fit_model`, and returns a
:class:`ModelFits` holding everything the stage writes -- the per-model records, fit.json's
content (one model's record, or the container of several), the curves of fit.parquet and the
stage's facts. The decisions made here:

* the ``offset`` term (:func:`fits_offset`): added to every model when theta's zero was not
  measured (``[fit] offset = "auto"``), or always, or never; every standard error includes the
  axle's uncertainty (:func:`with_axle_uncertainty`: its share of theta's zero and of its scale);
* the data's filter (:func:`observation_from`), from the kinematics provenance;
* the selected model: the trustworthy fit (converged, no parameter flagged) with the lowest BIC,
  or if none is, the converged one (same data and cost for every model);
* the cross-model relations, when classic and fractional were both fitted;
* the exit rule (:func:`fit_problems`): a fit not converged or flagged is not trustworthy.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Mapping, Sequence
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy.signal import savgol_coeffs

from pendtrack.config import FitConfig, ModelsConfig
from pendtrack.errors import FitError
from pendtrack.fitting.cross_model import cross_model_relations
from pendtrack.fitting.fitter import fit_model
from pendtrack.fitting.leastsq.cost import Observation
from pendtrack.fitting.leastsq.samples import axle_shares, check_record, slow_frames
from pendtrack.fitting.predict import predict
from pendtrack.fitting.result import FitResult, ParamEstimate, _num, in_range
from pendtrack.fitting.uncertainty import Z95

log = logging.getLogger(__name__)

#: Zeros of theta that were not measured (the kinematics' ``zero_reference``): the image vertical
#: (``"vertical"``) and a plain table's own convention (``"table"``). A measured rest or the
#: renderer's truth (``"rest"``, ``"truth"``) and an unrecorded zero (``"unknown"``) are taken as measured.
ZERO_NOT_MEASURED = ("vertical", "table")
#: How fit.json's container chooses its ``selected`` model, by whether a trustworthy fit exists.
SELECTED_BY = {True: "lowest bic among trustworthy fits (converged, no parameter flagged; same data and cost)",
               False: "lowest bic among converged fits (same data and cost)"}


def model_json_name(model: str) -> str:
    """File name of one model's fit record: ``fit_<model>.json`` (``+`` of composed names kept)."""
    safe = "".join(c if c.isalnum() or c in "+-_." else "_" for c in model)
    return f"fit_{safe}.json"


def fits_offset(mode: str, zero: str) -> bool:
    """Whether the measurement term ``offset`` (theta_off) is added to every model.

    ``mode`` is ``[fit] offset``: ``"always"``, ``"never"``, or ``"auto"`` -- when the record's
    zero of theta was not measured (``zero`` in :data:`ZERO_NOT_MEASURED`).
    """
    if mode == "always":
        return True
    if mode == "never":
        return False
    return zero in ZERO_NOT_MEASURED


def observation_from(extra: Mapping[str, Any], config: Mapping[str, Any], t: np.ndarray, *,
                     source: str = "the record") -> Observation:
    """The data's Savitzky-Golay filter, from the kinematics provenance (no filter if unknown).

    Parameters
    ----------
    extra : mapping
        The provenance's facts: ``window_points``, ``order`` (and ``h`` [s]) when known.
    config : mapping
        The provenance's config sections: ``kinematics.savgol_window_s`` [s], ``savgol_order``
        when the facts lack the window.
    t : array
        Times [s]: the step when the provenance has none.
    """
    w, order = extra.get("window_points"), extra.get("order")
    if w is None or order is None:
        kin = config.get("kinematics") or {}
        h = extra.get("h")
        if not kin or h is None:
            h = float(np.median(np.diff(t))) if t.size > 1 else None
        if kin.get("savgol_window_s") is not None and h:
            from pendtrack.kinematics import window_points

            order = int(kin.get("savgol_order", 3))
            w = window_points(float(kin["savgol_window_s"]), float(h), order)
    if w is None or order is None:
        log.warning("%s: no Savitzky-Golay window in the provenance; the model is compared unfiltered", source)
        return Observation()
    return Observation(savgol_window=int(w), savgol_order=int(order), smooth_theta=True)


def fit_problems(facts: Mapping[str, Any]) -> dict[str, str]:
    """Model -> why its fit is not trustworthy (not converged, or a parameter flagged), from the fit's facts.

    Works on the facts of a skipped stage too (read back from fit.json's provenance; older ones
    have no ``flagged``). `fit` and `run` exit 1 when it is not empty.
    """
    models = facts.get("models") or {}
    out: dict[str, str] = {}
    for name in facts.get("not_converged") or []:
        out[name] = f"did not converge: {(models.get(name) or {}).get('message', '')}".rstrip(": ")
    for name, flags in (facts.get("flagged") or {}).items():
        if name not in out and flags:
            out[name] = "flagged: " + "; ".join(f"{k} {v}" for k, v in flags.items())
    return out


def check_models(names: Sequence[str], *, source: object = None) -> dict[str, Any]:
    """The models by name (registry names), checked before any work: none, twice or unknown raise.

    Raises
    ------
    FitError
        No model, or a model listed twice.
    ModelError
        Unknown model name.
    """
    from pendtrack.models import get_model

    names = tuple(names)
    if not names:
        raise FitError("no model to fit", path=source)
    if len(set(names)) != len(names):
        raise FitError(f"a model is listed twice: {', '.join(names)}", path=source)
    return {n: get_model(n) for n in names}


@dataclass(frozen=True)
class FitFiles:
    """What a fit stage writes of its fits (a single record's, :class:`ModelFits`, or a joint fit's).

    Attributes
    ----------
    records : mapping
        Model name -> the content of ``fit_<model>.json`` (without provenance).
    files : mapping
        Model name -> its file name (:func:`model_json_name`).
    combined : dict
        fit.json's content: one model's record, or the container of several.
    curves : dict of arrays
        The curves' columns: t, theta, theta_model, omega_model, residual, model (models stacked;
        a joint fit's with run).
    facts : dict
        The stage's facts (its provenance's ``extra``); ``selected`` among them.
    """

    records: Mapping[str, dict[str, Any]]
    files: Mapping[str, str]
    combined: dict[str, Any]
    curves: dict[str, np.ndarray] = field(repr=False)
    facts: dict[str, Any]

    @property
    def selected(self) -> str | None:
        return self.facts["selected"]


@dataclass(frozen=True)
class ModelFits(FitFiles):
    """The fits of several models to one record, and what the fit stage writes of them (:class:`FitFiles`).

    Attributes
    ----------
    results : mapping
        Model name (as asked) -> :class:`~pendtrack.fitting.result.FitResult`, in the order fitted.

    ``curves`` are fit.parquet's columns; ``facts``: models, not_converged, flagged, selected,
    files, observation, zero_reference, zero_sigma_rad.
    """

    results: Mapping[str, FitResult]


def fit_models(models: Sequence[str], t: np.ndarray, theta: np.ndarray, omega: np.ndarray, *,
               alpha: np.ndarray, ok: np.ndarray, provenance_extra: Mapping[str, Any],
               provenance_config: Mapping[str, Any], options: FitConfig = FitConfig(),
               model_options: ModelsConfig = ModelsConfig(), source: str = "the record",
               progress: Callable[[str], AbstractContextManager[Callable[[int], None] | None]] | None = None,
               ) -> ModelFits:
    """Fit each model to one record: the fit stage's work, files excepted.

    Parameters
    ----------
    models : sequence of str
        Registry names (checked by :func:`check_models`).
    t, theta, omega, alpha, ok : arrays
        The kinematics: times [s], angle [rad], angular velocity [rad/s], acceleration [rad/s^2]
        (for the estimates) and the usable samples.
    provenance_extra, provenance_config : mapping
        The kinematics provenance's facts and config: the data's filter (:func:`observation_from`),
        the zero of theta (``zero_reference``, :func:`fits_offset`) and the marker's radius and frame
        interval (``marker_radius_px``, ``h``: the slow frames left out of the cost,
        :func:`pendtrack.fitting.leastsq.samples.slow_frames`).
    options, model_options : FitConfig, ModelsConfig
        ``[fit]`` (every option of each fit, ``offset`` and ``workers`` included) and ``[models]``.
    source : str
        The record's name in messages.
    progress : callable, optional
        ``progress(name)`` -> a context manager giving the ``on_progress`` callback of that model's fit.

    Returns
    -------
    ModelFits

    Raises
    ------
    FitError
        No model, a model twice, too few samples, none usable, no oscillation.
    ModelError
        Unknown model name.
    """
    from pendtrack.fitting.leastsq.ladder import search_pool
    from pendtrack.models import compose

    names = tuple(models)
    model_objs = check_models(names, source=source)
    zero = str(provenance_extra.get("zero_reference") or "unknown")
    if fits_offset(options.offset, zero):  # theta's zero not measured: fitted as theta_off
        model_objs = {n: m if "offset" in m.terms else compose(m, ["offset"]) for n, m in model_objs.items()}
    if t.size == 0:
        raise FitError("the kinematics file has no samples", path=source)
    obs = observation_from(provenance_extra, provenance_config, t, source=source)
    check_record(t, theta, omega, alpha=alpha, ok=ok, source=source)  # fail before any progress bar
    scale_rel = axle_shares(provenance_extra)["theta_scale_rel"]  # the axle's radius uncertainty over the radius [1]
    slow = slow_frames(dict(provenance_extra), omega, min_px=options.slow_motion_px, reach=obs.trim)
    results: dict[str, FitResult] = {}
    # the models' searches (and their profile sigmas) share one set of worker processes, started now (their
    # imports and kernels load while the first model's estimates run) rather than one set per model
    workers = search_pool(options.workers)
    try:
        for name in names:
            with (progress(name) if progress else nullcontext()) as advance:
                results[name] = fit_model(model_objs[name], t, theta, omega, options=options,
                                          model_options=model_options, alpha=alpha, ok=ok, observation=obs,
                                          on_progress=advance, source=source, pool=workers,
                                          theta_scale_rel=scale_rel, cost_out=slow)
    finally:
        if workers is not None:
            workers.shutdown(wait=True, cancel_futures=True)

    results = {n: with_axle_uncertainty(r, provenance_extra.get("zero_sigma_rad")) for n, r in results.items()}
    noise_seen = filtered_noise(provenance_extra.get("noise_rad"), obs.savgol_window, obs.savgol_order)
    # "model" is the model asked for (file names, batch columns and the report key on it), "fitted_model"
    # the one fitted (e.g. "classic+offset")
    records = {n: {**r.to_dict(), "model": n, "fitted_model": r.model} for n, r in results.items()}
    files = {n: model_json_name(n) for n in names}
    converged = [n for n in names if results[n].converged]
    trusted = [n for n in converged if results[n].trustworthy]
    pool = trusted or converged
    selected = min(pool, key=lambda n: results[n].bic) if pool else None
    facts: dict[str, Any] = {
        "models": {n: _model_facts(r, noise_seen) for n, r in results.items()},
        "not_converged": [n for n in names if not results[n].converged],
        "flagged": {n: dict(results[n].flags) for n in names if results[n].flags},
        "selected": selected,
        "files": dict(files),
        "observation": {"savgol_window": obs.savgol_window, "savgol_order": obs.savgol_order},
        "zero_reference": zero,
        "zero_sigma_rad": _num(provenance_extra.get("zero_sigma_rad")),
        "theta_scale_rel": scale_rel,
        "slow_frames": int(slow.sum()) if slow is not None else 0,
        "noise_rad": _num(provenance_extra.get("noise_rad")),
    }
    if len(names) == 1:
        combined = records[names[0]]
    else:
        cross = None
        if "classic" in names and "fractional" in names:
            cross = cross_model_relations(results["classic"], results["fractional"]).to_dict()
        combined = {"models": records, "files": files, "selected": selected, "selected_by": SELECTED_BY[bool(trusted)],
                    "all_converged": len(converged) == len(names), "cross_model": cross}
    return ModelFits(results=results, records=records, files=files, combined=combined,
                     curves=fit_curves(results, model_objs, t, theta), facts=facts)


def with_axle_uncertainty(result: FitResult, zero_sigma: Any) -> FitResult:
    """``result`` with the axle's uncertainty in its standard errors (in quadrature).

    theta from a track is measured about the fitted axle, whose uncertainty moves every sample
    alike, so the fit's residuals cannot reveal it: their standard errors count the scatter of
    theta about the model only.

    * The axle off sideways by ``dx`` turns theta's zero by ``dx / radius``: ``zero_sigma``
      [rad] (angle.parquet's ``zero_sigma_rad``, :func:`pendtrack.track.circle.circle_uncertainty`)
      is added to a fitted ``theta_off``.
    * The axle off along the radius scales theta: each parameter's shift under that scale
      (``stderr_scale``, computed in the fit from ``theta_scale_rel``) is added to its own.

    ``stderr``, ``stderr_low``, ``stderr_high`` and the intervals (at their own number of standard
    errors) include them (``stderr_naive`` and
    ``stderr_bootstrap`` stay the fit's own).
    """
    zs = float(zero_sigma) if isinstance(zero_sigma, (int, float)) and not isinstance(zero_sigma, bool) else 0.0

    def widened(name: str, p: ParamEstimate) -> ParamEstimate:
        extra = float(np.hypot(p.stderr_scale if math.isfinite(p.stderr_scale) else 0.0,
                               zs if name == "theta_off" else 0.0))
        if extra == 0.0:
            return p
        return replace(p, stderr=float(np.hypot(p.stderr, extra)), stderr_low=float(np.hypot(p.stderr_low, extra)),
                       stderr_high=float(np.hypot(p.stderr_high, extra)),
                       interval68=in_range(name, _widened(p.value, p.interval68, extra)),
                       interval95=in_range(name, _widened(p.value, p.interval95, Z95 * extra)))

    return replace(result, params={n: widened(n, p) for n, p in result.params.items()},
                   initial_state={n: widened(n, p) for n, p in result.initial_state.items()})


def _widened(value: float, interval: tuple[float, float], extra: float) -> tuple[float, float]:
    """``interval`` about ``value`` with ``extra`` added to each side's half-width in quadrature."""
    lo, hi = interval
    return (float(value - np.hypot(value - lo, extra)), float(value + np.hypot(hi - value, extra)))


#: A fit's residual this many times the noise the fit sees (:func:`filtered_noise`) is structure the model
#: misses. The true model leaves 1.8 times it on bench_run's 60-s render (its tracking noise is correlated from
#: frame to frame, which the white-noise figure leaves out); lab1's classic fit 5.2, the render's OPA fit 15.
MISFIT_RATIO = 4.0


def filtered_noise(noise: Any, window: Any, order: Any) -> float | None:
    """The rms a white noise of ``noise`` [rad] keeps through the Savitzky-Golay filter the fit compares
    data and model after (``window`` points, ``order``): ``noise sqrt(c0)``, c0 the filter's weight on the
    centre sample [rad]. None when the noise or the window is unknown."""
    if not isinstance(noise, (int, float)) or isinstance(noise, bool) or not math.isfinite(noise) or noise <= 0:
        return None
    try:
        w, k = int(window), int(order)
    except (TypeError, ValueError):
        return None
    if w <= k + 1 or w % 2 == 0:
        return None
    return float(noise) * math.sqrt(float(savgol_coeffs(w, k)[w // 2]))


def _model_facts(r: FitResult, noise_seen: float | None = None) -> dict[str, Any]:
    """One model's line of the stage's facts; ``rms_over_noise``: its residual over :func:`filtered_noise`,
    ``misses_structure``: that ratio at :data:`MISFIT_RATIO` or more."""
    def param(name: str, what: str) -> float | None:
        return _num(getattr(r.params[name], what)) if name in r.params else None

    ratio = _num(r.rms / noise_seen) if noise_seen else None
    return {"converged": r.converged, "trustworthy": r.trustworthy, "flags": dict(r.flags),
            "findings": dict(r.findings), "n_starts": r.n_starts,
            "xi2_min": _num(r.xi2_min), "rms": _num(r.rms), "bic": _num(r.bic),
            "Omega0": param("Omega0", "value"), "Omega0_stderr": param("Omega0", "stderr"),
            "fitted_model": r.model,
            "theta_off": param("theta_off", "value"), "theta_off_stderr": param("theta_off", "stderr"),
            "runtime_s": _num(r.runtime_s), "message": r.message, "stderr_reliable": bool(r.stderr_reliable),
            "rms_over_noise": ratio, "misses_structure": ratio is not None and ratio >= MISFIT_RATIO}


def fit_curves(results: Mapping[str, FitResult], model_objs: Mapping[str, Any], t: np.ndarray,
               theta: np.ndarray) -> dict[str, np.ndarray]:
    """fit.parquet's columns: every model's simulated curves (from its fitted initial state), stacked.

    A model whose fitted curve cannot be integrated over the record (a fit that did not converge,
    e.g. an undamped model driven into a runaway) gets NaN curves: its fit is already flagged, and
    the other models' curves and files are still written.
    """
    cols: dict[str, list[np.ndarray]] = {k: [] for k in ("t", "theta", "theta_model", "omega_model", "residual", "model")}
    for name, res in results.items():
        try:
            th_m, om_m = predict(res, model_objs[name], t)
        except FloatingPointError:
            if res.converged:
                raise
            th_m = om_m = np.full(t.size, np.nan)
        for key, value in (("t", t), ("theta", theta), ("theta_model", th_m), ("omega_model", om_m),
                           ("residual", theta - th_m), ("model", np.full(t.size, name, dtype=object))):
            cols[key].append(np.asarray(value))
    return {k: np.concatenate(v) if v else np.zeros(0) for k, v in cols.items()}
