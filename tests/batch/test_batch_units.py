"""Batch building blocks: run codes, folder scanning, done markers, summary frame, scheduler names."""

import json

import numpy as np
import pandas as pd
import pytest

from pendtrack.artifacts import SCHEMAS, Provenance, read_artifact
from pendtrack.batch.executor import check_scheduler, is_dask_address
from pendtrack.parallel import worker_count as local_worker_count
from pendtrack.batch.resume import (
    DONE_NAME,
    is_run_complete,
    remove_stale_temp_files,
    run_config,
    write_done,
)
from pendtrack.batch.runcode import RunCode, RunCodeError, find_videos, parse_run_code, plan_runs
from pendtrack.batch.summary import (
    fit_columns,
    skipped_row,
    summary_frame,
    write_summary,
)
from pendtrack.config import Config
from pendtrack.errors import ConfigError


@pytest.mark.parametrize(
    "name, tile, launched, alley, trial, suffix, run_id",
    [
        ("06na5.mp4", 6, False, True, 5, "", "06na5"),
        ("24LA1.MOV", 24, True, True, 1, "", "24la1"),
        ("00nn12", 0, False, False, 12, "", "00nn12"),
        ("09ln1_take2.mp4", 9, True, False, 1, "take2", "09ln1_take2"),
        ("12NA3-Repeat Two.mkv", 12, False, True, 3, "repeat-two", "12na3_repeat-two"),
        ("03la07.avi", 3, True, True, 7, "", "03la7"),
    ],
)
def test_parse_run_code(name, tile, launched, alley, trial, suffix, run_id):
    code = parse_run_code(name)
    assert (code.tile_cm, code.launched, code.alley, code.trial, code.suffix) == (tile, launched, alley, trial, suffix)
    assert code.run_id == run_id
    assert code.l1_m == pytest.approx(tile / 100)


def test_run_code_kind_matches_table_kindofrun():
    assert [RunCode(tile_cm=6, launched=lo, alley=a, trial=1).kind
            for lo, a in ((True, True), (True, False), (False, True), (False, False))] == ["la", "ln", "na", "nn"]
    assert RunCode(tile_cm=6, launched=False, alley=True, trial=5).code == "06na5"


@pytest.mark.parametrize("name", ["6na5.mp4", "06xa5.mp4", "06nb5.mp4", "06na.mp4", "06na5b.mp4", "run1.mp4",
                                  "x06na5.mp4", "06na5_.mp4"])
def test_non_run_codes_are_rejected_with_reason(name):
    with pytest.raises(RunCodeError, match="is not a run code"):
        parse_run_code(name)


def test_find_videos_and_plan(tmp_path):
    for name in ("06na5.mp4", "06NA05.MOV", "12la1_take2.mp4", "hello.mp4", "notes.txt", ".06nn1.mp4"):
        (tmp_path / name).write_bytes(b"x")
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "03nn1.mp4").write_bytes(b"x")
    videos = find_videos(tmp_path, extensions=(".mp4", ".mov"))
    assert [v.name for v in videos] == ["06NA05.MOV", "06na5.mp4", "12la1_take2.mp4", "hello.mp4"]
    assert [v.name for v in find_videos(tmp_path, extensions=(".mp4",), recursive=True,
                                        exclude=tmp_path / "sub")] == ["06na5.mp4", "12la1_take2.mp4", "hello.mp4"]
    runs, skipped = plan_runs(videos)
    assert [r.run_id for r in runs] == ["06na5", "12la1_take2"]
    assert runs[0].video.name == "06NA05.MOV"  # first in name order wins
    reasons = {s.video.name: s.reason for s in skipped}
    assert "duplicate run id '06na5'" in reasons["06na5.mp4"]
    assert "is not a run code" in reasons["hello.mp4"]


def test_done_marker_detects_changes(tmp_path):
    video = tmp_path / "06na5.mp4"
    video.write_bytes(b"video")
    run_dir = tmp_path / "out" / "06na5"
    run_dir.mkdir(parents=True)
    (run_dir / "track.parquet").write_bytes(b"artifact")
    cfg = run_config(Config().to_dict(), models=("classic",), discover=False)
    from pendtrack.artifacts import file_sha256

    sha = file_sha256(video)
    assert not is_run_complete(run_dir, video=video, video_sha256=sha, config=cfg)  # no marker yet
    write_done(run_dir, run_id="06na5", video=video, video_sha256=sha, config=cfg, runtime_s=1.0)
    assert json.loads((run_dir / DONE_NAME).read_text())["artifacts"] == {"track.parquet": file_sha256(run_dir / "track.parquet")}
    assert is_run_complete(run_dir, video=video, video_sha256=sha, config=cfg)
    # Another config, another video, a changed or missing artifact: not complete.
    other = run_config(Config().replace("fit", n_starts=3).to_dict(), models=("classic",), discover=False)
    assert not is_run_complete(run_dir, video=video, video_sha256=sha, config=other)
    assert not is_run_complete(run_dir, video=video, video_sha256="0" * 64, config=cfg)
    (run_dir / "track.parquet").write_bytes(b"changed")
    assert not is_run_complete(run_dir, video=video, video_sha256=sha, config=cfg)
    (run_dir / "track.parquet").unlink()
    assert not is_run_complete(run_dir, video=video, video_sha256=sha, config=cfg)


def test_run_config_ignores_render_and_batch_sections():
    a = run_config(Config().to_dict(), models=("classic",), discover=False)
    b = run_config(Config().replace("render", seconds=3.0).replace("batch", workers=7).to_dict(),
                   models=("classic",), discover=False)
    assert a == b
    assert a != run_config(Config().to_dict(), models=("classic", "opa"), discover=False)


def test_stale_temp_files_are_removed(tmp_path):
    (tmp_path / ".track.parquet.abc.tmp").write_bytes(b"half")
    (tmp_path / "track.parquet").write_bytes(b"whole")
    assert [p.name for p in remove_stale_temp_files(tmp_path)] == [".track.parquet.abc.tmp"]
    assert [p.name for p in tmp_path.iterdir()] == ["track.parquet"]


def _fit_record(model="classic", omega0=5.2):
    return {"model": model, "params": {"Omega0": {"value": omega0, "stderr": 1e-3, "u_paper": 2e-3},
                                       "C0": {"value": 0.01, "stderr": None, "u_paper": 1e-3}},
            "xi2_min": 1.5, "rms": 0.01, "aic": -10.0, "bic": -8.0, "n": 480, "converged": True,
            "runtime_s": 2.0, "seed": 0}


def test_summary_frame_round_trips_with_nullable_columns(tmp_path):
    code = parse_run_code("06na5")
    ok = {"run_id": "06na5", "file": "06na5.mp4", "status": "ok", "reason": "", "resumed": False,
          "code": "06na5", "kind": "na", "tile_cm": 6, "l1_m": 0.06, "launched": False, "alley": True, "trial": 5,
          "frames": 480, "fps": 120.0, "duration_s": 4.0, "ok_fraction": 1.0, "runtime_s": 3.0,
          "video_sha256": "ab", **fit_columns({"classic": _fit_record()})}
    assert code.run_id == ok["run_id"]
    rows = [ok, skipped_row(video=tmp_path / "hello.mp4", reason="not a run code")]
    df = summary_frame(rows)
    assert list(df.columns[: len(SCHEMAS["summary"].columns)]) == list(SCHEMAS["summary"].names)
    assert df.loc[1, "tile_cm"] is pd.NA and df.loc[1, "classic__converged"] is pd.NA
    assert np.isnan(df.loc[0, "classic__C0__stderr"])
    assert df.columns.get_loc("classic__xi2_min") < df.columns.get_loc("classic__Omega0__value")
    parquet, csv = write_summary(df, tmp_path, provenance=Provenance(stage="batch"))
    back = read_artifact(parquet, "summary").data
    pd.testing.assert_frame_equal(back, df, check_dtype=False)
    assert back["tile_cm"].dtype.kind == "i" and back["launched"].dtype.kind == "b"
    text = pd.read_csv(csv)
    assert list(text.columns) == list(df.columns) and text.loc[0, "classic__Omega0__value"] == 5.2


def test_summary_frame_takes_a_composed_models_columns(tmp_path):
    # `[fit] models = ["classic+angle_gain"]` in a batch: its columns were refused ("not in the summary schema")
    row = {"run_id": "06na5", "file": "06na5.mp4", "status": "ok", "reason": "", "resumed": False,
           **fit_columns({"classic+angle_gain": _fit_record(model="classic+angle_gain")})}
    df = summary_frame([row])
    assert df.loc[0, "classic+angle_gain__Omega0__value"] == 5.2 and df["classic+angle_gain__n"].dtype == "Int64"
    parquet, _ = write_summary(df, tmp_path, provenance=Provenance(stage="batch"))
    assert read_artifact(parquet, "summary").data.loc[0, "classic+angle_gain__xi2_min"] == 1.5


def test_scheduler_names():
    assert check_scheduler("processes") == "processes"
    assert is_dask_address("tcp://127.0.0.1:8786") and is_dask_address("scheduler.lab:8786")
    assert not is_dask_address("processes")
    with pytest.raises(ConfigError, match="scheduler must be"):
        check_scheduler("threads")
    assert local_worker_count(0, 1) == 1 and local_worker_count(3, 10) == 3
    with pytest.raises(ConfigError):
        local_worker_count(-1, 3)


def test_two_cuboid_check_recovers_x_and_l0_from_exact_points():
    # Omega0 from eq. consistencycheck with X = 1.48, l0 = 0.54 m plus seeded noise of 1e-3 rad/s.
    from pendtrack.apparatus import two_cuboid_omega0
    from pendtrack.batch.twocuboid import two_cuboid_check

    rng = np.random.default_rng(0)
    l1 = np.repeat(np.arange(0, 25, 3) / 100, 2)
    w = two_cuboid_omega0(l1, x=1.48, l0=0.54) + rng.normal(0, 1e-3, l1.size)
    df = pd.DataFrame({"run_id": [f"r{i}" for i in range(l1.size)], "kind": "nn", "status": "ok", "l1_m": l1,
                       "classic__Omega0__value": w, "classic__Omega0__stderr": 1e-3,
                       "classic__Omega0__u_paper": 2e-3, "classic__converged": True})
    df.loc[0, "status"] = "failed"  # not used
    check = two_cuboid_check(df, preference=("fractional", "classic"))
    assert check["status"] == "ok" and check["model"] == "classic" and check["n"] == l1.size - 1
    # 3 standard errors: the fit's covariance is absolute (sigma = the points' true noise).
    assert abs(check["X"]["value"] - 1.48) < 3 * check["X"]["stderr"]
    assert abs(check["l0_m"]["value"] - 0.54) < 3 * check["l0_m"]["stderr"]
    assert check["corr_X_l0"] > 0.5 and 0.2 < check["chi2_red"] < 3
    json.dumps(check, allow_nan=False)  # plain JSON, no NaN
    assert two_cuboid_check(df.iloc[:3], preference=("classic",))["status"] == "too few runs"
    assert two_cuboid_check(df.drop(columns="classic__Omega0__value"), preference=("classic",))["status"] == "no Omega0"


def test_discovery_columns_from_discovery_json(tmp_path):
    from pendtrack.artifacts import DISCOVERY_JSON_KEYS, write_json_artifact
    from pendtrack.batch.summary import discovery_columns

    assert discovery_columns(tmp_path) == {}
    rec = {"baseline": "standard", "effects": ["quarter_power", "memory"], "steps": [], "diagnosis": {},
           "final_model": {"model": "standard+quarter_power+memory", "rms": 0.001, "heldout_rms": 0.002},
           "baseline_fit": {"model": "standard", "rms": 0.004, "heldout_rms": None}}
    write_json_artifact(rec, tmp_path / "discovery.json", required=DISCOVERY_JSON_KEYS,
                        provenance=Provenance(stage="discover"))
    cols = discovery_columns(tmp_path)
    assert cols["discover__final_model"] == "standard+quarter_power+memory"
    assert cols["discover__effects"] == "quarter_power+memory" and cols["discover__final_rms"] == 0.001
    assert np.isnan(cols["discover__baseline_heldout_rms"])
    row = {"run_id": "06na5", "file": "06na5.mp4", "status": "ok", **cols}
    df = summary_frame([row])
    assert df["discover__baseline_rms"].dtype == "float64" and df.columns[-1].startswith("discover__")
    write_summary(df, tmp_path, provenance=Provenance(stage="batch"))  # the schema admits them


def test_unreachable_dask_scheduler_is_a_user_error():
    pytest.importorskip("dask.distributed")
    from pendtrack.batch.executor import DaskExecutor
    from pendtrack.errors import PendtrackError

    with pytest.raises(PendtrackError, match="cannot connect to the Dask scheduler at tcp://127.0.0.1:9"):
        DaskExecutor("tcp://127.0.0.1:9", timeout_s=1.0)


@pytest.mark.parametrize("make", ["missing", "no_videos"])
def test_a_campaign_without_videos_fails_before_any_run(tmp_path, make):
    from pendtrack.batch.campaign import BatchError, run_campaign

    folder = tmp_path / "videos"
    if make == "no_videos":
        folder.mkdir()
        (folder / "notes.txt").write_text("x")
    with pytest.raises(BatchError, match="folder not found" if make == "missing" else "no video files"):
        run_campaign(folder, out_dir=tmp_path / "out", config=Config(), job=print)
    assert not (tmp_path / "out").exists()
