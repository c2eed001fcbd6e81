"""Same input, same answer: a fit does not depend on numba's cache, on the machine's load or on the
CPU's code generation.

Each fit runs as a user runs it, ``pendtrack fit`` in a process of its own:

* with an empty numba cache (every kernel compiles) and again with that cache filled: the two
  ``fit_<model>.json`` are identical apart from the runtime fields -- no result may depend on
  the wall clock (a fit counts its work, never its seconds);
* under numba's generic code generation (``NUMBA_CPU_NAME=generic``, the rounding of another
  CPU) against the host's: the same minimum. The last digits may differ (other instructions,
  other rounding), so the bar is the statistics': the same Xi^2_min to 1e-6 relative and every
  value within 0.05 of its standard error.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from factory import angle_file, swing

from pendtrack.config import Config
from pendtrack.stages.kinematics import kinematics_stage

pytestmark = [pytest.mark.slow, pytest.mark.integration]  # four processes that each compile the kernels from nothing

MODELS = ("classic", "fractional")
RUNTIME_KEYS = ("runtime_s", "provenance")
CONFIG = "[fit]\nn_starts = 6\nworkers = 2\nprofile = false\n"
# a cost that differs only by rounding: the minimum moves by far less than 1e-6 relative (a 0.01-0.03
# standard-error move of a parameter changes Xi^2 by ~1e-8 relative on this record)
XI2_REL = 1e-6
SE_SHARE = 0.05  # values within this share of their standard error: the same measurement


@pytest.fixture(scope="module")
def kinematics(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("determinism")
    truth = {"Omega0": 5.0, "C0": 0.01, "C3": 0.05, "p": 1.6, "Ca": 0.01}
    angle_file(d / "angle.parquet", *swing("classic", truth, seconds=30.0, theta0=2.0, noise=2e-3, seed=7))
    (d / "fit.toml").write_text(CONFIG)
    return kinematics_stage(d / "angle.parquet", out_dir=d, config=Config(), progress=False).path


def run_fit(kin: Path, out: Path, cache: Path, **env: str) -> dict[str, dict]:
    """``pendtrack fit`` in a fresh process; its fit_<model>.json records by model."""
    cmd = [str(Path(sys.executable).parent / "pendtrack"), "fit", str(kin), "--config", str(kin.parent / "fit.toml"),
           "--out", str(out), "-q", *(a for m in MODELS for a in ("--model", m))]
    res = subprocess.run(cmd, env={**os.environ, "NUMBA_CACHE_DIR": str(cache), **env}, capture_output=True,
                         text=True, timeout=900)
    assert res.returncode in (0, 1), res.stderr  # 1: a fit flagged (files written); 2 would be an error
    return {m: json.loads((out / f"fit_{m}.json").read_text()) for m in MODELS}


def strip(record: dict) -> dict:
    return {k: v for k, v in record.items() if k not in RUNTIME_KEYS}


@pytest.fixture(scope="module")
def host_fits(kinematics: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[dict, dict]:
    """The host's fits with an empty numba cache, then with that cache filled (compiled once for both tests)."""
    d = tmp_path_factory.mktemp("host")
    cold = run_fit(kinematics, d / "cold", d / "numba-cache")
    warm = run_fit(kinematics, d / "warm", d / "numba-cache")
    return cold, warm


def test_a_cold_cache_and_a_warm_one_give_the_same_fit(host_fits):
    cold, warm = host_fits
    for m in MODELS:
        assert strip(cold[m]) == strip(warm[m]), m


def test_generic_code_generation_finds_the_same_minimum(kinematics, host_fits, tmp_path):
    host = host_fits[1]
    generic = run_fit(kinematics, tmp_path / "generic", tmp_path / "cache-generic", NUMBA_CPU_NAME="generic")
    for m in MODELS:
        a, b = host[m], generic[m]
        assert b["xi2_min"] == pytest.approx(a["xi2_min"], rel=XI2_REL), m
        assert a["converged"] == b["converged"] and a["trustworthy"] == b["trustworthy"], m
        assert sorted(a["flags"]) == sorted(b["flags"]) and sorted(a["findings"]) == sorted(b["findings"]), m
        for name, p in a["params"].items():
            se = p["stderr"]
            if se and np.isfinite(se) and se > 0:
                assert abs(b["params"][name]["value"] - p["value"]) <= SE_SHARE * se, (m, name)
