"""`fit` over several records: models fitted jointly to a series of runs -> fit_<model>.json, fit.json.

The stage reads every record as the fit stage does (:func:`pendtrack.stages.kinematics.kinematics_input`:
kinematics.parquet or any angle record, differentiated with ``[kinematics]``), names each run by
its run code (:func:`pendtrack.batch.runcode.run_names`: the file's stem, else its folder's name, as
``pendtrack batch`` writes ``DIR/06na5/kinematics.parquet``), calls
:func:`pendtrack.fitting.joint.fit_joint_models` (every decision is made there: the offset term,
the fits, the selection; ``pt.fit([...])`` and ``batch --joint`` come here too) and writes what it returns.

Files: ``fit_<model>.json`` per model (:mod:`pendtrack.fitting.joint.outcome`: the issue's keys over
the runs pooled, the shared values, the groups, each run's values and residual), ``fit.json``
(the one model's record, or ``{"models", "files", "selected", "all_converged"}`` with the lowest
BIC among the converged fits) and ``fit_runs.parquet`` (schema ``joint_fit``: each model's curves
on each run's times, :func:`pendtrack.fitting.joint.joint_curves`). All are written atomically,
after every fit succeeded.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Mapping, Sequence
from pathlib import Path

from pendtrack.artifacts import SCHEMAS, Provenance, file_sha256
from pendtrack.batch.runcode import run_names
from pendtrack.config import Config
from pendtrack.errors import FitError
from pendtrack.fitting.joint import fit_joint_models, resolve_scopes
from pendtrack.fitting.leastsq.samples import Record, axle_shares, slow_frames
from pendtrack.fitting.models_fit import check_models, model_json_name, observation_from
from pendtrack.stages import StageOutput, several_records, up_to_date
from pendtrack.stages.fit import COMBINED, fit_sections, write_fits
from pendtrack.stages.kinematics import kinematics_input
from pendtrack.tables import TableSpec

log = logging.getLogger(__name__)

CURVES = SCHEMAS["joint_fit"].filename  # fit_runs.parquet


def series_fit_stage(kinematics: Sequence[str | Path], *, out_dir: str | Path, config: Config,
                     models: tuple[str, ...] | None = None, sharing: Mapping[str, str] | None = None,
                     table: TableSpec | None = None, force: bool = False) -> StageOutput:
    """Fit each model jointly to every record; writes fit_<model>.json, fit.json and fit_runs.parquet in ``out_dir``.

    Parameters
    ----------
    kinematics : sequence of path
        Two or more records (kinematics.parquet or any angle record).
    out_dir : path
        Output folder (created).
    config : Config
        ``[fit]`` (each run's own fit, ``joint_starts``, ...), ``[models]``, ``[kinematics]``.
    models : tuple of str, optional
        Model names; default ``config.fit.models``.
    sharing : mapping, optional
        Parameter name -> scope (``shared``, ``run``, ``tile``, ``tile+alley``, ...;
        :mod:`pendtrack.fitting.joint.scopes`), overriding the defaults.
    table : TableSpec, optional
        Column names and pivot of table inputs.
    force : bool
        Refit even if the outputs are up to date.

    Returns
    -------
    StageOutput
        ``paths``: fit.json, the per-model files, then fit_runs.parquet. ``facts``: ``models`` (per model: converged,
        trustworthy, flags, xi2_min, rms, bic, shared values, runtime_s, message), ``runs``,
        ``not_converged``, ``flagged``, ``selected``, ``files``.

    Raises
    ------
    FitError
        Fewer than two records, one given twice, a bad sharing, a record a fit refuses.
    ArtifactError, ModelError
        A missing or malformed record, an unknown model.
    """
    paths = several_records(kinematics, what="a joint fit")
    out_dir = Path(out_dir)
    names = tuple(models or config.fit.models)
    model_objs = check_models(names, source=paths[0])
    runs, labels = run_names(paths)
    for model in model_objs.values():  # a bad sharing fails before any record is read
        resolve_scopes(model, sharing, labels=dict(zip(runs, labels)))
    read = [kinematics_input(p, config=config, table=table) for p in paths]
    sections = {**fit_sections(config, {}, names), "runs": {r: s for r, (_, s) in zip(runs, read)},
                "sharing": dict(sharing or {})}
    # keyed by run: every run's file is typically kinematics.parquet, and keyed by file name the
    # last run's hash would hide the others' (a changed earlier run would leave the fit "up to date")
    inputs = {run: file_sha256(p) for run, p in zip(runs, paths)}
    out_paths = (out_dir / COMBINED, *(out_dir / model_json_name(n) for n in names), out_dir / CURVES)
    if (up_to_date(out_paths[:-1], "fit", inputs=inputs, config=sections, force=force)
            and up_to_date(out_paths[-1:], "joint_fit", inputs=inputs, config=sections, force=force)):
        record = json.loads((out_dir / COMBINED).read_text(encoding="utf-8"))
        return StageOutput(out_paths, skipped=True, facts=(record.get("provenance") or {}).get("extra") or {})

    records, zeros = {}, {}
    for run, (art, _) in zip(runs, read):
        df, prov = art.data, art.provenance
        t = df["t"].to_numpy(float)
        obs = observation_from(dict(prov.extra or {}), dict(prov.config or {}), t, source=str(art.path))
        records[run] = Record(t, df["theta"].to_numpy(float), df["omega"].to_numpy(float),
                              alpha=df["alpha"].to_numpy(float), ok=df["ok"].to_numpy(bool), observation=obs,
                              source=str(art.path), **axle_shares(prov.extra or {}),
                              cost_out=slow_frames(dict(prov.extra or {}), df["omega"].to_numpy(float),
                                                   min_px=config.fit.slow_motion_px, reach=obs.trim))
        zeros[run] = (prov.extra or {}).get("zero_reference")
    fits = fit_joint_models(names, records, zeros=zeros, sharing=sharing, labels=dict(zip(runs, labels)),
                            options=config.fit, model_options=config.models, source=paths[0])
    write_fits(fits, out_dir, Provenance(stage="fit", config=sections, inputs=inputs, extra=fits.facts),
               schema="joint_fit", remove_stale=False)
    return StageOutput(out_paths, facts=fits.facts)


JOINT_DIR = "joint"  # `batch --joint`: the joint fit's folder inside the batch's


def batch_joint_fit(out_dir: Path, run_ids: Sequence[str], *, config: Config, models: tuple[str, ...] | None,
                    sharing: Mapping[str, str] | None = None, force: bool = False) -> StageOutput:
    """`batch --joint`: the joint fit of a batch's runs (``DIR/<run id>/kinematics.parquet``) into ``DIR/joint/``.

    Raises
    ------
    FitError
        Fewer than two runs to fit.
    """
    files = [Path(out_dir) / run / "kinematics.parquet" for run in run_ids]
    if len(files) < 2:
        raise FitError(f"batch --joint needs at least two runs that succeeded, got {len(files)}", path=out_dir)
    return series_fit_stage(files, out_dir=Path(out_dir) / JOINT_DIR, config=config, models=models, sharing=sharing,
                            force=force)
