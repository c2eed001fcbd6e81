"""`fit` stage: kinematics.parquet -> fit_<model>.json (one per model), fit.json, fit.parquet.

The stage reads the kinematics, calls :func:`pendtrack.fitting.models_fit.fit_models` (every
decision below is made there; ``pt.fit`` calls the same function) and writes what it returns.

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
:func:`pendtrack.fitting.models_fit.fits_offset`). The records keep the requested name in ``"model"`` (and the file name
``fit_<model>.json``) and give the fitted model's full name in ``"fitted_model"`` (e.g.
``"classic+offset"``); ``theta_off`` is in ``"params"`` like any parameter.

A fit that did not converge is still written (``"converged": false``, with ``"message"``) so it
can be inspected, and listed in the stage's ``facts["not_converged"]``; a fit with a flagged
parameter (``"flags"``, :func:`pendtrack.fitting.result.plausibility_flags`) is listed in
``facts["flagged"]``. :func:`~pendtrack.fitting.models_fit.fit_problems` sums both up; `fit` and `run` then exit 1.
Fit files of models that an earlier run of this stage wrote and this one does not are removed.

The data's Savitzky-Golay filter (window and order, from the kinematics artifact's
provenance) is applied to the model as well (:class:`pendtrack.fitting.Observation`).
"""

from __future__ import annotations

import json
import logging
from pathlib import Path
from typing import Any

import pandas as pd

from pendtrack.artifacts import FIT_JSON_KEYS, SCHEMAS, Artifact, Provenance, inputs_for, write_artifact, write_json_artifact
from pendtrack.config import Config
from pendtrack.fitting.models_fit import FitFiles, ModelFits, check_models, fit_models, fit_problems, model_json_name
from pendtrack.progress import progress_bar
from pendtrack.stages import StageOutput, up_to_date
from pendtrack.stages.kinematics import kinematics_input
from pendtrack.tables import TableSpec

log = logging.getLogger(__name__)

PARQUET = SCHEMAS["fit"].filename
COMBINED = "fit.json"
CONTAINER_KEYS = ("models", "files", "selected", "all_converged")


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
        without the offset term), runtime_s, message, stderr_reliable), ``not_converged``, ``flagged`` (model ->
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
    kinematics = Path(kinematics)
    out_dir = Path(out_dir)
    names = tuple(models or config.fit.models)
    check_models(names, source=kinematics)  # unknown names fail before any work
    art, input_sections = kinematics_input(kinematics, config=config, table=table)
    inputs = inputs_for(kinematics)
    sections = fit_sections(config, input_sections, names)
    paths = (out_dir / COMBINED, out_dir / PARQUET, *(out_dir / model_json_name(n) for n in names))
    if up_to_date(paths, "fit", inputs=inputs, config=sections, force=force):
        record = json.loads((out_dir / COMBINED).read_text(encoding="utf-8"))
        facts = (record.get("provenance") or {}).get("extra") or {}
        return StageOutput(paths, skipped=True, facts=facts)

    fits = fit_artifact(art, names, config=config, source=str(kinematics), progress=progress)
    write_fits(fits, out_dir, Provenance(stage="fit", config=sections, inputs=inputs, extra=fits.facts))
    for n, why in fit_problems(fits.facts).items():
        log.warning("%s: the %s fit %s", kinematics, n, why)
    return StageOutput(paths, facts=fits.facts)


def fit_artifact(art: Artifact, names: tuple[str, ...], *, config: Config, source: str,
                 progress: bool) -> ModelFits:
    """:func:`~pendtrack.fitting.models_fit.fit_models` on a kinematics artifact: its columns and provenance."""
    df = art.data
    return fit_models(names, df["t"].to_numpy(float), df["theta"].to_numpy(float), df["omega"].to_numpy(float),
                      alpha=df["alpha"].to_numpy(float), ok=df["ok"].to_numpy(bool),
                      provenance_extra=dict(art.provenance.extra or {}),
                      provenance_config=dict(art.provenance.config or {}), options=config.fit,
                      model_options=config.models, source=source,
                      progress=lambda name: progress_bar(config.fit.n_starts, f"fit {name}", enabled=progress))


def fit_sections(config: Config, input_sections: dict[str, Any], names: tuple[str, ...]) -> dict[str, Any]:
    """The config sections a fit's outputs depend on (its provenance's ``config``)."""
    sections: dict[str, Any] = {**config.sections("fit", "models"), **input_sections, "fitted_models": list(names)}
    # the number of worker processes does not change a fit: not part of what the outputs depend on
    sections["fit"] = {k: v for k, v in sections["fit"].items() if k != "workers"}
    return sections


def write_fits(fits: FitFiles, out_dir: Path, prov: Provenance, *, schema: str = "fit",
               remove_stale: bool = True) -> None:
    """Write what a fit's core returned: its curves, fit_<model>.json, fit.json.

    The curves go to ``schema``'s file (fit.parquet; a joint fit's fit_runs.parquet,
    :func:`~pendtrack.fitting.joint.fit_joint_models`). With ``remove_stale``, fit files of models
    that an earlier run of this stage wrote and this one does not are removed.
    """
    write_artifact(pd.DataFrame(fits.curves), out_dir / SCHEMAS[schema].filename, schema, provenance=prov)
    for name, rec in fits.records.items():
        write_json_artifact(rec, out_dir / fits.files[name], required=FIT_JSON_KEYS, provenance=prov)
    required = FIT_JSON_KEYS if len(fits.records) == 1 else CONTAINER_KEYS
    write_json_artifact(fits.combined, out_dir / COMBINED, required=required, provenance=prov)
    if remove_stale:
        _remove_stale(out_dir, set(fits.files.values()))
