"""Where the runs execute: local worker processes or a Dask cluster, same results either way.

``scheduler="processes"`` (the default) starts a process pool
(:func:`pendtrack.parallel.process_pool`: ``spawn`` start method, so each worker starts clean
with its thread limits already in the environment); nothing else needs to run. A Dask
scheduler address (``tcp://HOST:PORT``) submits the runs to that cluster with
``dask.distributed.Client(address).submit`` and collects them with ``as_completed``; the workers must have pendtrack installed and see the
videos and the output folder under the same paths (a shared file system), and should run
one thread each (``dask worker ADDRESS --nthreads 1``).
"""

from __future__ import annotations

import contextlib
import logging
import re
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Future, as_completed
from typing import Any

from pendtrack.errors import ConfigError, PendtrackError
from pendtrack.parallel import process_pool, worker_count

log = logging.getLogger(__name__)

_ADDRESS_RE = re.compile(r"^(?:(?:tcp|tls|ws|wss|ucx|inproc)://)?[^\s/]+:\d+/?$")


def is_dask_address(scheduler: str) -> bool:
    """True for a Dask scheduler address (``tcp://HOST:PORT`` or ``HOST:PORT``)."""
    return scheduler != "processes" and bool(_ADDRESS_RE.match(scheduler))


def check_scheduler(scheduler: str) -> str:
    """Return ``scheduler`` if it is ``processes`` or a Dask address, else raise :class:`ConfigError`."""
    if scheduler == "processes" or is_dask_address(scheduler):
        return scheduler
    raise ConfigError(f"scheduler must be 'processes' or a Dask scheduler address like tcp://HOST:8786, "
                      f"got {scheduler!r}")


class LocalExecutor:
    """Local worker processes (:func:`pendtrack.parallel.process_pool`: ``spawn``), each capped at
    ``threads`` threads."""

    def __init__(self, workers: int, threads: int) -> None:
        self.workers = workers
        self.threads = threads
        self._pool = process_pool(workers, threads=threads)

    def submit(self, fn: Callable[..., Any], *args: Any) -> Future:
        """Start ``fn(*args)`` in a worker; a ``concurrent.futures.Future``."""
        return self._pool.submit(fn, *args)

    def as_completed(self, futures: Sequence[Future]) -> Iterator[Future]:
        """The futures in the order they finish."""
        return as_completed(futures)

    def close(self) -> None:
        """Wait for the workers to exit (pending runs cancelled) and restore the environment."""
        self._pool.shutdown(wait=True, cancel_futures=True)

    def describe(self) -> str:
        """One line for the log."""
        return f"{self.workers} local worker process(es), {self.threads} thread(s) each"


class DaskExecutor:
    """A running Dask cluster, reached through its scheduler address."""

    def __init__(self, address: str, *, timeout_s: float = 20.0) -> None:
        try:
            from dask.distributed import Client
        except ImportError:
            raise PendtrackError("a Dask scheduler was given but dask.distributed is not installed "
                                 "(pip install 'pendtrack[dask]')") from None
        try:
            self._client = Client(address, timeout=f"{timeout_s}s", set_as_default=False)
        except (OSError, TimeoutError) as exc:
            raise PendtrackError(f"cannot connect to the Dask scheduler at {address} ({exc})") from None
        self.address = address

    def submit(self, fn: Callable[..., Any], *args: Any) -> Any:
        """Submit ``fn(*args)`` to the cluster (never cached: ``pure=False``); a Dask future."""
        return self._client.submit(fn, *args, pure=False, retries=0)

    def as_completed(self, futures: Sequence[Any]) -> Iterator[Any]:
        """The futures in the order they finish."""
        from dask.distributed import as_completed as dask_as_completed

        return iter(dask_as_completed(futures, loop=self._client.loop))

    def close(self) -> None:
        """Disconnect (the cluster keeps running)."""
        self._client.close()

    def describe(self) -> str:
        """One line for the log."""
        n = len(self._client.scheduler_info(n_workers=-1).get("workers", {}))
        return f"Dask cluster at {self.address} ({n} worker(s))"


@contextlib.contextmanager
def open_executor(scheduler: str, *, workers: int, threads: int, n_tasks: int) -> Iterator[Any]:
    """The executor for ``scheduler``: :class:`LocalExecutor` or :class:`DaskExecutor`, closed on exit."""
    check_scheduler(scheduler)
    ex: LocalExecutor | DaskExecutor
    if scheduler == "processes":
        ex = LocalExecutor(worker_count(workers, n_tasks), threads)
    else:
        ex = DaskExecutor(scheduler)
    log.info("batch on %s", ex.describe())
    try:
        yield ex
    finally:
        ex.close()


def execute(fn: Callable[..., Any], argsets: Sequence[tuple[Any, ...]], *, scheduler: str = "processes",
            workers: int = 0, threads: int = 1) -> Iterator[tuple[int, Any]]:
    """Run ``fn(*args)`` for every argument tuple; yield ``(index, result)`` as each finishes.

    Parameters
    ----------
    fn : callable
        Module-level function (pickled by reference to the workers).
    argsets : sequence of tuple
        Plain picklable arguments, one tuple per call.
    scheduler : str
        ``processes`` or a Dask scheduler address.
    workers : int
        Local processes (0 = all cores); ignored for Dask.
    threads : int
        Thread cap inside each local worker.

    Yields
    ------
    (int, object)
        The call's index in ``argsets`` and its return value, or the exception that the
        executor raised for it (a worker that died, a lost connection).
    """
    if not argsets:
        return
    with open_executor(scheduler, workers=workers, threads=threads, n_tasks=len(argsets)) as ex:
        futures = [ex.submit(fn, *args) for args in argsets]
        index = {id(f): i for i, f in enumerate(futures)}
        for fut in ex.as_completed(futures):
            try:
                result: Any = fut.result()
            except Exception as exc:  # executor failure for this call; the others go on
                result = exc
            yield index[id(fut)], result
