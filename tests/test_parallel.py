"""pendtrack.parallel: worker counts, thread limits, spawn pools with single-threaded workers."""

from __future__ import annotations

import ast
import os
from pathlib import Path

import pytest

from pendtrack.errors import ConfigError
from pendtrack.parallel import THREAD_ENV_VARS, process_pool, thread_env, usable_cores, worker_count


def test_worker_count():
    assert worker_count(0) == usable_cores() >= 1
    assert worker_count(0, 1) == 1 and worker_count(3, 10) == 3 and worker_count(5, 2) == 2
    assert worker_count(2, 0) == 1  # never fewer than one process
    with pytest.raises(ConfigError, match="workers must be >= 0"):
        worker_count(-1)


def test_thread_env_sets_and_restores():
    before = {v: os.environ.get(v) for v in THREAD_ENV_VARS}
    with thread_env(3):
        assert all(os.environ[v] == "3" for v in THREAD_ENV_VARS)
    assert {v: os.environ.get(v) for v in THREAD_ENV_VARS} == before


def _facts(tag: str) -> dict:
    import cv2
    import numba

    return {"tag": tag, "env": {v: os.environ.get(v) for v in THREAD_ENV_VARS}, "cv2": cv2.getNumThreads(),
            "numba": numba.get_num_threads(), "init": os.environ.get("PENDTRACK_TEST_INIT")}


def _init(value: str) -> None:
    os.environ["PENDTRACK_TEST_INIT"] = value


@pytest.mark.integration
def test_pool_workers_are_single_threaded_and_initialised():
    before = {v: os.environ.get(v) for v in THREAD_ENV_VARS}
    with process_pool(2, initializer=_init, initargs=("yes",)) as pool:
        facts = [f.result() for f in [pool.submit(_facts, str(i)) for i in range(2)]]
    assert {v: os.environ.get(v) for v in THREAD_ENV_VARS} == before  # restored at shutdown
    for f in facts:
        assert f["env"] == dict.fromkeys(THREAD_ENV_VARS, "1")
        assert f["cv2"] == 1 and f["numba"] == 1 and f["init"] == "yes"


def _imports(path: Path) -> set[str]:
    """Every module a file imports, function-level imports included."""
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module)
    return names


def test_batch_and_parallel_stay_in_their_layers():
    # batch sits below stages (the per-run job lives in stages.batch_job); parallel below all
    # but errors/config/progress.
    root = Path(__file__).resolve().parents[1] / "pendtrack"
    for path in (root / "batch").glob("*.py"):
        assert not any(m.startswith("pendtrack.stages") for m in _imports(path)), path.name
    allowed = {"pendtrack.errors", "pendtrack.config", "pendtrack.progress"}
    assert {m for m in _imports(root / "parallel.py") if m.startswith("pendtrack")} <= allowed
