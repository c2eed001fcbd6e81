"""`kinematics` stage: an angle record -> kinematics.parquet (Savitzky-Golay + initial analysis).

The input is anything :func:`pendtrack.tables.read_record` reads (angle.parquet, a Parquet file
or a CSV/whitespace table of t, theta or t, x, y), read here by :func:`read_input`, the reader
`fit` and `discover` share: x, y columns without ``--pivot`` get the pivot from a robust circle
fit of their path (:func:`pendtrack.track.axle.fitted_pivot`). :func:`kinematics_input` is what `fit` reads: a
kinematics artifact as it is, or this stage's derivatives of any other record, in memory.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pandas as pd

from pendtrack.artifacts import SCHEMAS, Artifact, Provenance, inputs_for, read_metadata, write_artifact
from pendtrack.config import Config
from pendtrack.errors import ArtifactError
from pendtrack.kinematics.record import differentiate_record, kinematic_columns, kinematics_table, sample_noise
from pendtrack.stages import StageOutput, up_to_date
from pendtrack.tables import Record, TableSpec, read_record
from pendtrack.track.axle import fitted_pivot

FILENAME = SCHEMAS["kinematics"].filename


def read_input(path: str | Path, *, table: TableSpec | None = None, min_samples: int = 0,
               purpose: str = "this stage") -> Record:
    """The record `kinematics`, `fit` and `discover` read: :func:`pendtrack.tables.read_record`
    with the pivot of x, y columns fitted when ``table.pivot`` is not given."""
    try:
        return read_record(path, spec=table, pivot_fit=fitted_pivot, min_samples=min_samples, purpose=purpose)
    except ArtifactError as exc:
        if exc.path is None:
            raise ArtifactError(str(exc), path=path) from None
        raise


def table_sections(table: TableSpec | None) -> dict[str, Any]:
    """What a stage adds to its provenance config for ``--columns``/``--pivot`` (nothing by default)."""
    return {} if table is None or table.default else {"table": table.to_dict()}


def kinematics_input(path: str | Path, *, config: Config, table: TableSpec | None = None
                     ) -> tuple[Artifact, dict[str, Any]]:
    """What `fit` reads: a kinematics artifact, or the derivatives of any record :func:`read_input` reads.

    Parameters
    ----------
    path : path
        kinematics.parquet, or an angle record (differentiated with ``config.kinematics``,
        as this stage would).
    config : Config
    table : TableSpec, optional
        ``--columns``, ``--pivot``.

    Returns
    -------
    artifact : Artifact
        Columns t, theta, omega, alpha, ok (segment); provenance with the Savitzky-Golay facts
        (``window_points``, ``order``, ``h``), ``zero_reference`` (:attr:`pendtrack.tables.Record.zero_reference`)
        and the axle's shares ``zero_sigma_rad``, ``theta_scale_rel`` (:meth:`pendtrack.tables.Record.axle_share`).
    sections : dict
        To add to the consumer's provenance config: ``kinematics`` (when computed here),
        ``input`` (how it was read, when it was not a kinematics artifact used as it is) and
        ``table``.
    """
    rec = read_input(path, table=table)
    sections = table_sections(table)
    if rec.kind == "kinematics":
        frame = pd.DataFrame({"t": rec.t, "theta": rec.theta, **rec.columns, "ok": rec.ok})
        if rec.info["resampled"] is not None:
            sections["input"] = rec.info
        return Artifact(frame, rec.provenance or Provenance(stage="kinematics"), rec.source), sections
    kin = differentiate_record(rec.t, rec.theta, rec.ok, options=config.kinematics, source=rec.source)
    frame = kinematic_columns(kin)
    sections |= {**config.sections("kinematics"), "input": rec.info}
    noise = sample_noise(rec.theta, kin)
    prov = Provenance(stage="kinematics", config=config.sections("kinematics"),
                      extra={**kin.info, "zero_reference": rec.zero_reference,
                             "zero_sigma_rad": rec.zero_sigma_rad, "theta_scale_rel": rec.theta_scale_rel,
                             "marker_radius_px": rec.marker_radius_px,
                             # the fit's residual is judged against it ("x the noise"), as on a kinematics artifact
                             "noise_rad": noise if math.isfinite(noise) else None})
    return Artifact(frame, prov, rec.source), sections


def kinematics_stage(angle: str | Path, *, out_dir: str | Path, config: Config, table: TableSpec | None = None,
                     force: bool = False, progress: bool = True) -> StageOutput:
    """Smoothed theta, omega, alpha and the paper's initial analysis; writes ``out_dir/kinematics.parquet``.

    Parameters
    ----------
    angle : path
        angle.parquet (columns t [s], theta [rad], ok), or a Parquet file or CSV/whitespace
        table of t, theta or t, x, y (:mod:`pendtrack.tables`); slightly uneven time stamps
        are resampled onto a uniform grid first (recorded in ``facts["input"]``).
    out_dir : path
        Output folder (created).
    config : Config
        Uses ``[kinematics]``: Savitzky-Golay window [s] and order, gap bridging and
        minimum segment length (see :func:`pendtrack.kinematics.savgol_kinematics`).
    table : TableSpec, optional
        Column names and pivot of a table (``--columns``, ``--pivot``).
    force, progress : bool
        As every stage (nothing here is long enough for a progress bar).

    Returns
    -------
    StageOutput
        ``facts`` (also in the artifact's provenance ``extra``): ``Omega0`` and
        ``Omega0_stderr`` [rad/s] (model-free, eq. straightline, Savitzky-Golay bias
        corrected; None if the record does not allow it, ``Omega0_reason`` says why),
        ``Omega0_raw`` (uncorrected), ``n_turning_points``, ``negative_damping_fraction``,
        and the differentiation facts ``h``, ``window_points``, ``window_s``,
        ``window_clipped``, ``n_segments``, ``n_dropped_segments``, ``n_bridged``,
        ``resampled``, ``ok_fraction``; ``input``: how the file was read (columns, pivot,
        ``resampled`` grid, ``warnings``); ``zero_reference``: where theta's zero comes from
        (:attr:`pendtrack.tables.Record.zero_reference`; `fit` and `run` fit it as ``theta_off`` when it was not
        measured); ``zero_sigma_rad``: its uncertainty from the axle's (:attr:`pendtrack.tables.Record.zero_sigma_rad`;
        part of theta_off's stderr); ``theta_scale_rel``: theta's relative scale uncertainty from the axle's (part of every
        parameter's stderr); ``marker_radius_px``: the marker's distance from the fitted axle [px] (None
        without a fitted circle), from which the fit finds the frames too slow for a compressed video
        (:func:`pendtrack.fitting.leastsq.samples.slow_frames`).

    Raises
    ------
    ArtifactError
        Missing or malformed angle file, or a kinematics artifact (already differentiated).
    KinematicsError
        The series cannot be differentiated (bad time axis, nothing long enough).
    """
    angle = Path(angle)
    out = Path(out_dir) / FILENAME
    sections = config.sections("kinematics") | table_sections(table)
    rec = read_input(angle, table=table)
    if rec.kind == "kinematics":
        raise ArtifactError("is a kinematics artifact, already differentiated: give it to `pendtrack fit` or "
                            "`pendtrack discover`", path=angle)
    inputs = inputs_for(angle)
    if up_to_date((out,), "kinematics", inputs=inputs, config=sections, force=force):
        record = read_metadata(out) or {}
        return StageOutput((out,), skipped=True, facts=dict(record.get("extra", {})))
    result = kinematics_table(rec.t, rec.theta, rec.ok, options=config.kinematics, source=angle)
    facts = {**result.facts, "input": rec.info, "zero_reference": rec.zero_reference,
             "zero_sigma_rad": rec.zero_sigma_rad, "theta_scale_rel": rec.theta_scale_rel,
             "marker_radius_px": rec.marker_radius_px}
    write_artifact(result.frame, out, "kinematics",
                   provenance=Provenance(stage="kinematics", config=sections, inputs=inputs, extra=facts))
    return StageOutput((out,), facts=facts)
