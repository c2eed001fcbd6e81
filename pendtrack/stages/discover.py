"""`discover` stage: a record (angle/kinematics Parquet, text table or video) -> discovery.json + .md.

For a video the video stages run first (track, angle) into the same folder and discovery
reads their ``angle.parquet``. Both outputs are written atomically, and only after the
whole analysis succeeded: a bad input leaves no discovery artifact.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pendtrack.artifacts import (DISCOVERY_JSON_KEYS, Provenance, atomic_write, file_sha256, inputs_for,
                                 write_json_artifact)
from pendtrack.config import Config
from pendtrack.errors import ArtifactError
from pendtrack.progress import progress_bar
from pendtrack.stages import StageOutput, several_records, up_to_date
from pendtrack.stages.kinematics import read_input, table_sections
from pendtrack.tables import TableSpec, is_video

JSON_NAME = "discovery.json"
MD_NAME = "discovery.md"


def _analysed_file(source: Path, out_dir: Path, config: Config, force: bool, progress: bool) -> Path:
    """The file discovery reads: the input itself, or the angle.parquet made from a video."""
    if not source.is_file():
        raise ArtifactError("file not found", path=source)
    if not is_video(source):
        return source
    from pendtrack.stages.angle import angle_stage
    from pendtrack.stages.track import track_stage

    common = {"out_dir": out_dir, "config": config, "force": force, "progress": progress}
    track = track_stage(source, **common)
    return angle_stage(track.path, **common).path


def discover_stage(source: str | Path, *, out_dir: str | Path, config: Config, baseline: str | None = None,
                   effects: tuple[str, ...] | None = None, table: TableSpec | None = None, force: bool = False,
                   progress: bool = True) -> StageOutput:
    """Diagnose the baseline, name the missing physics, extend the model, measure the gain.

    Parameters
    ----------
    source : path
        angle.parquet, kinematics.parquet, a Parquet file or CSV/whitespace table of t,
        theta or t, x, y (read as `kinematics` and `fit` read it:
        :func:`pendtrack.stages.kinematics.read_input`), or a video.
    out_dir : path
        Output folder (created): discovery.json, discovery.md (and, for a video, the video
        stages' artifacts).
    config : Config
        Uses [discover], [kinematics], [models] and [fit] (cost); for a video also the
        video stages' sections.
    baseline : str, optional
        Overrides ``config.discover.baseline``.
    effects : tuple of str, optional
        Overrides ``config.discover.effects`` (the catalogue to try; empty = all).
    table : TableSpec, optional
        Column names and pivot of a table (``--columns``, ``--pivot``).
    force : bool
        Recompute even if the outputs are up to date.
    progress : bool
        Progress bar over the fits (stderr).

    Returns
    -------
    StageOutput
        ``paths``: discovery.json, discovery.md. ``facts``: baseline, effects, rms and
        held-out RMS of the baseline and the final model, runtime, and ``input`` (how the
        file was read: columns, pivot, resampling, warnings).

    Raises
    ------
    ArtifactError
        Missing or unreadable input (the message names the file).
    ConfigError
        Unknown baseline or effect.
    FitError
        A record that cannot support the analysis.
    """
    from pendtrack.discovery import catalogue
    from pendtrack.discovery.inputs import MIN_SAMPLES, series_from_record
    from pendtrack.discovery.narrative import write_markdown
    from pendtrack.discovery.loop import discover

    source = Path(source)
    out_dir = Path(out_dir)
    if baseline is not None or effects is not None:
        overrides: dict[str, Any] = {}
        if baseline is not None:
            overrides["baseline"] = baseline
        if effects is not None:
            overrides["effects"] = tuple(effects)
        config = config.replace("discover", **overrides)
    dc = config.discover
    pool = catalogue.candidates(dc.baseline, dc.effects)  # unknown names fail before any work
    analysed = _analysed_file(source, out_dir, config, force, progress)
    rec = read_input(analysed, table=table, min_samples=MIN_SAMPLES, purpose="discovery")
    series = series_from_record(rec)
    paths = (out_dir / JSON_NAME, out_dir / MD_NAME)
    inputs = inputs_for(analysed)
    sections = (config.sections("discover", "kinematics", "models") | {"fit": {"cost": config.fit.cost}}
                | table_sections(table))
    if up_to_date(paths[:1], "discovery", inputs=inputs, config=sections, force=force) and paths[1].is_file():
        import json

        record = json.loads(paths[0].read_text(encoding="utf-8"))
        return StageOutput(paths, skipped=True, facts=(record.get("provenance") or {}).get("extra") or {})

    meas = catalogue.measurement_candidates(dc.baseline, dc.measurement)
    # an estimate (the bar may end early or run over): the baseline, the measurement terms, the steps' singles
    total = 1 + len(meas) + len(pool) * max(1, min(dc.max_effects, len(pool)))
    with progress_bar(total, "discover", enabled=progress) as advance:
        result = discover(series, config=config, on_progress=advance)
    record = result.to_dict()
    facts = {"source": str(source), "analysed": str(analysed), "baseline": result.baseline,
             "effects": list(result.effects), "partial": list(result.partial), "measurement": list(result.measurement),
             "unexplained": list(result.unexplained), "baseline_rms": result.baseline_fit.rms,
             "baseline_heldout_rms": result.baseline_heldout_rms, "final_rms": result.final_fit.rms,
             "final_heldout_rms": result.final_heldout_rms, "runtime_s": result.runtime_s, "input": rec.info}
    prov = Provenance(stage="discover", config=sections, inputs=inputs, extra=facts)
    text = write_markdown(result)
    # measurement and unexplained (issue #14) are required of what this stage writes; readers of older
    # records ask only for DISCOVERY_JSON_KEYS
    write_json_artifact(record, paths[0], required=(*DISCOVERY_JSON_KEYS, "measurement", "unexplained"),
                        provenance=prov)
    atomic_write(paths[1], lambda tmp: tmp.write_text(text + "\n", encoding="utf-8"))
    return StageOutput(paths, facts=facts)


def discover_runs_stage(sources: list[str | Path], *, out_dir: str | Path, config: Config,
                        baseline: str | None = None, effects: tuple[str, ...] | None = None,
                        table: TableSpec | None = None, sharing: dict[str, str] | None = None, force: bool = False,
                        progress: bool = True) -> StageOutput:
    """Discovery across several runs of one pendulum (:mod:`pendtrack.discovery.across_runs`).

    Parameters
    ----------
    sources : list of path
        Two or more records (angle or kinematics Parquet, Parquet or text tables), read as
        :func:`discover_stage` reads one; each run is named by its run code
        (:func:`pendtrack.batch.runcode.run_names`), whose tile and alley set the default scopes.
    out_dir : path
        Output folder: discovery.json and discovery.md.
    config, baseline, effects, table, force, progress
        As :func:`discover_stage`.
    sharing : dict, optional
        Parameter -> scope (``shared``, ``run``, ``tile+alley``) over the defaults.

    Returns
    -------
    StageOutput
        ``paths``: discovery.json, discovery.md. ``facts``: runs, baseline, effects, partial, scopes,
        unexplained, runtime.

    Raises
    ------
    ArtifactError
        A missing or unreadable record, or a video (each video goes through ``pendtrack run`` first).
    ConfigError
        Unknown baseline or effect.
    FitError
        Fewer than two records, one given twice, a record too short, a bad sharing.
    """
    from pendtrack.batch.runcode import run_names
    from pendtrack.discovery import catalogue
    from pendtrack.discovery.across_runs import discover_runs
    from pendtrack.discovery.inputs import MIN_SAMPLES, series_from_record
    from pendtrack.fitting.joint.scopes import resolve_scopes
    from pendtrack.models import compose

    paths = several_records(sources, what="discovery across runs")
    out_dir = Path(out_dir)
    for p in paths:
        if not p.is_file():
            raise ArtifactError("file not found", path=p)
        if is_video(p):
            raise ArtifactError("discovery across runs reads records: run `pendtrack run` on each video first, "
                                "then give its angle.parquet", path=p)
    overrides: dict[str, Any] = {}
    if baseline is not None:
        overrides["baseline"] = baseline
    if effects is not None:
        overrides["effects"] = tuple(effects)
    if overrides:
        config = config.replace("discover", **overrides)
    dc = config.discover
    pool = catalogue.candidates(dc.baseline, dc.effects)  # unknown names fail before any work
    runs, labels = run_names(paths)
    label_of = dict(zip(runs, labels))
    widest = compose(dc.baseline, [*(["offset"] if "offset" in dc.measurement else []), *(e.name for e in pool)])
    resolve_scopes(widest, sharing, labels=label_of)  # a bad sharing fails before any fit
    recs = [read_input(p, table=table, min_samples=MIN_SAMPLES, purpose="discovery") for p in paths]
    series = {run: series_from_record(rec) for run, rec in zip(runs, recs)}
    out_paths = (out_dir / JSON_NAME, out_dir / MD_NAME)
    inputs = {run: file_sha256(p) for run, p in zip(runs, paths)}  # keyed by run: the files may share a name
    sections = (config.sections("discover", "kinematics", "models") | {"fit": {"cost": config.fit.cost}}
                | table_sections(table) | {"sharing": dict(sharing or {})})
    if up_to_date(out_paths[:1], "discovery", inputs=inputs, config=sections, force=force) and out_paths[1].is_file():
        import json

        record = json.loads(out_paths[0].read_text(encoding="utf-8"))
        return StageOutput(out_paths, skipped=True, facts=(record.get("provenance") or {}).get("extra") or {})
    # an estimate: the baseline, then the catalogue's singles at each step and a scope fit per kept effect
    total = 1 + len(pool) * max(1, min(dc.max_effects, len(pool))) + dc.max_effects
    with progress_bar(total, "discover", enabled=progress) as advance:
        result = discover_runs(series, config=config, labels=label_of, sharing=sharing, on_progress=advance)
    record = result.to_dict()
    facts = {"sources": [str(p) for p in paths], "runs": list(result.runs), "baseline": result.baseline,
             "effects": list(result.effects), "partial": list(result.partial),
             "scopes": {k: v["scope"] for k, v in result.scopes.items()},
             "unexplained": {r: list(v) for r, v in result.unexplained.items()},
             "baseline_rms": result.baseline_fit.rms, "final_rms": result.final_fit.rms,
             "runtime_s": result.runtime_s}
    prov = Provenance(stage="discover", config=sections, inputs=inputs, extra=facts)
    write_json_artifact(record, out_paths[0], required=("kind", "runs", "baseline", "effects", "partial", "scopes",
                                                        "candidates"), provenance=prov)
    text = result.summary()
    atomic_write(out_paths[1], lambda tmp: tmp.write_text(text, encoding="utf-8"))
    return StageOutput(out_paths, facts=facts)
