"""`pendtrack batch`: the whole pipeline over a folder of run-coded videos, resumable.

For every video whose name is a run code (see :mod:`pendtrack.batch.runcode`) the per-run
job (:func:`pendtrack.stages.batch_job.pipeline_job`: ``run_pipeline``, plus discovery when
asked) runs into ``DIR/<run id>/`` on local worker processes or a Dask cluster
(:mod:`pendtrack.batch.executor`). A run already complete for the same video and config is
not recomputed (:mod:`pendtrack.batch.resume`); a failing video is recorded with its error
and the others go on. At the end ``DIR/summary.parquet`` + ``DIR/summary.csv``
(:mod:`pendtrack.batch.summary`) and ``DIR/batch.json`` (counts, failures and the paper's
two-cuboid fit of Omega0(l1), :mod:`pendtrack.batch.twocuboid`) are written, then the batch
report ``DIR/report.html`` (:func:`pendtrack.stages.report.write_batch_report`) unless
``[batch] report = false``.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pendtrack.artifacts import Provenance, file_sha256, write_json_artifact
from pendtrack.batch.executor import check_scheduler, execute
from pendtrack.batch.resume import DONE_NAME, is_run_complete, read_done, run_config
from pendtrack.batch.runcode import PlannedRun, SkippedFile, find_videos, plan_runs
from pendtrack.batch.summary import failed_row, run_row, skipped_row, summary_frame, write_summary
from pendtrack.batch.twocuboid import two_cuboid_check
from pendtrack.batch.worker import RunTask, describe_error, run_task
from pendtrack.config import Config
from pendtrack.errors import PendtrackError
from pendtrack.progress import progress_bar
from pendtrack.stages.batch_job import pipeline_job

log = logging.getLogger(__name__)

BATCH_JSON = "batch.json"
BATCH_JSON_KEYS = ("counts", "groups", "two_cuboid", "failures", "skipped")


class BatchError(PendtrackError):
    """The batch folder is missing or holds no videos."""


@dataclass(frozen=True)
class RunRecord:
    """How one run of the batch ended.

    Attributes
    ----------
    run_id, file : str
        Run id (output folder name) and video file name.
    status : str
        ``ok`` or ``failed``.
    reason : str
        One-line error message ("" if ok).
    resumed : bool
        Found complete from an earlier batch; not recomputed.
    runtime_s : float
        Wall time of the run in its worker [s] (NaN if resumed or lost).
    traceback : str
        The worker's traceback of a failure ("" otherwise).
    """

    run_id: str
    file: str
    status: str
    reason: str = ""
    resumed: bool = False
    runtime_s: float = float("nan")
    traceback: str = ""

    def to_dict(self) -> dict[str, Any]:
        """Plain dict (no traceback)."""
        return {"run_id": self.run_id, "file": self.file, "status": self.status, "reason": self.reason,
                "resumed": self.resumed, "runtime_s": self.runtime_s}


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
        return _counts(self.runs, self.skipped)

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


def _counts(runs: tuple[RunRecord, ...], skipped: tuple[SkippedFile, ...]) -> dict[str, int]:
    return {"videos": len(runs) + len(skipped), "runs": len(runs),
            "ok": sum(r.status == "ok" for r in runs), "resumed": sum(r.resumed for r in runs),
            "failed": sum(r.status == "failed" for r in runs), "skipped": len(skipped)}


def batch_stage(folder: str | Path, *, out_dir: str | Path, config: Config, models: tuple[str, ...] | None = None,
                scheduler: str | None = None, workers: int | None = None, discover: bool = False,
                force: bool = False, progress: bool = True,
                job: Callable[..., str | None] = pipeline_job) -> BatchOutput:
    """Run ``job`` on every run-coded video of ``folder`` into ``out_dir/<run id>/``; summarise.

    Parameters
    ----------
    folder : path
        Folder of videos named by run code (``06na5.mp4``; see :mod:`pendtrack.batch.runcode`).
    out_dir : path
        Batch output folder (created).
    config : Config
        Pipeline configuration; its ``[batch]`` section holds the scheduling defaults.
    models : tuple of str, optional
        Models to fit; default ``config.fit.models``.
    scheduler : str, optional
        ``processes`` or a Dask scheduler address ``tcp://HOST:PORT``; default ``config.batch.scheduler``.
    workers : int, optional
        Local worker processes (0 = all cores); default ``config.batch.workers``.
    discover : bool
        Also run discovery per run.
    force : bool
        Recompute every run and stage, complete or not.
    progress : bool
        One progress bar over the runs on stderr (workers never draw any).
    job : callable
        The per-run job, module-level with the :class:`pendtrack.batch.worker.Job` signature
        (tests inject a stand-in).

    Returns
    -------
    BatchOutput

    Raises
    ------
    BatchError
        ``folder`` does not exist or holds no video files.
    ConfigError, ModelError
        Bad scheduler or workers, unknown model (before any run starts).
    """
    t0 = time.perf_counter()
    folder, out_dir = Path(folder), Path(out_dir)
    bc = config.batch
    scheduler = check_scheduler(scheduler or bc.scheduler)
    workers = bc.workers if workers is None else workers
    planned, skipped = _plan(folder, out_dir, config)
    cfg = inner_config(config)
    models = _check_models(tuple(models or cfg.fit.models))
    depends = run_config(cfg.to_dict(), models=models, discover=discover)
    tasks = [RunTask(run_id=r.run_id, video=str(r.video), out_dir=str(out_dir / r.run_id), config=cfg.to_dict(),
                     run_config=depends, models=models, force=force, discover=discover,
                     threads=bc.threads_per_worker) for r in planned]
    records: dict[str, RunRecord] = {}
    with progress_bar(len(tasks), "batch", enabled=progress) as advance:
        todo = []
        for run, task in zip(planned, tasks):
            if not force and _complete(run, Path(task.out_dir), depends):
                records[run.run_id] = RunRecord(run.run_id, run.video.name, "ok", resumed=True)
                advance(1)
            else:
                todo.append((run, task))
        log.info("%d run(s) to do, %d already complete, %d file(s) skipped", len(todo), len(records), len(skipped))
        argsets = [(job, task.to_dict()) for _, task in todo]
        for i, result in execute(run_task, argsets, scheduler=scheduler, workers=workers,
                                 threads=bc.threads_per_worker):
            run = todo[i][0]
            records[run.run_id] = _record(run, result)
            advance(1)
    runs = tuple(records[r.run_id] for r in planned)
    return _finish(folder, out_dir, cfg, planned, runs, tuple(skipped), depends=depends,
                   scheduler=scheduler, runtime_s=time.perf_counter() - t0)


def _check_models(models: tuple[str, ...]) -> tuple[str, ...]:
    """The models, each known to the registry (a typo fails the batch before any run)."""
    from pendtrack.models import get_model

    for name in models:
        get_model(name)  # raises ModelError naming the unknown model
    return models


def inner_config(config: Config) -> Config:
    """The config a run uses: ``[fit]`` and ``[discover]`` workers set to ``[batch] inner_workers``.

    The batch parallelises runs; a run's own process pools would oversubscribe the cores
    (and Dask's daemonic workers may not start child processes).
    """
    inner = config.batch.inner_workers
    cfg = config.replace("fit", workers=inner)
    return cfg.replace("discover", workers=inner) if hasattr(cfg, "discover") else cfg


def _plan(folder: Path, out_dir: Path, config: Config) -> tuple[list[PlannedRun], list[SkippedFile]]:
    if not folder.is_dir():
        raise BatchError("folder not found" if not folder.exists() else "not a folder", path=folder)
    bc = config.batch
    videos = find_videos(folder, extensions=bc.extensions, recursive=bc.recursive, exclude=out_dir)
    if not videos:
        raise BatchError(f"no video files ({', '.join(bc.extensions)}) in the folder", path=folder)
    return plan_runs(videos)


def _complete(run: PlannedRun, run_dir: Path, depends: Mapping[str, Any]) -> bool:
    if not (run_dir / DONE_NAME).is_file():
        return False
    return is_run_complete(run_dir, video=run.video, video_sha256=file_sha256(run.video), config=depends)


def _record(run: PlannedRun, result: Any) -> RunRecord:
    if isinstance(result, BaseException):  # the executor lost the run (worker died, connection lost)
        reason = f"worker lost: {describe_error(result)}"
        log.info("run %s failed: %s", run.run_id, reason)
        return RunRecord(run.run_id, run.video.name, "failed", reason=reason)
    if result["reason"]:  # the CLI prints it with the run; details in DIR/<run id>/run.log
        log.info("run %s %s: %s", run.run_id, result["status"], result["reason"])
    return RunRecord(run.run_id, run.video.name, result["status"], reason=result["reason"],
                     runtime_s=float(result["runtime_s"]), traceback=result.get("traceback", ""))


def _finish(folder: Path, out_dir: Path, cfg: Config, planned: list[PlannedRun], runs: tuple[RunRecord, ...],
            skipped: tuple[SkippedFile, ...], *, depends: Mapping[str, Any], scheduler: str,
            runtime_s: float) -> BatchOutput:
    rows, inputs = [], {}
    for run, rec in zip(planned, runs):
        run_dir = out_dir / run.run_id
        if rec.status == "ok":
            done = read_done(run_dir) or {}
            sha = str(done.get("video_sha256", ""))
            inputs[run.video.name] = sha
            rows.append(run_row(run_dir, video=run.video, code=run.code, resumed=rec.resumed,
                                runtime_s=done.get("runtime_s"), video_sha256=sha, note=str(done.get("note", ""))))
        else:
            rows.append(failed_row(video=run.video, code=run.code, reason=rec.reason, runtime_s=rec.runtime_s))
    rows += [skipped_row(video=s.video, reason=s.reason) for s in skipped]
    df = summary_frame(rows)
    prov = Provenance(stage="batch", config={**depends, "batch": cfg.to_dict()["batch"]}, inputs=inputs,
                      extra={"folder": str(folder), "scheduler": scheduler})
    summary, csv = write_summary(df, out_dir, provenance=prov)
    check = two_cuboid_check(df, preference=cfg.batch.omega0_models)
    payload = {
        "folder": str(folder), "scheduler": scheduler, "models": list(depends["batch_run"]["models"]),
        "counts": _counts(runs, skipped), "groups": _groups(df), "two_cuboid": check,
        "failures": [{"run_id": r.run_id, "file": r.file, "reason": r.reason, "traceback": r.traceback}
                     for r in runs if r.status == "failed"],
        "skipped": [{"file": s.video.name, "reason": s.reason} for s in skipped],
        "runtime_s": runtime_s,
    }
    batch_json = write_json_artifact(payload, out_dir / BATCH_JSON, required=BATCH_JSON_KEYS, provenance=prov)
    report = _write_report(out_dir, cfg) if cfg.batch.report else None
    return BatchOutput(out_dir, summary, csv, batch_json, runs, skipped, check, report)


def _groups(df: Any) -> dict[str, Any]:
    """Counts per run kind (la, ln, na, nn) and per tile length, by status."""
    runs = df[df["status"] != "skipped"]
    out: dict[str, Any] = {"kind": {}, "tile_cm": {}}
    for key, col in (("kind", "kind"), ("tile_cm", "tile_cm")):
        for value, sub in runs.groupby(col, sort=True):
            out[key][str(value)] = {"runs": int(len(sub)), "ok": int((sub["status"] == "ok").sum()),
                                    "failed": int((sub["status"] == "failed").sum())}
    return out


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
