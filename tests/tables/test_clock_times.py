"""Times of day (pendtrack.tables.clock_times): a logger's clock column and the Arduino Serial Monitor's
timestamped lines, on small synthetic files written in each format's exact layout.

The Serial Monitor's layout (``HH:MM:SS.mmm -> payload``) is the Arduino IDE's with "Show timestamp"
on; the lab handouts that tell students to save its text (e.g. a course's "Lab 10 Pendulum II":
release at 120 degrees, export the Serial Monitor to a .txt file) made pendtrack answer "no row of
numbers" to it.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_tables import _one_line_error, invoke

from pendtrack.models import get_model, simulate
from pendtrack.tables import TableSpec, read_record
from pendtrack.tables.clock_times import clock_lines

RATE = 100.0  # a sketch printing every 10 ms
T = np.arange(int(8.0 * RATE)) / RATE
THETA = simulate(get_model("standard"), {"Omega0": 6.0, "C1": 0.1, "C0": 0.02, "C2": 0.05}, T,
                 theta0=2.0, omega0=0.0).theta
DEG = np.degrees(THETA)


def _clock(seconds: float) -> str:
    seconds %= 86400.0
    ms = int(round(seconds * 1000))
    h, rest = divmod(ms, 3_600_000)
    m, rest = divmod(rest, 60_000)
    return f"{h:02d}:{m:02d}:{rest // 1000:02d}.{rest % 1000:03d}"


def test_clocks_become_seconds_since_the_first_to_the_digits_written_across_midnight():
    lines = [(1, "time,angle"), (2, "23:59:59.5,1.0"), (3, "23:59:59.75,1.5"), (4, "00:00:00.25,2.0")]
    out, clock = clock_lines(lines)
    assert [s for _, s in out] == ["time,angle", "0.00,1.0", "0.25,1.5", "0.75,2.0"]
    assert clock is not None and clock.kind == "logger" and clock.first == "23:59:59.5"
    dated = [(1, "time,angle"), (2, "2023-11-24 23:59:59.5,1.0"), (3, "2023-11-24T23:59:59.75,1.5"),
             (4, "2023-11-25 00:00:00.25,2.0")]
    assert [s for _, s in clock_lines(dated)[0]] == ["time,angle", "0.00,1.0", "0.25,1.5", "0.75,2.0"]
    plain = [(1, "t,theta"), (2, "0.0,1.0"), (3, "0.1,1.1")]
    assert clock_lines(plain) == (plain, None)


def test_a_logger_clock_column_is_read_as_the_time(tmp_path):
    src = tmp_path / "logger.csv"
    start = 23 * 3600 + 59 * 60 + 57.0  # the record runs past midnight
    src.write_text("Time,Angle (deg)\n" + "".join(f"{_clock(start + t)},{d!r}\n" for t, d in zip(T, DEG)))
    rec = read_record(src)
    # the clock is written to 1 ms and the rows are 10 ms apart: times exact to the millisecond's rounding
    np.testing.assert_allclose(rec.t - rec.t[0], T, rtol=0, atol=1e-9)
    np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=1e-9)
    assert rec.info["clock"]["kind"] == "logger"


@pytest.mark.integration
def test_serial_monitor_lines_of_one_value_take_the_receive_times_with_a_warning(tmp_path):
    src = tmp_path / "serial.txt"
    rng = np.random.default_rng(3)
    received = 51785.0 + T + 0.004 + rng.uniform(0, 0.002, T.size)  # a latency, no bursts
    src.write_text("".join(f"{_clock(r)} -> {d:.2f}\n" for r, d in zip(received, DEG)))
    res = invoke("kinematics", str(src), "--out", str(tmp_path / "plain"))
    _one_line_error(res, "serial.txt", "--columns t,theta[deg]")  # the unit, as for any table
    rec = read_record(src, spec=TableSpec(columns=("t", "theta[deg]")))
    assert rec.info["clock"] == {"kind": "serial_monitor", "receive_times": True, "t0_clock": _clock(received[0])}
    assert any("when the computer received each line" in w and "millis()" in w for w in rec.info["warnings"])
    # the receive times carry the latency's 2-ms spread: theta at them is the swing's within omega x 2 ms
    spacing = np.diff(rec.t)
    assert np.all(spacing > 0) and abs(np.median(spacing) - 0.01) < 0.002


@pytest.mark.integration
def test_serial_monitor_bursts_without_the_boards_time_are_refused(tmp_path):
    src = tmp_path / "burst.txt"
    received = 51785.0 + np.ceil((T + 0.003) / 0.016) * 0.016  # USB hands the lines over every 16 ms
    src.write_text("".join(f"{_clock(r)} -> {d:.2f}\n" for r, d in zip(received, DEG)))
    out = tmp_path / "out"
    res = invoke("fit", str(src), "--model", "standard", "--out", str(out))
    _one_line_error(res, "burst.txt", "Arduino Serial Monitor", "when the computer received each line", "millis()",
                    "--rate HZ")
    assert not out.exists()
    # with the sketch's rate the rows are timed by it, the receive times dropped
    rec = read_record(src, spec=TableSpec(columns=("theta[deg]",), rate_hz=RATE))
    np.testing.assert_allclose(rec.t, T, rtol=0, atol=1e-12)
    np.testing.assert_allclose(rec.theta, np.radians(np.round(DEG, 2)), rtol=0, atol=1e-12)


@pytest.mark.parametrize("name, scale", [("millis", 1e-3), ("micros", 1e-6)])
def test_serial_monitor_lines_with_the_boards_own_time_use_it(tmp_path, name, scale):
    src = tmp_path / "board.txt"
    received = 51785.0 + np.ceil((T + 0.003) / 0.016) * 0.016  # bursts: the board's clock is the one to read
    board = np.round((T + 5.0) / scale).astype(np.int64)
    src.write_text(f"{_clock(received[0] - 1)} -> {name},angle_deg\n"
                   + "".join(f"{_clock(r)} -> {b},{d!r}\n" for r, b, d in zip(received, board, DEG)))
    rec = read_record(src)
    np.testing.assert_allclose(rec.t, T + 5.0, rtol=0, atol=1e-9)
    np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=1e-9)
    assert rec.info["clock"]["receive_times"] is False and not rec.info["warnings"]


def test_serial_monitor_lines_of_one_labelled_value(tmp_path):
    src = tmp_path / "labelled.txt"
    received = 51785.0 + T + 0.004  # no bursts
    src.write_text("".join(f"{_clock(r)} -> Angle (deg): {d:.2f}\n" for r, d in zip(received, DEG)))
    rec = read_record(src)  # the label names the unit
    np.testing.assert_allclose(rec.t - rec.t[0], T, rtol=0, atol=1e-9)
    np.testing.assert_allclose(rec.theta, np.radians(np.round(DEG, 2)), rtol=0, atol=1e-12)
    assert rec.info["clock"]["receive_times"] is True


def test_a_stopwatchs_minutes_and_seconds_are_read_as_the_time(tmp_path):
    """``MM:SS.fff`` (a stopwatch's or a video player's elapsed time) is the time, past the hour's 60 minutes;
    a bare ``12:34`` (hours and minutes, or minutes and seconds?) is not taken for one."""
    lines = [(1, "time,angle"), (2, "59:59.75,1.0"), (3, "60:00.00,1.5"), (4, "60:00.25,2.0")]
    out, clock = clock_lines(lines)
    assert [s for _, s in out] == ["time,angle", "0.00,1.0", "0.25,1.5", "0.50,2.0"]
    assert clock is not None and clock.kind == "elapsed" and clock.first == "59:59.75"
    bare = [(1, "time,angle"), (2, "12:34,1.0"), (3, "12:35,1.5")]
    assert clock_lines(bare) == (bare, None)
    src = tmp_path / "stopwatch.csv"
    src.write_text("time,angle (deg)\n" + "".join(f"{int(t // 60):02d}:{t % 60:06.3f},{d!r}\n"
                                                   for t, d in zip(T + 55.0, DEG)))  # past a minute's turn
    rec = read_record(src)
    # written to 1 ms, the rows 10 ms apart: the times exact to the millisecond's rounding
    np.testing.assert_allclose(rec.t - rec.t[0], T, rtol=0, atol=1e-9)
    np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=1e-9)
    assert rec.info["clock"]["kind"] == "elapsed"
