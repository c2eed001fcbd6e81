"""`pendtrack render`: happy path and bad arguments (one-line error, exit 2, no files)."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from pendtrack.artifacts import read_artifact
from pendtrack.cli import cli


def invoke(*args: str):
    return CliRunner().invoke(cli, list(args))


@pytest.mark.video
@pytest.mark.integration
def test_render_happy_path(tmp_path):
    out = tmp_path / "run"
    result = invoke("render", "--seconds", "0.1", "--size", "320x180", "--out", str(out), "-q",
                    "--tile", "6", "--alley", "--theta0", "2.5", "--param", "C0=0.02", "--seed", "3")
    assert result.exit_code == 0, result.output
    assert "wrote" in result.stdout and "12 frames" in result.stdout and "06na1" in result.stdout
    truth = read_artifact(out / "truth.parquet", "truth")
    assert len(truth.data) == 12 and truth.data["theta"][0] == 2.5
    cfg = truth.provenance.config["render"]
    assert cfg["tile_length_m"] == pytest.approx(0.06) and cfg["alley"] is True and cfg["seed"] == 3
    assert truth.provenance.extra["params"]["C0"] == 0.02
    assert (out / "video.mp4").stat().st_size > 0
    again = invoke("render", "--seconds", "0.1", "--size", "320x180", "--out", str(out), "-q",
                   "--tile", "6", "--alley", "--theta0", "2.5", "--param", "C0=0.02", "--seed", "3")
    assert again.exit_code == 0 and "up to date" in again.stdout


@pytest.mark.video
@pytest.mark.integration
def test_render_name_by_run_code(tmp_path):
    result = invoke("render", "--seconds", "0.05", "--size", "160x96", "--out", str(tmp_path), "-q",
                    "--tile", "24", "--omega0", "-1", "--trial", "2", "--name-by-run-code")
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["24ln2.mp4", "24ln2.truth.parquet"]


@pytest.mark.integration
@pytest.mark.parametrize("args, fragment", [
    (["--size", "garbage"], "--size must look like WIDTHxHEIGHT"),
    (["--seconds", "-1"], "render.seconds must be > 0"),
    (["--model", "nope"], "unknown model 'nope'"),
    (["--model", "standard+nope"], "unknown term 'nope'"),
    (["--model", "standard+offset"], "measurement terms (offset) cannot be rendered"),
    (["--param", "Omega0=abc"], "'Omega0' must be a number"),
    (["--param", "G2=1"], "no parameter 'G2'"),
    (["--fps", "0"], "render.fps"),
    (["--seconds", "abc"], "'abc' is not a valid float"),
])
def test_render_bad_argument(tmp_path, args, fragment):
    out = tmp_path / "out"
    result = invoke("render", "--size", "160x96", "--seconds", "0.05", "--out", str(out), "-q", *args)
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and fragment in lines[0], result.stderr
    assert not out.exists()


@pytest.mark.integration
def test_render_a_composed_model(tmp_path):
    """`--model baseline+term` in any term order: the composed model, named in catalogue order."""
    out = tmp_path / "run"
    result = invoke("render", "--seconds", "0.05", "--size", "160x96", "--out", str(out), "-q",
                    "--model", "standard+memory+added_mass", "--param", "G2=0.001")
    assert result.exit_code == 0, result.output
    truth = read_artifact(out / "truth.parquet", "truth")
    assert truth.provenance.extra["params"]["G2"] == 0.001
    assert truth.provenance.extra["params"]["Ca"] == 0.01  # the default of the term's first built-in model
    assert "model standard+added_mass+memory" in result.stdout
