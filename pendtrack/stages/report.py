"""`report` stage: a run or batch folder -> ``report.html``, one self-contained page.

:func:`report_stage` is what ``pendtrack report DIR`` calls; it decides whether DIR is a batch
(summary.parquet / summary.csv / batch.json) or a run (any run artifact) and skips the work
when the page is up to date (same input files, same pendtrack version, same config). Other
stages call :func:`write_run_report` and :func:`write_batch_report` at their end; those always
write.

The page embeds its provenance (inputs' sha256, config, version, time) in a
``<script type="application/json">`` element, which is also what the up-to-date check reads.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

from pendtrack.artifacts import Provenance, atomic_write, file_sha256
from pendtrack.config import Config
from pendtrack.errors import ArtifactError
from pendtrack.progress import progress_bar
from pendtrack.stages import StageOutput

log = logging.getLogger(__name__)

REPORT_NAME = "report.html"
CONFIG_SECTIONS = ("kinematics",)  # fallbacks the run report may use when an artifact does not record them


def _provenance(kind: str, inputs: dict[str, str], config: Config,
                extra: dict[str, Any] | None = None) -> dict[str, Any]:
    prov = Provenance(stage="report", config=config.sections(*CONFIG_SECTIONS), inputs=inputs,
                      extra={"kind": kind, **(extra or {})})
    return prov.to_dict()


def _is_up_to_date(path: Path, record: dict[str, Any]) -> bool:
    from pendtrack.report.html import read_provenance

    if not path.is_file():
        return False
    try:
        old = read_provenance(path.read_text(encoding="utf-8", errors="replace"))
    except OSError:
        return False
    if old is None:
        return False
    keys = ("version", "inputs", "config", "extra")
    return all(old.get(k) == record.get(k) for k in keys)


def _write(path: Path, text: str) -> Path:
    def write(tmp: Path) -> None:
        tmp.write_text(text, encoding="utf-8")
        tmp.chmod(0o644)  # a page to open and share: readable like any document, not 0600 like a temp file

    return atomic_write(path, write)


def _check_dir(folder: str | Path) -> Path:
    folder = Path(folder)
    if not folder.exists():
        raise ArtifactError("folder not found", path=folder)
    if not folder.is_dir():
        raise ArtifactError("not a folder (give a run or batch output folder)", path=folder)
    return folder


def _run_inputs(run_dir: Path) -> dict[str, str]:
    from pendtrack.report.load import run_files

    return {p.name: file_sha256(p) for p in run_files(run_dir)}


def _batch_inputs(batch_dir: Path) -> tuple[dict[str, str], list[str]]:
    from pendtrack.report.load import BATCH_JSON, SUMMARY_CSV, SUMMARY_PARQUET

    inputs = {n: file_sha256(batch_dir / n) for n in (SUMMARY_PARQUET, SUMMARY_CSV, BATCH_JSON)
              if (batch_dir / n).is_file()}
    linked = sorted(p.parent.name for p in batch_dir.glob(f"*/{REPORT_NAME}") if p.is_file())
    return inputs, linked


def _render_run(run_dir: Path, out: Path, *, config: Config, inputs: dict[str, str], progress: bool) -> Path:
    from pendtrack.report.html import render_page
    from pendtrack.report.load import load_run
    from pendtrack.report.run_report import build_run_page, count_figures

    run = load_run(run_dir)
    if run.empty:
        detail = f" ({'; '.join(run.problems)})" if run.problems else ""
        raise ArtifactError(f"nothing to report: no readable run artifact (track.parquet, angle.parquet, "
                            f"kinematics.parquet, fit.json, discovery.json){detail}", path=run_dir)
    record = _provenance("run", inputs, config)
    with progress_bar(count_figures(run), f"report {run.name}", enabled=progress) as advance:
        page = build_run_page(run, config=config, provenance=record, on_progress=advance)
    return _write(out, render_page(page))


def _render_batch(batch_dir: Path, out: Path, *, config: Config, inputs: dict[str, str], linked: list[str],
                  progress: bool) -> Path:
    from pendtrack.report.batch_report import build_batch_page, count_figures
    from pendtrack.report.html import render_page
    from pendtrack.report.load import load_batch

    batch = load_batch(batch_dir)
    if batch.empty:
        detail = f" ({'; '.join(batch.problems)})" if batch.problems else ""
        raise ArtifactError(f"nothing to report: summary.parquet, summary.csv and batch.json are all unreadable"
                            f"{detail}", path=batch_dir)
    record = _provenance("batch", inputs, config, {"linked_reports": linked})
    with progress_bar(count_figures(batch), "report batch", enabled=progress) as advance:
        page = build_batch_page(batch, out_dir=out.parent, provenance=record, on_progress=advance)
    return _write(out, render_page(page))


def write_run_report(run_dir: str | Path, *, out_dir: str | Path | None = None, config: Config | None = None,
                     progress: bool = False) -> Path:
    """Write ``report.html`` for a run folder (always; no up-to-date check) and return its path.

    Parameters
    ----------
    run_dir : path
        A run's output folder (track.parquet, ..., fit files, discovery.json).
    out_dir : path, optional
        Where to write report.html; default ``run_dir``.
    config : Config, optional
        Fallbacks for facts the artifacts do not record; default the paper's defaults.
    progress : bool
        Progress bar on stderr.

    Raises
    ------
    ArtifactError
        The folder does not exist or holds nothing to report.
    """
    run_dir = _check_dir(run_dir)
    out = Path(out_dir or run_dir) / REPORT_NAME
    return _render_run(run_dir, out, config=config or Config(), inputs=_run_inputs(run_dir), progress=progress)


def write_batch_report(batch_dir: str | Path, *, out_dir: str | Path | None = None, config: Config | None = None,
                       progress: bool = False) -> Path:
    """Write ``report.html`` for a batch folder (always) and return its path.

    The run reports it links to are the ones found in ``batch_dir/<run id>/report.html``;
    ``report_stage`` on a batch folder also writes the missing ones.

    Raises
    ------
    ArtifactError
        The folder does not exist or holds no readable summary or batch.json.
    """
    batch_dir = _check_dir(batch_dir)
    out = Path(out_dir or batch_dir) / REPORT_NAME
    inputs, linked = _batch_inputs(batch_dir)
    return _render_batch(batch_dir, out, config=config or Config(), inputs=inputs, linked=linked, progress=progress)


def _run_dirs(batch_dir: Path) -> list[Path]:
    from pendtrack.report.load import run_files

    return sorted(p for p in batch_dir.iterdir() if p.is_dir() and run_files(p))


def report_stage(run_or_batch_dir: str | Path, *, out_dir: str | Path | None = None, config: Config,
                 force: bool = False, progress: bool = True) -> StageOutput:
    """Write (or find up to date) the report of a run or a batch folder.

    Parameters
    ----------
    run_or_batch_dir : path
        A run folder (from ``pendtrack run``) or a batch folder (from ``pendtrack batch``).
    out_dir : path, optional
        Folder for report.html; default the input folder.
    config : Config
        Fallbacks for facts the artifacts do not record.
    force : bool
        Rewrite even if up to date.
    progress : bool
        Progress bars on stderr.

    Returns
    -------
    StageOutput
        ``paths[0]`` is the report; for a batch, the run reports written or found follow.
        ``facts``: ``kind`` (run | batch), and for a batch ``run_reports`` written.

    Raises
    ------
    ArtifactError
        The folder does not exist, or holds neither run artifacts nor a batch summary.
    """
    from pendtrack.report.load import is_batch_dir, run_files

    folder = _check_dir(run_or_batch_dir)
    out = Path(out_dir or folder) / REPORT_NAME
    if is_batch_dir(folder):
        run_paths, written = [], 0
        for run_dir in _run_dirs(folder):
            sub = report_stage(run_dir, config=config, force=force, progress=progress)
            run_paths.append(sub.path)
            written += not sub.skipped
        inputs, linked = _batch_inputs(folder)
        record = _provenance("batch", inputs, config, {"linked_reports": linked})
        facts = {"kind": "batch", "run_reports": written}
        if not force and _is_up_to_date(out, record):
            return StageOutput((out, *run_paths), skipped=True, facts=facts)
        path = _render_batch(folder, out, config=config, inputs=inputs, linked=linked, progress=progress)
        return StageOutput((path, *run_paths), facts=facts)
    if not run_files(folder):
        raise ArtifactError("nothing to report: neither run artifacts (track.parquet, angle.parquet, "
                            "kinematics.parquet, fit.json, discovery.json) nor a batch summary "
                            "(summary.parquet, summary.csv, batch.json)", path=folder)
    inputs = _run_inputs(folder)
    if not force and _is_up_to_date(out, _provenance("run", inputs, config)):
        return StageOutput((out,), skipped=True, facts={"kind": "run"})
    path = _render_run(folder, out, config=config, inputs=inputs, progress=progress)
    return StageOutput((path,), facts={"kind": "run"})
