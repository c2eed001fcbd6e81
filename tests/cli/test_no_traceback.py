"""No traceback on any input tried (issue #15): `track`, `angle` and `run` over the failure
modes of footage and flags.

Each invocation either works (exit 0) or prints one line ``error: ...`` naming the file, a
flag or a config key, and exits 2; never a traceback, never a partial artifact (every
Parquet file left in the output folder reads back whole, and none of the stage that failed).
Videos are small synthetic swings (``tests/data/make_test_videos.py``) and lens renders.
"""

import re
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from factory import write_swing_video

from pendtrack.artifacts import read_artifact
from pendtrack.cli import cli

pytestmark = [pytest.mark.video, pytest.mark.integration]  # `track`, `angle` and `run` on videos through the CLI


FLAG_OR_KEY = r"--[a-z]|\[[a-z]+\]|'[a-z]+\.[a-z_]+'"
ARTIFACT_KIND = {"track.parquet": "track", "angle.parquet": "angle", "kinematics.parquet": "kinematics",
                 "fit.parquet": "fit"}
# `run` fits one model with two starts: the fit is not what is tested here
FAST_FIT = '[fit]\nmodels = ["classic"]\nn_starts = 2\nworkers = 1\nprofile = false\n'

# video name -> write_swing_video arguments (160x120, 60 fps)
IN_FRAME = {"pivot": (80.0, 30.0), "arm": 60.0}
VIDEOS = {
    "never_visible": {"n_frames": 30, "hide": (0, 30), **IN_FRAME},
    "static": {"n_frames": 30, "amplitude": 0.0, **IN_FRAME},
    "one_frame": {"n_frames": 1, **IN_FRAME},
    "few_frames": {"n_frames": 6, **IN_FRAME},
    "pivot_out_of_frame": {"n_frames": 40, "pivot": (80.0, -150.0), "arm": 230.0, "amplitude": 0.25},
    "leaves_the_frame": {"n_frames": 60, "pivot": (140.0, 20.0), "arm": 70.0, "amplitude": 1.3},
    "good": {"n_frames": 90, "amplitude": 1.0, "period_s": 1.0, **IN_FRAME},
}


@pytest.fixture(scope="module")
def videos(tmp_path_factory):
    d = tmp_path_factory.mktemp("fuzz")
    out = {}
    for name, kw in VIDEOS.items():
        out[name] = d / f"{name}.mp4"
        write_swing_video(out[name], width=160, height=120, radius=6.0, **kw)
    (d / "empty.mp4").write_bytes(b"")
    (d / "corrupt.mp4").write_bytes(np.random.default_rng(0).integers(0, 256, 5000, dtype=np.uint8).tobytes())
    good = out["good"].read_bytes()
    (d / "truncated.mp4").write_bytes(good[: len(good) // 3])
    (d / "notes.txt").write_text("not a video\n")
    (d / "a_folder.mp4").mkdir()
    (d / "fast.toml").write_text(FAST_FIT)
    for name in ("empty", "corrupt", "truncated", "notes", "a_folder", "missing"):
        out[name] = d / {"notes": "notes.txt", "missing": "missing.mp4"}.get(name, f"{name}.mp4")
    out["config"] = d / "fast.toml"
    return out


def _check(res, out: Path, *, failed_kinds: tuple[str, ...], names: tuple[str, ...]) -> None:
    """Exit 0, 1 (a fit flagged, every file written), or exit 2 with one line ``error: ...`` naming one of
    ``names``; no traceback; whole artifacts."""
    text = res.output
    assert "Traceback" not in text, text
    if res.exception is not None and not isinstance(res.exception, SystemExit):
        raise AssertionError(f"uncaught {type(res.exception).__name__}: {res.exception}")
    # 1 (issue #15, the exit rule of `fit` and `run`): every file written, a fit not converged or flagged
    assert res.exit_code in (0, 1, 2), (res.exit_code, text)
    if res.exit_code == 1:
        assert (out / "fit.json").exists() and "warning: the " in text, text
    if res.exit_code == 2:
        errors = [ln for ln in text.splitlines() if ln.startswith("error:")]
        assert len(errors) == 1 and len(text.strip().splitlines()[-1]) == len(errors[0]), text
        # the file, a flag, or a config key ([section] or 'section.key', as the config's own checks say it)
        assert any(n in errors[0] for n in names) or re.search(FLAG_OR_KEY, errors[0]), (names, errors[0])
    if out.is_dir():
        assert not list(out.glob(".*.tmp")), list(out.iterdir())  # no temp file left behind
        for p in out.glob("*.parquet"):
            read_artifact(p, ARTIFACT_KIND[p.name])  # reads back whole
        if res.exit_code == 2:
            for kind in failed_kinds:
                assert not (out / f"{kind}.parquet").exists(), (kind, text)


def _invoke(*args) -> object:
    return CliRunner().invoke(cli, [str(a) for a in args])


@pytest.mark.parametrize("name", ["never_visible", "static", "one_frame", "few_frames", "pivot_out_of_frame",
                                  "leaves_the_frame", "good", "empty", "corrupt", "truncated", "notes",
                                  "a_folder", "missing"])
def test_track_then_angle(videos, tmp_path, name):
    video = videos[name]
    # drawn without a lens: on the default fisheye the short arc's theta would rest on an unchecked lens (refused)
    res = _invoke("track", video, "--projection", "none", "--out", tmp_path, "-q")
    _check(res, tmp_path, failed_kinds=("track",), names=(video.name, "--"))
    track = tmp_path / "track.parquet"
    if res.exit_code == 0:
        res = _invoke("angle", track, "--out", tmp_path, "-q")
        _check(res, tmp_path, failed_kinds=("angle",), names=("track.parquet", "--", "["))
    if name == "good":
        assert res.exit_code == 0 and (tmp_path / "angle.parquet").exists()


@pytest.mark.parametrize("flags", [
    ("--start", "99"), ("--start", "-1"), ("--start", "1", "--end", "0.5"), ("--end", "0.02"),
    ("--roi", "1000,1000,20,20"), ("--roi=-50,-50,20,20",), ("--roi", "0,0,160,120"), ("--roi", "1,2,x,4"),
    ("--fps", "-5"), ("--fps", "0.001"), ("--fov", "400"), ("--fov", "-1"), ("--fixed-pixels", "0"),
    ("--projection", "fisheye"), ("--marker-color", "#zzzzzz"), ("--marker-color", "dark"), ("--min-score", "2"),
    ("--min-score", "-3"), ("--search-margin", "0"), ("--evolution-rate", "1.5"), ("--corrected", "--fov", "179"),
])
def test_track_flags(videos, tmp_path, flags):
    res = _invoke("track", videos["good"], *flags, "--out", tmp_path, "-q")
    _check(res, tmp_path, failed_kinds=("track",), names=("good.mp4",))


@pytest.mark.parametrize("flags", [("--axle", "1e9,1e9"), ("--axle", "80,30"), ("--axle", "nan,1"),
                                   ("--rest-seconds", "-1"), ("--rest-seconds", "1e9")])
def test_angle_flags(videos, tmp_path, flags):
    assert _invoke("track", videos["good"], "--projection", "none", "--out", tmp_path, "-q").exit_code == 0
    res = _invoke("angle", tmp_path / "track.parquet", *flags, "--out", tmp_path, "-q", "--force")
    _check(res, tmp_path, failed_kinds=("angle",), names=("track.parquet", "--"))


def test_angle_on_what_is_no_track(videos, tmp_path):
    for bad in (videos["good"], videos["notes"], videos["missing"], videos["empty"]):
        res = _invoke("angle", bad, "--out", tmp_path, "-q")
        _check(res, tmp_path, failed_kinds=("angle",), names=(bad.name,))
        assert res.exit_code == 2
    broken = tmp_path / "track.parquet"
    broken.write_bytes(b"PAR1" + b"\0" * 100)
    res = _invoke("angle", broken, "--out", tmp_path / "o", "-q")
    _check(res, tmp_path / "o", failed_kinds=("angle",), names=("track.parquet",))
    assert res.exit_code == 2


@pytest.mark.parametrize("name, flags", [
    ("never_visible", ()), ("static", ()), ("one_frame", ()), ("empty", ()), ("corrupt", ()), ("missing", ()),
    ("good", ("--start", "99")), ("good", ("--roi", "1000,1000,20,20")), ("few_frames", ("--projection", "none")),
    ("pivot_out_of_frame", ("--projection", "none")),
])
def test_run(videos, tmp_path, name, flags):
    res = _invoke("run", videos[name], *flags, "--config", videos["config"], "--out", tmp_path, "-q")
    _check(res, tmp_path, failed_kinds=(), names=(videos[name].name, ".parquet", "--"))


@pytest.mark.slow
@pytest.mark.parametrize("name", ["good", "leaves_the_frame", "long"])
def test_run_to_the_end(videos, tmp_path, name):
    # through kinematics and fit: works or says why in one line
    video = videos.get(name)
    if name == "long":  # 6 s of swinging: every stage runs
        video = tmp_path / "long.mp4"
        write_swing_video(video, width=160, height=120, radius=6.0, n_frames=360, amplitude=1.0, period_s=1.0,
                          **IN_FRAME)
    out = tmp_path / "out"
    res = _invoke("run", video, "--projection", "none", "--config", videos["config"], "--out", out, "-q")
    _check(res, out, failed_kinds=(), names=(video.name, ".parquet", "--", "["))
    if name == "long":  # an undamped swing: the classic fit's damping exponent is not determined -> exit 1
        assert res.exit_code in (0, 1) and (out / "report.html").exists(), res.output
