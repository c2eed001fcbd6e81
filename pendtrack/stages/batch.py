"""`pendtrack batch`: the whole pipeline over a folder of run-coded videos, resumable.

The stage calls :func:`pendtrack.batch.campaign.run_campaign` with the per-run job
:func:`pendtrack.stages.batch_job.pipeline_job` (``run_pipeline``, plus discovery when asked):
every video whose name is a run code runs into ``DIR/<run id>/`` on local worker processes
or a Dask cluster, a run already complete for the same video and config is not recomputed,
and a failing video is recorded with its error while the others go on. The stage then
writes ``DIR/summary.parquet`` + ``DIR/summary.csv`` (:mod:`pendtrack.batch.summary`) and
``DIR/batch.json`` (counts, groups, failures, skipped files and the paper's two-cuboid fit of
Omega0(l1), :mod:`pendtrack.batch.twocuboid`), with provenance, then the batch report
``DIR/report.html`` (:func:`pendtrack.stages.report.write_batch_report`) unless
``[batch] report = false``.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pendtrack.artifacts import Provenance, write_json_artifact
from pendtrack.batch.campaign import BatchError, Campaign, RunRecord, run_campaign, run_counts
from pendtrack.batch.runcode import SkippedFile
from pendtrack.batch.summary import write_summary
from pendtrack.batch.worker import describe_error
from pendtrack.config import Config
from pendtrack.progress import progress_bar
from pendtrack.stages.batch_job import pipeline_job

__all__ = ["BATCH_JSON", "BATCH_JSON_KEYS", "BatchError", "BatchOutput", "RunRecord", "batch_stage"]

log = logging.getLogger(__name__)

BATCH_JSON = "batch.json"
BATCH_JSON_KEYS = ("counts", "groups", "two_cuboid", "failures", "skipped")


@dataclass(frozen=True)
class BatchOutput:
    """What a batch wrote."""

    out_dir: Path
    summary: Path
    summary_csv: Path
    batch_json: Path
    runs: tuple[RunRecord, ...]
    skipped: tuple[SkippedFile, ...]
    two_cuboid: Mapping[str, Any] = field(default_factory=dict)
    report: Path | None = None

    @property
    def counts(self) -> dict[str, int]:
        """Videos, runs, ok, resumed, failed and skipped files."""
        return run_counts(self.runs, self.skipped)

    @property
    def failed(self) -> tuple[RunRecord, ...]:
        """The runs that failed."""
        return tuple(r for r in self.runs if r.status == "failed")

    def to_dict(self) -> dict[str, Any]:
        """Plain dict of the paths, counts, runs, skipped files and two-cuboid check."""
        return {"out_dir": str(self.out_dir), "summary": str(self.summary), "summary_csv": str(self.summary_csv),
                "batch_json": str(self.batch_json), "counts": self.counts,
                "runs": [r.to_dict() for r in self.runs],
                "skipped": [{"file": s.video.name, "reason": s.reason} for s in self.skipped],
                "two_cuboid": dict(self.two_cuboid), "report": str(self.report) if self.report else None}


def batch_stage(folder: str | Path, *, out_dir: str | Path, config: Config, models: tuple[str, ...] | None = None,
                scheduler: str | None = None, workers: int | None = None, discover: bool = False,
                force: bool = False, progress: bool = True,
                job: Callable[..., str | None] = pipeline_job) -> BatchOutput:
    """Run ``job`` on every run-coded video of ``folder`` into ``out_dir/<run id>/``; summarise.

    Parameters
    ----------
    folder, out_dir, config, models, scheduler, workers, discover, force
        As :func:`pendtrack.batch.campaign.run_campaign`; ``out_dir`` is created.
    progress : bool
        One progress bar over the runs on stderr (workers never draw any).
    job : callable
        The per-run job (:class:`pendtrack.batch.worker.Job`); default the pipeline's, tests
        inject a stand-in.

    Returns
    -------
    BatchOutput

    Raises
    ------
    BatchError, ConfigError, ModelError
        As :func:`~pendtrack.batch.campaign.run_campaign`, before any run starts or file is written.
    """
    campaign = run_campaign(folder, out_dir=out_dir, config=config, job=job, models=models, scheduler=scheduler,
                            workers=workers, discover=discover, force=force,
                            progress=lambda total: progress_bar(total, "batch", enabled=progress))
    return _write(campaign)


def _write(campaign: Campaign) -> BatchOutput:
    """summary.parquet/csv, batch.json and the report (unless ``[batch] report = false``) of a campaign."""
    c = campaign
    prov = Provenance(stage="batch", config={**c.run_config, "batch": c.config.to_dict()["batch"]},
                      inputs=dict(c.inputs), extra={"folder": str(c.folder), "scheduler": c.scheduler})
    summary, csv = write_summary(c.summary, c.out_dir, provenance=prov)
    batch_json = write_json_artifact(c.to_dict(), c.out_dir / BATCH_JSON, required=BATCH_JSON_KEYS, provenance=prov)
    report = _write_report(c.out_dir, c.config) if c.config.batch.report else None
    return BatchOutput(c.out_dir, summary, csv, batch_json, c.runs, c.skipped, c.two_cuboid, report)


def _write_report(out_dir: Path, config: Config) -> Path | None:
    """``DIR/report.html`` via :func:`pendtrack.stages.report.write_batch_report`; None if it fails.

    The batch's data are already written: a report problem is logged, never fatal.
    """
    from pendtrack.stages.report import write_batch_report

    try:
        return Path(write_batch_report(out_dir, config=config, progress=False))
    except Exception as exc:  # figures must not fail a batch whose results are on disk
        log.warning("batch report failed: %s", describe_error(exc))
        return None
