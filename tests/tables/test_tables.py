"""One table reader for `kinematics`, `fit` and `discover` (pendtrack.tables): forms, refusals, warnings, jitter."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from factory import swing

from pendtrack.artifacts import Provenance, read_artifact, read_metadata, write_artifact
from pendtrack.cli import cli
from pendtrack.config import Config
from pendtrack.errors import ArtifactError, ConfigError
from pendtrack.models import get_model, simulate
from pendtrack.stages.kinematics import read_input
from pendtrack.tables import TableSpec, parse_column_name, parse_columns, read_record, theta_warnings, uniform_grid

ROOT = Path(__file__).resolve().parents[2]
REAL = ROOT.parent / "shared" / "data" / "real-tyler-phy180" / "lab1_data.txt"
if not REAL.is_file():  # the work tree may sit elsewhere; the shared data do not move
    REAL = Path("/work/shared/data/real-tyler-phy180/lab1_data.txt")

RATE = 60.0
L, PX, PY = 0.65, 0.3, 1.2  # pendulum length and pivot of the x, y forms [m], y up
# Damping large enough that the standard fit determines each of its three terms on 8 s at 1 mrad
# noise (weaker ones, e.g. C2 = 0.002, are honestly flagged "not determined" and `fit` exits 1).
SWING = {"Omega0": 5.0, "C1": 0.1, "C0": 0.05, "C2": 0.05}


def _swing(seconds: float = 8.0) -> tuple[np.ndarray, np.ndarray]:
    return swing("standard", SWING, seconds=seconds, fps=RATE, theta0=1.0, noise=1e-3)


def _lines(*cols: np.ndarray, sep: str = " ") -> str:
    return "\n".join(sep.join(repr(float(v)) for v in row) for row in zip(*cols)) + "\n"


T, THETA = _swing()
X, Y = PX + L * np.sin(THETA), PY - L * np.cos(THETA)


def _write(folder: Path, form: str) -> tuple[Path, tuple[str, ...]]:
    """One accepted form of the same record; returns the file and the table flags it needs."""
    if form == "plain":  # headerless t, theta: as before
        p = folder / "plain.txt"
        p.write_text(_lines(T, THETA))
        return p, ()
    if form == "three_columns":  # headerless with an ignored third column (the lab1 file's shape)
        p = folder / "three.txt"
        p.write_text(_lines(T, THETA, np.zeros_like(T)))
        return p, ("--columns", "t,theta,_")
    if form == "degrees_header":
        p = folder / "deg.csv"
        p.write_text("time [s],angle [deg],note\n" + _lines(T, np.degrees(THETA), T, sep=","))
        return p, ()
    if form == "ms_theta_symbol":
        p = folder / "ms.txt"
        p.write_text("# exported\nt (ms)   θ [rad]\n" + _lines(T * 1000.0, THETA))
        return p, ()
    if form == "xy_pivot":
        p = folder / "xy.csv"
        p.write_text("t,x [m],y [m]\n" + _lines(T, X, Y, sep=","))
        return p, ("--pivot", str(PX), str(PY))
    if form == "xy_fitted":
        p = folder / "xyfit.csv"
        p.write_text("t;x;y\n" + _lines(T, X, Y, sep=";"))
        return p, ()
    if form == "xy_down_columns":  # image-like axes, y down, headerless: named by --columns
        p = folder / "xydown.txt"
        p.write_text(_lines(T, 100.0 * X, -100.0 * Y))
        return p, ("--columns", "t,x,y_down")
    if form == "rate":  # a logger's angles alone, one per line at a fixed rate (an Arduino's encoder log)
        p = folder / "encoder.txt"
        p.write_text(_lines(np.degrees(THETA)))
        return p, ("--columns", "theta[deg]", "--rate", repr(RATE))
    if form == "german_semicolon":  # Logger Pro in German: names and decimal commas of the locale, Windows-1252
        p = folder / "pendel.csv"
        p.write_bytes(("Zeit (s);Winkel (°)\n" + _lines(T, np.degrees(THETA), sep=";").replace(".", ",")).encode("cp1252"))
        return p, ()
    if form == "utf16_spanish":  # Windows' "Unicode text" (UTF-16 with its byte-order mark), tab separated
        p = folder / "pendulo.txt"
        p.write_text("tiempo (s)\tángulo (grados)\n" + _lines(T, np.degrees(THETA), sep="\t"), encoding="utf-16")
        return p, ()
    if form == "parquet":
        p = folder / "plain.parquet"
        pd.DataFrame({"t": T, "theta": THETA}).to_parquet(p)
        return p, ()
    if form == "angle_artifact":
        p = folder / "angle.parquet"
        write_artifact(pd.DataFrame({"t": T, "theta": THETA, "ok": np.ones(T.size, bool)}), p, "angle",
                       provenance=Provenance(stage="test"))
        return p, ()
    raise AssertionError(form)


FORMS = ("plain", "three_columns", "degrees_header", "ms_theta_symbol", "xy_pivot", "xy_fitted", "xy_down_columns",
         "rate", "german_semicolon", "utf16_spanish", "parquet", "angle_artifact")


def _spec(flags: tuple[str, ...]) -> TableSpec | None:
    if not flags:
        return None
    if flags[0] == "--pivot":
        return TableSpec(pivot=(float(flags[1]), float(flags[2])))
    given = dict(zip(flags[::2], flags[1::2]))
    return TableSpec(columns=parse_columns(given["--columns"], check_roles=False),
                     rate_hz=float(given["--rate"]) if "--rate" in given else None)


def invoke(*args: str):
    return CliRunner().invoke(cli, list(args))


@pytest.fixture(scope="module")
def fast_fit(tmp_path_factory: pytest.TempPathFactory) -> Path:
    cfg = tmp_path_factory.mktemp("cfg") / "fast.toml"
    cfg.write_text("[fit]\nn_starts = 1\nworkers = 1\nprofile = false\n")
    return cfg


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory, fast_fit: Path) -> dict[str, pd.DataFrame]:
    """kinematics.parquet and fit.parquet of the plain table: what every other form must give."""
    d = tmp_path_factory.mktemp("reference")
    src, _ = _write(d, "plain")
    assert invoke("kinematics", str(src), "--out", str(d), "-q").exit_code == 0
    res = invoke("fit", str(src), "--model", "standard", "--config", str(fast_fit), "--out", str(d), "-q")
    assert res.exit_code == 0, res.output
    return {"kinematics": read_artifact(d / "kinematics.parquet", "kinematics").data,
            "fit": read_artifact(d / "fit.parquet", "fit").data}


# --- one reader, every form --------------------------------------------------------------

@pytest.mark.parametrize("form", FORMS)
def test_every_form_reads_the_same_t_theta(tmp_path, form):
    src, flags = _write(tmp_path, form)
    rec = read_input(src, table=_spec(flags))
    np.testing.assert_allclose(rec.t, T, rtol=0, atol=1e-12)  # repr() round-trips; ms -> s is exact to 1e-15
    # 1e-9 rad: degrees and x, y (with a fitted pivot, exact data) convert back with float rounding only
    np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=1e-9)
    assert rec.ok.all() and rec.info["resampled"] is None and rec.warnings == ()


@pytest.mark.integration
@pytest.mark.parametrize("form", FORMS)
def test_kinematics_fit_and_discover_agree_on_every_form(tmp_path, form, reference, fast_fit, monkeypatch):
    src, flags = _write(tmp_path, form)
    res = invoke("kinematics", str(src), *flags, "--out", str(tmp_path / "k"), "-q")
    assert res.exit_code == 0, res.output
    kin = read_artifact(tmp_path / "k" / "kinematics.parquet", "kinematics").data
    ref = reference["kinematics"]
    np.testing.assert_allclose(kin["t"], ref["t"], rtol=0, atol=1e-12)
    # the same theta in, the same Savitzky-Golay out (float rounding of the conversions only)
    np.testing.assert_allclose(kin["theta"], ref["theta"], rtol=0, atol=1e-8)

    res = invoke("fit", str(src), *flags, "--model", "standard", "--config", str(fast_fit), "--out",
                 str(tmp_path / "f"), "-q")
    assert res.exit_code == 0, res.output
    fit = read_artifact(tmp_path / "f" / "fit.parquet", "fit").data
    np.testing.assert_allclose(fit["t"], reference["fit"]["t"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(fit["theta"], reference["fit"]["theta"], rtol=0, atol=1e-8)

    # discover: what the stage hands to the search is the same record (the search itself is
    # tested in test_discover_stage.py; here it is stopped once it has the series)
    seen = {}

    class Stop(Exception):
        pass

    def capture(series, **_):
        seen["series"] = series
        raise Stop

    import pendtrack.discovery.loop as search

    monkeypatch.setattr(search, "discover", capture)
    from pendtrack.stages.discover import discover_stage

    with pytest.raises(Stop):
        discover_stage(src, out_dir=tmp_path / "d", config=Config(), table=_spec(flags), progress=False)
    np.testing.assert_allclose(seen["series"].t, T, rtol=0, atol=1e-12)
    np.testing.assert_allclose(seen["series"].theta, THETA, rtol=0, atol=1e-9)


@pytest.mark.integration
def test_fit_of_a_table_equals_fit_of_its_kinematics_file(tmp_path, reference, fast_fit):
    src, _ = _write(tmp_path, "plain")
    assert invoke("kinematics", str(src), "--out", str(tmp_path), "-q").exit_code == 0
    res = invoke("fit", str(tmp_path / "kinematics.parquet"), "--model", "standard", "--config", str(fast_fit),
                 "--out", str(tmp_path / "f"), "-q")
    assert res.exit_code == 0, res.output
    fit = read_artifact(tmp_path / "f" / "fit.parquet", "fit").data
    # same data, same Savitzky-Golay observation, same seed: the same fit (solver rounding only)
    np.testing.assert_allclose(fit["theta_model"], reference["fit"]["theta_model"], rtol=0, atol=1e-9)
    prov = json.loads((tmp_path / "f" / "fit.json").read_text())["provenance"]
    assert "input" not in prov["config"] and "table" not in prov["config"]  # a kinematics file: as before


@pytest.mark.integration
def test_table_flags_make_outputs_stale(tmp_path):
    src, _ = _write(tmp_path, "xy_fitted")
    out = tmp_path / "k"
    assert invoke("kinematics", str(src), "--out", str(out), "-q").exit_code == 0
    again = invoke("kinematics", str(src), "--out", str(out), "-q")
    assert "up to date" in again.output
    moved = invoke("kinematics", str(src), "--pivot", str(PX + 0.01), str(PY), "--out", str(out), "-q")
    assert moved.exit_code == 0 and "up to date" not in moved.output
    extra = read_artifact(out / "kinematics.parquet", "kinematics").provenance.extra
    assert extra["input"]["pivot"]["source"] == "--pivot"


@pytest.mark.integration
def test_a_rate_times_a_log_of_angles_and_is_recorded(tmp_path):
    src, flags = _write(tmp_path, "rate")
    out = tmp_path / "k"
    assert invoke("kinematics", str(src), *flags, "--out", str(out), "-q").exit_code == 0
    extra = read_artifact(out / "kinematics.parquet", "kinematics").provenance.extra
    assert extra["input"]["columns"] == ["theta[deg]", "t = row / 60 Hz"]
    faster = invoke("kinematics", str(src), "--columns", "theta[deg]", "--rate", "120", "--out", str(out), "-q")
    assert faster.exit_code == 0 and "up to date" not in faster.output
    k = read_artifact(out / "kinematics.parquet", "kinematics").data
    np.testing.assert_allclose(k["t"], np.arange(T.size) / 120.0, rtol=0, atol=1e-12)
    _one_line_error(invoke("kinematics", str(src), "--columns", "theta[deg]", "--rate", "0", "--out",
                           str(tmp_path / "zero")), "--rate must be a sampling rate > 0")
    assert not (tmp_path / "zero").exists()


# --- column names -------------------------------------------------------------------------

@pytest.mark.parametrize("label, role, scale", [
    ("t", "t", 1.0), ("Time [s]", "t", 1.0), ("time_ms", "t", 1e-3), ("t (ms)", "t", 1e-3),
    ("theta", "theta", 1.0), ("θ", "theta", 1.0), ("Angle (deg)", "theta", math.pi / 180),
    ("theta_deg", "theta", math.pi / 180), ("theta [rad]", "theta", 1.0), ("angle°", "theta", math.pi / 180),
    ("x [m]", "x", 1.0), ("y_down", "y", 1.0), ("_", "_", 1.0),
    ("Zeit (s)", "t", 1.0), ("temps (ms)", "t", 1e-3), ("Winkel (°)", "theta", math.pi / 180),
    ("ángulo (grados)", "theta", math.pi / 180), ("время (мс)", "t", 1e-3), ("угол (рад)", "theta", 1.0),
    ("angle (gon)", None, None),
])
def test_column_names_and_units(label, role, scale):
    if role is None:  # a unit not known: refused, not guessed
        with pytest.raises(ConfigError, match="unknown unit"):
            parse_column_name(label)
        return
    c = parse_column_name(label)
    assert c is not None and c.role == role and c.scale == pytest.approx(scale)


def test_unknown_names_and_units():
    assert parse_column_name("residual") is None
    with pytest.raises(ConfigError, match="unknown unit 'grad'"):
        parse_column_name("theta [grad]")
    with pytest.raises(ConfigError, match="unknown column name 'foo'"):
        parse_columns("t,foo")
    with pytest.raises(ConfigError, match="missing column 'theta'"):
        parse_columns("t,_,_")
    with pytest.raises(ConfigError, match="two columns are theta"):
        parse_columns("t,theta,angle")


# --- refusals: one line, exit 2, no artifact ----------------------------------------------

def _one_line_error(res, *fragments: str) -> str:
    assert res.exit_code == 2, res.output
    lines = [line for line in res.output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), res.output
    for f in fragments:
        assert f in lines[0], lines[0]
    return lines[0]


COMMANDS = (("kinematics",), ("fit", "--model", "standard"), ("discover",))


@pytest.mark.integration
@pytest.mark.parametrize("command", COMMANDS, ids=lambda c: c[0])
@pytest.mark.parametrize("case", ["three_columns", "unknown_header", "count", "repeated", "y_axis", "positions",
                                  "four_columns", "web_page", "header_only", "gyroscope", "gyroscope_named", "light",
                                  "light_named", "one_column", "settings_line", "rate_and_times", "rate_two_columns",
                                  "distance", "distance_named"])
def test_refusals_are_one_line_errors_without_artifacts(tmp_path, command, case):
    src = tmp_path / "in.txt"
    flags: tuple[str, ...] = ()
    if case == "three_columns":
        src.write_text(_lines(T, THETA, T))
        fragments = (str(src), "3 columns and no header", "add --columns t,theta,_")
    elif case == "unknown_header":
        src.write_text("a b\n" + _lines(T, THETA))
        fragments = (str(src), "missing column 't'", "--columns t,theta")
    elif case == "positions":
        # t, x, y of the bob without a header, y counting down (mohamedelsayed-0/PHY180-Pendulum-Project's data3.txt):
        # the hint offered t,theta,_ first, which fitted x in metres as an angle in radians
        src.write_text(_lines(T, X, -Y))
        fragments = (str(src), "columns 2 and 3 trace a pendulum's arc: add --columns t,x,y_down")
    elif case == "four_columns":
        # spreadsheet names (JLefebvre55/PHY180-Pendulum's q2_data.csv): the hint named 3 columns of 4
        src.write_text("X,Y,X',Y'\n" + _lines(T, THETA, T, T, sep=","))
        fragments = (str(src), "missing column 't'", "--columns t,theta,_,_ or --columns t,x,y,_")
    elif case == "web_page":  # a repository's file page saved from the browser: "missing column 't'" before
        src.write_text("<!DOCTYPE html>\n<html><head><title>data.csv</title></head><body>1,2</body></html>\n")
        fragments = (str(src), "a web page (HTML), not a table", "Raw")
    elif case == "header_only":  # a logger that wrote its header and no sample: "only 0 usable samples" before
        src.write_text("time,angle\n")
        fragments = (str(src), "no row of numbers", "below the header 'time,angle'")
    elif case in ("gyroscope", "gyroscope_named"):
        # a phone's gyroscope log (phyphox's CSV export, as in ubsuny/data-analysis-final20's Gyroscope/data): rates,
        # no angle. The hint offered --columns t,theta,_,_,_, which read an angular velocity as the angle
        omega = np.gradient(THETA, T)
        header = '"Time (s)","Gyroscope x (rad/s)","Gyroscope y (rad/s)","Gyroscope z (rad/s)","Absolute (rad/s)"\n'
        src.write_text(header + _lines(T, omega, 0 * T, 0 * T, np.abs(omega), sep=","))
        if case == "gyroscope":
            fragments = (str(src), "'Gyroscope x (rad/s)'", "are rates (an angular velocity), not an angle")
        else:
            flags = ("--columns", "t,theta,_,_,_")
            fragments = (str(src), "column 2 theta", "'Gyroscope x (rad/s)', a rate (an angular velocity)")
    elif case in ("light", "light_named"):
        # a light sensor's log beside a swinging bob (Vernier's "Light Intensity (%)"): no angle; the hint offered
        # --columns t,theta, which read a light level in percent as the angle
        header = "Time (s),Light Intensity (%)\n"
        src.write_text(header + _lines(T, 18.0 + 60.0 * (np.abs(THETA) < 0.05), sep=","))
        if case == "light":
            fragments = (str(src), "the column 'Light Intensity (%)' is a percentage, not an angle or positions")
        else:
            flags = ("--columns", "t,theta")
            fragments = (str(src), "column 2 theta", "'Light Intensity (%)', a percentage, not an angle")
    elif case == "one_column":  # angles alone, one per line: read as times ("time going back") before
        src.write_text(_lines(np.degrees(THETA)))
        fragments = (str(src), "one column of numbers", "give it with --rate HZ")
    elif case == "rate_and_times":  # --rate on a table that has its times: which times would be meant?
        src.write_text("t,theta\n" + _lines(T, THETA, sep=","))
        flags = ("--rate", "60")
        fragments = (str(src), "--rate gives the rows their times, but the header names column 1 ('t') a time")
    elif case == "rate_two_columns":  # --rate on two unnamed columns: either could be the angle
        src.write_text(_lines(THETA, T))
        flags = ("--rate", "60")
        fragments = (str(src), "2 columns, no header and --rate", "--columns (e.g. theta,_)")
    elif case == "settings_line":
        # a logger's settings line above one angle per line (jensen-benard/rotary-inverted-pendulum's
        # pendulum_free_swing_data_01.txt: start angle, rate and duration): its 3 numbers were taken for the columns
        src.write_text("trigger_start_deg, sample_rate, duration_sec\n90, 1000, 5\n" + _lines(np.degrees(THETA)))
        fragments = (str(src), "line 2 ('90, 1000, 5') has 3 values", "a line of settings above the samples?")
    elif case in ("distance", "distance_named"):
        # an ultrasonic sensor's log of a pendulum (a counter, the time, the distance to the bob): the hint put t on
        # the counter (--columns t,theta,_: the times read as the angle), and theta named over 'Distance (cm)' was
        # read as radians
        src.write_text("Counter,Time (s),Distance (cm)\n" + _lines(np.arange(T.size), T, 40 + 70 * np.sin(THETA),
                                                                   sep=","))
        if case == "distance":
            fragments = (str(src), "recognised: 'Time (s)'", "--columns _,t,theta")
        else:
            flags = ("--columns", "_,t,theta")
            fragments = (str(src), "column 3 theta", "'Distance (cm)', a length (cm), not an angle")
    elif case == "count":
        src.write_text(_lines(T, THETA, T))
        flags = ("--columns", "t,theta")
        fragments = (str(src), "--columns names 2 columns, the table has 3")
    elif case == "repeated":  # a repeated time: the only times refused are unusable ones
        t = T.copy()
        t[100] = t[99]
        src.write_text(_lines(t, THETA))
        fragments = (str(src), "a repeated time, t[100]")
    else:  # y down, read as y up: the bob would be above its pivot
        src.write_text("t x y\n" + _lines(T, X, -Y))
        fragments = (str(src), "above the pivot", "y_down")
    out = tmp_path / "out"
    _one_line_error(invoke(*command[:1], str(src), *command[1:], *flags, "--out", str(out), "-q"), *fragments)
    assert not out.exists() or not any(out.iterdir())


def test_names_without_units_take_the_headers_units(tmp_path):
    # --columns t,theta over a header 'Time (ms)', 'Angle (deg)': the names without units were read as s and rad
    src = tmp_path / "log.csv"
    src.write_text("Time (ms),Angle (deg),Position (cm)\n"
                   + _lines(1e3 * T, np.degrees(THETA), 40 * np.sin(THETA), sep=","))
    for columns in ("t,theta,_", "t,theta[deg],_"):
        rec = read_record(src, spec=TableSpec(columns=tuple(columns.split(","))))
        np.testing.assert_allclose(rec.t, T, rtol=0, atol=1e-9)
        np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=1e-9)
    rec = read_record(src, spec=TableSpec(columns=("t[s]", "theta", "_")))  # a declared unit is taken as declared
    np.testing.assert_allclose(rec.t, 1e3 * T, rtol=1e-12)
    with pytest.raises(ArtifactError, match=r"column 2 x, but the header gives it as 'Angle \(deg\)', an angle"):
        read_record(src, spec=TableSpec(columns=("t", "x", "y")))


def test_a_sample_written_twice_is_read_once(tmp_path):
    # an encoder logger (satyamchoudhary1303/MTP, "-10 deg angle log.csv") writes some samples two to four
    # times, time and angle alike: refused at "a repeated time" although nothing in it is ambiguous
    rows = np.repeat(np.arange(T.size), np.where(np.arange(T.size) % 7 == 3, 3, 1))  # every 7th row thrice
    src = tmp_path / "log.csv"
    src.write_text("Timestamp (s),Angle (rad)\n" + _lines(T[rows], THETA[rows], sep=","))
    rec = read_record(src)
    np.testing.assert_array_equal(rec.t, T)
    np.testing.assert_array_equal(rec.theta, THETA)
    assert any(f"{rows.size - T.size} rows repeat the row before them exactly" in w for w in rec.info["warnings"])
    t = T[rows].copy()
    theta = THETA[rows].copy()
    theta[4] += 0.01  # a time repeated with another angle: which sample is at t? refused, naming it
    src.write_text("Timestamp (s),Angle (rad)\n" + _lines(t, theta, sep=","))
    with pytest.raises(ArtifactError, match=r"a repeated time \(one of 2\), t\[4\]"):
        read_record(src)


@pytest.mark.integration
def test_a_record_laid_out_in_rows_is_named_in_one_short_line(tmp_path):
    # a logger's export with one row of times [ms] and one of angles [deg] (1477 values each): the
    # --columns hint spelled out for every column was a 6000-character "one line"
    src = tmp_path / "rows.csv"
    n = 300
    src.write_text(",".join(f"{50 * i}" for i in range(n)) + "\n"
                   + ",".join(f"{round(np.degrees(v))}" for v in THETA[:n]) + "\n")
    line = _one_line_error(invoke("fit", str(src), "--model", "standard", "--out", str(tmp_path / "o"), "-q"),
                           str(src), f"2 rows of {n} values", "transpose")
    assert len(line) < 300
    assert not (tmp_path / "o").exists() or not any((tmp_path / "o").iterdir())


@pytest.mark.integration
@pytest.mark.parametrize("name", ["log.csv", "angle.parquet", "run.trk"])
def test_a_git_lfs_pointer_in_place_of_a_table_is_named_as_one(tmp_path, name):
    # a user's repository cloned without git lfs: each log is this three-line text
    src = tmp_path / name
    src.write_text("version https://git-lfs.github.com/spec/v1\n"
                   "oid sha256:99a69d69d8d1438396810b22e54ebcbea63bd11b931f5ed2ed655bbaba58d1f7\nsize 27513\n")
    for command in COMMANDS:
        out = tmp_path / f"out_{command[0]}"
        _one_line_error(invoke(*command[:1], str(src), *command[1:], "--out", str(out), "-q"),
                        str(src), "a Git LFS pointer, not the data itself (fetch it: git lfs pull)")
        assert not out.exists() or not any(out.iterdir())


@pytest.mark.integration
def test_a_placeholder_theta_beside_moving_positions_names_the_columns_to_read(tmp_path):
    # a tracker's CSV (pandas' index, time, x, y, and theta written as 0 in every row for later): read as a
    # constant angle it was "no oscillation to fit"
    src = tmp_path / "track.csv"
    src.write_text("Unnamed: 0,time,x,y,theta\n" + "".join(
        f"{i},{float(t)!r},{float(x)!r},{float(y)!r},0.0\n" for i, (t, x, y) in enumerate(zip(T, X, Y))))
    _one_line_error(invoke("fit", str(src), "--model", "standard", "--out", str(tmp_path / "o"), "-q"),
                    str(src), "theta is 0 in every row", "--columns _,t,x,y,_")
    assert not (tmp_path / "o").exists() or not any((tmp_path / "o").iterdir())
    # ... and the hint reads the swing
    res = invoke("kinematics", str(src), "--columns", "_,t,x,y,_", "--out", str(tmp_path / "k"), "-q")
    assert res.exit_code == 0, res.output


@pytest.mark.integration
def test_a_wide_headerless_table_gets_a_short_columns_hint(tmp_path):
    src = tmp_path / "wide.txt"
    src.write_text(_lines(*([T, THETA] + [T] * 10)))
    line = _one_line_error(invoke("kinematics", str(src), "--out", str(tmp_path / "o"), "-q"),
                           "12 columns and no header", "--columns t,theta,_,...", "10 to ignore")
    assert len(line) < 300


@pytest.mark.integration
def test_bad_columns_flag_is_a_one_line_usage_error(tmp_path):
    src, _ = _write(tmp_path, "plain")
    _one_line_error(invoke("kinematics", str(src), "--columns", "t,omega", "--out", str(tmp_path / "o")),
                    "--columns", "unknown column name 'omega'")


@pytest.mark.integration
def test_kinematics_artifact_is_refused_by_kinematics(tmp_path, reference):
    p = tmp_path / "kinematics.parquet"
    write_artifact(reference["kinematics"], p, "kinematics", provenance=Provenance(stage="kinematics"))
    _one_line_error(invoke("kinematics", str(p), "--out", str(tmp_path / "o")), "already differentiated")


@pytest.mark.integration
def test_xy_path_too_short_to_fit_its_pivot(tmp_path):
    src = tmp_path / "xy.txt"
    tiny = 1e-3 * THETA  # a 0.03 deg swing
    src.write_text("t x y\n" + _lines(T, L * np.sin(tiny), -L * np.cos(tiny)))
    _one_line_error(invoke("kinematics", str(src), "--out", str(tmp_path / "o")), "give --pivot X Y")


# --- warnings -----------------------------------------------------------------------------

def test_degrees_without_a_unit_are_an_error_naming_the_fix(tmp_path):
    src = tmp_path / "deg.txt"
    src.write_text(_lines(T, np.degrees(THETA)))
    with pytest.raises(ArtifactError, match=r"looks like degrees: declare the unit with --columns t,theta\[deg\]"):
        read_record(src)
    # declared, it reads as the radians it is
    rec = read_record(src, spec=TableSpec(columns=("t", "theta[deg]")))
    np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=1e-12)
    # a pendulum spun over the top before it swings declares rad: turns are not degrees
    t = np.arange(6000) / 120
    over = np.where(t < 5, 2.6 * t, 13.0 + 0.8 * np.exp(-t / 30) * np.sin(5 * (t - 5)))
    src.write_text(_lines(t, over))
    np.testing.assert_allclose(read_record(src, spec=TableSpec(columns=("t", "theta[rad]"))).theta, over, atol=0)
    # swings of up to 8 between turning points are degrees; declared rad they are refused, as no free pendulum
    # swings beyond a full turn between two turning points (it would turn back beyond the top)
    turns = 4.0 * THETA
    src.write_text(_lines(T, turns))
    with pytest.raises(ArtifactError, match="not radians, it looks like degrees"):
        read_record(src)
    with pytest.raises(ArtifactError, match="more than a full turn, which no free pendulum does .*: column 2 is not an "
                                            r"angle in rad"):
        read_record(src, spec=TableSpec(columns=("t", "theta[rad]")))
    np.testing.assert_allclose(read_record(src, spec=TableSpec(columns=("t", "theta[deg]"))).theta,
                               np.radians(turns), rtol=1e-15)



def test_a_headerless_column_too_large_for_radians_may_also_be_a_position(tmp_path):
    # a headerless t, x track in pixels about the axle (60 px swings) was told "it looks like degrees", and read so
    # its Omega0 came out 4.27 against the 4.12 of the swing: with no header the same numbers may be a position
    src = tmp_path / "track.txt"
    src.write_text(_lines(T, 60.0 * np.sin(THETA)))
    with pytest.raises(ArtifactError, match=r"it looks like degrees: declare .*; with no header to say what the column "
                                            r"is, it may be the bob's position \(px, mm\) instead: .*--columns t,x,y"):
        read_record(src)
    src.write_text("t,theta\n" + _lines(T, np.degrees(THETA), sep=","))  # a header calls it theta: degrees alone
    with pytest.raises(ArtifactError, match="it looks like degrees") as err:
        read_record(src)
    assert "position" not in str(err.value)

def test_pixels_are_no_angle_in_any_unit(tmp_path):
    # a phone track's x, y [px] without a header, its bob swinging 0.2 rad on a 1000-px arm with 4 px of noise:
    # read as theta, the numbers are neither radians nor degrees (x swings by 400 between turning points), and
    # the error says so instead of suggesting degrees; declared in degrees they are refused too (they were read
    # as a 200-degree swing, Omega0 9.15 rad/s against 5.87); as the positions they are, they read
    rng = np.random.default_rng(8)
    t = np.arange(0, 60, 1 / 30)
    th = 0.2 * np.exp(-t / 80) * np.cos(5.87 * t)
    x = 1000 * np.sin(th) + rng.normal(0, 4, t.size)
    y = 650 - 1000 * np.cos(th) + rng.normal(0, 4, t.size)
    src = tmp_path / "track.txt"
    np.savetxt(src, np.c_[t, x, y], fmt="%.4f\t%.2f\t%.2f")
    with pytest.raises(ArtifactError, match=r"read as degrees the numbers do not make a pendulum's swing either: "
                                            r"not an angle \(a position in pixels or mm\? then name the columns x and y\)"):
        read_record(src, spec=TableSpec(columns=("t", "theta", "_")))
    with pytest.raises(ArtifactError, match=r"column 2 is not an angle in deg"):
        read_record(src, spec=TableSpec(columns=("t", "theta[deg]", "_")))
    rec = read_record(src, spec=TableSpec(columns=("t", "x", "y"), pivot=(0.0, 650.0)))
    assert np.max(np.abs(rec.theta)) < 0.25


def test_a_count_that_only_grows_is_no_angle_in_any_unit(tmp_path):
    # a light gate's log (gkowash/Pendulum-Lab): event number, then the board's millis() at each event, no header;
    # read as t, theta the millis were called "it looks like degrees", and declared in degrees "does not swing"
    events = np.arange(1, 200)
    millis = 6944 + 830 * events + np.random.default_rng(9).integers(-5, 5, events.size)
    src = tmp_path / "gate.csv"
    src.write_text("".join(f"{e},{m}\n" for e, m in zip(events, millis)))
    with pytest.raises(ArtifactError, match=r"in degrees too: not an angle \(a count, a clock\?\)") as err:
        read_record(src)
    assert "deg]" not in str(err.value)


def test_position_given_as_theta_warns(tmp_path):
    src = tmp_path / "x.txt"
    src.write_text(_lines(T, X + 0.5))  # x [m] of a pivot 0.8 m from the origin, read as theta
    rec = read_record(src)
    assert len(rec.warnings) == 1 and "looks like a position" in rec.warnings[0]


def test_plausible_angles_do_not_warn():
    assert theta_warnings(THETA) == []
    # a pendulum launched over the top twice, then swinging about 4 pi: turns are not degrees
    t = np.arange(6000) / 120
    over = np.where(t < 5, 2.6 * t, 13.0 + 0.8 * np.exp(-t / 30) * np.sin(5 * (t - 5)))
    assert theta_warnings(over) == []


@pytest.mark.integration
def test_cli_prints_the_warning_and_records_it(tmp_path):
    src = tmp_path / "x.txt"
    src.write_text(_lines(T, X + 0.5))
    out = tmp_path / "o"
    env_path = str(ROOT)
    proc = subprocess.run([sys.executable, "-m", "pendtrack", "kinematics", str(src), "--out", str(out), "-q"],
                          capture_output=True, text=True, env={"PYTHONPATH": env_path, "PATH": "/usr/bin:/bin"})
    assert proc.returncode == 0, proc.stderr
    assert "looks like a position" in proc.stderr and str(src) in proc.stderr
    extra = (read_metadata(out / "kinematics.parquet") or {})["extra"]
    assert any("looks like a position" in w for w in extra["input"]["warnings"])


# --- time stamps --------------------------------------------------------------------------

def _jittered(seconds: float = 8.0, jitter: float = 0.1) -> tuple[np.ndarray, np.ndarray]:
    """Phone-like times: true instants off the 60 Hz grid by up to ``jitter`` step; theta at those instants."""
    t_grid = np.arange(int(seconds * RATE)) / RATE
    rng = np.random.default_rng(2)
    t = t_grid + rng.uniform(-jitter, jitter, t_grid.size) / RATE
    t[0] = 0.0  # the motion starts at the first sample (simulate starts there)
    sim = simulate(get_model("standard"), SWING, t, theta0=1.0, omega0=0.0)
    return t, sim.theta


def test_slightly_uneven_times_are_resampled_by_a_cubic_spline(tmp_path):
    t, theta = _jittered()
    src = tmp_path / "phone.txt"
    src.write_text(_lines(t, theta))
    rec = read_record(src)
    r = rec.info["resampled"]
    # jitter of up to 0.1 step about the true grid; the fitted grid's origin and step move it by a hair
    assert r is not None and "cubic" in r["method"] and 0.05 < r["max_offset_steps"] <= 0.11
    assert np.ptp(np.diff(rec.t)) < 1e-9 * r["step_s"] + 1e-12  # a uniform grid
    assert r["step_s"] == pytest.approx(1 / RATE, rel=1e-3)
    # the resampled values are the motion at the grid times (the grid may start a hair off 0):
    # the model on a fine grid from 0, splined to the grid times, is the truth there
    from scipy.interpolate import CubicSpline

    fine = np.arange(0, 8.1, 1e-3)
    ref = simulate(get_model("standard"), SWING, fine, theta0=1.0, omega0=0.0).theta
    truth = CubicSpline(fine, ref)(rec.t)
    # 1e-6 rad: the cubic spline's error on a 1 rad, 5 rad/s swing at 60 Hz (order h^4) measured 2.7e-7;
    # linear interpolation of the same times is off by ~1e-3 (order h^2), far above tracking noise
    assert np.max(np.abs(rec.theta - truth)) < 1e-6


@pytest.mark.integration
def test_kinematics_then_fit_on_phone_timestamps(tmp_path, fast_fit):
    # before: kinematics accepted these times and `fit` refused them ("not on a uniform grid")
    t, theta = _jittered(seconds=8.0, jitter=0.2)
    angle = tmp_path / "angle.parquet"
    write_artifact(pd.DataFrame({"t": t, "theta": theta, "ok": np.ones(t.size, bool)}), angle, "angle",
                   provenance=Provenance(stage="test"))
    assert invoke("kinematics", str(angle), "--out", str(tmp_path), "-q").exit_code == 0
    extra = read_artifact(tmp_path / "kinematics.parquet", "kinematics").provenance.extra
    assert extra["input"]["resampled"]["max_offset_steps"] > 0.1
    res = invoke("fit", str(tmp_path / "kinematics.parquet"), "--model", "standard", "--config", str(fast_fit),
                 "--out", str(tmp_path / "f"), "-q")
    assert res.exit_code == 0, res.output
    # and a kinematics file written with jittered times (an older pendtrack's) is resampled by `fit` itself
    kin = read_artifact(tmp_path / "kinematics.parquet", "kinematics")
    old = kin.data.copy()
    old["t"] = t
    write_artifact(old, tmp_path / "old" / "kinematics.parquet", "kinematics", provenance=kin.provenance)
    res = invoke("fit", str(tmp_path / "old" / "kinematics.parquet"), "--model", "standard", "--config",
                 str(fast_fit), "--out", str(tmp_path / "f2"), "-q")
    assert res.exit_code == 0, res.output
    prov = json.loads((tmp_path / "f2" / "fit.json").read_text())["provenance"]
    assert prov["config"]["input"]["resampled"]["method"].startswith("cubic")


def test_times_written_with_too_few_decimals_are_taken_on_their_grid(tmp_path, fast_fit):
    """Found on mohamedcansiz-jpg/Pendulo@699ef7c (an OpenCV tracker's 30-fps table, times to 5 decimals): 0.03333
    for 1/30 s drifts 3.3 us a row off the median spacing's grid, 0.003 s (9 % of a step) after 900 rows, and the
    fit refused the record as "not on a uniform grid". Each time is within half a unit of its last decimal (5 us,
    1.5e-4 of a step) of the least-squares grid: the rows are taken there."""
    t = np.arange(900) / 30.0
    theta = 0.165 * np.cos(3.7 * t)
    src = tmp_path / "tracker.csv"
    src.write_text("t,theta\n" + "".join(f"{a:.5f},{b:.5f}\n" for a, b in zip(t, theta)))
    rec = read_input(src)
    assert rec.info["times_rounded"] is not None and rec.info["times_rounded"]["max_offset_steps"] < 2e-4
    assert rec.info["resampled"] is None  # the angles are the file's, not interpolated
    # the times are the grid's: 1/30 s to the least-squares step's accuracy (5 us over 900 rows, ~1e-8 s)
    np.testing.assert_allclose(rec.t, t, rtol=0, atol=1e-6)
    np.testing.assert_array_equal(rec.theta, np.round(theta, 5))
    res = invoke("fit", str(src), "--model", "standard", "--config", str(fast_fit), "--out", str(tmp_path / "f"), "-q")
    assert res.exit_code == 0, res.output
    fit = json.loads((tmp_path / "f" / "fit.json").read_text())
    # a 0.165-rad swing at 3.7 rad/s is a pendulum of Omega0 = 3.7 / (1 - A^2/16) (next term 11 A^4/3072, 3e-6);
    # the angle was written to 5 decimals (2.9e-6 rad rms): within 1e-4
    assert fit["params"]["Omega0"]["value"] == pytest.approx(3.7 / (1 - 0.165 ** 2 / 16), rel=1e-4)


def test_gaps_stay_gaps():
    t = np.arange(600) / RATE
    t = np.delete(t, np.arange(200, 230))  # half a second missing
    t[::7] += 0.1 / RATE  # and jitter
    grid = uniform_grid(t)
    assert grid is not None and np.diff(grid.index).max() == 31 and grid.max_offset < 0.11
    assert uniform_grid(np.arange(600) / RATE) is None


@pytest.mark.integration
def test_lab1_needs_columns_and_then_reads_20_hz(tmp_path):
    if not REAL.is_file():
        pytest.skip(f"real data not found at {REAL}")
    with pytest.raises(ArtifactError, match="add --columns t,theta,_"):
        read_input(REAL)
    rec = read_input(REAL, table=TableSpec(columns=("t", "theta", "_")))
    assert rec.t.size == 2330 and 1 / np.median(np.diff(rec.t)) == pytest.approx(20.0, rel=0.01)
    # its phone timestamps are off a uniform grid by ~0.5 % of a step: resampled, not refused
    assert rec.info["resampled"] is not None and rec.info["resampled"]["max_offset_steps"] < 0.01
    assert rec.warnings == ()
    res = invoke("kinematics", str(REAL), "--columns", "t,theta,_", "--out", str(tmp_path), "-q")
    assert res.exit_code == 0 and "Omega0 =" in res.output


def test_positions_from_a_turned_camera_are_refused_naming_the_columns(tmp_path):
    """A camera turned by 90 degrees (georgePadolsey/PendulaTools' `pts-*.txt`: `t x y` with the swing along y)
    puts the bob's swing 90 degrees from straight down: its angle's zero would be meaningless, and the fit of
    such a record ran for minutes. Refused, naming the columns; with them, the record reads as the plain one."""
    src = tmp_path / "turned.txt"
    src.write_text(_lines(T, PY - Y, X - PX))  # gravity along +x; the horizontal along y
    res = invoke("kinematics", str(src), "--columns", "t,x,y", "--out", str(tmp_path / "out"))
    _one_line_error(res, "the vertical is not the y column")
    assert "--columns t,y,x or t,y_down,x" in res.output and not (tmp_path / "out").exists()
    # the suggestion swaps the roles in the user's own names: a skipped time column and units stay where they are
    res = invoke("kinematics", str(src), "--columns", "_,x[cm],y[cm]", "--rate", "120", "--out", str(tmp_path / "out"))
    _one_line_error(res, "the vertical is not the y column")
    assert "--columns _,y[cm],x[cm] or _,y_down[cm],x[cm]" in res.output and not (tmp_path / "out").exists()
    rec = read_input(src, table=TableSpec(columns=parse_columns("t,y_down,x", check_roles=False)))
    # y_down = PY - Y points down, x = X - PX: the plain record's angle about the fitted pivot (exact data)
    np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=1e-9)


def test_a_swing_over_the_top_is_read_though_it_lingers_above_its_pivot(tmp_path):
    # Algath/Physic_project_double_pendulum@fb1e8e8: a track from near the top, its pivot given, was refused as
    # "above the pivot in most samples"; a swing from 3.05 rad spends 78 % of its time above the pivot, but moves
    # fastest below it
    t, theta = swing("classic", {"Omega0": 5.1, "C0": 0.003, "C3": 0.002, "p": 1.4, "Ca": 0.0}, seconds=6.0,
                     fps=60.0, theta0=3.05)
    x, y = 0.3 * np.sin(theta), -0.3 * np.cos(theta)  # y up, pivot at the origin
    src = tmp_path / "top.txt"
    src.write_text("t x y\n" + _lines(t, x, y))
    rec = read_record(src, spec=TableSpec(pivot=(0.0, 0.0)))
    np.testing.assert_allclose(rec.theta, theta, rtol=0, atol=1e-9)
    # the same positions with y read the other way: above in most samples and fastest there, refused
    src.write_text("t x y_down\n" + _lines(t, x, y))
    with pytest.raises(ArtifactError, match="above the pivot"):
        read_record(src, spec=TableSpec(pivot=(0.0, 0.0)))
    # a pivot below the whole path: above in every sample
    src.write_text("t x y\n" + _lines(t, x, y))
    with pytest.raises(ArtifactError, match="above the pivot"):
        read_record(src, spec=TableSpec(pivot=(0.0, -1.0)))


def test_a_header_naming_more_columns_than_the_rows_hold_is_answered_with_the_rows_count(tmp_path):
    # BY-Chai/PHY180-Projects@a71b1d94: Tracker tables headed "x y dx dy" whose rows hold t and theta [deg] only;
    # the hint counted the header's four names (--columns t,theta,_,_), which the next run refused
    src = tmp_path / "10cm.txt"
    src.write_text("x y dx dy\n" + _lines(T, np.degrees(THETA)))
    with pytest.raises(ArtifactError, match=r"names 4 columns, the rows hold 2, .* e\.g\. --columns t,theta$"):
        read_record(src)
    rec = read_record(src, spec=TableSpec(columns=("t", "theta[deg]")))
    np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=1e-12)


@pytest.mark.parametrize("sep", [",", ";"])
def test_a_table_starting_in_a_later_spreadsheet_column_reads_as_its_own_columns(tmp_path, sep):
    # planT-444/phy180-pendulum@92719396: every row of the CSV starts with three empty cells (the table began in
    # column D of the spreadsheet); its last data row was taken for the header and nothing was read
    src = tmp_path / "table.csv"
    src.write_text("".join(f"{sep * 3}{line}\n" for line in
                           ["t" + sep + "theta (rad)", *(f"{a!r}{sep}{b!r}" for a, b in zip(T, THETA))]))
    rec = read_record(src)
    np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=0)
    np.testing.assert_allclose(rec.t, T, rtol=0, atol=0)
