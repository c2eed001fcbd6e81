"""Parallel execution in one place: process pools, worker counts and thread limits.

Fitting (multi-start), discovery (candidate fits) and batch (one run per video) all run work
in worker processes. They use this module so that every pool

* starts its workers with the ``spawn`` method (clean children, safe with numba's and
  OpenMP's threads in the parent);
* caps the threads of each worker (BLAS/OpenMP, numba, OpenCV) at ``threads`` (default 1:
  one process per core already): the thread variables (:data:`THREAD_ENV_VARS`) are set in
  this process while the pool can start workers -- a library reads them when it loads, which
  in a spawned child can happen before any initializer runs (unpickling its arguments) --
  and restored when the pool shuts down; each child then applies :func:`limit_threads`
  before its own initializer;
* counts its workers the same way (:func:`worker_count`: 0 = the cores this process may use,
  never more than the tasks).

Importing this module is cheap (no numpy), so a worker can limit its threads before the
numerical libraries load. Layer: just above :mod:`pendtrack.errors` / :mod:`pendtrack.config`.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor
from typing import Any

from pendtrack.errors import ConfigError

THREAD_ENV_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "VECLIB_MAXIMUM_THREADS",
                   "NUMEXPR_NUM_THREADS", "NUMBA_NUM_THREADS")


def usable_cores() -> int:
    """Cores this process may run on (its CPU affinity where the OS reports it) [1]."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def worker_count(workers: int, n_tasks: int | None = None) -> int:
    """Processes to use: ``workers`` (0 = :func:`usable_cores`), at most ``n_tasks``, at least 1.

    Parameters
    ----------
    workers : int
        Requested processes, >= 0 (0 = all usable cores).
    n_tasks : int, optional
        Number of tasks; no more processes than tasks. None: no cap.

    Raises
    ------
    ConfigError
        ``workers < 0``.
    """
    if workers < 0:
        raise ConfigError(f"workers must be >= 0, got {workers}")
    n = workers or usable_cores()
    if n_tasks is not None:
        n = min(n, n_tasks)
    return max(1, n)


def limit_threads(n: int) -> None:
    """Cap the threads of BLAS/OpenMP, numba and OpenCV in this process at ``n``.

    Environment variables only bind libraries loaded later (a pool sets them before it
    starts its workers, see :func:`thread_env`); numba, OpenCV and BLAS pools already loaded
    (threadpoolctl, if installed) are also capped at run time.
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


@contextlib.contextmanager
def thread_env(n: int) -> Iterator[None]:
    """Set the thread variables (:data:`THREAD_ENV_VARS`) to ``n`` while the block runs, then restore them."""
    saved = {v: os.environ.get(v) for v in THREAD_ENV_VARS}
    os.environ.update({v: str(max(1, int(n))) for v in THREAD_ENV_VARS})
    try:
        yield
    finally:
        for var, value in saved.items():
            if value is None:
                os.environ.pop(var, None)
            else:
                os.environ[var] = value


def _init_worker(threads: int, initializer: Callable[..., Any] | None, initargs: tuple[Any, ...]) -> None:
    """Child initializer: thread limits first, then the caller's initializer."""
    limit_threads(threads)
    if initializer is not None:
        initializer(*initargs)


class ProcessPool(ProcessPoolExecutor):
    """A ``spawn`` process pool whose workers run with at most ``threads`` threads each.

    Use :func:`process_pool` to make one. The thread variables stay set in this process
    from creation until :meth:`shutdown` (workers are spawned lazily, on submit), then
    are restored.
    """

    def __init__(self, workers: int, *, threads: int = 1, initializer: Callable[..., Any] | None = None,
                 initargs: tuple[Any, ...] = ()) -> None:
        self.workers = workers
        self.threads = max(1, int(threads))
        self._env: contextlib.AbstractContextManager[None] | None = thread_env(self.threads)
        self._env.__enter__()
        try:
            super().__init__(max_workers=workers, mp_context=multiprocessing.get_context("spawn"),
                             initializer=_init_worker, initargs=(self.threads, initializer, tuple(initargs)))
        except BaseException:
            self._restore_env()
            raise

    def _restore_env(self) -> None:
        env, self._env = self._env, None
        if env is not None:
            env.__exit__(None, None, None)

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        """Shut the pool down (see ``ProcessPoolExecutor.shutdown``), then restore the environment."""
        try:
            super().shutdown(wait=wait, cancel_futures=cancel_futures)
        finally:
            self._restore_env()


def process_pool(workers: int, *, threads: int = 1, initializer: Callable[..., Any] | None = None,
                 initargs: tuple[Any, ...] = ()) -> ProcessPool:
    """A ``spawn`` process pool of ``workers`` processes, each capped at ``threads`` threads.

    Parameters
    ----------
    workers : int
        Number of processes (>= 1; see :func:`worker_count`).
    threads : int
        Thread cap inside each worker (BLAS/OpenMP, numba, OpenCV).
    initializer : callable, optional
        Module-level function run in each worker after the thread limits, with ``initargs``.
    initargs : tuple
        Its (picklable) arguments.

    Returns
    -------
    ProcessPool
        A ``concurrent.futures.ProcessPoolExecutor``; use it as a context manager or call
        ``shutdown()``.
    """
    return ProcessPool(workers, threads=threads, initializer=initializer, initargs=initargs)
