"""The records of the pipeline: track, angle, kinematics, a measured table, a simulation, a render."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pendtrack.api.frames import read_frame, staged, to_frame, workdir
from pendtrack.api.options import ANGLE, KINEMATICS, TRACK, base_config, configure
from pendtrack.artifacts import Artifact, Provenance
from pendtrack.config import Config

ConfigLike = Config | str | Path | None


def track(video: str | Path, *, config: ConfigLike = None, out: str | Path | None = None, progress: bool = False,
          **options: Any) -> pd.DataFrame:
    """Track the marker through ``video``: the `track` stage (``pendtrack track``).

    Parameters
    ----------
    video : path
        The video.
    config : Config, path or None
        As ``--config`` (None: the defaults).
    out : path, optional
        Keep track.parquet there (``--out``); default a scratch folder.
    progress : bool
        Progress bar on stderr.
    **options
        The flags of ``pendtrack track``: ``marker_color`` (or ``marker``), ``roi``, ``min_score``,
        ``evolution_rate``, ``search_margin_px``, ``track_in_corrected``, ``projection``, ``fov``,
        ``fixed_pixels``, ``fps``, ``start``, ``end``.

    Returns
    -------
    DataFrame
        track.parquet's columns (frame, t [s], x_px, y_px, x, y [px], score, ok); provenance in
        ``.attrs["provenance"]``.
    """
    from pendtrack.stages.track import track_stage

    cfg = configure(config, options, TRACK, what="pt.track")
    with workdir(out) as folder:
        res = track_stage(video, out_dir=folder, config=cfg, force=out is None, progress=progress)
        return read_frame(res.path, "track")


def angle(track_table: pd.DataFrame, *, config: ConfigLike = None, out: str | Path | None = None,
          **options: Any) -> pd.DataFrame:
    """theta(t) from a track: the `angle` stage (axle, lens check, zero at rest).

    ``options``: ``axle`` (x, y [px]), ``rest_seconds``, ``lens_check``. Returns angle.parquet's
    columns (t [s], theta [rad], ok) with provenance.
    """
    from pendtrack.stages.angle import angle_stage

    cfg = configure(config, options, ANGLE, what="pt.angle")
    with staged(track_table, what="pt.angle") as src, workdir(out) as folder:
        res = angle_stage(src, out_dir=folder, config=cfg, force=True, progress=False)
        return read_frame(res.path, "angle")


def kinematics(record: pd.DataFrame, *, config: ConfigLike = None, out: str | Path | None = None,
               **options: Any) -> pd.DataFrame:
    """Savitzky-Golay theta, omega, alpha and the paper's initial analysis: the `kinematics` stage.

    ``record``: a DataFrame of :func:`angle` or :func:`read_record`. ``options``: ``window_s`` [s],
    ``order``, ``max_gap_s`` [s], ``min_segment_s`` [s]. Returns kinematics.parquet's columns with
    provenance (``Omega0`` and the differentiation facts under ``["provenance"]["extra"]``).
    """
    from pendtrack.stages.kinematics import kinematics_stage

    cfg = configure(config, options, KINEMATICS, what="pt.kinematics")
    with staged(record, what="pt.kinematics") as src, workdir(out) as folder:
        res = kinematics_stage(src, out_dir=folder, config=cfg, force=True, progress=False)
        return read_frame(res.path, "kinematics")


def read_record(path: str | Path, *, columns: str | tuple[str, ...] | None = None,
                pivot: tuple[float, float] | None = None, rate_hz: float | None = None) -> pd.DataFrame:
    """theta(t) from a measured table or an artifact, read as `kinematics`, `fit` and `discover` read it.

    Parameters
    ----------
    path : path
        A CSV/whitespace table, a Parquet file, or a pendtrack artifact.
    columns : str or tuple of str, optional
        As ``--columns``: ``"t,theta,_"``, units as ``theta_deg``, ``"theta [deg]"``, ``t_ms``.
    pivot : (float, float), optional
        As ``--pivot`` (x, y tables).
    rate_hz : float, optional
        As ``--rate``: a table without a time column, row k at ``t = k / rate_hz`` [Hz].

    Returns
    -------
    DataFrame
        t [s], theta [rad], ok (and omega, alpha of a kinematics artifact); ``.attrs["provenance"]``
        records how the file was read and where theta's zero comes from.
    """
    from pendtrack.stages.kinematics import read_input
    from pendtrack.tables import TableSpec, parse_columns

    cols = parse_columns(columns, check_roles=False) if isinstance(columns, str) else columns  # TableSpec checks
    spec = (None if cols is None and pivot is None and rate_hz is None else
            TableSpec(columns=cols, pivot=pivot, rate_hz=rate_hz))
    rec = read_input(path, table=spec)
    frame = pd.DataFrame({"t": rec.t, "theta": rec.theta, **rec.columns, "ok": rec.ok})
    if rec.kind == "kinematics" and rec.provenance is not None:
        return to_frame(Artifact(frame, rec.provenance, rec.source), "kinematics")
    prov = Provenance(stage="read_record", extra={"zero_reference": rec.zero_reference, "input": rec.info})
    frame = frame[["t", "theta", "ok"]]
    return to_frame(Artifact(frame, prov, rec.source), "angle")


def simulate(model: str, params: Mapping[str, float], t: Any, *, theta0: float, omega0: float = 0.0,
             config: ConfigLike = None) -> pd.DataFrame:
    """A model's trajectory from ``(theta0, omega0)`` at ``t[0]``: :func:`pendtrack.models.simulate`.

    ``model`` is any name ``--model`` takes (``"standard+memory"``); the memory and the
    predictor-corrector's step are ``[models]`` of ``config``. Returns t [s], theta [rad],
    omega [rad/s], alpha [rad/s^2].
    """
    from pendtrack.models import get_model
    from pendtrack.models import simulate as run

    mc = base_config(config).models
    sim = run(get_model(model), params, np.asarray(t, float), theta0=theta0, omega0=omega0, memory_s=mc.memory_s,
              full_history=mc.full_history, max_step_s=mc.max_step_s)
    df = pd.DataFrame({"t": sim.t, "theta": sim.theta, "omega": sim.omega, "alpha": sim.alpha})
    df.attrs["provenance"] = Provenance(stage="simulate", config={"models": base_config(config).sections("models")},
                                        extra={"model": sim.model, "params": dict(sim.params), "theta0": theta0,
                                               "omega0": omega0}).to_dict()
    return df


def render(out: str | Path, *, config: ConfigLike = None, progress: bool = False, **options: Any) -> pd.DataFrame:
    """Film a virtual pendulum into ``out`` (video.mp4, truth.parquet): the `render` stage.

    ``options`` are ``[render]`` keys (``seconds``, ``model``, ``theta0``, ``fps``, ``width``,
    ``lens_projection``, ``marker_color``, ...; ``configs/default.toml``). Returns the truth
    (t [s], theta [rad], omega [rad/s]) with provenance; ``.attrs["video"]`` is the video's path.
    """
    from pendtrack.stages.render import render_stage

    cfg = base_config(config)
    known = {k: ("render", k) for k in cfg.sections("render")["render"]}
    cfg = configure(cfg, options, known, what="pt.render")
    res = render_stage(out_dir=out, config=cfg, progress=progress)
    video, truth = res.paths
    df = read_frame(truth, "truth")
    df.attrs["video"] = str(video)
    return df
