"""`fit` stage: kinematics.parquet -> fit_<model>.json (one per model), fit.json, fit.parquet.

Files
-----
``fit_<model>.json``
    One model's fit, exactly the issue's keys (:data:`pendtrack.artifacts.FIT_JSON_KEYS`) plus
    extras (:mod:`pendtrack.fitting.result`).
``fit.json``
    With one model: the same record as ``fit_<model>.json``, so ``fit.json`` of a single-model
    fit has exactly the issue's keys. With several models: a container
    ``{"models": {name: record}, "files": {name: "fit_<name>.json"}, "selected": name,
    "selected_by", "all_converged", "cross_model"}`` -- ``selected`` is the trustworthy fit
    (converged, no parameter flagged) with the lowest BIC, or if none is, the converged one (same
    data and cost for every model; ``selected_by`` says which), ``cross_model`` the paper's
    relations when classic and fractional were both fitted (:mod:`pendtrack.fitting.cross_model`).
``fit.parquet``
    ``t, theta, theta_model, omega_model, residual, model``: every model's simulated curves
    (from the fitted initial state) against the data, stacked.

theta's zero: when it was not measured -- the kinematics' ``zero_reference`` (passed on from
angle.parquet) is ``"vertical"``, or the input is a plain table -- every model is fitted with
the measurement term ``offset`` (``[fit] offset = "auto"``; ``"always"``, ``"never"``:
:func:`fits_offset`). The records keep the requested name in ``"model"`` (and the file name
``fit_<model>.json``) and give the fitted model's full name in ``"fitted_model"`` (e.g.
``"classic+offset"``); ``theta_off`` is in ``"params"`` like any parameter.

A fit that did not converge is still written (``"converged": false``, with ``"message"``) so it
can be inspected, and listed in the stage's ``facts["not_converged"]``; a fit with a flagged
parameter (``"flags"``, :func:`pendtrack.fitting.result.plausibility_flags`) is listed in
``facts["flagged"]``. :func:`fit_problems` sums both up; `fit` and `run` then exit 1.
Fit files of models that an earlier run of this stage wrote and this one does not are removed.

The data's Savitzky-Golay filter (window and order, from the kinematics artifact's
provenance) is applied to the model as well (:class:`pendtrack.fitting.Observation`).
"""

from __future__ import annotations

import json
import logging
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pendtrack.artifacts import FIT_JSON_KEYS, SCHEMAS, Provenance, inputs_for, write_artifact, write_json_artifact
from pendtrack.config import Config
from pendtrack.errors import FitError
from pendtrack.progress import progress_bar
from pendtrack.stages import StageOutput, up_to_date
from pendtrack.stages.kinematics import kinematics_input
from pendtrack.tables import TableSpec

log = logging.getLogger(__name__)

PARQUET = SCHEMAS["fit"].filename
COMBINED = "fit.json"
CONTAINER_KEYS = ("models", "files", "selected", "all_converged")


def model_json_name(model: str) -> str:
    """File name of one model's fit record: ``fit_<model>.json`` (``+`` of composed names kept)."""
    safe = "".join(c if c.isalnum() or c in "+-_." else "_" for c in model)
    return f"fit_{safe}.json"


def _observation(art: Any) -> Any:
    """The data's Savitzky-Golay filter, from the kinematics provenance (None-filter if unknown)."""
    from pendtrack.fitting import Observation

    extra = dict(art.provenance.extra or {})
    w, order = extra.get("window_points"), extra.get("order")
    if w is None or order is None:
        kin = dict(art.provenance.config or {}).get("kinematics") or {}
        h = extra.get("h")
        if not kin or h is None:
            t = art.data["t"].to_numpy(float)
            h = float(np.median(np.diff(t))) if t.size > 1 else None
        if kin.get("savgol_window_s") is not None and h:
            from pendtrack.kinematics import window_points

            order = int(kin.get("savgol_order", 3))
            w = window_points(float(kin["savgol_window_s"]), float(h), order)
    if w is None or order is None:
        log.warning("%s: no Savitzky-Golay window in the provenance; the model is compared unfiltered", art.path)
        return Observation()
    return Observation(savgol_window=int(w), savgol_order=int(order), smooth_theta=True)


def fits_offset(mode: str, zero: str) -> bool:
    """Whether `fit` and `run` add the measurement term ``offset`` (theta_off) to every model.

    ``mode`` is ``[fit] offset``: ``"always"``, ``"never"``, or ``"auto"`` -- when the record's
    zero of theta was not measured (``zero``, :func:`pendtrack.stages.kinematics.zero_reference`,
    is ``"vertical"``: the image vertical, or ``"table"``: a plain table's own convention). A
    measured rest (``"rest"``), the renderer's truth and an unrecorded zero (``"unknown"``) fit
    as before.
    """
    from pendtrack.stages.kinematics import ZERO_NOT_MEASURED

    if mode == "always":
        return True
    if mode == "never":
        return False
    return zero in ZERO_NOT_MEASURED


def fit_problems(facts: dict[str, Any]) -> dict[str, str]:
    """Model -> why its fit is not trustworthy (not converged, or a parameter flagged), from the stage's facts.

    Works on the facts of a skipped stage too (read back from fit.json's provenance; older ones
    have no ``flagged``).
    """
    models = facts.get("models") or {}
    out: dict[str, str] = {}
    for name in facts.get("not_converged") or []:
        out[name] = f"did not converge: {(models.get(name) or {}).get('message', '')}".rstrip(": ")
    for name, flags in (facts.get("flagged") or {}).items():
        if name not in out and flags:
            out[name] = "flagged: " + "; ".join(f"{k} {v}" for k, v in flags.items())
    return out


def _remove_stale(out_dir: Path, keep: set[str]) -> None:
    """Delete fit_<model>.json files this stage wrote earlier for models not fitted now."""
    for path in out_dir.glob("fit_*.json"):
        if path.name in keep:
            continue
        try:
            record = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            continue
        if isinstance(record, dict) and (record.get("provenance") or {}).get("stage") == "fit":
            path.unlink(missing_ok=True)


def fit_stage(kinematics: str | Path, *, out_dir: str | Path, config: Config, models: tuple[str, ...] | None = None,
              table: TableSpec | None = None, force: bool = False, progress: bool = True) -> StageOutput:
    """Fit each model to a record; writes fit_<model>.json, fit.json and fit.parquet in ``out_dir``.

    Parameters
    ----------
    kinematics : path
        kinematics.parquet (t [s], theta [rad], omega [rad/s], alpha [rad/s^2], ok), or any
        angle record the kinematics stage reads (differentiated in memory with ``[kinematics]``;
        :func:`pendtrack.stages.kinematics.kinematics_input`).
    out_dir : path
        Output folder (created).
    config : Config
        Uses ``[fit]`` (every option of the fit: :func:`pendtrack.fitting.fit_model`'s ``options``)
        and ``[models]`` (memory).
    models : tuple of str, optional
        Model names (registry names); default ``config.fit.models``.
    table : TableSpec, optional
        Column names and pivot of a table input (``--columns``, ``--pivot``).
    force : bool
        Refit even if the outputs are up to date.
    progress : bool
        Progress bar over the starts of each model (stderr).

    Returns
    -------
    StageOutput
        ``paths``: fit.json, fit.parquet, then the per-model files. ``facts``: ``models``
        (per model: converged, trustworthy, flags, findings, n_starts, xi2_min,
        rms, bic, Omega0, Omega0_stderr, fitted_model, theta_off, theta_off_stderr (None
        without the offset term), runtime_s, message), ``not_converged``, ``flagged`` (model ->
        flags), ``selected``, ``files``, ``zero_reference``.

    Raises
    ------
    ArtifactError
        Missing or malformed kinematics file.
    ModelError
        Unknown model name.
    FitError
        Too few samples, none usable, no oscillation.
    """
    from pendtrack.fitting import check_record, cross_model_relations, fit_model, predict
    from pendtrack.fitting.leastsq.ladder import search_pool
    from pendtrack.fitting.result import _num
    from pendtrack.models import compose, get_model

    kinematics = Path(kinematics)
    out_dir = Path(out_dir)
    names = tuple(models or config.fit.models)
    if not names:
        raise FitError("no model to fit", path=kinematics)
    if len(set(names)) != len(names):
        raise FitError(f"a model is listed twice: {', '.join(names)}", path=kinematics)
    model_objs = {n: get_model(n) for n in names}  # unknown names fail before any work
    art, input_sections = kinematics_input(kinematics, config=config, table=table)
    zero = str((art.provenance.extra or {}).get("zero_reference") or "unknown")
    if fits_offset(config.fit.offset, zero):  # theta's zero not measured: fitted as theta_off
        model_objs = {n: m if "offset" in m.terms else compose(m, ["offset"]) for n, m in model_objs.items()}
    inputs = inputs_for(kinematics)
    sections: dict[str, Any] = {**config.sections("fit", "models"), **input_sections, "fitted_models": list(names)}
    # the number of worker processes does not change a fit: not part of what the outputs depend on
    sections["fit"] = {k: v for k, v in sections["fit"].items() if k != "workers"}
    files = {n: model_json_name(n) for n in names}
    paths = (out_dir / COMBINED, out_dir / PARQUET, *(out_dir / f for f in files.values()))
    if up_to_date(paths, "fit", inputs=inputs, config=sections, force=force):
        record = json.loads((out_dir / COMBINED).read_text(encoding="utf-8"))
        facts = (record.get("provenance") or {}).get("extra") or {}
        return StageOutput(paths, skipped=True, facts=facts)

    df = art.data
    t = df["t"].to_numpy(float)
    theta = df["theta"].to_numpy(float)
    omega = df["omega"].to_numpy(float)
    alpha = df["alpha"].to_numpy(float)
    ok = df["ok"].to_numpy(bool)
    if t.size == 0:
        raise FitError("the kinematics file has no samples", path=kinematics)
    obs = _observation(art)
    check_record(t, theta, omega, alpha=alpha, ok=ok, source=str(kinematics))  # fail before any progress bar
    results = {}
    # the models' searches (and their profile sigmas) share one set of worker processes, started now (their
    # imports and kernels load while the first model's estimates run) rather than one set per model
    workers = search_pool(config.fit.workers)
    try:
        for name in names:
            model = model_objs[name]
            with progress_bar(config.fit.n_starts, f"fit {name}", enabled=progress) as advance:
                results[name] = fit_model(model, t, theta, omega, options=config.fit, model_options=config.models,
                                          alpha=alpha, ok=ok, observation=obs, on_progress=advance,
                                          source=str(kinematics), pool=workers)
    finally:
        if workers is not None:
            workers.shutdown(wait=True, cancel_futures=True)

    # "model" is the model asked for (file names, batch columns and the report key on it), "fitted_model"
    # the one fitted (e.g. "classic+offset")
    records = {n: {**r.to_dict(), "model": n, "fitted_model": r.model} for n, r in results.items()}
    converged = [n for n in names if results[n].converged]
    trusted = [n for n in converged if results[n].trustworthy]
    pool = trusted or converged
    selected = min(pool, key=lambda n: results[n].bic) if pool else None
    selected_by = ("lowest bic among trustworthy fits (converged, no parameter flagged; same data and cost)" if trusted
                   else "lowest bic among converged fits (same data and cost)")
    cross = None
    classic = next((n for n in names if n == "classic"), None)
    fractional = next((n for n in names if n == "fractional"), None)
    if classic and fractional:
        cross = cross_model_relations(results[classic], results[fractional]).to_dict()
    facts: dict[str, Any] = {
        "models": {n: {"converged": r.converged, "trustworthy": r.trustworthy, "flags": dict(r.flags),
                       "findings": dict(r.findings), "n_starts": r.n_starts,
                       "xi2_min": _num(r.xi2_min), "rms": _num(r.rms), "bic": _num(r.bic),
                       "Omega0": _num(r.params["Omega0"].value) if "Omega0" in r.params else None,
                       "Omega0_stderr": _num(r.params["Omega0"].stderr) if "Omega0" in r.params else None,
                       "fitted_model": r.model,
                       "theta_off": _num(r.params["theta_off"].value) if "theta_off" in r.params else None,
                       "theta_off_stderr": _num(r.params["theta_off"].stderr) if "theta_off" in r.params else None,
                       "runtime_s": _num(r.runtime_s), "message": r.message} for n, r in results.items()},
        "not_converged": [n for n in names if not results[n].converged],
        "flagged": {n: dict(results[n].flags) for n in names if results[n].flags},
        "selected": selected,
        "files": dict(files),
        "observation": {"savgol_window": obs.savgol_window, "savgol_order": obs.savgol_order},
        "zero_reference": zero,
    }
    prov = Provenance(stage="fit", config=sections, inputs=inputs, extra=facts)

    frames = []
    for name, res in results.items():
        th_m, om_m = predict(res, model_objs[name], t)
        frames.append(pd.DataFrame({"t": t, "theta": theta, "theta_model": th_m, "omega_model": om_m,
                                    "residual": theta - th_m, "model": np.full(t.size, name, dtype=object)}))
    write_artifact(pd.concat(frames, ignore_index=True), out_dir / PARQUET, "fit", provenance=prov)
    for name, rec in records.items():
        write_json_artifact(rec, out_dir / files[name], required=FIT_JSON_KEYS, provenance=prov)
    if len(names) == 1:
        write_json_artifact(records[names[0]], out_dir / COMBINED, required=FIT_JSON_KEYS, provenance=prov)
    else:
        container = {"models": records, "files": files, "selected": selected,
                     "selected_by": selected_by,
                     "all_converged": len(converged) == len(names), "cross_model": cross}
        write_json_artifact(container, out_dir / COMBINED, required=CONTAINER_KEYS, provenance=prov)
    _remove_stale(out_dir, set(files.values()))
    for n, why in fit_problems(facts).items():
        log.warning("%s: the %s fit %s", kinematics, n, why)
    return StageOutput(paths, facts=facts)
