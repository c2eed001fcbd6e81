"""A hold before the release (pendtrack.kinematics.release): found, left out of the fit, and never invented.

A logger often runs before the bob is let go. Measured before the hold was found: a standard fit of
a 30-s record at 30 fps whose first 1.5 s held the bob at 1 rad ended 0.44 rad rms from the data.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner
from factory import swing

from pendtrack.artifacts import read_metadata
from pendtrack.cli import cli
from pendtrack.discovery.inputs import read_angle_series
from pendtrack.kinematics.release import find_hold

PARAMS = {"Omega0": 6.0, "C1": 0.02, "C0": 0.005, "C2": 0.01}  # the standard model, a lab bob's size of damping


def _held(hold_s: float, theta_h: float, *, fps: float, seconds: float = 20.0, noise: float = 0.002,
          seed: int = 0, step: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``hold_s`` at rest at ``theta_h``, then a free swing from rest, sampled at ``fps`` with noise."""
    n_hold = int(round(hold_s * fps))
    _, free = swing("standard", PARAMS, seconds=seconds - hold_s, theta0=theta_h, fps=fps)
    clean = np.concatenate([np.full(n_hold, theta_h), free])
    theta = clean + np.random.default_rng(seed).normal(0.0, noise, clean.size)
    if step is not None:  # an encoder's whole steps
        theta = step * np.round(theta / step)
    return np.arange(clean.size) / fps, theta


@pytest.mark.parametrize("fps", [30.0, 120.0])
def test_a_hold_is_found_up_to_the_release(fps):
    t, theta = _held(1.5, 1.0, fps=fps)
    hold = find_hold(t, theta, np.ones(t.size, bool))
    assert hold is not None
    # the first sample kept is the first one outside the band: the bob leaves 12 mrad (6 x 2 mrad) within
    # sqrt(2 x 0.012 / (36 sin 1)) = 0.029 s of the release, at most one sample later at 30 fps (4 at 120)
    assert 1.5 <= hold.release_s <= 1.5 + 0.03 + 2.0 / fps
    assert hold.theta_h == pytest.approx(1.0, abs=0.002)  # the median of the held samples (2 mrad noise)


def test_an_encoder_in_whole_degrees_holds_at_one_value():
    t, theta = _held(2.0, math.radians(40.0), fps=20.0, noise=0.0005, step=math.radians(1.0))
    hold = find_hold(t, theta, np.ones(t.size, bool))
    assert hold is not None and 2.0 <= hold.release_s <= 2.0 + 0.2


@pytest.mark.parametrize("theta0, fps", [(2.5, 120.0), (math.pi - 0.01, 120.0), (1.0, 30.0), (0.3, 240.0)])
def test_a_free_release_is_not_a_hold(theta0, fps):
    # released at t = 0: near the top (pi - 0.01) the bob stays within the band for 0.26 s, a free swing's stay
    t, theta = _held(0.0, theta0, fps=fps)
    assert find_hold(t, theta, np.ones(t.size, bool)) is None


def test_a_record_starting_mid_swing_is_not_a_hold():
    t, theta = swing("standard", PARAMS, seconds=20.0, theta0=0.3, omega0=1.5, fps=60.0, noise=0.002)
    assert find_hold(t, theta, np.ones(t.size, bool)) is None


def _write(path, t, theta):
    path.write_text("t theta\n" + "\n".join(f"{float(a)!r} {float(b)!r}" for a, b in zip(t, theta)) + "\n")
    return path


def test_discovery_reads_a_held_record_from_the_release(tmp_path):
    t, theta = _held(1.5, 1.0, fps=30.0, seed=4)
    series = read_angle_series(_write(tmp_path / "held.txt", t, theta))
    assert 1.5 <= series.t[0] <= 1.6 and series.t[-1] == t[-1]


@pytest.mark.integration
def test_fit_of_a_held_record_starts_at_the_release(tmp_path, caplog):
    t, theta = _held(1.5, 1.0, fps=30.0, seconds=30.0, seed=3)
    src = _write(tmp_path / "held.txt", t, theta)
    with caplog.at_level("WARNING"):
        res = CliRunner().invoke(cli, ["kinematics", str(src), "--out", str(tmp_path / "k"), "-q"])
    assert res.exit_code == 0, res.output
    assert any("held.txt: the bob is at rest at 1 rad until t = 1.5" in r.getMessage() for r in caplog.records)
    extra = read_metadata(tmp_path / "k" / "kinematics.parquet")["extra"]
    assert 1.5 <= extra["held_until_s"] <= 1.6 and extra["n_held"] == int(round(extra["held_until_s"] * 30.0))

    res = CliRunner().invoke(cli, ["fit", str(src), "--model", "standard", "--starts", "4", "--workers", "1",
                                   "--out", str(tmp_path / "f"), "-q"])
    assert res.exit_code == 0, res.output
    fit = json.loads((tmp_path / "f" / "fit_standard.json").read_text())
    assert fit["converged"]
    # Omega0's standard error on 28.5 s at 30 fps with 2 mrad of noise is 5e-5 rad/s (fit.json); 10 of them
    assert abs(fit["params"]["Omega0"]["value"] - 6.0) < 5e-4
    assert fit["rms"] < 0.003  # the noise (2 mrad) and no more: the hold is not fitted
