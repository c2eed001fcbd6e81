"""The CLI shell: help, version, one-line errors with exit code 2."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from pendtrack import __version__
from pendtrack.cli import COMMANDS, cli

pytestmark = pytest.mark.integration  # the CLI as a user runs it (in process and as the console script)


def invoke(*args):
    return CliRunner().invoke(cli, list(args))


def test_help_lists_every_stage():
    res = invoke("--help")
    assert res.exit_code == 0
    for name in ("render", "track", "angle", "kinematics", "fit", "run", "undistort"):
        assert name in res.output


def test_version():
    res = invoke("--version")
    assert res.exit_code == 0 and __version__ in res.output


def test_every_registered_command_has_help_with_common_options():
    for name in COMMANDS:
        res = invoke(name, "--help")
        assert res.exit_code == 0, (name, res.output)
        for opt in ("--config", "--out", "--verbose", "--force"):
            assert opt in res.output, (name, opt)


def test_unknown_command_is_one_line_error_exit_2():
    res = invoke("frobnicate")
    assert res.exit_code == 2
    lines = [line for line in res.output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: ") and "frobnicate" in lines[0]


def test_unknown_option_is_one_line_error_exit_2():
    res = invoke("fit", "--no-such-flag")
    assert res.exit_code == 2
    lines = [line for line in res.output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: ") and "--no-such-flag" in lines[0]


def test_bad_config_file_is_one_line_error_naming_the_file(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[lens]\nfov = 1\n")
    res = invoke("kinematics", str(tmp_path / "angle.parquet"), "--config", str(bad), "--out", str(tmp_path))
    assert res.exit_code == 2
    assert res.output.strip().splitlines() == [f"error: {bad}: unknown key 'lens.fov'"]


def test_console_script_entry_point_runs():
    out = subprocess.run([sys.executable, "-m", "pendtrack", "--version"], capture_output=True, text=True)
    assert out.returncode == 0 and __version__ in out.stdout


def test_run_with_a_bad_config_value_fails_before_any_stage(tmp_path):
    # a real video: without the load-time check, `run` would track it whole before the kinematics stage failed
    video = Path(__file__).resolve().parents[2] / "sample_videos" / "12na1.mp4"
    bad = tmp_path / "x.toml"
    bad.write_text("[kinematics]\nsavgol_window_s = -1\n")
    out = tmp_path / "out"
    res = invoke("run", str(video), "--config", str(bad), "--out", str(out), "-q")
    assert res.exit_code == 2
    assert res.output.strip().splitlines() == [f"error: {bad}: 'kinematics.savgol_window_s' must be > 0, got -1"]
    assert not out.exists() or not any(out.iterdir())  # no artifact, not even a partial one


def test_the_fit_summary_says_when_its_errors_are_unreliable(capsys):
    # mohamedelsayed-0/PHY180-Pendulum-Project's data3.txt: fit.json had stderr_reliable false (the sandwich changed
    # with the finite-difference step) while the console printed "+- 0.005" like any other error
    from pendtrack.cli.fit_cmd import echo_fit_summary

    line = {"converged": True, "flags": {}, "findings": {}, "xi2_min": 1e-4, "rms": 0.007, "bic": -4454.0,
            "Omega0": 5.459, "Omega0_stderr": 0.005, "runtime_s": 3.0}
    echo_fit_summary({"models": {"classic": {**line, "stderr_reliable": False}, "opa": {**line, "stderr_reliable": True}}})
    out = capsys.readouterr().out.splitlines()
    assert "errors unreliable" in out[0] and "errors unreliable" not in out[1]


def test_run_on_a_measured_table_fits_and_reports_it(tmp_path):
    # `pendtrack run FILE` on a logger's or a tracker's table: `run VIDEO` was all there was, and a table got "not a
    # readable video"; `discover` already took either
    import json

    from pendtrack.discovery.synthetic import simulate_run

    t, theta = simulate_run({"Omega0": 4.0, "C1": 0.05, "C0": 0.0, "C2": 0.0}, (), duration=12.0, theta0=1.0,
                            noise=0.002, rng=np.random.default_rng(3), rate_hz=60.0)
    table = tmp_path / "swing.csv"
    np.savetxt(table, np.c_[t, np.degrees(theta)], delimiter=",", header="t,theta[deg]", comments="")
    few = tmp_path / "few.toml"
    few.write_text("[fit]\nn_starts = 4\n")
    out = tmp_path / "out"
    res = invoke("run", str(table), "--model", "standard", "--config", str(few), "--out", str(out), "-q")
    assert res.exit_code == 0, res.output
    assert {p.name for p in out.iterdir()} >= {"kinematics.parquet", "fit_standard.json", "report.html"}
    assert not (out / "track.parquet").exists()
    fit = json.loads((out / "fit_standard.json").read_text())
    # 12 s at 60 Hz with 2 mrad of noise pin Omega0 to ~1e-4 (degrees read as degrees: a unit slip is 57x off)
    assert abs(fit["params"]["Omega0"]["value"] / 4.0 - 1) < 1e-3


def test_run_on_a_video_takes_no_table_flags(tmp_path):
    video = Path(__file__).resolve().parents[2] / "sample_videos" / "12na1.mp4"
    out = tmp_path / "out"
    res = invoke("run", str(video), "--columns", "t,theta", "--out", str(out), "-q")
    assert res.exit_code == 2
    assert res.output.strip().splitlines() == [f"error: {video}: --columns, --pivot, --track and --rate describe a "
                                               "measured record's table, and this is a video"]
    assert not out.exists() or not any(out.iterdir())
