"""The per-run job of ``pendtrack batch``: the pipeline's stages for one video.

:func:`pipeline_job` is what :func:`pendtrack.stages.batch.batch_stage` hands to the batch
executor (:func:`pendtrack.batch.worker.run_task` calls it in a worker). It is a module-level
function with plain arguments, so it pickles by reference to local worker processes and to
Dask workers. It lives here, not in :mod:`pendtrack.batch`, because it runs stages and
``batch`` sits below ``stages`` in the import layers.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pendtrack.batch.worker import describe_error
from pendtrack.errors import PendtrackError


def pipeline_job(video: str, *, out_dir: str, config: Any, models: tuple[str, ...], force: bool,
                 discover: bool) -> str | None:
    """The real per-run job: :func:`pendtrack.stages.run.run_pipeline` (track, angle,
    kinematics, fit, report.html), then discovery if asked.

    Follows :class:`pendtrack.batch.worker.Job`. A failure of discovery alone (a
    :class:`~pendtrack.errors.PendtrackError`, e.g. a record too short for its held-out test)
    does not fail the run: it is returned as a note.
    """
    from pendtrack.stages.run import run_pipeline

    run_pipeline(video, out_dir=out_dir, config=config, models=models, force=force, progress=False)
    if not discover:
        return None
    try:
        discover_job(out_dir=out_dir, config=config, force=force)
    except PendtrackError as exc:
        return f"discover: {describe_error(exc)}"
    return None


def discover_job(*, out_dir: str, config: Any, force: bool) -> None:
    """Discovery on a run folder's kinematics (:func:`pendtrack.stages.discover.discover_stage`),
    then the run's report again so that it shows discovery too."""
    from pendtrack.stages.discover import discover_stage
    from pendtrack.stages.report import report_stage

    discover_stage(Path(out_dir) / "kinematics.parquet", out_dir=Path(out_dir), config=config, force=force,
                   progress=False)
    report_stage(Path(out_dir), config=config, force=force, progress=False)
