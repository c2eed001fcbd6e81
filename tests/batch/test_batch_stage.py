"""The batch machinery with a stand-in job: executors agree, resume, failures, kill, CLI errors.

The stand-in job (module level, so workers import it by name) reads a tiny JSON "video"
and writes a track.parquet and one fit.json per model through the artifact contract, so
these tests exercise scheduling, resuming and summarising in seconds, independent of the
real stages (tests/batch/test_batch_pipeline.py runs those).
"""

import json
import logging
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from pendtrack.artifacts import (
    Provenance,
    inputs_for,
    read_artifact,
    read_json_artifact,
    write_artifact,
    write_json_artifact,
)
from pendtrack.batch.resume import DONE_NAME
from pendtrack.cli import cli
from pendtrack.config import Config
from pendtrack.errors import VideoError
from pendtrack.stages.batch import batch_stage

pytestmark = pytest.mark.integration  # the batch stage and its CLI, worker processes and a killed subprocess

HERE = Path(__file__).resolve().parent


def fake_job(video, *, out_dir, config, models, force, discover):
    """Stand-in for the pipeline: deterministic artifacts from the JSON 'video'."""
    spec = json.loads(Path(video).read_text())
    if "fail" in spec:
        raise VideoError(spec["fail"], path=video)
    if spec.get("die"):
        os._exit(3)  # a worker that dies (native crash, OOM kill)
    out = Path(out_dir)
    n = int(spec["frames"])
    t = np.arange(n) / 120.0
    ok = np.arange(n) % 10 != 0
    track = pd.DataFrame({"frame": np.arange(n), "t": t, "x_px": t, "y_px": t, "x": t, "y": t,
                          "score": np.where(ok, 0.9, 0.1), "ok": ok})
    write_artifact(track, out / "track.parquet", "track",
                   provenance=Provenance(stage="track", config=config.sections("track"), inputs=inputs_for(video),
                                         extra={"fps": 120.0}))
    time.sleep(float(spec.get("sleep", 0.0)))
    for model in models:
        rec = {"model": model, "params": {"Omega0": {"value": spec["omega0"], "stderr": 1e-3, "u_paper": 2e-3},
                                          "C0": {"value": 0.01 * n, "stderr": 1e-4, "u_paper": 3e-4}},
               "xi2_min": 1.0 + n / 1000, "rms": 0.01, "aic": -5.0, "bic": -4.0, "n": n, "converged": True,
               "runtime_s": 0.5, "seed": config.fit.seed}
        write_json_artifact(rec, out / f"fit_{model}.json", required=("model", "params"),
                            provenance=Provenance(stage="fit", config=config.sections("fit")))


def make_folder(folder, specs):
    folder.mkdir(parents=True, exist_ok=True)
    for name, spec in specs.items():
        (folder / name).write_text(json.dumps(spec))
    return folder


GOOD = {
    "00nn1.mp4": {"frames": 240, "omega0": 5.22},
    "06na5.mp4": {"frames": 300, "omega0": 5.18},
    "12la1.mp4": {"frames": 360, "omega0": 5.14},
    "24ln2_take2.mp4": {"frames": 420, "omega0": 5.07},
}
CFG = Config().replace("fit", models=("classic",), n_starts=2)
VOLATILE = ["runtime_s", "classic__runtime_s", "resumed"]


def test_processes_and_dask_give_the_same_summary(tmp_path):
    distributed = pytest.importorskip("dask.distributed")
    folder = make_folder(tmp_path / "videos", GOOD)
    local = batch_stage(folder, out_dir=tmp_path / "local", config=CFG, workers=2, progress=False, job=fake_job)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                  silence_logs=logging.ERROR) as cluster:
        remote = batch_stage(folder, out_dir=tmp_path / "dask", config=CFG, scheduler=cluster.scheduler_address,
                             progress=False, job=fake_job)
    a = read_artifact(local.summary, "summary").data.drop(columns=VOLATILE)
    b = read_artifact(remote.summary, "summary").data.drop(columns=VOLATILE)
    pd.testing.assert_frame_equal(a, b)
    assert list(a["run_id"]) == ["00nn1", "06na5", "12la1", "24ln2_take2"]
    assert a["status"].eq("ok").all() and list(a["tile_cm"]) == [0, 6, 12, 24]
    assert list(a["kind"]) == ["nn", "na", "la", "ln"]
    assert a["frames"].tolist() == [240, 300, 360, 420] and np.allclose(a["ok_fraction"], 0.9)
    assert np.allclose(a["duration_s"], a["frames"] / 120.0)
    assert a["classic__Omega0__value"].tolist() == [5.22, 5.18, 5.14, 5.07]
    # The Dask workers really ran the runs (their pids differ from the local pool's).
    hosts = {read_json_artifact(tmp_path / "dask" / r / DONE_NAME, required=("pid",))["pid"] for r in a["run_id"]}
    assert os.getpid() not in hosts


def test_rerun_skips_complete_runs_and_redoes_changed_ones(tmp_path):
    folder = make_folder(tmp_path / "videos", dict(list(GOOD.items())[:3]))
    out = tmp_path / "out"
    first = batch_stage(folder, out_dir=out, config=CFG, workers=1, progress=False, job=fake_job)
    assert first.counts == {"videos": 3, "runs": 3, "ok": 3, "resumed": 0, "failed": 0, "skipped": 0}
    mtimes = {p: p.stat().st_mtime_ns for p in out.rglob("*") if p.is_file() and p.parent != out}
    again = batch_stage(folder, out_dir=out, config=CFG, workers=1, progress=False, job=fake_job)
    assert again.counts["resumed"] == 3
    assert {p: p.stat().st_mtime_ns for p in mtimes} == mtimes  # nothing recomputed
    summary = read_artifact(again.summary, "summary").data
    assert summary["resumed"].all() and summary["classic__Omega0__value"].notna().all()
    # A changed video and a changed config are redone; a deleted artifact too.
    (folder / "06na5.mp4").write_text(json.dumps({"frames": 310, "omega0": 5.19}))
    (out / "12la1" / "fit_classic.json").unlink()
    third = batch_stage(folder, out_dir=out, config=CFG, workers=1, progress=False, job=fake_job)
    assert [r.resumed for r in third.runs] == [True, False, False]
    fourth = batch_stage(folder, out_dir=out, config=CFG.replace("fit", seed=1), workers=1, progress=False,
                         job=fake_job)
    assert fourth.counts["resumed"] == 0


def test_failures_and_bad_names_are_reported_and_the_rest_succeeds(tmp_path):
    specs = {**dict(list(GOOD.items())[:2]), "12nn1.mp4": {"fail": "cannot decode: moov atom not found"},
             "hello.mp4": {"frames": 10, "omega0": 1.0}, "notes.txt": {}}
    folder = make_folder(tmp_path / "videos", specs)
    res = batch_stage(folder, out_dir=tmp_path / "out", config=CFG, workers=2, progress=False, job=fake_job)
    assert res.counts == {"videos": 4, "runs": 3, "ok": 2, "resumed": 0, "failed": 1, "skipped": 1}
    df = read_artifact(res.summary, "summary").data.set_index("file")
    assert df.loc["12nn1.mp4", "status"] == "failed"
    assert "12nn1.mp4: cannot decode: moov atom not found" in df.loc["12nn1.mp4", "reason"]
    assert df.loc["12nn1.mp4", "tile_cm"] == 12 and pd.isna(df.loc["12nn1.mp4", "frames"])
    assert df.loc["hello.mp4", "status"] == "skipped" and "is not a run code" in df.loc["hello.mp4", "reason"]
    assert (df.loc[["00nn1.mp4", "06na5.mp4"], "status"] == "ok").all()
    assert not (tmp_path / "out" / "12nn1" / DONE_NAME).exists()
    assert "moov atom not found" in (tmp_path / "out" / "12nn1" / "run.log").read_text()  # worker log, not stderr
    batch = json.loads(res.batch_json.read_text())
    assert batch["failures"][0]["run_id"] == "12nn1" and "VideoError" in batch["failures"][0]["traceback"]
    assert batch["skipped"] == [{"file": "hello.mp4", "reason": df.loc["hello.mp4", "reason"]}]
    assert batch["groups"]["kind"]["nn"] == {"runs": 2, "ok": 1, "failed": 1}
    assert batch["two_cuboid"]["status"] == "too few runs"
    assert pd.read_csv(res.summary_csv).shape[0] == 4
    assert res.report == tmp_path / "out" / "report.html" and res.report.is_file()  # the report engineer's page


def test_a_dying_worker_is_recorded_as_failed(tmp_path):
    folder = make_folder(tmp_path / "videos", {"00nn1.mp4": {"frames": 50, "omega0": 5.2},
                                               "03nn1.mp4": {"die": True}})
    res = batch_stage(folder, out_dir=tmp_path / "out", config=CFG, workers=1, progress=False, job=fake_job)
    by_id = {r.run_id: r for r in res.runs}
    assert by_id["03nn1"].status == "failed" and "worker lost" in by_id["03nn1"].reason
    assert read_artifact(res.summary, "summary").data.shape[0] == 2


def test_the_campaign_plans_runs_and_summarises_and_leaves_the_batch_files_to_the_stage(tmp_path):
    from contextlib import contextmanager

    from pendtrack.artifacts import file_sha256
    from pendtrack.batch.campaign import run_campaign
    from pendtrack.stages.batch import BATCH_JSON_KEYS

    specs = {**dict(list(GOOD.items())[:2]), "12nn1.mp4": {"fail": "cannot decode"},
             "hello.mp4": {"frames": 10, "omega0": 1.0}}
    folder = make_folder(tmp_path / "videos", specs)
    out = tmp_path / "out"
    ticks = []

    @contextmanager
    def progress(total):
        ticks.append(("open", total))
        yield ticks.append

    camp = run_campaign(folder, out_dir=out, config=CFG, job=fake_job, workers=1, progress=progress)
    assert ticks[0] == ("open", 3) and ticks[1:] == [1, 1, 1]
    assert [r.run_id for r in camp.planned] == [r.run_id for r in camp.runs] == ["00nn1", "06na5", "12nn1"]
    assert [r.status for r in camp.runs] == ["ok", "ok", "failed"] and "cannot decode" in camp.runs[2].reason
    assert camp.counts == {"videos": 4, "runs": 3, "ok": 2, "resumed": 0, "failed": 1, "skipped": 1}
    assert [s.video.name for s in camp.skipped] == ["hello.mp4"]
    assert camp.inputs == {n: file_sha256(folder / n) for n in ("00nn1.mp4", "06na5.mp4")}
    assert list(camp.summary["file"]) == ["00nn1.mp4", "06na5.mp4", "12nn1.mp4", "hello.mp4"]
    assert camp.summary["classic__Omega0__value"].iloc[:2].tolist() == [5.22, 5.18]
    assert camp.groups["kind"]["nn"] == {"runs": 2, "ok": 1, "failed": 1}
    assert camp.two_cuboid["status"] == "too few runs"
    assert camp.config.fit.workers == CFG.batch.inner_workers and camp.models == ("classic",)
    assert set(BATCH_JSON_KEYS) <= set(camp.to_dict()) and camp.to_dict()["failures"][0]["run_id"] == "12nn1"
    assert sorted(p.name for p in out.iterdir()) == ["00nn1", "06na5", "12nn1"]  # no summary, batch.json, report
    again = run_campaign(folder, out_dir=out, config=CFG, job=fake_job, workers=1)
    assert [r.resumed for r in again.runs] == [True, True, False]


KILL_SCRIPT = """
import sys
sys.path.insert(0, {here!r})
from test_batch_stage import fake_job, CFG
from pendtrack.stages.batch import batch_stage
batch_stage({folder!r}, out_dir={out!r}, config=CFG, workers=1, progress=False, job=fake_job)
"""


def test_killed_batch_resumes_without_redoing_finished_runs(tmp_path):
    specs = {name: {**spec, "sleep": 1.0} for name, spec in GOOD.items()}
    folder = make_folder(tmp_path / "videos", specs)
    out = tmp_path / "out"
    script = KILL_SCRIPT.format(here=str(HERE), folder=str(folder), out=str(out))
    proc = subprocess.Popen([sys.executable, "-c", script], start_new_session=True)
    first_done = out / "00nn1" / DONE_NAME
    deadline = time.monotonic() + 120
    while not first_done.exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)  # the batch and its workers, mid-way
    proc.wait()
    assert first_done.exists() and not (out / "summary.parquet").exists()
    finished = {p: p.stat().st_mtime_ns for p in (out / "00nn1").iterdir()}
    res = batch_stage(folder, out_dir=out, config=CFG, workers=1, progress=False, job=fake_job)
    assert res.counts["ok"] == 4 and [r.resumed for r in res.runs][0]
    assert {p: p.stat().st_mtime_ns for p in finished} == finished
    assert not list(out.rglob("*.tmp"))
    for p in out.rglob("*.parquet"):
        read_artifact(p, "summary" if p.name == "summary.parquet" else "track")


@pytest.mark.parametrize("make", ["missing", "empty", "no_videos"])
def test_bad_folder_is_one_line_error_exit_2(tmp_path, make):
    folder = tmp_path / "videos"
    if make != "missing":
        folder.mkdir()
    if make == "no_videos":
        (folder / "readme.txt").write_text("x")
    res = CliRunner().invoke(cli, ["batch", str(folder), "--out", str(tmp_path / "out")])
    assert res.exit_code == 2
    lines = [line for line in res.output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith(f"error: {folder}: "), res.output


def test_bad_scheduler_is_one_line_error_exit_2(tmp_path):
    folder = make_folder(tmp_path / "videos", {"00nn1.mp4": {}})
    res = CliRunner().invoke(cli, ["batch", str(folder), "--scheduler", "threads", "--out", str(tmp_path)])
    assert res.exit_code == 2 and res.output.startswith("error: scheduler must be")


def threads_job(video, *, out_dir, config, models, force, discover):
    """Records the thread limits a worker runs under (as the run's only artifact)."""
    import cv2
    import numba

    facts = {"cv2": cv2.getNumThreads(), "numba": numba.get_num_threads(),
             "env": {v: os.environ.get(v) for v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")},
             "fit_workers": config.fit.workers}
    Path(out_dir, "threads.json").write_text(json.dumps(facts))


def test_workers_are_single_threaded(tmp_path):
    from pendtrack.parallel import THREAD_ENV_VARS

    folder = make_folder(tmp_path / "videos", {"00nn1.mp4": {}, "03nn1.mp4": {}})
    env_before = {v: os.environ.get(v) for v in THREAD_ENV_VARS}
    res = batch_stage(folder, out_dir=tmp_path / "out", config=CFG, workers=2, progress=False, job=threads_job)
    assert {v: os.environ.get(v) for v in THREAD_ENV_VARS} == env_before  # the parent's env is restored
    assert res.counts["ok"] == 2
    for run in ("00nn1", "03nn1"):
        facts = json.loads((tmp_path / "out" / run / "threads.json").read_text())
        assert facts == {"cv2": 1, "numba": 1, "env": dict.fromkeys(("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS",
                                                                     "MKL_NUM_THREADS"), "1"), "fit_workers": 1}


def test_unknown_model_is_one_line_error_exit_2(tmp_path):
    folder = make_folder(tmp_path / "videos", {"00nn1.mp4": {}})
    res = CliRunner().invoke(cli, ["batch", str(folder), "--models", "classic,nosuch", "--out", str(tmp_path / "o")])
    assert res.exit_code == 2 and res.output.startswith("error: ") and "nosuch" in res.output
    assert len(res.output.strip().splitlines()) == 1 and not (tmp_path / "o").exists()
