"""`pendtrack discover`: the CLI and stage on real data, bad inputs, and a rendered video."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from pendtrack.artifacts import DISCOVERY_JSON_KEYS
from pendtrack.cli import cli

pytestmark = pytest.mark.integration  # `pendtrack discover` end to end

ROOT = Path(__file__).resolve().parents[2]
REAL = ROOT.parent / "shared" / "data" / "real-tyler-phy180" / "lab1_data.txt"
if not REAL.is_file():  # the work tree may sit elsewhere; the shared data do not move
    REAL = Path("/work/shared/data/real-tyler-phy180/lab1_data.txt")


def invoke(*args: str):
    return CliRunner().invoke(cli, list(args))


@pytest.fixture(scope="module")
def real_discovery(tmp_path_factory: pytest.TempPathFactory) -> Path:
    if not REAL.is_file():
        pytest.skip(f"real data not found at {REAL}")
    out = tmp_path_factory.mktemp("discover_real")
    res = invoke("discover", str(REAL), "--columns", "t,theta,_", "--out", str(out), "-q")
    assert res.exit_code == 0, res.output
    return out


def test_real_data_discovery_completes_and_every_kept_effect_predicts_better(real_discovery):
    record = json.loads((real_discovery / "discovery.json").read_text())
    for key in DISCOVERY_JSON_KEYS:
        assert key in record
    assert record["baseline"] == "standard"
    assert record["provenance"]["stage"] == "discover"
    # every effect kept is a cause or a partial effect (kept while structure remains: not a cause)
    assert sum(len(s["terms"]) for s in record["steps"]) == len(record["effects"]) + len(record["partial"])
    for step in [*record["measurement_steps"], *record["steps"]]:
        assert step["heldout_rms_after"] < step["heldout_rms_before"]  # test gain > 0
        assert step["delta_bic"] < -10
        assert step["rms_after"] < step["rms_before"]  # kept only if it lowers the whole-record residual
        assert step["margins"]["z"]["margin"] > 0 and step["margins"]["delta_bic"]["margin"] > 0
        assert 0.0 <= step["stability"] <= 1.0 and step["borderline"] == (step["stability"] < 0.8)
        assert not set(step["params"]) & set(step["flags"])  # a term whose own fit is flagged is not kept
    for cand in record["runners_up"]:  # every decision has its margins and stability
        assert "margins" in cand and (cand["stability"] is None or 0.0 <= cand["stability"] <= 1.0)
    # no cause named whose fit is flagged: the final fit carries no flag the baseline's does not
    if record["effects"]:
        assert set(record["final_model"]["flags"]) <= set(record["baseline_fit"]["flags"])
        assert not record["unexplained"]
    # theta's zero is ~10 mrad from the rest position: a measurement finding, never a physical effect
    assert "offset" in record["measurement"] and "offset" not in record["effects"]
    (off_step,) = [s for s in record["measurement_steps"] if "offset" in s["terms"]]
    assert off_step["kind"] == "measurement" and off_step["test"] == "interleaved"
    # the README's author put the vertical by eye; a few mrad either side of the 10 found when the issue was
    # written is the same finding, a sign flip or 0 is not
    assert 0.005 < abs(off_step["params"]["theta_off"]["value"]) < 0.02
    assert off_step["heldout_rms_after"] < off_step["heldout_rms_before"]
    assert set(record["effects"]).isdisjoint({"offset", "angle_scale"})
    assert "theta_off" in record["final_model"]["params"]  # the measurement stays in the final model
    assert isinstance(record["unexplained"], list)
    assert record["final_model"]["rms"] < record["baseline_fit"]["rms"]
    # 20 Hz, 116 s: the third column (the author's residual) must not have been read as data
    assert record["data"]["rate_hz"] == pytest.approx(20.0, rel=0.01)
    assert record["data"]["duration_s"] == pytest.approx(116.0, abs=1.0)


def test_real_data_page_says_what_was_found(real_discovery):
    record = json.loads((real_discovery / "discovery.json").read_text())
    text = (real_discovery / "discovery.md").read_text()
    assert "## Verdict" in text and "## What the baseline gets wrong" in text
    (off_step,) = [s for s in record["measurement_steps"] if "offset" in s["terms"]]
    lead = "Borderline measurement finding" if off_step["borderline"] else "Measurement finding"
    assert f"{lead}: **zero offset**" in text and "not of the pendulum's physics" in text
    assert "same decision on" in text and "resampled records" in text  # each decision's stability, in words
    if record["partial"]:  # kept while structure remains: improving the fit, never "the cause"
        assert "No cause is named" in text and "improves the fit" in text and "The cause" not in text
    assert "Residual RMS, term by term in the order kept" in text
    if record["unexplained"]:
        assert "Not explained by the catalogue" in text
        assert all(name in text for name in record["unexplained"])
    if record["effects"]:
        assert f"`{record['effects'][0]}`" in text and "held-out RMS" in text
    else:
        assert "no effect" in text.lower() or "no cause" in text.lower()


def test_second_run_is_up_to_date(real_discovery):
    before = (real_discovery / "discovery.json").stat().st_mtime_ns
    res = invoke("discover", str(REAL), "--columns", "t,theta,_", "--out", str(real_discovery), "-q")
    assert res.exit_code == 0 and "up to date" in res.output
    assert (real_discovery / "discovery.json").stat().st_mtime_ns == before


@pytest.mark.parametrize("content, extra, fragment", [
    ("0 0.1\n0.05 oops\n", (), "line 2"),
    (None, (), "file not found"),
    ("ok", ("--effects", "magic"), "unknown effect 'magic'"),
    ("ok", ("--baseline", "nosuchmodel"), "unknown model 'nosuchmodel'"),
])
def test_bad_input_is_one_line_error_exit_2_and_no_artifact(tmp_path, content, extra, fragment):
    src = tmp_path / "in.txt"
    if content == "ok":
        t = np.arange(400) * 0.05
        src.write_text("\n".join(f"{a} {0.3 * np.cos(5 * a)}" for a in t))
    elif content is not None:
        src.write_text(content)
    out = tmp_path / "out"
    res = invoke("discover", str(src), "--out", str(out), "-q", *extra)
    assert res.exit_code == 2, res.output
    lines = [line for line in res.output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: ") and fragment in lines[0]
    if content not in ("ok",):
        assert str(src) in lines[0]
    assert not (out / "discovery.json").exists() and not (out / "discovery.md").exists()


def test_help_lists_discover():
    res = invoke("--help")
    assert res.exit_code == 0 and "discover" in res.output
    res = invoke("discover", "--help")
    assert res.exit_code == 0 and "--effects" in res.output and "--baseline" in res.output


@pytest.mark.video
@pytest.mark.slow
def test_video_with_memory_is_discovered(rendered_run, tmp_path):
    # The renderer takes registered model names only; "fractional" (quarter-power friction +
    # memory) is the registered model that carries memory. Its memory is set well above the
    # paper's (G2 0.01) so that the standard baseline cannot absorb it.
    folder = rendered_run(seconds=40.0, seed=3, model="fractional", width=640, height=360,
                          params={"G1": 0.002, "G2": 0.01, "beta": 0.5, "p_f": 1.5})
    out = tmp_path / "disc"
    res = invoke("discover", str(folder / "video.mp4"), "--out", str(out), "-q")
    assert res.exit_code == 0, res.output
    record = json.loads((out / "discovery.json").read_text())
    assert (out / "angle.parquet").is_file()  # the video stages ran into the folder
    # memory is the first effect kept; it is named the cause only when the final model leaves no structure the
    # catalogue cannot remove -- on a tracked video the residual's colour (whiteness, excess rms) usually stays,
    # and the effect is then listed as improving the fit (``partial``), with what stays unexplained
    kept = record["effects"] or record["partial"]
    assert kept[:1] == ["memory"], json.dumps(record["runners_up"], indent=1)[:3000]
    assert not (record["effects"] and record["partial"])
    assert not record["effects"] or not record["unexplained"]  # a cause is named only when nothing stays off
