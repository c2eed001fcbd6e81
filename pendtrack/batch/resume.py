"""Resuming a batch: the per-run ``done.json`` marker.

A run's folder ``DIR/<run id>/`` gets ``done.json`` last, written atomically after every
artifact of the run: the video's sha256, the configuration the run depended on, the
models, and the sha256 of every artifact the run left. A run is complete (and skipped by
the next batch) only if that marker exists, was made from the same video and config,
and every listed artifact is still there with the same bytes. A run killed half-way has
no marker and is redone; its stages then reuse only complete artifacts (each stage's own
up-to-date check reads the provenance of a file that ``atomic_write`` renamed into place
whole), and stale ``.*.tmp`` files of the killed writer are removed.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pendtrack.artifacts import Provenance, file_sha256, is_up_to_date, read_json_artifact, write_json_artifact
from pendtrack.errors import ArtifactError

DONE_NAME = "done.json"
LOG_NAME = "run.log"  # the worker's log of the run (pendtrack.batch.worker), not an artifact
DONE_KEYS = ("run_id", "video", "video_sha256", "artifacts", "runtime_s")
# Config sections a run depends on (render and batch scheduling do not change its results);
# [discover] too when discovery runs.
RUN_SECTIONS = ("lens", "video", "track", "angle", "kinematics", "models", "fit")


def run_config(config: Mapping[str, Any], *, models: tuple[str, ...], discover: bool) -> dict[str, Any]:
    """What a run's results depend on: the pipeline's config sections, models and discovery.

    Parameters
    ----------
    config : mapping
        ``Config.to_dict()`` of the configuration the run uses.
    models : tuple of str
        Models fitted.
    discover : bool
        Whether discovery runs too.
    """
    sections = RUN_SECTIONS + (("discover",) if discover else ())
    out = {name: dict(config[name]) for name in sections if name in config}
    out["batch_run"] = {"models": list(models), "discover": bool(discover)}
    return out


def list_artifacts(run_dir: str | Path) -> dict[str, str]:
    """Every file a run left in its folder (relative name -> sha256), except the marker, the log
    and temp files."""
    run_dir = Path(run_dir)
    out = {}
    for p in sorted(run_dir.rglob("*")):
        if p.is_file() and p.name not in (DONE_NAME, LOG_NAME) and not p.name.startswith("."):
            out[p.relative_to(run_dir).as_posix()] = file_sha256(p)
    return out


def remove_stale_temp_files(run_dir: str | Path) -> list[Path]:
    """Delete the ``.*.tmp`` files a killed ``atomic_write`` left in a run folder; return them."""
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        return []
    stale = [p for p in run_dir.rglob(".*.tmp") if p.is_file()]
    for p in stale:
        p.unlink(missing_ok=True)
    return stale


def write_done(run_dir: str | Path, *, run_id: str, video: str | Path, video_sha256: str,
               config: Mapping[str, Any], runtime_s: float, extra: Mapping[str, Any] | None = None) -> Path:
    """Write ``done.json`` (atomically, last) listing the run's artifacts and their sha256."""
    run_dir = Path(run_dir)
    payload = {
        "run_id": run_id,
        "video": str(video),
        "video_sha256": video_sha256,
        "artifacts": list_artifacts(run_dir),
        "runtime_s": float(runtime_s),
        **dict(extra or {}),
    }
    prov = Provenance(stage="batch-run", config=config, inputs={Path(video).name: video_sha256})
    return write_json_artifact(payload, run_dir / DONE_NAME, required=DONE_KEYS, provenance=prov)


def read_done(run_dir: str | Path) -> dict[str, Any] | None:
    """The run's ``done.json`` record, or None if absent or unreadable."""
    try:
        return read_json_artifact(Path(run_dir) / DONE_NAME, required=DONE_KEYS)
    except ArtifactError:
        return None


def is_run_complete(run_dir: str | Path, *, video: str | Path, video_sha256: str,
                    config: Mapping[str, Any]) -> bool:
    """True if the run folder holds a finished run of this video and config, every artifact intact.

    Parameters
    ----------
    run_dir : path
        ``DIR/<run id>``.
    video : path
        The input video (only its name is compared; the bytes via ``video_sha256``).
    video_sha256 : str
        sha256 of the video now.
    config : mapping
        :func:`run_config` of the configuration now.
    """
    run_dir = Path(run_dir)
    done = run_dir / DONE_NAME
    if not is_up_to_date(done, "done", inputs={Path(video).name: video_sha256}, config=config):
        return False
    record = read_done(run_dir)
    if record is None or record.get("video_sha256") != video_sha256:
        return False
    artifacts = record.get("artifacts")
    if not isinstance(artifacts, dict) or not artifacts:
        return False
    for name, sha in artifacts.items():
        path = run_dir / name
        if not path.is_file() or file_sha256(path) != sha:
            return False
    return True
