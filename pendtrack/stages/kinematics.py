"""`kinematics` stage: an angle record -> kinematics.parquet (Savitzky-Golay + initial analysis).

The input is anything :func:`pendtrack.tables.read_record` reads (angle.parquet, a Parquet file
or a CSV/whitespace table of t, theta or t, x, y), read here by :func:`read_input`, the reader
`fit` and `discover` share: x, y columns without ``--pivot`` get the pivot from a robust circle
fit of their path (:func:`fitted_pivot`). :func:`kinematics_input` is what `fit` reads: a
kinematics artifact as it is, or this stage's derivatives of any other record, in memory.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pendtrack.artifacts import SCHEMAS, Artifact, Provenance, inputs_for, read_metadata, write_artifact
from pendtrack.config import Config
from pendtrack.errors import ArtifactError
from pendtrack.kinematics import KinematicsError, KinematicsResult, analyse, omega0_from_kinematics, savgol_kinematics
from pendtrack.stages import StageOutput, up_to_date
from pendtrack.tables import Record, TableSpec, read_record

log = logging.getLogger(__name__)

FILENAME = SCHEMAS["kinematics"].filename
MIN_ARC_RAD = 0.1  # a path spanning less arc (~6 deg) does not locate its pivot: --pivot is needed


def fitted_pivot(x: np.ndarray, y: np.ndarray) -> tuple[tuple[float, float], dict[str, Any]]:
    """The pivot of an x, y path: the centre of a robust circle fit (:func:`pendtrack.track.fit_circle`).

    Parameters
    ----------
    x, y : ndarray
        Positions (any length unit).

    Returns
    -------
    (px, py), facts
        The centre, and ``radius``, ``rms`` (radial residual) and ``arc_deg`` for the provenance.

    Raises
    ------
    ArtifactError
        The path covers too little arc (below :data:`MIN_ARC_RAD`) to locate the centre.
    """
    from pendtrack.track.circle import fit_circle

    scale = float(np.hypot(np.ptp(x), np.ptp(y))) if x.size else 0.0
    fit = fit_circle(x, y, f_scale=max(0.01 * scale, 1e-12)) if x.size >= 3 and scale > 0 else None
    if fit is None or fit.arc_span < MIN_ARC_RAD:
        span = 0.0 if fit is None else math.degrees(fit.arc_span)
        raise ArtifactError(f"the x, y path spans {span:.2g} deg of arc, too little to fit its pivot: "
                            "give --pivot X Y")
    return (fit.xc, fit.yc), {"radius": fit.radius, "rms": fit.rms, "arc_deg": math.degrees(fit.arc_span)}


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


# Where a record's zero of theta comes from (:func:`zero_reference`): a measured rest or the renderer's
# truth ("rest", "truth"), the image vertical ("vertical"), a plain table's own convention ("table"),
# or not recorded ("unknown", e.g. an artifact written by a test or an older version). The fit reads
# it (pendtrack.fitting.models_fit.ZERO_NOT_MEASURED).


def zero_reference(rec: Record) -> str:
    """Where the zero of ``rec``'s theta comes from: an artifact's ``zero_reference`` (angle.parquet,
    passed on by kinematics.parquet), ``"truth"`` for truth.parquet, ``"table"`` for a plain table
    or Parquet file, ``"unknown"`` if an artifact does not say."""
    if rec.kind == "truth":
        return "truth"
    if rec.kind in ("angle", "kinematics"):
        value = ((rec.provenance.extra or {}) if rec.provenance is not None else {}).get("zero_reference")
        return value if isinstance(value, str) and value else "unknown"
    return "table"


def zero_sigma(rec: Record) -> float | None:
    """The standard uncertainty [rad] of theta's zero from the axle's sideways uncertainty (angle.parquet's
    ``axle_uncertainty.zero_sigma_rad``, passed on by kinematics.parquet as ``zero_sigma_rad``); None when the
    record does not carry one (a given axle, a table, the truth)."""
    extra = (rec.provenance.extra or {}) if rec.provenance is not None and rec.kind in ("angle", "kinematics") else {}
    value = extra.get("zero_sigma_rad") if rec.kind == "kinematics" else (extra.get("axle_uncertainty") or {}).get(
        "zero_sigma_rad")
    return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) else None


def table_sections(table: TableSpec | None) -> dict[str, Any]:
    """What a stage adds to its provenance config for ``--columns``/``--pivot`` (nothing by default)."""
    return {} if table is None or table.default else {"table": table.to_dict()}


def _differentiate(rec: Record, config: Config) -> KinematicsResult:
    kc = config.kinematics
    try:
        return savgol_kinematics(rec.t, rec.theta, rec.ok, window_s=kc.savgol_window_s, order=kc.savgol_order,
                                 max_gap_s=kc.max_gap_s, min_segment_s=kc.min_segment_s)
    except KinematicsError as exc:
        raise KinematicsError(str(exc), path=rec.source) from None


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
        (``window_points``, ``order``, ``h``), ``zero_reference`` (:func:`zero_reference`) and
        ``zero_sigma_rad`` (:func:`zero_sigma`).
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
    kin = _differentiate(rec, config)
    frame = pd.DataFrame({"t": kin.t, "theta": kin.theta, "omega": kin.omega, "alpha": kin.alpha, "ok": kin.ok,
                          "segment": kin.segment})
    sections |= {**config.sections("kinematics"), "input": rec.info}
    prov = Provenance(stage="kinematics", config=config.sections("kinematics"),
                      extra={**kin.info, "zero_reference": zero_reference(rec), "zero_sigma_rad": zero_sigma(rec)})
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
        (:func:`zero_reference`; `fit` and `run` fit it as ``theta_off`` when it was not measured);
        ``zero_sigma_rad``: its uncertainty from the axle's (:func:`zero_sigma`; part of theta_off's stderr).

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
    kin = _differentiate(rec, config)
    ana = analyse(kin)
    raw = omega0_from_kinematics(kin, correct_smoothing=False) if ana.omega0 is not None else None
    if ana.omega0 is None:
        log.warning("%s: no model-free Omega0 (%s); analysis columns left out", angle, ana.reason)
    frame = pd.DataFrame({"t": kin.t, "theta": kin.theta, "omega": kin.omega, "alpha": kin.alpha,
                          "ok": kin.ok, "segment": kin.segment})
    for name, values in ana.columns.items():
        frame[name] = values
    facts: dict[str, Any] = {
        "Omega0": None if ana.omega0 is None else ana.omega0.omega0,
        "Omega0_stderr": None if ana.omega0 is None else ana.omega0.stderr,
        "Omega0_raw": None if raw is None else raw.omega0,
        "Omega0_reason": ana.reason,
        "n_turning_points": len(ana.turning),
        "negative_damping_fraction": None if math.isnan(ana.negative_damping_fraction)
        else ana.negative_damping_fraction,
        "ok_fraction": float(np.mean(kin.ok)) if kin.ok.size else 0.0,
        **kin.info,
        "input": rec.info,
        "zero_reference": zero_reference(rec),
        "zero_sigma_rad": zero_sigma(rec),
    }
    write_artifact(frame, out, "kinematics",
                   provenance=Provenance(stage="kinematics", config=sections, inputs=inputs, extra=facts))
    return StageOutput((out,), facts=facts)
