"""Lines of labelled values (pendtrack.tables.labelled_values): a sketch's ``Angle: 12.3`` or ``t=10 theta=0.52``
on every line, read as a table with the labels as its header."""

from __future__ import annotations

import numpy as np

from pendtrack.models import get_model, simulate
from pendtrack.tables import read_record
from pendtrack.tables.labelled_values import labelled_lines

T = np.arange(800) / 100.0
THETA = simulate(get_model("standard"), {"Omega0": 6.0, "C1": 0.1, "C0": 0.02, "C2": 0.05}, T,
                 theta0=2.0, omega0=0.0).theta


def test_labels_become_a_header_and_other_tables_are_left_alone():
    lines = [(1, "Starting"), (2, "Time (ms): 10 | Angle (deg): 12.3"), (3, "Time (ms): 20 | Angle (deg): 12.1"),
             (4, "Time (ms): 30 | Angle (deg): 11.9")]
    assert labelled_lines(lines) == [(1, "Starting"), (2, "Time (ms),Angle (deg)"), (2, "10,12.3"), (3, "20,12.1"),
                                     (4, "30,11.9")]
    assert labelled_lines([(1, "t=0.010 theta=0.52"), (2, "t=0.020, theta=0.51"), (3, "t=0.030 theta=nan")])[1:] == [
        (1, "0.010,0.52"), (2, "0.020,0.51"), (3, "0.030,nan")]
    for table in ([(1, "t,theta"), (2, "0.0,1.0"), (3, "0.1,1.1"), (4, "0.2,1.2")],
                  [(1, "Run 1: Time (s),Run 1: Angle (deg)"), (2, "0.0,1.0"), (3, "0.1,1.1"), (4, "0.2,1.2")],
                  [(1, "mass A"), (2, "t\tx\ty"), (3, "0\t1\t2"), (4, "1\t2\t3")]):
        assert labelled_lines(table) == table


def test_a_sketchs_labelled_log_is_read_by_its_labels(tmp_path):
    src = tmp_path / "sketch.txt"
    src.write_text("Pendulum logger v1\n" + "".join(f"t_ms={1000 * t:.0f} angle_deg={float(np.degrees(th))!r}\n"
                                                    for t, th in zip(T, THETA)))
    rec = read_record(src)
    np.testing.assert_allclose(rec.t, T, rtol=0, atol=1e-12)
    np.testing.assert_allclose(rec.theta, THETA, rtol=0, atol=1e-9)
