"""A batch campaign: every run-coded video of a folder through the per-run job, resumable.

:func:`run_campaign` is the batch's one core call. It lists the folder's videos and plans a
run per run code (:mod:`pendtrack.batch.runcode`), checks the models, finds the runs already
complete for the same video and config (:mod:`pendtrack.batch.resume`), executes the others
(:func:`pendtrack.batch.worker.run_task` around the per-run ``job``, on local processes or a
Dask cluster, :mod:`pendtrack.batch.executor`), records how each run ended (a failing video
is recorded with its error and the others go on), and builds the summary table
(:mod:`pendtrack.batch.summary`), the two-cuboid check (:mod:`pendtrack.batch.twocuboid`),
the counts and the groups. The job writes each run's own files into ``out_dir/<run id>/``
inside its worker; the batch's own files (summary, batch.json, report) are the stage's
(:func:`pendtrack.stages.batch.batch_stage`).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Mapping
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pendtrack.artifacts import file_sha256
from pendtrack.batch.executor import check_scheduler, execute
from pendtrack.batch.resume import DONE_NAME, is_run_complete, read_done, run_config
from pendtrack.batch.runcode import PlannedRun, SkippedFile, find_videos, plan_runs
from pendtrack.batch.summary import failed_row, run_row, skipped_row, summary_frame
from pendtrack.batch.twocuboid import two_cuboid_check
from pendtrack.batch.worker import RunTask, describe_error, run_task
from pendtrack.config import Config
from pendtrack.errors import PendtrackError

if TYPE_CHECKING:
    import pandas as pd

log = logging.getLogger(__name__)

#: ``progress(total)`` -> a context manager giving the callback advanced by 1 per finished run
Progress = Callable[[int], AbstractContextManager[Callable[[int], None]]]


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


def run_counts(runs: tuple[RunRecord, ...], skipped: tuple[SkippedFile, ...]) -> dict[str, int]:
    """Videos, runs, ok, resumed, failed and skipped files."""
    return {"videos": len(runs) + len(skipped), "runs": len(runs),
            "ok": sum(r.status == "ok" for r in runs), "resumed": sum(r.resumed for r in runs),
            "failed": sum(r.status == "failed" for r in runs), "skipped": len(skipped)}


@dataclass(frozen=True, eq=False)
class Campaign:
    """What a batch campaign found and did (its files excepted).

    Attributes
    ----------
    folder, out_dir : Path
        The videos' folder and the batch output folder (runs in ``out_dir/<run id>/``).
    scheduler : str
        ``processes`` or the Dask scheduler address the runs went to.
    config : Config
        The config each run used (:func:`inner_config` of the given one).
    run_config : dict
        What a run's results depend on (:func:`pendtrack.batch.resume.run_config`): the
        sections, the models and discovery.
    models : tuple of str
        The models fitted per run.
    planned : tuple of PlannedRun
        The runs, in folder order.
    runs : tuple of RunRecord
        How each planned run ended, in the same order.
    skipped : tuple of SkippedFile
        Videos whose names are no run code.
    summary : pandas.DataFrame
        One row per run and skipped file (:func:`pendtrack.batch.summary.summary_frame`).
    two_cuboid : dict
        The two-cuboid fit of Omega0(l1) (:func:`pendtrack.batch.twocuboid.two_cuboid_check`).
    groups : dict
        Runs, ok and failed per run kind and per tile length.
    inputs : dict
        Video file name -> sha256 of each run that ended ok.
    runtime_s : float
        Wall time of planning and running [s].
    """

    folder: Path
    out_dir: Path
    scheduler: str
    config: Config
    run_config: dict[str, Any]
    models: tuple[str, ...]
    planned: tuple[PlannedRun, ...]
    runs: tuple[RunRecord, ...]
    skipped: tuple[SkippedFile, ...]
    summary: pd.DataFrame
    two_cuboid: dict[str, Any]
    groups: dict[str, Any]
    inputs: dict[str, str]
    runtime_s: float

    @property
    def counts(self) -> dict[str, int]:
        """Videos, runs, ok, resumed, failed and skipped files."""
        return run_counts(self.runs, self.skipped)

    def to_dict(self) -> dict[str, Any]:
        """The batch.json payload: folder, scheduler, models, counts, groups, two-cuboid check,
        failures (with tracebacks), skipped files and runtime."""
        return {
            "folder": str(self.folder), "scheduler": self.scheduler, "models": list(self.models),
            "counts": self.counts, "groups": self.groups, "two_cuboid": self.two_cuboid,
            "failures": [{"run_id": r.run_id, "file": r.file, "reason": r.reason, "traceback": r.traceback}
                         for r in self.runs if r.status == "failed"],
            "skipped": [{"file": s.video.name, "reason": s.reason} for s in self.skipped],
            "runtime_s": self.runtime_s,
        }


def run_campaign(folder: str | Path, *, out_dir: str | Path, config: Config, job: Callable[..., str | None],
                 models: tuple[str, ...] | None = None, scheduler: str | None = None, workers: int | None = None,
                 discover: bool = False, force: bool = False, progress: Progress | None = None) -> Campaign:
    """Run ``job`` on every run-coded video of ``folder`` into ``out_dir/<run id>/``; summarise.

    Parameters
    ----------
    folder : path
        Folder of videos named by run code (``06na5.mp4``; see :mod:`pendtrack.batch.runcode`).
    out_dir : path
        Batch output folder; its own videos are not listed.
    config : Config
        Pipeline configuration; its ``[batch]`` section holds the scheduling defaults.
    job : callable
        The per-run job, module-level with the :class:`pendtrack.batch.worker.Job` signature.
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
    progress : callable, optional
        ``progress(total)`` -> a context manager giving the callback advanced by 1 per finished
        run (resumed ones included); opened once the runs are planned.

    Returns
    -------
    Campaign

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
    with (progress(len(tasks)) if progress else nullcontext(lambda n: None)) as advance:
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
    runtime_s = time.perf_counter() - t0
    summary, inputs = _summary(out_dir, planned, runs, tuple(skipped))
    return Campaign(folder=folder, out_dir=out_dir, scheduler=scheduler, config=cfg, run_config=depends,
                    models=models, planned=tuple(planned), runs=runs, skipped=tuple(skipped), summary=summary,
                    two_cuboid=two_cuboid_check(summary, preference=cfg.batch.omega0_models),
                    groups=_groups(summary), inputs=inputs, runtime_s=runtime_s)


def inner_config(config: Config) -> Config:
    """The config a run uses: ``[fit]`` and ``[discover]`` workers set to ``[batch] inner_workers``.

    The batch parallelises runs; a run's own process pools would oversubscribe the cores
    (and Dask's daemonic workers may not start child processes).
    """
    inner = config.batch.inner_workers
    cfg = config.replace("fit", workers=inner)
    return cfg.replace("discover", workers=inner) if hasattr(cfg, "discover") else cfg


def _check_models(models: tuple[str, ...]) -> tuple[str, ...]:
    """The models, each known to the registry (a typo fails the batch before any run)."""
    from pendtrack.models import get_model

    for name in models:
        get_model(name)  # raises ModelError naming the unknown model
    return models


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


def _summary(out_dir: Path, planned: list[PlannedRun], runs: tuple[RunRecord, ...],
             skipped: tuple[SkippedFile, ...]) -> tuple[pd.DataFrame, dict[str, str]]:
    """The summary table (run rows from each run folder, then skipped files) and the ok runs' video sha256."""
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
    return summary_frame(rows), inputs


def _groups(df: pd.DataFrame) -> dict[str, Any]:
    """Counts per run kind (la, ln, na, nn) and per tile length, by status."""
    runs = df[df["status"] != "skipped"]
    out: dict[str, Any] = {"kind": {}, "tile_cm": {}}
    for key, col in (("kind", "kind"), ("tile_cm", "tile_cm")):
        for value, sub in runs.groupby(col, sort=True):
            out[key][str(value)] = {"runs": int(len(sub)), "ok": int((sub["status"] == "ok").sum()),
                                    "failed": int((sub["status"] == "failed").sum())}
    return out
