"""Instrument files with units (pendtrack.tables): each format physicists export, on small synthetic
files that carry the format's exact header; the unit checks; real sample times with jitter."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from factory import swing
from scipy.interpolate import CubicSpline

from pendtrack.artifacts import read_artifact
from pendtrack.errors import ArtifactError, ConfigError
from pendtrack.models import get_model, simulate
from pendtrack.stages.kinematics import read_input
from pendtrack.tables import TableSpec, parse_column_name, read_record
from pendtrack.tables.rounded_times import digit_unit
from pendtrack.tables.trk import image_to_world
from test_tables import _one_line_error, invoke

RATE = 60.0
SWING = {"Omega0": 5.0, "C1": 0.1, "C0": 0.05, "C2": 0.05}
L, PX, PY = 0.65, 0.1, 0.4  # pendulum length and pivot [m], world axes (y up)
T = np.arange(int(6.0 * RATE)) / RATE
THETA = simulate(get_model("standard"), SWING, T, theta0=1.0, omega0=0.0).theta
X, Y = PX + L * np.sin(THETA), PY - L * np.cos(THETA)
# float round trips: repr() is exact; degrees and x, y convert back with float rounding only (1e-12 rad)
ATOL = 1e-9


def _rows(*cols: np.ndarray, sep: str = ",", fmt=repr) -> str:
    return "".join(sep.join(fmt(float(v)) for v in row) + "\n" for row in zip(*cols))


# --- names and units ----------------------------------------------------------------------

@pytest.mark.parametrize("label, role, scale, unit", [
    ("t_s", "t", 1.0, "s"), ("time (s)", "t", 1.0, "s"), ("Time [ms]", "t", 1e-3, "ms"),
    ("t_us", "t", 1e-6, "µs"), ("t (µs)", "t", 1e-6, "µs"), ("T [μs]", "t", 1e-6, "µs"),
    ("t [min]", "t", 60.0, "min"),
    ("theta1_rad", "theta", 1.0, "rad"), ("Angle (°)", "theta", math.pi / 180, "°"),
    ("angle_deg", "theta", math.pi / 180, "deg"), ("theta [mrad]", "theta", 1e-3, "mrad"),
    ("VideoAnalysis: Time (s)", "t", 1.0, "s"), ('"Time (s)"', "t", 1.0, "s"),
    ("Run 1: Angle (°)", "theta", math.pi / 180, "°"),
    ("Latest: Time (s)", "t", 1.0, "s"), ("angle 1", "theta", 1.0, ""), ("x1", "x", 1.0, ""),
    ("VideoAnalysis: X (m)", "x", 1.0, "m"), ("x [cm]", "x", 0.01, "cm"), ("y_down [px]", "y", 1.0, "px"),
    ("Angle (deg)", "theta", math.pi / 180, "deg"),
])
def test_header_spellings(label, role, scale, unit):
    c = parse_column_name(label)
    assert c is not None and c.role == role and c.scale == pytest.approx(scale, rel=1e-15) and c.unit == unit


@pytest.mark.parametrize("label", ["Angular velocity (rad/s)", "VideoAnalysis: X Velocity (m/s)", "v_{x}", "θ_{r}",
                                   "pixel_{x}", "step", "frame", "Run 1: Acceleration (m/s²)"])
def test_other_instrument_columns_are_not_read(label):
    assert parse_column_name(label) is None


def test_units_that_do_not_fit_are_refused():
    with pytest.raises(ConfigError, match="unknown unit 'm'"):
        parse_column_name("theta [m]")
    with pytest.raises(ConfigError, match="not a length"):
        parse_column_name("x [deg]")


# --- plain encoder logs and the unit checks -------------------------------------------------

@pytest.mark.integration
def test_encoder_log_in_degrees_is_an_error_then_reads_with_the_unit(tmp_path):
    src = tmp_path / "encoder.csv"  # an encoder log `Time,Angle` in degrees
    src.write_text("Time,Angle\n" + _rows(T, np.degrees(THETA)))
    out = tmp_path / "o"
    _one_line_error(invoke("kinematics", str(src), "--out", str(out), "-q"), str(src), "looks like degrees",
                    "--columns t,theta[deg]")
    assert not out.exists() or not any(out.iterdir())  # no artifact
    res = invoke("kinematics", str(src), "--columns", "t,theta[deg]", "--out", str(out), "-q")
    assert res.exit_code == 0, res.output
    kin = read_artifact(out / "kinematics.parquet", "kinematics")
    np.testing.assert_allclose(kin.data["t"], T, rtol=0, atol=1e-12)
    assert kin.provenance.extra["input"]["columns"] == ["t", "theta[deg]"]


def test_parquet_in_degrees_names_the_column_to_rename(tmp_path):
    import pandas as pd

    src = tmp_path / "angles.parquet"
    pd.DataFrame({"t": T, "theta": np.degrees(THETA)}).to_parquet(src)
    with pytest.raises(ArtifactError, match=r"looks like degrees: name the Parquet column 'theta \[deg\]'"):
        read_record(src)
    pd.DataFrame({"t": T, "theta [deg]": np.degrees(THETA)}).to_parquet(src)
    np.testing.assert_allclose(read_record(src).theta, THETA, rtol=0, atol=ATOL)


def test_encoder_log_degrees_in_the_header(tmp_path):
    src = tmp_path / "encoder.csv"
    src.write_text("t_s,angle_deg\n" + _rows(T, np.degrees(THETA)))
    np.testing.assert_allclose(read_record(src).theta, THETA, rtol=0, atol=ATOL)


def _encoder_us(jitter: float, seed: int = 4) -> tuple[np.ndarray, np.ndarray, CubicSpline]:
    """Sample times of a 50 Hz encoder with real jitter (up to ``jitter`` of a step), theta there,
    and the motion itself (a fine simulation, splined: exact to ~1e-11 rad at 1 ms)."""
    fine = np.arange(0.0, 8.1, 1e-3)
    motion = CubicSpline(fine, simulate(get_model("standard"), SWING, fine, theta0=1.0, omega0=0.0).theta)
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 8.0, 0.02) + rng.uniform(-jitter, jitter, 400) * 0.02
    t[0] = 0.0
    t = np.round(t * 1e6) / 1e6  # whole microseconds, as the encoder writes them
    return t, motion(t), motion


@pytest.mark.integration
def test_headerless_us_degree_log_with_jitter(tmp_path):
    t, theta, motion = _encoder_us(jitter=0.3)
    src = tmp_path / "encoder.txt"  # headerless: t in µs, theta in degrees, real sampling jitter
    src.write_text("".join(f"{int(round(a * 1e6)) + 2_000_000} {math.degrees(b)!r}\n" for a, b in zip(t, theta)))
    msg = _one_line_error(invoke("kinematics", str(src), "--out", str(tmp_path / "o"), "-q"), str(src),
                          "looks like µs", "looks like degrees", "--columns t[us],theta[deg]")
    assert "uneven" not in msg
    rec = read_record(src, spec=TableSpec(columns=("t[us]", "theta[deg]")))
    r = rec.info["resampled"]
    assert r["irregular"] and np.ptp(np.diff(rec.t)) < 1e-9  # a uniform grid
    # the mean spacing: the encoder's step, off by the last sample's jitter spread over 399 steps
    assert r["step_s"] == pytest.approx(0.02, rel=0.3 / 399)
    # the stated bound holds: the resampled theta is the motion at the grid times within it, and it is
    # small (H <= 1.6 steps of 20 ms: 5/384 H^4 |theta''''| ~ 1e-5 rad, far below an encoder's resolution)
    err = np.max(np.abs(rec.theta - motion(rec.t - 2.0)))
    assert err <= r["error_bound_rad"] < 1e-4
    assert rec.t.size >= 395 and rec.ok.all()
    res = invoke("kinematics", str(src), "--columns", "t[us],theta[deg]", "--out", str(tmp_path / "o"), "-q")
    assert res.exit_code == 0 and "Omega0 = 4.9" in res.output  # Omega0 5 with the damping's shift


def test_time_in_ms_without_a_unit_is_an_error(tmp_path):
    src = tmp_path / "log.txt"
    src.write_text("time angle\n" + _rows(T * 1000.0, THETA, sep=" "))
    with pytest.raises(ArtifactError, match=r"looks like ms: declare the unit with --columns t\[ms\],theta"):
        read_record(src)
    np.testing.assert_allclose(read_record(src, spec=TableSpec(columns=("t[ms]", "theta"))).t, T, atol=1e-12)
    # a declared unit is taken as declared
    src.write_text("time [ms],angle\n" + _rows(T * 1000.0, THETA))
    np.testing.assert_allclose(read_record(src).theta, THETA, atol=0)


def test_irregular_times_with_a_gap_and_close_samples():
    t, theta, motion = _encoder_us(jitter=0.45, seed=5)
    lost = np.arange(150, 170)  # 0.4 s lost
    t, theta = np.delete(t, lost), np.delete(theta, lost)
    import pendtrack.tables.grid as grid

    ok = np.ones(t.size, bool)
    new_theta, _, new_t, rec = grid.resample_irregular(t, theta, ok, {})
    assert rec["irregular"] and np.all(np.diff(new_t) > 0)
    steps = np.rint(np.diff(new_t) / rec["step_s"])
    assert steps.max() >= 20 and set(np.unique(steps)) - {1} == {steps.max()}  # one gap, no grid point in it
    assert np.max(np.abs(new_theta - motion(new_t))) <= rec["error_bound_rad"]


def _change_driven(count: float, seconds: float = 20.0, lost: tuple[float, float] | None = None
                   ) -> tuple[np.ndarray, np.ndarray, CubicSpline]:
    """An encoder logger writing a row each time its count changes (y-fysiks/PHY180-Pendulum-datafit's
    Lab2/data2_20.csv: 2400 counts a turn, a row per change, dwells of 0.3-0.6 s at the late turning points):
    the crossing times of the count edges k * count (to 1 us) and the count written, moving up the one
    above the edge, moving down the one below. ``lost``: a stretch [s] the logger missed."""
    fine = np.arange(0.0, seconds + 0.1, 1e-3)
    motion = CubicSpline(fine, simulate(get_model("standard"), SWING, fine, theta0=0.6, omega0=0.0).theta)
    tt = np.arange(0.0, seconds, 2e-5)
    th = motion(tt)
    level = np.floor(th / count)
    at = np.flatnonzero(np.diff(level)) + 1  # first fine sample past each crossing
    if lost is not None:
        at = at[(tt[at] < lost[0]) | (tt[at] > lost[1])]
    edge = np.maximum(level[at], level[at - 1]) * count  # the edge crossed, either way
    t = tt[at - 1] + (edge - th[at - 1]) / (th[at] - th[at - 1]) * 2e-5  # its time, linear within 20 us
    return np.round(t * 1e9) / 1e9, level[at] * count, motion


@pytest.mark.integration
def test_a_log_written_on_each_change_of_the_count(tmp_path):
    # Such a log's long spacings are the bob dwelling within one count near its turning points: every one of them
    # was a gap ("no gap-free stretch of at least 1 s ... 209 segment(s), all too short"), and each row's value is
    # the count above or below the edge crossed, a hysteresis of one count between rising and falling halves.
    count = 2.0 * np.pi / 2400.0
    t, theta, motion = _change_driven(count)
    src = tmp_path / "encoder.csv"
    src.write_text("timestamp, angle\n" + "".join(f"{a:.9f}, {b!r}\n" for a, b in zip(t.tolist(), theta.tolist())))
    rec = read_record(src)
    r = rec.info["resampled"]
    assert r["change_driven"] and r["count_rad"] == pytest.approx(count, rel=1e-9) and rec.ok.all()
    assert rec.t[-1] > 19.0 and rec.t.size == pytest.approx(np.ptp(rec.t) / r["step_s"] + 1, abs=0.5)  # no gaps
    err = rec.theta - motion(rec.t)
    omega = motion(rec.t, 1)
    fast = np.abs(omega) > 0.3 * np.max(np.abs(omega))  # away from the turning points' dwells
    rising, falling = err[fast & (omega > 0)], err[fast & (omega < 0)]
    # at the edges the bob crossed: rising and falling halves agree to well within a count (as written they
    # differ by one), and the angle is the motion's up to the constant half count of the labels
    assert abs(np.mean(rising) - np.mean(falling)) < 0.1 * count
    assert np.mean(err) == pytest.approx(-0.5 * count, abs=0.1 * count)
    assert np.std(err[fast]) < 0.2 * count
    res = invoke("kinematics", str(src), "--out", str(tmp_path / "o"), "-q")
    assert res.exit_code == 0, res.output


def test_a_change_driven_log_keeps_the_gaps_it_has():
    # a stretch the logger missed moves the count by many: that spacing is a gap, the dwells are not
    import pendtrack.tables.grid as grid

    count = 2.0 * np.pi / 2400.0
    t, theta, _ = _change_driven(count, seconds=12.0, lost=(5.0, 5.6))
    ok = np.ones(t.size, bool)
    assert grid.change_count(theta, ok) == pytest.approx(count, rel=1e-9)
    edge, ok, gap_after = grid.at_count_edges(theta, ok, count)
    assert np.count_nonzero(gap_after) == 1 and 4.9 < t[:-1][gap_after][0] < 5.0
    # a clock-sampled log of the same swing repeats its count at the turning points: not change-driven
    clock = np.arange(0.0, 12.0, 0.005)
    assert grid.change_count(np.floor(_change_driven(count, seconds=12.0)[2](clock) / count) * count,
                             np.ones(clock.size, bool)) is None


def test_a_change_driven_log_that_stops_writing_has_a_gap_not_an_invented_swing(tmp_path):
    # y-fysiks/PHY180-Pendulum-datafit@607a0fa, Lab2/data2_29.csv: 39 s of a swing, then one row 30.7 s later, a
    # count from the last. A dwell within one count, by the change-driven reading: the cubic spline through it
    # invented a 10-rad bump over 30 s (its stated error bound 6e7 rad), and a 4-start fit of the 70-s record ran
    # for minutes. A spacing longer than a period is no swinging bob's dwell: a gap, said in a warning.
    count = 2.0 * np.pi / 2400.0
    t, theta, motion = _change_driven(count, seconds=12.0)
    t = np.r_[t, t[-1] + 30.7]
    theta = np.r_[theta, theta[-1] + count]
    src = tmp_path / "encoder.csv"
    src.write_text("timestamp, angle\n" + "".join(f"{a:.9f}, {b!r}\n" for a, b in zip(t.tolist(), theta.tolist())))
    rec = read_record(src)
    r = rec.info["resampled"]
    # the period of SWING (Omega0 5 rad/s, 1.26 s) measured from the rows' turning points, within 5 %
    assert r["change_driven"] and r["dwell_limit_s"] == pytest.approx(2 * np.pi / 5.0, rel=0.05)
    assert rec.t[-1] < 12.0 and r["n_samples_unused"] == 1  # the lone last row: a run too short for a spline
    assert np.max(np.abs(rec.theta)) < 0.61  # the swing's own reach (0.6 rad), no bump
    assert any("longest 30.7 s after" in w and "a gap" in w for w in rec.warnings)
    # the log as written before its last row reads as it did: no spacing of the swing itself is taken for a gap
    plain = tmp_path / "plain.csv"
    plain.write_text("timestamp, angle\n" + "".join(f"{a:.9f}, {b!r}\n" for a, b in zip(t[:-1].tolist(),
                                                                                       theta[:-1].tolist())))
    ref = read_record(plain)
    assert ref.warnings == () and ref.t.size == rec.t.size and np.array_equal(ref.theta, rec.theta)


# --- column names: indexed, t_s ---------------------------------------------------------------

def test_indexed_names_t_s_theta1_rad(tmp_path):
    src = tmp_path / "run.csv"
    src.write_text("t_s, theta1_rad, omega1_rad_s\n" + _rows(T, THETA, T))
    np.testing.assert_allclose(read_record(src).theta, THETA, rtol=0, atol=0)


def test_two_indexed_angles_are_ambiguous(tmp_path):
    src = tmp_path / "double.csv"
    src.write_text("t,theta1,theta2\n" + _rows(T, THETA, 2 * THETA))
    with pytest.raises(ArtifactError, match=r"two columns are theta .*pick one with --columns t,theta,_"):
        read_record(src)


# --- Vernier: Video Analysis, Logger Pro --------------------------------------------------------

def test_vernier_video_analysis_csv(tmp_path):
    src = tmp_path / "video_analysis.csv"
    head = ('"VideoAnalysis: Time (s)","VideoAnalysis: X (m)","VideoAnalysis: Y (m)",'
            '"VideoAnalysis: X Velocity (m/s)","VideoAnalysis: Y Velocity (m/s)"\n')
    src.write_text(head + _rows(T, X, Y, np.gradient(X, T), np.gradient(Y, T)))
    rec = read_input(src)  # the pivot from the circle fit
    np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=ATOL)
    assert rec.info["pivot"]["x"] == pytest.approx(PX, abs=1e-9) and rec.info["pivot"]["y_axis"] == "up"


def test_logger_pro_latest_run(tmp_path):
    src = tmp_path / "logger_pro.csv"
    src.write_text('"Latest: Time (s)","Latest: Angle (°)","Latest: Angular Velocity (rad/s)"\n'
                   + _rows(T, np.degrees(THETA), T), encoding="cp1252")  # Logger Pro on Windows writes cp1252
    np.testing.assert_allclose(read_record(src).theta, THETA, rtol=0, atol=ATOL)


@pytest.mark.integration
@pytest.mark.parametrize("names, unit, scale", [
    (("Run 1: Time (s)", "Run 1: Angle (°)", "Run 2: Time (s)", "Run 2: Angle (°)"), "deg", math.degrees(1.0)),
    (("Time (s) Run #1", "Angle (rad) Run #1", "Time (s) Run #2", "Angle (rad) Run #2"), "rad", 1.0),
], ids=["logger_pro", "pasco_capstone"])
def test_runs_side_by_side(tmp_path, names, unit, scale):
    # Logger Pro names a run before the column, PASCO Capstone after its unit
    n2 = 200  # run 2 is shorter: its cells are empty below
    src = tmp_path / "runs.csv"
    head = ",".join(f'"{n}"' for n in names) + "\n"
    body = "".join(f"{a!r},{scale * b!r}," + (f"{a!r},{-scale * b!r}" if k < n2 else ",") + "\n"
                   for k, (a, b) in enumerate(zip(T.tolist(), THETA.tolist())))
    src.write_text(head + body)
    out = tmp_path / "o"
    _one_line_error(invoke("fit", str(src), "--model", "standard", "--out", str(out), "-q"), str(src),
                    "two columns are t", f"--columns t[s],theta[{unit}],_,_")
    run1 = read_record(src, spec=TableSpec(columns=("t[s]", f"theta[{unit}]", "_", "_")))
    np.testing.assert_allclose(run1.theta, THETA, rtol=0, atol=ATOL)
    run2 = read_record(src, spec=TableSpec(columns=("_", "_", "t", f"theta[{unit}]")))
    assert run2.t.size == n2
    np.testing.assert_allclose(run2.theta, -THETA[:n2], rtol=0, atol=ATOL)


def test_logger_pro_text_export(tmp_path):
    src = tmp_path / "logger_pro.txt"  # Logger Pro's File > Export As > Text: names, short names, units
    head = "Vernier Format 2\nswing.cmbl 11/25/2026 10:12:03 .\nLatest\nTime\tAngle\nt\tθ\ns\t°\n\n"
    src.write_text(head + _rows(T, np.degrees(THETA), sep="\t"))
    rec = read_record(src)
    np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=ATOL)
    assert rec.info["columns"] == ["t[s]", "theta[deg]"]


@pytest.mark.parametrize("units", ["(s),(°)", "[ms],[deg]"])
def test_a_spreadsheets_units_line_in_brackets(tmp_path, units):
    # a units line under the names, each unit in its brackets as a spreadsheet user writes them: read without its
    # units, the degrees were taken for radians ("it looks like degrees")
    src = tmp_path / "sheet.csv"
    scale = 1e3 if "ms" in units else 1.0
    src.write_text("Time,Angle\n" + units + "\n" + _rows(scale * T, np.degrees(THETA), sep=","))
    rec = read_record(src)
    np.testing.assert_allclose(rec.t, T, rtol=0, atol=ATOL)
    np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=ATOL)


@pytest.mark.parametrize("header, scale, unit", [("s,rad", 1.0, "rad"), ("(ms),(°)", 1e3, "deg"),
                                                  ("s,rad,rad/s", 1.0, "rad"), ("t,rad,xerr", 1.0, "rad")])
def test_a_header_of_units_alone_names_time_and_angle(tmp_path, header, scale, unit):
    # a logger that heads its columns with their units only ('s,rad'): refused as "missing column 't'", although
    # the units say which column is the time and which the angle; a rate's column (rad/s) is passed over, and so is
    # an unknown word beside a column named by its unit (zjs0221/PHY180-Pendulum-Project's 't rad xerr yerr')
    src = tmp_path / "log.csv"
    angle = np.degrees(THETA) if unit == "deg" else THETA
    cols = (scale * T, angle) + ((np.gradient(THETA, T),) if header.count(",") == 2 else ())
    src.write_text(header + "\n" + _rows(*cols, sep=","))
    rec = read_record(src)
    np.testing.assert_allclose(rec.t, T, rtol=0, atol=ATOL)
    np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=ATOL)


def test_a_header_of_quantities_over_their_units(tmp_path):
    # a remote lab's encoder log (timdrysdale/pendulum-data): 'Time/s,Angle/rad,AngVel/rad/s' was refused as
    # "missing column 't' (recognised: none)"; the angular velocity, a rate, is passed over
    src = tmp_path / "run.csv"
    src.write_text("Time/s,Angle/rad,AngVel/rad/s\n" + _rows(T, THETA, np.gradient(THETA, T), sep=","))
    rec = read_record(src)
    np.testing.assert_allclose(rec.t, T, rtol=0, atol=ATOL)
    np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=ATOL)
    src.write_text("Time/ms,Angle/deg\n" + _rows(1e3 * T, np.degrees(THETA), sep=","))
    rec = read_record(src)
    np.testing.assert_allclose(rec.t, T, rtol=0, atol=ATOL)
    np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=ATOL)


@pytest.mark.parametrize("header", ["s,rad,deg", "rad,deg", "s,s,rad"])
def test_a_header_of_units_that_do_not_say_which_column_is_which_is_refused(tmp_path, header):
    src = tmp_path / "log.csv"
    src.write_text(header + "\n" + _rows(*(T, THETA, THETA)[: header.count(",") + 1], sep=","))
    with pytest.raises(ArtifactError, match="missing column"):
        read_record(src)


@pytest.mark.parametrize("footer", ["\nmean,0.0012\nstd,0.21\n", "Period (s):,1.26\n", "Stopped\n"])
def test_summary_lines_below_a_table_are_passed_over_with_a_warning(tmp_path, footer):
    # a spreadsheet's table with its mean and standard deviation under it, saved as CSV: refused at "line 363:
    # expected numbers t, theta, got 'mean,0.0012'", although every sample above it reads
    src = tmp_path / "sheet.csv"
    src.write_text("t (s),theta (rad)\n" + _rows(T, THETA, sep=",") + footer)
    rec = read_record(src)
    np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=ATOL)
    assert any("below the table" in w and "passed over" in w for w in rec.warnings)
    rows = _rows(T, THETA, sep=",").splitlines()
    src.write_text("t (s),theta (rad)\n" + "\n".join(rows[:5] + ["mean,0.0012"] + rows[5:]) + "\n")
    with pytest.raises(ArtifactError, match="line 7: expected numbers"):  # a word among the rows is still an error
        read_record(src)


# --- Logger Pro's and Graphical Analysis' own files ------------------------------------------------

def _vernier_xml(runs: list[tuple[str, list[tuple[str, str, list[str]]]]]) -> str:
    """A Logger Pro document (.cmbl's XML, the layout of Logger Pro 3.10's files): its settings, then a data set
    per run with a column per (name, unit, cells), then the data set where Logger Pro keeps its curve fits."""
    def column(i: int, name: str, unit: str, cells: list[str]) -> str:
        return (f"    <DataColumn>\n      <ID>{102 + i} </ID>\n      <DataObjectName>{name}</DataObjectName>\n"
                f"      <DataObjectShortName>{name[:1].lower()}</DataObjectShortName>\n"
                f"      <ColumnUnits>{unit}</ColumnUnits>\n      <ColumnTreatAsText>0</ColumnTreatAsText>\n"
                f"      <ColumnCells>\n" + "\n".join(cells) + "\n</ColumnCells>\n    </DataColumn>\n")
    sets = "".join(f"  <DataSet>\n    <ID>{101 + 10 * k} </ID>\n    <DataSetName>{name}</DataSetName>\n"
                   "    <DataSetShowInDataBrowser>1</DataSetShowInDataBrowser>\n"
                   + "".join(column(i, *c) for i, c in enumerate(cols)) + "  </DataSet>\n"
                   for k, (name, cols) in enumerate(runs))
    return ('<?xml version="1.0" encoding="UTF-8"?>\n<Document>\n  <FileCoherence>1</FileCoherence>\n'
            "  <Version>3.10.1</Version>\n  <FileName>swing.cmbl</FileName>\n  <Radians>0</Radians>\n" + sets +
            "  <DataSet>\n    <ID>109 </ID>\n    <DataSetName>&#38;&#38;^% CurveFitFunctions %^&#38;&#38;</DataSetName>\n"
            "    <FunctionModel>\n      <ID>110 </ID>\n      <FunctionModelString>A*sin(B*t+C)+D</FunctionModelString>\n"
            "    </FunctionModel>\n  </DataSet>\n</Document>\n")


def _cells(values: np.ndarray) -> list[str]:
    return [repr(float(v)) for v in values]


def test_logger_pro_file(tmp_path):
    # Logger Pro's own file (File > Save): a Rotary Motion Sensor's angle in degrees, an angular velocity column
    # beside it, and a missed sample written as no number
    deg = _cells(np.degrees(THETA))
    deg[40] = "Z1 1:"
    src = tmp_path / "swing.cmbl"
    src.write_text(_vernier_xml([("Latest", [("Time", "s", _cells(T)), ("Angle", "°", deg),
                                             ("Angular Velocity", "°/s", _cells(np.degrees(np.gradient(THETA, T))))])]))
    rec = read_record(src)
    assert rec.info["columns"] == ["t[s]", "theta[deg]", "_"]  # the angular velocity is no angle: left out
    keep = np.arange(T.size) != 40
    np.testing.assert_allclose(rec.theta[keep], THETA[keep], rtol=0, atol=ATOL)
    assert not rec.ok[40]


@pytest.mark.integration
def test_graphical_analysis_file_with_two_runs(tmp_path):
    # Graphical Analysis' file: a tar archive holding the same XML; two runs are one error naming the --columns
    # that picks the first, and that --columns reads it
    import io
    import tarfile

    n2 = 200
    xml = _vernier_xml([("Run 1", [("Time", "s", _cells(T)), ("Angle", "rad", _cells(THETA))]),
                        ("Run 2", [("Time", "s", _cells(T[:n2])), ("Angle", "rad", _cells(-THETA[:n2]))])])
    src = tmp_path / "swing.gambl"
    with tarfile.open(src, "w") as archive:
        for name, data in (("vstudm/manifest.json", b"{}"), ("vstudm/data.udm", xml.encode())):
            info = tarfile.TarInfo(name)
            info.size = len(data)
            archive.addfile(info, io.BytesIO(data))
    out = tmp_path / "o"
    _one_line_error(invoke("fit", str(src), "--model", "standard", "--out", str(out), "-q"), str(src),
                    "--columns t[s],theta[rad],_,_")
    run1 = read_record(src, spec=TableSpec(columns=("t[s]", "theta[rad]", "_", "_")))
    np.testing.assert_allclose(run1.theta, THETA, rtol=0, atol=ATOL)
    run2 = read_record(src, spec=TableSpec(columns=("_", "_", "t", "theta")))
    assert run2.t.size == n2


@pytest.mark.integration
@pytest.mark.parametrize("suffix, content, fragment", [
    (".cmbl", "Time\tAngle\n0\t1\n", "not a Logger Pro file"),
    (".gambl", "not a tar archive", "not a Graphical Analysis file"),
    (".cmbl", '<?xml version="1.0"?>\n<Document><DataSet><DataSetName>Latest</DataSetName></DataSet></Document>',
     "without a column of values"),
])
def test_vernier_files_that_are_not(tmp_path, suffix, content, fragment):
    src = tmp_path / f"swing{suffix}"
    src.write_text(content)
    _one_line_error(invoke("fit", str(src), "--model", "standard", "--out", str(tmp_path / "o"), "-q"), str(src),
                    fragment)


# --- MATLAB ----------------------------------------------------------------------------------------

def _savemat(path: Path, variables: dict) -> Path:
    from scipy.io import savemat

    savemat(path, variables)  # MATLAB 5 format, what MATLAB's save writes by default up to -v7
    return path


def test_matlab_matrix_a_sample_per_row(tmp_path):
    # a rig's log saved from MATLAB as one matrix (`save('DataPendulum.mat', 'data')`: time from the logger's
    # start, angle in degrees, a sample per row), the form of VDB-Bram/Tutorial-Direct-Collocation's knee
    # pendulum test; the same samples stored a sample per column read alike
    t = T + 13.84
    for name, data in (("rows", np.column_stack((t, np.degrees(THETA)))), ("cols", np.vstack((t, np.degrees(THETA))))):
        src = _savemat(tmp_path / f"{name}.mat", {"data": data})
        rec = read_record(src, spec=TableSpec(columns=("t", "theta[deg]")))
        np.testing.assert_allclose(rec.t, t, rtol=0, atol=1e-12)
        np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=ATOL)


def test_matlab_vectors_are_named_columns(tmp_path):
    # one vector per quantity (MATLAB keeps them 1 x n): their names are the header
    src = _savemat(tmp_path / "swing.mat", {"t": T, "theta": THETA})
    rec = read_record(src)
    np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=ATOL)


@pytest.mark.integration
def test_matlab_matrix_in_degrees_is_refused_without_the_unit(tmp_path):
    src = _savemat(tmp_path / "DataPendulum.mat", {"data": np.column_stack((T, np.degrees(THETA)))})
    out = tmp_path / "o"
    _one_line_error(invoke("fit", str(src), "--model", "standard", "--out", str(out), "-q"), str(src),
                    "looks like degrees", "--columns t,theta[deg]")
    assert not out.exists() or not any(out.iterdir())


@pytest.mark.integration
@pytest.mark.parametrize("content, fragment", [
    ("hdf5", "MATLAB 7.3 file (HDF5)"),
    ({"simout": {"time": T, "signals": THETA}}, "holds simout (1x1 a struct)"),
    ({"t": T, "theta": THETA[:-5]}, "vectors of one length"),
    ("text", "not a MATLAB data file"),
])
def test_matlab_files_pendtrack_cannot_read(tmp_path, content, fragment):
    src = tmp_path / "run.mat"
    if content == "hdf5":  # a 7.3 file: MATLAB's 128-byte text header, then HDF5
        src.write_bytes(b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Sat Nov 28 10:00:00 2026 HDF5 schema "
                        b"1.00 .".ljust(128, b" ") + b"\x89HDF\r\n\x1a\n" + bytes(64))
    elif content == "text":
        src.write_text("t,theta\n0,1\n")
    else:
        _savemat(src, content)
    _one_line_error(invoke("fit", str(src), "--model", "standard", "--out", str(tmp_path / "o"), "-q"), str(src),
                    fragment)


# --- PASCO Capstone ------------------------------------------------------------------------------

def test_pasco_capstone_csv(tmp_path):
    # Capstone writes the run after the unit ("Time (s) Run #1"); its Rotary Motion Sensor's angle is
    # "Angle (rad)" or, in DataStudio's naming, "Angular Position, Ch 1&2 (rad)"
    src = tmp_path / "capstone.csv"
    head = '"Time (s) Run #1","Angle (rad) Run #1","Angular Velocity (rad/s) Run #1"\n'
    src.write_text(head + _rows(T, THETA, T))
    np.testing.assert_allclose(read_record(src).theta, THETA, rtol=0, atol=ATOL)
    # a European export: tabs, decimal commas, the sensor's channel in the name
    src.write_text("Time (s) Run #1\tAngular Position, Ch 1&2 (rad) Run #1\n"
                   + _rows(T, THETA, sep="\t", fmt=lambda v: repr(v).replace(".", ",")))
    np.testing.assert_allclose(read_record(src).theta, THETA, rtol=0, atol=ATOL)


def _tracker_rows(theta_cells: list[str], sep: str, comma: bool) -> str:
    """Tracker's export rows t, x, y, θ, ω about an origin at the pivot: t exact (Tracker's rounded times are
    test_tables' matter), x, y to 4 digits, θ and ω
    (degrees, deg/s) to 0.1, ω blank on the first frame (a space-separated row is then a value short)."""
    x, y = L * np.sin(THETA), -L * np.cos(THETA)
    omega = [""] + [f"{v:.1f}" for v in np.degrees(np.gradient(THETA, T))[1:]]
    rows = []
    for a, b, c, d, e in zip(T, x, y, theta_cells, omega):
        cells = [repr(float(a)), f"{b:.4g}", f"{c:.4g}", d] + ([e] if e or sep != " " else [])
        rows.append(sep.join(v.replace(".", ",") if comma else v for v in cells) + "\n")
    return "".join(rows)


@pytest.mark.parametrize("sep, comma, track, theta_name", [("\t", False, "\tmass A\t\t\t\t", "θ"),
                                                           (" ", True, " masa A    ", "θr")],
                         ids=["tab", "space_decimal_comma"])
def test_tracker_export_of_t_x_y_theta_omega(tmp_path, sep, comma, track, theta_name):
    # florzoffi/fisica-tp2@0785750's exports of a pendulum filmed at 30 fps (File > Export > Data, five columns
    # chosen, Spanish locale for the second): no subscripted name marks them as Tracker's, θ is the angle of
    # (x, y) about Tracker's origin (the pivot) in degrees, and ω is blank on the first frame
    polar = [f"{v:.1f}" for v in np.degrees(np.arctan2(-L * np.cos(THETA), L * np.sin(THETA)))]
    src = tmp_path / "exp1_mar_L1_chico.txt"
    src.write_text(f"{track}\n" + sep.join(["t", "x", "y", theta_name, "ω"]) + f"{sep}\n"
                   + _tracker_rows(polar, sep, comma))
    rec = read_record(src, spec=TableSpec(pivot=(0.0, 0.0)))
    assert rec.info["columns"][3] == "_"  # θ passed over: x, y read
    # x, y to 4 significant digits of 0.65 m: 1e-4 relative, 1e-4 rad (more where the bob is near a coordinate's 0)
    np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=3e-4)


def test_a_pendulum_angle_beside_x_y_is_read():
    # control: a theta column that is the pendulum's angle (about the vertical), not the polar angle of x, y
    from pendtrack.tables.text import _polar_angle

    x, y = L * np.sin(THETA), -L * np.cos(THETA)
    assert _polar_angle(np.arctan2(y, x), x, y) and _polar_angle(np.degrees(np.arctan2(y, x)), x, y)
    assert not _polar_angle(THETA, x, y) and not _polar_angle(np.degrees(THETA), x, y)


# --- phyphox -----------------------------------------------------------------------------------

def _phyphox(value: float, comma: bool) -> str:
    text = f"{value:.9E}"  # phyphox writes 9 decimals, exponent
    return text.replace(".", ",") if comma else text


@pytest.mark.parametrize("sep, comma", [(",", False), ("\t", False), (";", True), ("\t", True)],
                         ids=["comma", "tab", "semicolon_decimal_comma", "tab_decimal_comma"])
def test_phyphox_csv(tmp_path, sep, comma):
    src = tmp_path / "Angle.csv"
    head = sep.join(['"Time (s)"', '"Angle (deg)"', '"Angular velocity (rad/s)"']) + "\n"
    src.write_text(head + _rows(T, np.degrees(THETA), T, sep=sep, fmt=lambda v: _phyphox(v, comma)))
    rec = read_record(src)
    # 10 significant digits of degrees: 1e-9 relative of 60 deg ~ 1e-9 rad
    np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=5e-9)
    np.testing.assert_allclose(rec.t, T, rtol=0, atol=5e-9 * T.max())


# --- Tracker: data export, project file ---------------------------------------------------------

@pytest.mark.integration
def test_a_saved_phyphox_experiment_is_named_with_its_export(tmp_path):
    # the app's saved state (estmiguelplazas-web/Experimento-Phyphox---Pendulo-Simple): its XML was read as a table,
    # "no row of numbers ... below the header '<state-title>..."
    src = tmp_path / "pendulum.phyphox"
    src.write_text('<?xml version="1.0" encoding="UTF-8"?><phyphox version="1.14" locale="en">\n'
                   "  <title>Pendulum</title>\n  <data-containers>\n    <container size=\"0\">gyr_time</container>\n"
                   "  </data-containers>\n  <state-title>run 1</state-title>\n</phyphox>\n")
    res = invoke("kinematics", str(src), "--out", str(tmp_path / "out"), "-q")
    _one_line_error(res, str(src), "a saved phyphox experiment", "Export Data, as CSV")
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


def test_tracker_data_export(tmp_path):
    src = tmp_path / "mass_A.txt"  # File > Export > Data: the track name, then the table
    src.write_text("mass A\nt\tx\ty\n" + _rows(T, X, Y, sep="\t"))
    rec = read_record(src, spec=TableSpec(pivot=(PX, PY)))
    np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=ATOL)


def test_tracker_data_export_more_columns(tmp_path):
    # the position angle θ_{r} and the angle θ about Tracker's origin (in degrees) are not the
    # pendulum's angle: x, y are read; velocities are empty in the first and last rows
    v = np.gradient(X, T)
    cells = [repr(a) for a in v.tolist()]
    cells[0] = cells[-1] = ""
    src = tmp_path / "export.csv"
    theta_r = np.degrees(np.arctan2(Y, X))
    src.write_text("mass A\nt,x,y,r,θ_{r},v_{x},θ\n" + "".join(
        f"{a!r},{b!r},{c!r},{math.hypot(b, c)!r},{d!r},{e},{d!r}\n"
        for a, b, c, d, e in zip(T.tolist(), X.tolist(), Y.tolist(), theta_r.tolist(), cells)))
    rec = read_input(src)
    np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=ATOL)


@pytest.mark.integration
def test_tracker_protractor_export_in_degrees(tmp_path):
    src = tmp_path / "protractor.txt"
    src.write_text("protractor A\nt\tθ\n" + _rows(T, np.degrees(THETA), sep="\t"))
    _one_line_error(invoke("kinematics", str(src), "--out", str(tmp_path / "o"), "-q"), str(src),
                    "--columns t,theta[deg]")
    np.testing.assert_allclose(read_record(src, spec=TableSpec(columns=("t", "theta[deg]"))).theta, THETA,
                               rtol=0, atol=ATOL)


FPS, START, STEP = 120.0, 3, 2  # the clip: every 2nd frame of a 120 fps video from frame 3 (60 Hz steps)
CALIB = [(0, (320.0, 400.0, 10.0, 500.0, 500.0)), (START + STEP * 200, (330.0, 395.0, 10.0, 500.0, 500.0))]


def _prop(name: str, kind: str, value: object) -> str:
    return f'<property name="{name}" type="{kind}">{value}</property>'


def _obj(name: str, cls: str, *props: str) -> str:
    return (f'<property name="{name}" type="object">\n<object class="org.opensourcephysics.{cls}">\n'
            + "\n".join(props) + "\n</object>\n</property>")


def _framedata(cls: str, frames: dict[int, list[str]]) -> str:
    return (f'<property name="framedata" type="array" class="[Lorg.opensourcephysics.{cls};">\n'
            + "\n".join(_obj(f"[{n}]", cls, *p) for n, p in sorted(frames.items())) + "\n</property>")


def _world_to_image(x: np.ndarray, y: np.ndarray, calib: tuple[float, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Tracker's toImage transform (ImageCoordSystem.updateTransforms), angle in degrees."""
    xo, yo, a, xs, ys = calib
    c, s = math.cos(math.radians(a)), math.sin(math.radians(a))
    return xs * c * x - xs * s * y + xo, -ys * s * x - ys * c * y + yo


def _point_mass(name: str, x: np.ndarray, y: np.ndarray, extra: dict[int, tuple[float, float]]) -> str:
    frames = START + STEP * np.arange(x.size)
    marks: dict[int, list[str]] = {}
    for n, wx, wy in zip(frames, x, y):
        calib = CALIB[1][1] if n >= CALIB[1][0] else CALIB[0][1]
        ix, iy = _world_to_image(np.array(wx), np.array(wy), calib)
        marks[int(n)] = [_prop("x", "double", repr(float(ix))), _prop("y", "double", repr(float(iy)))]
    for n, (ix, iy) in extra.items():
        marks[n] = [_prop("x", "double", repr(ix)), _prop("y", "double", repr(iy))]
    return ('<property name="item" type="object">\n'
            '<object class="org.opensourcephysics.cabrillo.tracker.PointMass">\n'
            + _prop("mass", "double", 1.0) + "\n" + _prop("name", "string", name) + "\n"
            + _framedata("cabrillo.tracker.PointMass$FrameData", marks) + "\n</object>\n</property>")


def _trk(tracks: list[str]) -> str:
    """A Tracker project in the structure Tracker 6 saves (TrackerPanel, VideoClip, coords, tracks)."""
    dt = 1000.0 / FPS
    coords = {n: [_prop("xorigin", "double", c[0]), _prop("yorigin", "double", c[1]), _prop("angle", "double", c[2]),
                  _prop("xscale", "double", c[3]), _prop("yscale", "double", c[4])] for n, c in CALIB}
    return "\n".join([
        '<?xml version="1.0" encoding="UTF-8"?>',
        '<object class="org.opensourcephysics.cabrillo.tracker.TrackerPanel">',
        _prop("semantic_version", "string", "6.1.5"), _prop("width", "double", 1280.0),
        _obj("videoclip", "media.core.VideoClip",
             _obj("video", "media.mov.MovieVideo", _prop("path", "string", "swing.mp4"),
                  _prop("delta_t", "double", repr(dt))),
             _prop("video_framecount", "int", 1000), _prop("startframe", "int", START),
             _prop("stepsize", "int", STEP), _prop("stepcount", "int", T.size), _prop("starttime", "double", 0.0),
             _prop("readout", "string", "step"), _prop("playallsteps", "boolean", "true")),
        _obj("clipcontrol", "media.core.VideoClipControl", _prop("rate", "double", 1.0),
             _prop("delta_t", "double", repr(dt)), _prop("frame", "int", START)),
        _obj("coords", "media.core.ImageCoordSystem", _prop("fixedorigin", "boolean", "false"),
             _prop("fixedangle", "boolean", "true"), _prop("fixedscale", "boolean", "true"),
             _prop("locked", "boolean", "false"), _framedata("media.core.ImageCoordSystem$FrameData", coords)),
        _prop("length_unit", "string", "m"), _prop("mass_unit", "string", "kg"),
        '<property name="tracks" type="collection" class="java.util.ArrayList">',
        _obj("item", "cabrillo.tracker.CoordAxes", _prop("name", "string", "axes")),
        *tracks, "</property>", "</object>", ""])


def test_image_to_world_inverts_trackers_transform():
    for calib in (CALIB[0][1], (12.5, 700.0, -33.0, 812.0, 790.0)):
        ix, iy = _world_to_image(X, Y, calib)
        x, y = image_to_world(ix, iy, (calib[0], calib[1], math.radians(calib[2]), calib[3], calib[4]))
        np.testing.assert_allclose(x, X, atol=1e-12)
        np.testing.assert_allclose(y, Y, atol=1e-12)


@pytest.mark.integration
def test_tracker_project(tmp_path):
    # marks off the clip's steps (frame 1 before the start, frame 4 between steps) are left out
    src = tmp_path / "swing.trk"
    src.write_text(_trk([_point_mass("mass A", X, Y, {1: (5.0, 5.0), 4: (7.0, 7.0)})]))
    rec = read_record(src, spec=TableSpec(pivot=(PX, PY)))  # the pivot in world metres
    # times from the clip: (frame - start) * delta_t = k / 60 s; positions through both calibrations
    np.testing.assert_allclose(rec.t, T, rtol=0, atol=1e-12)
    np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=ATOL)
    assert rec.kind == "tracker" and rec.info["tracker"]["calibration_key_frames"] == [0, CALIB[1][0]]
    fitted = read_input(src)  # or the fitted pivot
    np.testing.assert_allclose(fitted.theta, THETA, rtol=0, atol=ATOL)
    res = invoke("kinematics", str(src), "--out", str(tmp_path / "o"), "-q")
    assert res.exit_code == 0 and "Omega0 = 4.9" in res.output, res.output


@pytest.mark.integration
def test_tracker_project_with_two_tracks(tmp_path):
    src = tmp_path / "two.trk"
    src.write_text(_trk([_point_mass("mass A", X, Y, {}), _point_mass("bob", X[::-1], Y[::-1], {})]))
    _one_line_error(invoke("kinematics", str(src), "--out", str(tmp_path / "o"), "-q"), str(src),
                    "2 point-mass tracks ('mass A', 'bob')", "--track NAME")
    rec = read_record(src, spec=TableSpec(track="mass A", pivot=(PX, PY)))
    np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=ATOL)
    with pytest.raises(ArtifactError, match="no point-mass track named 'mass B'"):
        read_record(src, spec=TableSpec(track="mass B"))


def test_a_tracker_track_above_its_pivot_names_the_options_that_apply(tmp_path):
    # Algath/Physic_project_double_pendulum: a track above the pivot in most samples was told to name
    # a column y_down with --columns, which a Tracker project refuses
    src = tmp_path / "swing.trk"
    src.write_text(_trk([_point_mass("mass A", X, Y, {})]))
    with pytest.raises(ArtifactError, match=r"above the pivot .* give the pivot with --pivot X Y .* --track") as err:
        read_record(src, spec=TableSpec(pivot=(PX, PY - 10.0)))  # a pivot 10 m below the bob's path
    assert "--columns" not in str(err.value)


def test_not_a_tracker_project(tmp_path):
    src = tmp_path / "other.trk"
    src.write_text('<?xml version="1.0"?>\n<object class="org.opensourcephysics.tools.DataToolTab"></object>\n')
    with pytest.raises(ArtifactError, match="not a Tracker project"):
        read_record(src)
    src.write_text("t theta\n")
    with pytest.raises(ArtifactError, match="not a readable Tracker project"):
        read_record(src)


def test_a_headerless_table_with_its_clock_in_column_2_is_named_in_the_hint(tmp_path):
    # a micro:bit logger writing "angle,running_time,accel" per line (no header): the hint puts t where the
    # clock is, not in column 1
    src = tmp_path / "pendulum.txt"
    src.write_text(_rows(np.degrees(THETA), T + 2.446, np.sin(THETA)))
    _one_line_error(invoke("kinematics", str(src), "--out", str(tmp_path / "o"), "-q"), str(src),
                    "column 2 increases like a time", "--columns theta,t,_")
    rec = read_record(src, spec=TableSpec(columns=("theta[deg]", "t", "_")))
    np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=ATOL)


# --- times written more coarsely than the rows are spaced (a spreadsheet's 0.00E+00 format) -------

FPS30 = 30.0
T30 = np.arange(int(20.0 * FPS30)) / FPS30  # 20 s: from 10 s on, three significant digits are 0.1 s
THETA30 = simulate(get_model("standard"), SWING, T30, theta0=1.0, omega0=0.0).theta
X30, Y30 = PX + L * np.sin(THETA30), PY - L * np.cos(THETA30)


def _excel_tracker(t: np.ndarray, x: np.ndarray, y: np.ndarray) -> str:
    # a Tracker export saved from a spreadsheet: the track name padded with commas, the theta column's
    # name lost to "???", times in scientific format to three significant digits
    return "mass_A,,,,\nt,x,y,???,err\n" + "".join(
        f"{a:.2E},{b!r},{c!r},{np.degrees(math.atan2(b, -c)):.2E},5.00E-01\n"
        for a, b, c in zip(t.tolist(), x.tolist(), y.tolist()))


@pytest.mark.parametrize("cell, unit", [("1.00E+01", 0.1), ("3.33E-02", 1e-4), ("0.033", 1e-3), ("12", 1.0),
                                        ("-8.73E+02", 1.0), ("1,5", math.nan), ("nan", math.nan)])
def test_the_unit_of_a_written_times_last_digit(cell, unit):
    assert digit_unit(cell) == pytest.approx(unit, rel=1e-12, nan_ok=True)


def test_times_rounded_to_three_significant_digits_are_read_on_their_grid(tmp_path):
    src = tmp_path / "1 Data.csv"
    src.write_text(_excel_tracker(T30, X30, Y30))
    rec = read_record(src, spec=TableSpec(pivot=(PX, PY)))
    # the rows' grid is pinned by the early times (written to 1e-4 .. 1e-3 s): over 600 rows its error stays
    # far below a millisecond, where the times as written are up to 50 ms off
    assert rec.t.size == T30.size and np.max(np.abs(rec.t - T30)) < 1e-3
    np.testing.assert_allclose(rec.theta, THETA30, rtol=0, atol=ATOL)
    assert rec.info["retimed"]["coarsest_unit_s"] == pytest.approx(0.1)
    assert any("written to 0.1 s at their coarsest" in w for w in rec.warnings)


def test_rounded_times_with_a_dropped_frame_are_refused_naming_the_rate(tmp_path):
    # five frames lost at 15 s: the rows are no uniform grid, and their times cannot tell where the gap is
    keep = np.r_[0:450, 455:T30.size]
    src = tmp_path / "2 Data.csv"
    src.write_text(_excel_tracker(T30[keep], X30[keep], Y30[keep]))
    _one_line_error(invoke("kinematics", str(src), "--pivot", repr(PX), repr(PY), "--out", str(tmp_path / "o"), "-q"),
                    str(src), "a repeated time", "written to 0.1 s there", "--rate HZ")


def test_a_long_record_of_rounded_times_and_angles_with_dropped_frames_is_refused_naming_the_rate(tmp_path):
    # BY-Chai/PHY180-Projects@a71b1d94's long takes: t and theta [deg] both to three significant digits, two
    # frames lost. Most of its time steps are 0 or 0.1 s (1 s from 100 s on), so the rows' 33-ms spacing is the
    # mean step, not the median of the steps that are not 0; rows whose rounded t and theta both repeat are
    # read once, and the times' units must follow them (the explanation and --rate were missing)
    t = np.delete(np.arange(0, 127, 1 / 30), [1500, 2500])
    theta = 20.0 * np.exp(-t / 200.0) * np.cos(2.0 * np.pi * t / 1.03)
    src = tmp_path / "60deg_long.txt"
    src.write_text("x y dx dy\n" + "".join(f"{a:.2E}\t{b:.2E}\t0.017\t0.05\n" for a, b in zip(t, theta)))
    _one_line_error(invoke("kinematics", str(src), "--columns", "t,theta[deg],_,_", "--out", str(tmp_path / "o"),
                           "-q"),
                    str(src), "a repeated time", "written to 0.1 s there", "33.6-ms spacing", "--rate HZ")


# --- a Python tracker's CSV: the bob's (x, y) written as a tuple or an array in one cell ---------

U, V = 640.0 + 1000.0 * X, 600.0 - 1000.0 * Y  # image pixels of the bob: x right, rows counting downwards


@pytest.mark.parametrize("scalars", [np.ndarray.tolist, list], ids=["floats", "numpy_scalars"])
def test_positions_written_as_python_tuples_read_like_their_columns(tmp_path, scalars):
    # an OpenCV tracker's DictWriter rows ("position,time,speed"; the tuple str()-ed; "\r\r\n" as
    # csv writes in text mode on Windows) read as x, y_down: the same angles as the columns written out.
    # Numpy 2 writes a tuple of its scalars as "(np.float64(1392.5), np.float64(685.0))".
    src = tmp_path / "movement_data.csv"
    src.write_bytes(("position,time,speed\r\r\n" + "".join(
        f'"{(u, v)!r}",{t!r},0.5\r\r\n' for u, v, t in zip(scalars(U), scalars(V), T.tolist()))).encode())
    plain = tmp_path / "plain.csv"
    plain.write_text("t,x,y_down\n" + _rows(T, U, V))
    rec, ref = read_input(src), read_input(plain)
    np.testing.assert_array_equal(rec.theta, ref.theta)
    # and they are the swing's angles (the pivot from the circle fit: exact positions, float rounding)
    np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=1e-6)


def test_positions_written_as_numpy_arrays_with_y_up(tmp_path):
    # "[x y]" as numpy prints an array, white space between cells, y counting upwards [mm]
    src = tmp_path / "track.txt"
    src.write_text("t  centroid (mm)\n" + "".join(
        f"{t!r}  [{1000.0 * x!r} {1000.0 * y!r}]\n" for t, x, y in zip(T.tolist(), X.tolist(), Y.tolist())))
    rec = read_input(src)
    np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=1e-6)


def test_a_pair_column_without_an_arc_names_both_directions(tmp_path):
    # a marker sliding along a straight line: its path cannot tell which way y counts
    src = tmp_path / "slide.csv"
    src.write_text("position,time\n" + "".join(f'"({u!r}, 300.0)",{t!r}\n' for u, t in zip(U.tolist(), T.tolist())))
    _one_line_error(invoke("kinematics", str(src), "--out", str(tmp_path / "o"), "-q"), str(src),
                    "holds (x, y) pairs", "--columns: x,y,t if y counts upwards, x,y_down,t if")
    assert not (tmp_path / "o").exists()


def test_columns_of_a_table_with_pairs_count_each_number(tmp_path):
    src = tmp_path / "movement_data.csv"
    src.write_text("position,time\n" + "".join(f'"({u!r}, {v!r})",{t!r}\n' for u, v, t in zip(*(a.tolist() for a in (U, V, T)))))
    _one_line_error(invoke("kinematics", str(src), "--columns", "x,y_down,t,_", "--out", str(tmp_path / "o"), "-q"),
                    "--columns names 4 columns, the table has 3", "is one column per number")
    rec = read_record(src, spec=TableSpec(columns=("x", "y_down", "t"), pivot=(640.0 + 1000.0 * PX, 600.0 - 1000.0 * PY)))
    np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=1e-6)


# --- legitimate radians stay radians --------------------------------------------------------------

def test_real_records_read_without_unit_errors():
    real = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "real-tyler-phy180"
    if not real.is_dir():
        real = Path("/work/shared/data/real-tyler-phy180")
    if not real.is_dir():
        pytest.skip("real data not found")
    rec = read_record(real / "lab2_trial1_rawdata.txt")  # 66 deg swings in rad, phone times
    assert rec.t.size == 500 and rec.warnings == () and np.max(np.abs(rec.theta)) < math.pi / 2


def test_unit_checks_without_turning_points():
    from pendtrack.tables.checks import theta_not_radians, time_not_seconds

    t = np.arange(300) / 60.0
    spin = 12.0 * t  # over the top, never turning back: 60 (degrees?) in 5 s, beyond two turns in rad
    why, in_degrees = theta_not_radians(spin)
    assert "without turning back twice" in why and in_degrees
    assert theta_not_radians(np.clip(spin, 0, 4 * math.pi - 0.1)) is None  # under two turns: plausible in rad
    # a record sampled 20 "s" apart cannot be a pendulum's in seconds: 20 ms, in ms
    assert time_not_seconds(t * 1200.0, spin) == ("the time column has a sample step of 20, too long for seconds",
                                                  "ms")
    assert time_not_seconds(t, spin) is None


def test_the_period_quoted_for_a_noisy_log_in_ms_is_the_swings():
    # a micro:bit's log (ES2Spring2019-ComputinginEngineering/project-one-nick-and-david, real_pendulum_data1.txt:
    # ms against a reading whose sample noise is half its swing, every 35 ms): the zigzag's turning points are
    # 3 samples apart, and the refusal quoted "a swing period of 204"; the swing's is 1273 ms
    from pendtrack.tables.checks import time_not_seconds

    t_ms = 35.0 * np.arange(400)
    reading = 80.0 * np.sin(2 * np.pi * t_ms / 1270.0) + np.random.default_rng(6).normal(0.0, 40.0, t_ms.size)
    why, unit = time_not_seconds(t_ms, reading)
    period = float(why.split("swing period of ")[1].split(",")[0])
    # the spectrum of 14 s resolves 1/14 s^-1 about 0.79 Hz: 1.18-1.39 s
    assert unit == "ms" and 1180.0 <= period <= 1390.0


def test_a_trackers_frame_numbers_are_not_taken_for_seconds(tmp_path):
    # an OpenCV tracker's `frame,x,y` (SamuelFoo/pendulum, data/pendulum_output2.csv, 30 fps): with the
    # --columns t,x,y the missing-t error suggested, a 1.7-s swing read as one of 50 s (Omega0 0.124 rad/s)
    k = np.arange(300)
    x = 200.0 + 80.0 * np.sin(2 * np.pi * k / 50.5)
    y = 400.0 - np.sqrt(300.0**2 - (x - 200.0) ** 2)
    src = tmp_path / "track.csv"
    src.write_text("frame,x,y\n" + "".join(f"{a:.1f},{b:.2f},{c:.2f}\n" for a, b, c in zip(k, x, y)))
    with pytest.raises(ArtifactError, match=r"column 1 'frame' numbers the frames .*--columns _,x,y --rate FPS"):
        read_record(src)
    with pytest.raises(ArtifactError, match=r"'frame': frame numbers, not seconds.*--columns _,x,y --rate FPS"):
        read_record(src, spec=TableSpec(columns=("t", "x", "y"), pivot=(200.0, 400.0)))
    rec = read_record(src, spec=TableSpec(columns=("_", "x", "y"), rate_hz=30.0, pivot=(200.0, 400.0)))
    np.testing.assert_allclose(rec.t, k / 30.0, atol=1e-12)


def test_a_trackers_frame_and_time_columns_are_named_after_the_header(tmp_path):
    # an OpenCV tracker's `frame,tempo,x,y` in image pixels (mohamedcansiz-jpg/Pendulo, dados_pendulo.csv: y counts
    # downwards): the y-direction error suggested `--columns t,x,y_down`, three names for four columns, and with
    # `--columns t,x,y_down,_` the frame error suggested `_,x,y_down,_ --rate FPS`, which names tempo x and x y
    k = np.arange(1, 301)
    x = 200.0 + 80.0 * np.sin(2 * np.pi * k / 50.5)
    y = 100.0 + np.sqrt(300.0**2 - (x - 200.0) ** 2)  # below the pivot (200, 100) in image rows
    src = tmp_path / "dados.csv"
    src.write_text("frame,tempo,x,y\n" + "".join(f"{a},{a / 30.0!r},{b:.0f},{c:.0f}\n" for a, b, c in zip(k, x, y)))
    with pytest.raises(ArtifactError, match=r"name the column y_down \(e.g. --columns _,t,x,y_down\)"):
        read_record(src, spec=TableSpec(pivot=(200.0, 100.0)))
    with pytest.raises(ArtifactError, match=r"the header's column 2 holds the times: name the columns after it "
                                            r"\(e.g. --columns _,t,x,y_down\)"):
        read_record(src, spec=TableSpec(columns=("t", "x", "y_down", "_"), pivot=(200.0, 100.0)))
    rec = read_record(src, spec=TableSpec(columns=("_", "t", "x", "y_down"), pivot=(200.0, 100.0)))
    assert rec.t.size == k.size and np.all(np.abs(rec.theta) < 0.3)


def test_a_header_shorter_than_its_rows_is_said_and_counted(tmp_path):
    # a potentiometer's logger (Christophori/ME_3300_Engineering_Measurement_Systems, Lab_03's CSVs): two names,
    # `Times (s),Voltage (Volts)`, over rows of three values (t, the angle in degrees, an acceleration); the error
    # suggested `--columns t,theta`, refused next for naming 2 of 3 columns
    t = np.arange(600) / 100.0
    src = tmp_path / "expt.csv"
    src.write_text("Times (s),Voltage (Volts)\n" + "".join(f"{a:.6f},{30 * math.cos(5 * a):.6f},0.1\n" for a in t))
    with pytest.raises(ArtifactError, match=r"--columns t,theta,_ or --columns t,x,y; "
                                          r"the header names 2 columns, the rows hold 3"):
        read_record(src)


def test_a_release_from_rest_that_travels_beyond_a_turn_is_degrees():
    from pendtrack.tables.checks import theta_not_radians

    # an encoder on a heavily damped rig (satyamchoudhary1303/MTP, 600_10deg.csv, "Time, Angle" in degrees):
    # released from rest at 10.7, through -6.15 and back to rest at -2.64 with no second turning point; read
    # in rad it passed every check (one turning point, under two turns)
    angle = np.array([10.7227, 9.4043, 5.9766, 1.6699, -2.0215, -4.6582, -6.0645, -6.1523, -5.4492, -4.5703,
                      -3.7793, -3.1641, -2.6367, -2.4609, -2.373, -2.4609] + [-2.6367] * 60)
    why, in_degrees = theta_not_radians(angle)
    assert "from its start at rest to its first turning point" in why and in_degrees
    assert theta_not_radians(np.radians(angle)) is None
    # released from rest just below the top, in rad: it travels less than a full turn before turning back
    _, theta = swing("standard", {"Omega0": 6.0, "C1": 0.01, "C0": 0.01, "C2": 0.01}, seconds=10.0,
                     theta0=math.pi - 0.01, fps=120.0, noise=0.003)
    assert theta_not_radians(theta) is None
