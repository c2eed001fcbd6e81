"""`angle` stage: track.parquet -> angle.parquet (axle by circle fit, theta unwrapped, zero at rest).

The stage reads the track, calls :func:`pendtrack.track.axle.angle_table` (every decision is made
there) and writes what it returns.
"""

from __future__ import annotations

from pathlib import Path

from pendtrack.artifacts import Provenance, inputs_for, read_artifact, write_artifact
from pendtrack.config import Config
from pendtrack.stages import StageOutput, up_to_date
from pendtrack.track.axle import angle_table


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
        the rest stretch that sets theta's zero, and the lens check: the track's circle
        under the track's lens against no correction, the paper's fisheye and a fitted
        field of view (:mod:`pendtrack.track.lens_check`, recorded as ``lens_check`` in the
        provenance); a mismatch is an error (``lens_check = "error"``, only when the track
        used the default lens: a lens the user named is kept with a warning), a warning
        (``"warn"``) or not looked for (``"off"``).
    force, progress : bool
        As every stage (no loop long enough for a progress bar here).

    Returns
    -------
    StageOutput
        ``facts``: axle, circle RMS residual [px], zero reference, lens-check verdict.

    Raises
    ------
    ArtifactError
        Missing or malformed track.
    TrackingError
        Too few ok points, or a track whose circle locates the axle so poorly that theta's
        scale is uncertain by more than :data:`pendtrack.track.axle.MAX_SCALE_REL` (an arc bending within the noise,
        or no arc about one axle). An arc shorter than :data:`pendtrack.track.axle.MIN_ARC_SPAN_DEG` within it gives
        theta with a warning; ``axle_uncertainty`` in the provenance: the axle's and the
        radius' standard uncertainties [px], theta's relative scale uncertainty and its zero's
        uncertainty from the axle's (``zero_sigma_rad``: sigma_x / radius; the kinematics pass it
        on and a fitted theta_off's stderr includes it).
    ConfigError
        Invalid ``[angle]`` values, or (``lens_check = "error"``) the track's default lens is
        clearly not the footage's.
    """
    track = Path(track)
    out = Path(out_dir) / "angle.parquet"
    sections = config.sections("angle")
    art = read_artifact(track, "track")
    inputs = inputs_for(track)
    if up_to_date((out,), "angle", inputs=inputs, config=sections, force=force):
        return StageOutput((out,), skipped=True)
    table = angle_table(art.data, options=config.angle, track_extra=art.provenance.extra,
                        track_config=art.provenance.config, source=track)
    write_artifact(table.frame, out, "angle", provenance=Provenance(stage="angle", config=sections, inputs=inputs,
                                                                    extra=table.extra))
    return StageOutput((out,), facts=table.facts)
