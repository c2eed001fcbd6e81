"""`kinematics` stage: angle.parquet -> kinematics.parquet (Savitzky-Golay + initial analysis)."""

from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pendtrack.artifacts import SCHEMAS, Provenance, inputs_for, read_artifact, read_metadata, write_artifact
from pendtrack.config import Config
from pendtrack.kinematics import KinematicsError, analyse, omega0_from_kinematics, savgol_kinematics
from pendtrack.stages import StageOutput, up_to_date

log = logging.getLogger(__name__)

FILENAME = SCHEMAS["kinematics"].filename


def kinematics_stage(angle: str | Path, *, out_dir: str | Path, config: Config, force: bool = False,
                     progress: bool = True) -> StageOutput:
    """Smoothed theta, omega, alpha and the paper's initial analysis; writes ``out_dir/kinematics.parquet``.

    Parameters
    ----------
    angle : path
        angle.parquet (columns t [s], theta [rad], ok).
    out_dir : path
        Output folder (created).
    config : Config
        Uses ``[kinematics]``: Savitzky-Golay window [s] and order, gap bridging and
        minimum segment length (see :func:`pendtrack.kinematics.savgol_kinematics`).
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
        ``resampled``, ``ok_fraction``.

    Raises
    ------
    ArtifactError
        Missing or malformed angle file.
    KinematicsError
        The series cannot be differentiated (bad time axis, nothing long enough).
    """
    angle = Path(angle)
    out = Path(out_dir) / FILENAME
    sections = config.sections("kinematics")
    art = read_artifact(angle, "angle")
    inputs = inputs_for(angle)
    if up_to_date((out,), "kinematics", inputs=inputs, config=sections, force=force):
        record = read_metadata(out) or {}
        return StageOutput((out,), skipped=True, facts=dict(record.get("extra", {})))
    df = art.data
    kc = config.kinematics
    try:
        kin = savgol_kinematics(df["t"].to_numpy(float), df["theta"].to_numpy(float), df["ok"].to_numpy(bool),
                                window_s=kc.savgol_window_s, order=kc.savgol_order, max_gap_s=kc.max_gap_s,
                                min_segment_s=kc.min_segment_s)
    except KinematicsError as exc:
        raise KinematicsError(str(exc), path=angle) from None
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
    }
    write_artifact(frame, out, "kinematics",
                   provenance=Provenance(stage="kinematics", config=sections, inputs=inputs, extra=facts))
    return StageOutput((out,), facts=facts)
