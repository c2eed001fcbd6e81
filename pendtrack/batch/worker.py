"""What runs inside a batch worker: one video's job, the done marker, thread limits.

Everything here is importable at module level and takes plain picklable arguments (paths
as ``str``, the config as a dict), so the same functions run in a local
``ProcessPoolExecutor`` and on a Dask cluster. Importing this module is cheap (no numpy),
so a worker can limit its threads before the numerical libraries load.
"""

from __future__ import annotations

import contextlib
import logging
import os
import socket
import time
import traceback
from collections.abc import Callable, Iterator, Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Protocol

THREAD_ENV_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "VECLIB_MAXIMUM_THREADS",
                   "NUMEXPR_NUM_THREADS", "NUMBA_NUM_THREADS")


class Job(Protocol):
    """The per-run job: process one video into a run folder.

    Raises on failure (the run is recorded as failed); may return a one-line note for a
    run that succeeded with a caveat (e.g. discovery could not be done), else None.
    """

    def __call__(self, video: str, *, out_dir: str, config: Any, models: tuple[str, ...], force: bool,
                 discover: bool) -> str | None: ...


def limit_threads(n: int) -> None:
    """Cap the threads of BLAS/OpenMP, numba and OpenCV in this process at ``n``.

    Environment variables only bind libraries loaded later (set them before the process
    starts, as the local pool does); numba and OpenCV are also capped at run time.
    """
    n = max(1, int(n))
    for var in THREAD_ENV_VARS:
        os.environ[var] = str(n)
    try:
        import cv2

        cv2.setNumThreads(n)
    except ImportError:  # pragma: no cover - OpenCV is a dependency
        pass
    try:
        import numba

        numba.set_num_threads(min(n, numba.config.NUMBA_NUM_THREADS))
    except (ImportError, ValueError):  # pragma: no cover
        pass
    try:  # optional: caps BLAS pools already loaded (e.g. in a Dask worker)
        from threadpoolctl import threadpool_limits

        threadpool_limits(n)
    except ImportError:
        pass


@dataclass(frozen=True)
class RunTask:
    """One run as plain data for a worker.

    Attributes
    ----------
    run_id : str
        Run id (folder name under the batch output).
    video : str
        Input video path.
    out_dir : str
        The run's folder ``DIR/<run id>``.
    config : dict
        ``Config.to_dict()`` of the configuration for this run.
    run_config : dict
        What the run depends on (:func:`pendtrack.batch.resume.run_config`), kept in done.json.
    models : tuple of str
        Models to fit.
    force : bool
        Recompute every stage.
    discover : bool
        Also run discovery.
    threads : int
        Thread cap inside the worker.
    """

    run_id: str
    video: str
    out_dir: str
    config: dict[str, Any]
    run_config: dict[str, Any]
    models: tuple[str, ...]
    force: bool = False
    discover: bool = False
    threads: int = 1

    def to_dict(self) -> dict[str, Any]:
        """Plain picklable dict for a worker."""
        d = asdict(self)
        d["models"] = list(self.models)
        return d

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> "RunTask":
        """Inverse of :meth:`to_dict`."""
        return cls(**{**d, "models": tuple(d["models"])})


def pipeline_job(video: str, *, out_dir: str, config: Any, models: tuple[str, ...], force: bool,
                 discover: bool) -> str | None:
    """The real per-run job: :func:`pendtrack.stages.run.run_pipeline` (track, angle,
    kinematics, fit, report.html), then discovery if asked.

    A failure of discovery alone (a :class:`~pendtrack.errors.PendtrackError`, e.g. a record
    too short for its held-out test) does not fail the run: it is returned as a note.
    """
    from pendtrack.errors import PendtrackError
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


@contextlib.contextmanager
def run_log(path: Path) -> Iterator[None]:
    """Send this process's log records (WARNING and up) to ``path`` while the block runs.

    Keeps the batch's terminal to its one progress bar: a worker's warnings (a fit that did
    not converge, ...) go to ``DIR/<run id>/run.log`` instead of stderr.
    """
    handler = logging.FileHandler(path, mode="w", encoding="utf-8", delay=True)
    handler.setLevel(logging.WARNING)
    handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s"))
    root = logging.getLogger()
    root.addHandler(handler)
    try:
        yield
    finally:
        root.removeHandler(handler)
        handler.close()


def run_task(job: Callable[..., str | None], task: Mapping[str, Any]) -> dict[str, Any]:
    """Run one task in a worker and write its done marker last; never raises for a run's failure.

    Parameters
    ----------
    job : callable
        Module-level job with the :class:`Job` signature (pickled by reference).
    task : dict
        :meth:`RunTask.to_dict`.

    Returns
    -------
    dict
        ``run_id``, ``status`` (``ok`` | ``failed``), ``reason`` (one line: the error, or the
        job's note for an ok run, else ""),
        ``traceback`` ("" if ok), ``runtime_s``, ``host``, ``pid``.
    """
    t0 = time.perf_counter()
    spec = RunTask.from_dict(task)
    limit_threads(spec.threads)
    out = {"run_id": spec.run_id, "status": "ok", "reason": "", "traceback": "", "host": socket.gethostname(),
           "pid": os.getpid()}
    from pendtrack.batch.resume import LOG_NAME

    run_dir = Path(spec.out_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    with run_log(run_dir / LOG_NAME):
        try:
            from pendtrack.artifacts import file_sha256
            from pendtrack.batch.resume import DONE_NAME, remove_stale_temp_files, write_done
            from pendtrack.config import config_from_dict

            (run_dir / DONE_NAME).unlink(missing_ok=True)  # an old marker must not outlive a redo
            remove_stale_temp_files(run_dir)
            sha = file_sha256(spec.video) if Path(spec.video).is_file() else ""
            config = config_from_dict(spec.config, source="<batch>")
            note = job(spec.video, out_dir=str(run_dir), config=config, models=spec.models, force=spec.force,
                       discover=spec.discover)
            out["reason"] = str(note or "")
            write_done(run_dir, run_id=spec.run_id, video=spec.video, video_sha256=sha, config=spec.run_config,
                       runtime_s=time.perf_counter() - t0,
                       extra={"note": out["reason"], "host": out["host"], "pid": out["pid"]})
        except Exception as exc:  # a failing video is recorded; the batch goes on
            out.update(status="failed", reason=describe_error(exc), traceback=traceback.format_exc())
            logging.getLogger(__name__).error("run %s failed: %s\n%s", spec.run_id, out["reason"], out["traceback"])
    out["runtime_s"] = time.perf_counter() - t0
    return out


def describe_error(exc: BaseException) -> str:
    """One line for the summary: a PendtrackError's own message, else ``Type: message``."""
    from pendtrack.errors import PendtrackError

    text = str(exc) if isinstance(exc, PendtrackError) else f"{type(exc).__name__}: {exc}"
    return " ".join(text.split()) or type(exc).__name__
