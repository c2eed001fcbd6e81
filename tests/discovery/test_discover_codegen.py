"""Same data, same answer across code generations: discovery on lab1 under numba's generic code and the host's.

numba compiles its kernels for the host CPU (``NUMBA_CPU_NAME`` unset: AVX-512 on an Ice Lake
Xeon, AVX2 on an EPYC) or, with ``NUMBA_CPU_NAME=generic``, for a baseline x86-64: the two round
differently, and a verdict that turns on rounding differs between machines. This test runs
``pendtrack discover`` on the real record twice in subprocesses, each with its own empty
``NUMBA_CACHE_DIR`` (a cache compiled for one target must not serve the other), and requires the
same keep/drop decisions: measurement terms, causes and partial effects, every candidate's
verdict, and each whole-record fit's minimum to the optimiser's tolerance.

The same on three synthetic records of the hidden-effect tests (a zero offset, a hidden effect, the
drifting-Omega0 control), written as t, theta tables.

Slow (discoveries that compile the kernels once per generation: 6-12 minutes for lab1 on 2 cores; lab1 and the
drifting-Omega0 control run by hand, PENDTRACK_CAMPAIGN=1).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.integration  # discovery in subprocesses under two code generations

ROOT = Path(__file__).resolve().parents[2]
REAL = ROOT.parent / "shared" / "data" / "real-tyler-phy180" / "lab1_data.txt"
if not REAL.is_file():
    REAL = Path("/work/shared/data/real-tyler-phy180/lab1_data.txt")

# The fits' minima must agree to what matters for a decision: their BIC (n ln Xi^2 + k ln n) within 1 % of the
# 10 a term needs to be kept. Measured: lab1's baseline and final Xi^2 agree to 1e-14 (relative); on the
# drifting-Omega0 control the final model (power drag, a sloppy valley in its exponent) to 5.7e-6, a BIC
# difference of 0.02.
BIC_ATOL = 0.1


@pytest.fixture(scope="module")
def caches(tmp_path_factory: pytest.TempPathFactory) -> dict[bool, Path]:
    """One numba cache per code generation (generic: True), shared by this module's runs."""
    return {g: tmp_path_factory.mktemp("numba-generic" if g else "numba-host") for g in (False, True)}


def _discover(source: Path, out: Path, cache: Path, *, generic: bool, columns: str = "t,theta,_",
              config: Path | None = None) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    env["NUMBA_CACHE_DIR"] = str(cache)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    if generic:
        env["NUMBA_CPU_NAME"] = "generic"
    args = [sys.executable, "-m", "pendtrack", "discover", str(source), "--columns", columns, "--out", str(out), "-q",
            *(["--config", str(config)] if config else [])]
    res = subprocess.run(args, env=env, capture_output=True, text=True, timeout=3600)
    assert res.returncode == 0, res.stdout + res.stderr
    return json.loads((out / "discovery.json").read_text())


def _same_minima(host: dict, generic: dict) -> None:
    """The baseline's, every kept step's and the final model's fits: BIC within :data:`BIC_ATOL`."""
    for key in ("baseline_fit", "final_model"):
        assert host[key]["bic"] == pytest.approx(generic[key]["bic"], abs=BIC_ATOL), key
    for a, b in zip(host["measurement_steps"] + host["steps"], generic["measurement_steps"] + generic["steps"]):
        assert a["delta_bic"] == pytest.approx(b["delta_bic"], abs=2 * BIC_ATOL), a["effect"]


def decisions(record: dict) -> dict:
    """What discovery decided, without the numbers that may differ by rounding."""
    return {"measurement": record["measurement"], "effects": record["effects"], "partial": record.get("partial", []),
            "order": record["order"],
            # a pair's name lists its effects in the order of their held-out gains, which rounding may swap
            "candidates": sorted((c["kind"], c["step"], "+".join(sorted(c["terms"])), c["earns_keep"])
                                 for c in record["runners_up"])}


# CI's time: on an Intel Xeon (2 cores) the slow suite takes 51-54 minutes and CI as a whole ran near its
# 90-minute limit. Three comparisons run by hand, PENDTRACK_CAMPAIGN=1, as the discovery campaigns do:
# - lab1 (9.5 min on that Xeon). CI still runs lab1's discovery under both code generations, each against the
#   same assertions (tests/discovery/test_discover_stage.py in `make test`, which CI runs under the host's code
#   and again under NUMBA_CPU_NAME=generic); this test adds the comparison of every candidate's decision.
# - The drifting-Omega0 control (60 s at 30 fps, outside the catalogue), whose memory fits reached different
#   minima from one start under the two code generations; the candidates' nested start (the current optimum
#   with the new terms at 1 %) makes them agree (docs/decisions.md, 2026-11-27). 4.6 min on the AMD EPYC,
#   about 7 on the Intel Xeon.
# - The added-mass case at 30 fps (3.8 min on the Intel Xeon). CI runs the offset case here, and the default
#   suite's hidden-effect tests under both code generations (`make test`, then again under NUMBA_CPU_NAME=generic).
CAMPAIGN = pytest.mark.skipif(not os.environ.get("PENDTRACK_CAMPAIGN"),
                              reason="by hand (CI's time): set PENDTRACK_CAMPAIGN=1 to run it")


@pytest.mark.slow
@CAMPAIGN
def test_lab1_same_decisions_under_generic_and_host_code(tmp_path, caches):
    if not REAL.is_file():
        pytest.skip(f"real data not found at {REAL}")
    host = _discover(REAL, tmp_path / "host", caches[False], generic=False)
    generic = _discover(REAL, tmp_path / "generic", caches[True], generic=True)
    assert decisions(host) == decisions(generic), json.dumps([decisions(host), decisions(generic)], indent=1)
    # the offset is kept as a measurement by both
    assert "offset" in host["measurement"]
    _same_minima(host, generic)


# one case of each kind the hidden-effect tests draw (their seeds): a zero offset (default suite), a hidden effect
# at 30 fps (slow suite) and the drifting-Omega0 control (slow suite)
SYNTHETIC = {
    "offset": dict(seed=967871454, effect=None, measurement="offset", rate_hz=30.0, duration=(20.0, 25.0)),
    "added_mass": dict(seed=835980378, effect="added_mass", rate_hz=30.0, duration=(40.0, 40.0),
                       noise=(0.003, 0.005)),
    "drifting_omega0": dict(seed=1234, effect=None, outside="drifting_omega0", rate_hz=30.0, duration=(60.0, 60.0),
                            noise=(0.003, 0.005)),
}


@pytest.mark.slow
@pytest.mark.parametrize("case", [pytest.param(c, marks=CAMPAIGN) if c in ("drifting_omega0", "added_mass") else c
                                  for c in sorted(SYNTHETIC)])
def test_synthetic_same_decisions_under_generic_and_host_code(tmp_path, caches, case):
    from pendtrack.discovery.synthetic import draw_run

    kw = dict(SYNTHETIC[case])
    run = draw_run(kw.pop("seed"), kw.pop("effect"), **kw)
    table = tmp_path / f"{case}.txt"
    table.write_text("\n".join(f"{a:.9f} {b:.9f}" for a, b in zip(run.t, run.theta)) + "\n")
    config = tmp_path / "discover.toml"  # as the hidden-effect tests run: one effect step (a control: two)
    config.write_text(f"[discover]\nmax_effects = {2 if run.effect is None else 1}\n")
    host = _discover(table, tmp_path / "host", caches[False], generic=False, columns="t,theta", config=config)
    generic = _discover(table, tmp_path / "generic", caches[True], generic=True, columns="t,theta", config=config)
    assert decisions(host) == decisions(generic), json.dumps([decisions(host), decisions(generic)], indent=1)
    _same_minima(host, generic)
