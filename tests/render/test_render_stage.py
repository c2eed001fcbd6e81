"""Render stage: determinism, the video and truth files, atomicity, skipping."""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from fractions import Fraction

import av
import numpy as np
import pytest

from pendtrack.artifacts import read_artifact
from pendtrack.config import Config
from pendtrack.errors import ConfigError, ModelError, VideoError
from pendtrack.stages.render import render_stage
from pendtrack.video.writer import VideoWriter, write_video

SMALL = dict(width=320, height=180, seconds=0.25)


def small_config(**values) -> Config:
    return Config().replace("render", **(SMALL | values))


def decode(path) -> tuple[list[np.ndarray], list[float]]:
    frames, times = [], []
    with av.open(str(path)) as container:
        for f in container.decode(video=0):
            frames.append(f.to_ndarray(format="bgr24"))
            times.append(float(f.time))
    return frames, times


@pytest.mark.video
@pytest.mark.integration
def test_same_seed_gives_identical_truth_and_frames(tmp_path):
    a = render_stage(out_dir=tmp_path / "a", config=small_config(seed=5), progress=False)
    b = render_stage(out_dir=tmp_path / "b", config=small_config(seed=5), progress=False)
    c = render_stage(out_dir=tmp_path / "c", config=small_config(seed=6), progress=False)
    ta, tb = (read_artifact(o.paths[1], "truth").data for o in (a, b))
    assert ta.equals(tb)
    fa, fb, fc = (decode(o.paths[0])[0] for o in (a, b, c))
    assert len(fa) == len(fb) == 30
    assert all(np.array_equal(x, y) for x, y in zip(fa, fb))
    assert not np.array_equal(fa[0], fc[0])  # the seed matters (noise, wall)


# Every field condition at once (tests/render/test_render_field.py): a normal lens, a blue ball on a
# string with a sticker, the axle above the frame, a hand letting go, a rolled camera, 60 fps.
FIELD = dict(lens_projection="none", lens_fov_deg=70.0, camera_offset_m=(0.0, 0.2), marker_color="blue",
             marker_shape="ball", rig="string", sticker_color="pink", hand_release_s=0.1, camera_roll_deg=2.0,
             theta0=0.7, fps=60.0)


def _render_sha(out_dir, field: bool = False) -> str:
    out = render_stage(out_dir=out_dir, config=small_config(seed=5, **(FIELD if field else {})), progress=False)
    return hashlib.sha256(out.paths[0].read_bytes()).hexdigest()


@pytest.mark.video
@pytest.mark.integration
@pytest.mark.parametrize("field", [False, True], ids=["paper", "field_conditions"])
def test_render_is_bit_identical_across_calls_and_processes(tmp_path, field):
    # The same seed and size give the same video file, byte for byte: in one process, with
    # the heap in a different state each time (the libx264 B-frame path on AVX-512 CPUs read
    # memory it had not initialised, so renders alternated between videos), and in a fresh
    # subprocess.
    churn = []
    shas = set()
    for k in range(3):
        churn.append(np.random.default_rng(k).integers(0, 255, size=50_000 * (k + 1), dtype=np.uint8))
        shas.add(_render_sha(tmp_path / f"in{k}", field))
        del churn[::2]
    code = ("import sys; from pathlib import Path; sys.path.insert(0, sys.argv[1]); import test_render_stage as t; "
            "print(t._render_sha(Path(sys.argv[2]), sys.argv[3] == 'field'))")
    env = os.environ | {"PYTHONPATH": os.pathsep.join(filter(None, [os.environ.get("PYTHONPATH"), os.getcwd()]))}
    sub = subprocess.run([sys.executable, "-c", code, os.path.dirname(__file__), str(tmp_path / "sub"),
                          "field" if field else "paper"], capture_output=True, text=True, check=True, env=env)
    shas.add(sub.stdout.strip().splitlines()[-1])
    assert len(shas) == 1


@pytest.mark.video
def test_video_and_truth_agree(rendered_run):
    out = rendered_run(seconds=0.25, width=640, height=360, theta0=1.0)
    truth = read_artifact(out / "truth.parquet", "truth")
    frames, times = decode(out / "video.mp4")
    assert len(frames) == len(truth.data) == 30
    assert frames[0].shape == (360, 640, 3)
    np.testing.assert_allclose(times, truth.data["t"], atol=1e-9)  # pts = k / fps
    assert truth.provenance.stage == "render"
    extra = truth.provenance.extra
    assert extra["model"] == "standard" and set(extra["params"]) == {"Omega0", "C0", "C1", "C2"}
    assert extra["run_code"] == "00nn1" and extra["video"] == "video.mp4"
    with av.open(str(out / "video.mp4")) as container:
        stream = container.streams.video[0]
        assert stream.codec_context.name == "h264" and stream.codec_context.pix_fmt == "yuv420p"
        assert stream.average_rate == Fraction(120)


@pytest.mark.video
def test_decoded_spot_is_where_the_truth_says(rendered_run):
    # End to end (lens, blur, noise, H.264): the pink blob of the first frames lies at the
    # projected spot. 0.5 px: chroma is subsampled 2x2 and the blob's centroid itself is
    # ~0.1 px from the projected centre (lens), see test_render_scene.
    from pendtrack.render.scene import scene_from_config

    out = rendered_run(seconds=0.25, width=640, height=360, theta0=1.0)
    truth = read_artifact(out / "truth.parquet", "truth").data
    scene = scene_from_config(Config().replace("render", width=640, height=360).render)
    frames, _ = decode(out / "video.mp4")
    for k in (0, 29):
        f = frames[k].astype(float)
        pink = np.clip(f[..., 2] - f[..., 1] - 60, 0, None)  # red minus green: only the spot is far above 60
        v, u = np.nonzero(pink)
        w = pink[v, u]
        pu, pv = scene.spot_centre_px(truth["theta"][k])
        assert np.hypot((w * u).sum() / w.sum() - pu, (w * v).sum() / w.sum() - pv) < 0.5


@pytest.mark.video
@pytest.mark.integration
def test_name_by_run_code(tmp_path):
    cfg = small_config(seconds=0.05, tile_length_m=0.06, alley=True, omega0=-1.0, trial=2)
    out = render_stage(out_dir=tmp_path, config=cfg, progress=False, name_by_run_code=True)
    assert [p.name for p in out.paths] == ["06la2.mp4", "06la2.truth.parquet"]
    assert out.facts["run_code"] == "06la2"
    with pytest.raises(ConfigError, match="no run code"):
        render_stage(out_dir=tmp_path, config=small_config(tile_length_m=0.045), progress=False,
                     name_by_run_code=True)


@pytest.mark.video
@pytest.mark.integration
def test_up_to_date_outputs_are_skipped_unless_forced(tmp_path):
    cfg = small_config(seconds=0.05)
    first = render_stage(out_dir=tmp_path, config=cfg, progress=False)
    assert not first.skipped
    assert render_stage(out_dir=tmp_path, config=cfg, progress=False).skipped
    assert not render_stage(out_dir=tmp_path, config=cfg, progress=False, force=True).skipped
    assert not render_stage(out_dir=tmp_path, config=small_config(seconds=0.05, seed=1), progress=False).skipped
    first.paths[0].write_bytes(b"not the video")  # a replaced video is not up to date
    assert not render_stage(out_dir=tmp_path, config=cfg, progress=False).skipped


@pytest.mark.integration
@pytest.mark.parametrize("values, error, fragment", [
    (dict(seconds=-1.0), ConfigError, "render.seconds"),
    (dict(width=321), ConfigError, "render.width"),
    (dict(exposure_s=0.1), ConfigError, "render.exposure_s"),
    (dict(model="nope"), ModelError, "unknown model 'nope'"),
    (dict(params=("C0=-1",)), ModelError, "'C0'"),
    (dict(params=("C0",)), ConfigError, "NAME=VALUE"),
])
def test_bad_input_raises_and_writes_nothing(tmp_path, values, error, fragment):
    with pytest.raises(error, match=fragment):
        render_stage(out_dir=tmp_path / "out", config=small_config(**values), progress=False)
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


@pytest.mark.video
def test_writer_leaves_no_partial_file_on_error(tmp_path):
    path = tmp_path / "v.mp4"
    with pytest.raises(RuntimeError):
        with VideoWriter(path, width=64, height=48, fps=30, crf=20) as w:
            w.write(np.zeros((48, 64, 3), np.uint8))
            raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(VideoError):
        write_video([], path, fps=30)
    with pytest.raises(VideoError, match="even"):
        VideoWriter(path, width=63, height=48, fps=30)


@pytest.mark.video
def test_writer_keeps_colours(tmp_path):
    # BT.601 limited range with rounding to nearest: greys stay grey within one level
    frames = [np.full((48, 64, 3), level, np.uint8) for level in (0, 16, 128, 200, 255)]
    frames.append(np.full((48, 64, 3), (180, 105, 250), np.uint8))
    path = write_video(frames, tmp_path / "v.mp4", fps=30, crf=0)
    decoded, _ = decode(path)
    for f, d in zip(frames, decoded):
        assert np.abs(d.astype(int) - f).max() <= 2
