"""One source for the fit's defaults: a library call and `pendtrack fit` with the defaults run the same fit.

The method's options live in :class:`pendtrack.config.FitConfig` (``[fit]``) and
:class:`pendtrack.config.ModelsConfig` (``[models]``) only; :func:`pendtrack.fitting.fit_model`
takes them as an object whose default is ``FitConfig()``. Both calls below use every default
but two on a short record: 4 starts instead of 150 and one process (the number of worker
processes does not change a fit), given the same way to both, so the test stays fast.
"""

from __future__ import annotations

import dataclasses
import inspect

import pytest
from click.testing import CliRunner
from factory import angle_file, swing

from pendtrack.artifacts import FIT_JSON_KEYS, read_artifact, read_json_artifact
from pendtrack.cli import cli
from pendtrack.config import Config, FitConfig, ModelsConfig
from pendtrack.fitting import Observation, fit_model
from pendtrack.models import get_model
from pendtrack.stages.kinematics import kinematics_stage

TRUTH = {"Omega0": 5.0, "C1": 0.02, "C0": 0.02, "C2": 0.002}
N_STARTS = 4


def _same(a, b):
    """Equal numbers to 1e-12 relative (None for a non-finite one on both sides), recursively."""
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if a is None or b is None or isinstance(a, (bool, str)):
        return a == b
    return b == pytest.approx(a, rel=1e-12, abs=0)


def test_fit_model_has_no_loose_copy_of_a_config_default():
    # the options of the method come only from the options objects; seed and workers may be
    # given apart, and then default to None (= the options' value)
    params = inspect.signature(fit_model).parameters
    fields = {f.name for f in dataclasses.fields(FitConfig)} | {f.name for f in dataclasses.fields(ModelsConfig)}
    loose = {n: p.default for n, p in params.items() if n in fields}
    assert loose == {"seed": None, "workers": None}


@pytest.mark.integration
def test_library_and_cli_defaults_give_the_same_fit(tmp_path):
    # a short record (6 s at 60 Hz: the default 150 starts stay cheap) through the kinematics stage
    t, theta = swing("standard", TRUTH, seconds=6.0, fps=60.0, theta0=2.5, noise=3e-3)
    angle = angle_file(tmp_path / "angle.parquet", t, theta)
    kin = kinematics_stage(angle, out_dir=tmp_path, config=Config(), progress=False).path

    res = CliRunner().invoke(cli, ["fit", str(kin), "--model", "standard", "--starts", str(N_STARTS), "--workers", "1",
                                   "-q", "--out", str(tmp_path / "cli")])
    assert res.exit_code == 0, res.output
    by_cli = read_json_artifact(tmp_path / "cli" / "fit.json", required=FIT_JSON_KEYS)

    # the library user reads the same file and passes the data's filter; no other option is given
    art = read_artifact(kin, "kinematics")
    df, info = art.data, art.provenance.extra
    obs = Observation(savgol_window=int(info["window_points"]), savgol_order=int(info["order"]), smooth_theta=True)
    by_lib = fit_model(get_model("standard"), df["t"].to_numpy(float), df["theta"].to_numpy(float),
                       df["omega"].to_numpy(float), alpha=df["alpha"].to_numpy(float), ok=df["ok"].to_numpy(bool),
                       observation=obs, options=FitConfig(n_starts=N_STARTS), workers=1).to_dict()

    assert by_lib["n_starts"] == by_cli["n_starts"] == N_STARTS
    # the same computation on the same numbers (JSON round-trips floats exactly); 1e-12 relative
    # is far below any difference a changed default makes (budgets, profile sigmas, spreads, seed)
    for key in ("xi2_min", "params", "initial_state", "stderr_low", "stderr_high", "stderr_bootstrap", "u_region",
                "estimates", "start_costs", "n_accepted", "converged", "aic", "bic", "memory_s", "cost", "seed",
                "accept_ratio", "message"):
        assert _same(by_cli[key], by_lib[key]), (key, by_cli[key], by_lib[key])
    assert any(v is not None for v in by_lib["stderr_low"].values())  # profile sigmas: on by default
