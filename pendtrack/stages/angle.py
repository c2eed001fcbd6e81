"""`angle` stage: track.parquet -> angle.parquet (axle by circle fit, theta unwrapped, zero at rest)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from pendtrack.artifacts import Provenance, inputs_for, read_artifact, write_artifact
from pendtrack.config import Config
from pendtrack.errors import ConfigError, TrackingError
from pendtrack.stages import StageOutput, up_to_date
from pendtrack.track.angle import theta_from_track
from pendtrack.track.circle import fit_circle

MIN_ARC_SPAN_DEG = 20.0  # a shorter arc cannot locate the axle: pass --axle


def angle_stage(track: str | Path, *, out_dir: str | Path, config: Config, force: bool = False,
                progress: bool = True) -> StageOutput:
    """Axle and theta(t) from a track; writes ``out_dir/angle.parquet``.

    Parameters
    ----------
    track : path
        track.parquet.
    out_dir : path
        Output folder (created).
    config : Config
        Uses ``[angle]``: the axle (else a robust circle fit to the ok corrected points),
        the rest stretch that sets theta's zero.
    force, progress : bool
        As every stage (no loop long enough for a progress bar here).

    Returns
    -------
    StageOutput
        ``facts``: axle, circle RMS residual [px], zero reference.

    Raises
    ------
    ArtifactError
        Missing or malformed track.
    TrackingError
        Too few ok points, or an arc too short to locate the axle.
    """
    track = Path(track)
    out = Path(out_dir) / "angle.parquet"
    sections = config.sections("angle")
    art = read_artifact(track, "track")
    inputs = inputs_for(track)
    if up_to_date((out,), "angle", inputs=inputs, config=sections, force=force):
        return StageOutput((out,), skipped=True)
    df = art.data
    ok = df["ok"].to_numpy(bool) & np.isfinite(df["x"].to_numpy()) & np.isfinite(df["y"].to_numpy())
    ac = config.angle
    circle = None
    if ac.axle:
        if len(ac.axle) != 2:
            raise ConfigError(f"[angle] axle must be x, y, got {list(ac.axle)}")
        axle = (float(ac.axle[0]), float(ac.axle[1]))
    else:
        if ok.sum() < 10:
            raise TrackingError(f"only {int(ok.sum())} ok points: too few to fit the axle", path=track)
        circle = fit_circle(df["x"].to_numpy()[ok], df["y"].to_numpy()[ok])
        if np.degrees(circle.arc_span) < MIN_ARC_SPAN_DEG:
            raise TrackingError(f"the marker's arc spans {np.degrees(circle.arc_span):.1f} deg, too short to "
                                f"locate the axle; pass --axle X,Y", path=track)
        axle = (circle.xc, circle.yc)
    res = theta_from_track(df["t"].to_numpy(float), df["x"].to_numpy(float), df["y"].to_numpy(float), ok,
                           axle=axle, rest_seconds=ac.rest_seconds, rest_omega_max=ac.rest_omega_max,
                           circle=circle)
    out_df = pd.DataFrame({"t": res.t, "theta": res.theta, "ok": res.ok})
    extra = {"axle_source": "config" if ac.axle else "circle_fit", **res.to_dict()}
    if circle is not None:
        extra["circle_rms_px"] = circle.rms
    write_artifact(out_df, out, "angle", provenance=Provenance(stage="angle", config=sections, inputs=inputs,
                                                               extra=extra))
    facts = {"axle": axle, "zero_reference": res.zero_reference,
             "circle_rms_px": circle.rms if circle is not None else None}
    return StageOutput((out,), facts=facts)
