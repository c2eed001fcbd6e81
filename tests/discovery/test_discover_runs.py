"""`pendtrack discover A B C`: discovery across several runs of one pendulum (pendtrack.discovery.across_runs)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from pendtrack.cli import cli
from pendtrack.discovery.synthetic import SERIES_RELEASES, draw_series


def invoke(*args: str):
    return CliRunner().invoke(cli, list(args))


def write_runs(folder: Path, series) -> list[str]:  # noqa: ANN001
    paths = []
    for i, run in enumerate(series.runs):
        p = folder / f"release{i + 1}.txt"
        np.savetxt(p, np.column_stack([run.t, run.theta]), header="t theta", comments="")
        paths.append(str(p))
    return paths


def test_a_series_is_one_pendulum_released_from_each_angle():
    s = draw_series(5, "added_mass", duration=4.0, check_size=False)
    assert [r.theta0 for r in s.runs] == list(SERIES_RELEASES)
    assert all(r.params is s.params for r in s.runs)  # one pendulum: the same physics in every run
    # each run starts at its release (noise 2-3 mrad: within 5 sigma) and has its own noise
    for run in s.runs:
        assert abs(run.theta[0] - run.theta0) < 5 * run.noise
    assert len({r.noise for r in s.runs}) == len(s.runs)
    again = draw_series(5, "added_mass", duration=4.0, check_size=False)
    assert all(np.array_equal(a.theta, b.theta) for a, b in zip(s.runs, again.runs))  # seeded


def test_several_records_errors_name_the_file_and_write_nothing(tmp_path):
    s = draw_series(5, None, duration=10.0, check_size=False)
    paths = write_runs(tmp_path, s)
    out = tmp_path / "out"
    res = invoke("discover", paths[0], paths[0], "--out", str(out), "-q")
    assert res.exit_code == 2 and "given twice" in res.output and "release1.txt" in res.output
    video = tmp_path / "swing.mp4"
    video.write_bytes(b"\x00" * 64)
    res = invoke("discover", paths[0], str(video), "--out", str(out), "-q")
    assert res.exit_code == 2 and "swing.mp4" in res.output and "pendtrack run" in res.output
    res = invoke("discover", paths[0], paths[1], "--shared", "nonsense", "--out", str(out), "-q")
    assert res.exit_code == 2 and "nonsense" in res.output
    res = invoke("discover", paths[0], "--shared", "C0", "--out", str(out), "-q")
    assert res.exit_code == 2 and "several records" in res.output
    assert not out.exists() or not any(out.iterdir())


@pytest.mark.slow
def test_added_mass_across_runs_is_named_shared_and_carries_to_runs_held_out(tmp_path):
    """Three 20-s runs of one pendulum with an added mass, released from pi - 0.1, 2.2 and 1.2 rad."""
    s = draw_series(3, "added_mass", duration=20.0)
    paths = write_runs(tmp_path, s)
    out = tmp_path / "out"
    res = invoke("discover", *paths, "--effects", "added_mass,time_varying_damping", "--out", str(out), "-q")
    assert res.exit_code == 0, res.output
    record = json.loads((out / "discovery.json").read_text())
    assert record["kind"] == "discovery_runs" and record["runs"] == ["release1", "release2", "release3"]
    assert record["effects"] == ["added_mass"] and record["partial"] == []
    assert record["scopes"]["added_mass"]["scope"] == "shared"
    (kept,) = [c for c in record["candidates"] if c["kept"]]
    # kept on both tests: the later times of every run and every run held out whole
    assert kept["later"]["z"] > 3 and kept["runs_held_out"]["z"] > 3 and kept["delta_bic"] < -10
    assert all(m["z"]["margin"] > 0 for m in kept["margins"].values())
    assert not any(c["kept"] for c in record["candidates"] if c["effect"] == "time_varying_damping")
    ca = record["final_fit"]["values"]["Ca"]
    # the shared added mass from all three runs: within 3 of its standard errors of the truth
    assert abs(ca["value"] - s.params["Ca"]) < 3 * ca["stderr"], (ca, s.params["Ca"])
    assert math.isfinite(ca["stderr"]) and ca["stderr"] < 0.3 * s.params["Ca"]
    text = (out / "discovery.md").read_text()
    assert "## Verdict" in text and "added_mass (shared)" in text


def test_the_library_door_takes_several_records_and_says_what_is_wrong(tmp_path):
    import pandas as pd

    import pendtrack as pt
    from pendtrack.errors import FitError

    s = draw_series(5, None, duration=10.0, check_size=False)
    frames = {f"rel{i}": pd.DataFrame({"t": r.t, "theta": r.theta}) for i, r in enumerate(s.runs)}
    with pytest.raises(FitError, match="at least two records"):
        pt.discover([frames["rel0"]])
    with pytest.raises(FitError, match="several records"):
        pt.discover(frames["rel0"], shared=["C0"])
    with pytest.raises(FitError, match="'nonsense' is not a parameter"):
        pt.discover(frames, shared=["nonsense"])
