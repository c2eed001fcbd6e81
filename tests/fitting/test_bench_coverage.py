"""benchmarks/bench_coverage.py's machinery, and the sandwich's meat it led to (issue #29 item 4).

The benchmark itself (hundreds of fits) is not run here: two short OPA records through the
whole loop (record, fit, JSON line, resume), the noise model, the coverage table on known
z-scores, and the Toeplitz meat against the exact covariance of a linear fit to
Savitzky-Golay-filtered noise.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import toeplitz
from scipy.signal import savgol_filter

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))

import bench_coverage as bench  # noqa: E402

from pendtrack.fitting.uncertainty import hac_covariance  # noqa: E402

pytestmark = pytest.mark.integration  # the coverage benchmark's records through whole fits


def test_truths_are_seeded_and_drawn_around_the_paper_values():
    a, b = bench.draw_truth("opa", 3), bench.draw_truth("opa", 3)
    assert a == b and a != bench.draw_truth("opa", 4)
    for model, centres in bench.CENTRES.items():
        truth = bench.draw_truth(model, 0)
        assert set(truth) == set(centres)
        for name, c in centres.items():
            spread = bench.OMEGA0_SPREAD if name == "Omega0" else bench.SPREAD
            assert abs(truth[name] / c - 1.0) <= spread


def test_tracking_noise_has_the_measured_level_and_correlation():
    e = bench.tracking_noise(200_000, fps=120.0, sigma=3e-3, rng=np.random.default_rng(0))
    # 2e5 samples correlated over a few: the rms and the lag-1 autocorrelation to ~1 % (several standard errors)
    assert np.std(e) == pytest.approx(3e-3, rel=0.02)
    rho1 = float(e[1:] @ e[:-1] / (e @ e))
    assert rho1 == pytest.approx(bench.AR_SHARE * bench.AR_RHO_120, abs=0.01)
    # at 30 fps the AR(1) part keeps its correlation time in seconds: rho per frame = 0.62^4
    e30 = bench.tracking_noise(200_000, fps=30.0, sigma=3e-3, rng=np.random.default_rng(1))
    assert float(e30[1:] @ e30[:-1] / (e30 @ e30)) == pytest.approx(bench.AR_SHARE * bench.AR_RHO_120**4, abs=0.01)


def _line(model: str, seed: int, z: float, *, trustworthy: bool = True) -> dict:
    truth = {"Omega0": 5.0}
    p = {"value": 5.0 + 0.01 * z, "stderr": 0.01, "stderr_low": 0.02, "stderr_high": 0.02, "u_paper": None,
         "stderr_bootstrap": None, "quote": "stderr"}
    return {"key": f"{model}-{seed}", "model": model, "seed": seed, "settings": {}, "truth": truth,
            "converged": True, "trustworthy": trustworthy, "params": {"Omega0": p}}


def test_coverage_counts_intervals_that_hold_the_truth():
    zs = [0.5, -0.9, 1.5, -2.5, 0.1]  # |z| <= 1: 3 of 5; <= 1.96: 4 of 5
    lines = [_line("opa", i, z) for i, z in enumerate(zs)] + [_line("opa", 9, 0.0, trustworthy=False)]
    out = bench.coverage(lines)["opa"]
    assert out["records"] == 6 and out["trustworthy"] == 5
    row = out["params"]["Omega0"]["stderr"]
    assert row["n"] == 5 and row["cover68"] == pytest.approx(0.6) and row["cover95"] == pytest.approx(0.8)
    assert row["se68"] == pytest.approx(math.sqrt(0.6 * 0.4 / 5))
    assert row["rms_z"] == pytest.approx(math.sqrt(np.mean(np.square(zs))))
    assert out["params"]["Omega0"]["quote"] == row  # the quoted interval is the sandwich here
    prof = out["params"]["Omega0"]["profile"]  # sigmas twice as large: |z|/2
    assert prof["cover68"] == pytest.approx(0.8)
    assert "u_paper" not in out["params"]["Omega0"]  # no finite sigma: not counted


def test_an_interval_counts_by_its_own_ends():
    # asymmetric intervals: [value - 2, value + 0.5] stderr at 68 %, [value - 3, value + 1] at 95 %
    lines = []
    for i, z in enumerate([1.5, -0.8, -2.5, 0.3]):  # value - truth in stderr units
        line = _line("fractional", i, z)
        p = line["params"]["Omega0"]
        v = p["value"]
        p.update(interval68=[v - 0.02, v + 0.005], interval95=[v - 0.03, v + 0.01], quote="interval")
        lines.append(line)
    row = bench.coverage(lines)["fractional"]["params"]["Omega0"]["interval"]
    # truth = value - 0.01 z: held by the 68 % interval for z in [-0.5, 2] (1.5, 0.3), by the 95 % one for
    # z in [-1, 3] (1.5, -0.8, 0.3)
    assert row["cover68"] == pytest.approx(0.5) and row["cover95"] == pytest.approx(0.75)
    assert bench.coverage(lines)["fractional"]["params"]["Omega0"]["quote"] == row


def test_two_records_fit_append_and_resume(tmp_path):
    settings = {"seconds": 6.0, "fps": 120.0, "starts": 1, "bootstrap": 0}
    jsonl = tmp_path / "c.jsonl"
    lines = bench.run(["opa"], 2, settings, jsonl=jsonl, workers=1)
    assert [ln["key"] for ln in lines] == ["opa-0", "opa-1"]
    assert len(jsonl.read_text().splitlines()) == 2
    for ln in lines:
        assert set(ln["params"]) == set(bench.CENTRES["opa"])
        assert ln["quote"]["Omega0"] == "interval" and ln["params"]["C4"]["stderr"] > 0
        lo, hi = ln["params"]["C4"]["interval95"]  # no memory: the sandwich's 1.96 standard errors
        assert (hi - lo) / 2 == pytest.approx(1.959964 * ln["params"]["C4"]["stderr"], rel=1e-9)
    again = bench.run(["opa"], 2, settings, jsonl=jsonl, workers=1)  # nothing left to fit
    assert len(jsonl.read_text().splitlines()) == 2
    assert json.dumps(again, sort_keys=True) == json.dumps(lines, sort_keys=True)
    with pytest.raises(ValueError, match="was run with"):
        bench.read_lines(jsonl, {**settings, "seconds": 7.0})


def test_toeplitz_meat_matches_the_exact_covariance_after_savitzky_golay():
    # a linear fit (6 slow columns at the pendulum's frequency) to the render's tracking noise passed through
    # the paper's 25-point cubic filter: the exact covariance of the estimate is B^-1 X^T Sigma X B^-1. The
    # sandwich's variance averaged over 60 records must match it within 10 % (measured: 2-4 % above; the mean's
    # own spread over 60 records is ~3 %); the Newey-West one falls 43-55 % short here (its scores sum to zero
    # at the optimum: a loss of ~p lag / n, large on this 5-s record)
    n, h, w = 600, 1 / 120, 5.0
    t = np.arange(n) * h
    x = np.column_stack([np.sin(w * t), np.cos(w * t), t * np.sin(w * t), t * np.cos(w * t), np.ones(n), t])
    eye = np.eye(n)
    filt = savgol_filter(eye, 25, 3, axis=0)
    k = np.arange(n)
    noise_cov = toeplitz(bench.AR_SHARE * bench.AR_RHO_120**k + (1 - bench.AR_SHARE) * (k == 0))
    binv = np.linalg.inv(x.T @ x)
    exact = np.diag(binv @ x.T @ filt @ noise_cov @ filt.T @ x @ binv)
    rng = np.random.default_rng(7)
    var_t, var_b = [], []
    for _ in range(60):
        e = filt @ (bench.tracking_noise(n, fps=120.0, sigma=1.0, rng=rng))
        r = e - x @ np.linalg.lstsq(x, e, rcond=None)[0]
        var_t.append(np.diag(hac_covariance(x, r, n, min_flat=24)[0]))
        var_b.append(np.diag(hac_covariance(x, r, n, kernel="bartlett")[0]))
    ratio_t = np.mean(var_t, axis=0) / exact
    ratio_b = np.mean(var_b, axis=0) / exact
    assert np.all(np.abs(ratio_t - 1.0) < 0.1), ratio_t
    assert np.all(ratio_b < 0.85), ratio_b
