"""What runs inside a batch worker: one run's task around a job, its log and done marker.

Everything here is importable at module level and takes plain picklable arguments (paths
as ``str``, the config as a dict), so the same functions run in a local process pool and on
a Dask cluster. Importing this module is cheap (no numpy), so a worker can limit its
threads (:func:`pendtrack.parallel.limit_threads`) before the numerical libraries load.

The job itself (the pipeline's stages for one video) is passed in by the caller as a
module-level function with the :class:`Job` signature:
:func:`pendtrack.stages.batch_job.pipeline_job` for ``pendtrack batch`` (``batch`` sits below
``stages`` in the import layers and does not import it).
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

from pendtrack.parallel import limit_threads

class Job(Protocol):
    """The per-run job: process one video into a run folder.

    Raises on failure (the run is recorded as failed); may return a one-line note for a
    run that succeeded with a caveat (e.g. discovery could not be done), else None.
    """

    def __call__(self, video: str, *, out_dir: str, config: Any, models: tuple[str, ...], force: bool,
                 discover: bool) -> str | None: ...


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
