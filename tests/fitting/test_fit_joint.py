"""Several runs of one pendulum fitted jointly: shared and per-group values, their standard errors, the doors.

Four short synthetic runs (standard model, 60 Hz, 15 s, 3 mrad white noise, seeded) of one rig with two
tiles: Omega0 differs by tile, the axle's Coulomb friction C0 is shared, the drag is the same in every run
and each run is released from its own angle. The records go through the kinematics stage (Savitzky-Golay)
as measured ones do; the runs are named by run codes (03na1, 03na2, 06na1, 06na2).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from pendtrack.artifacts import FIT_JSON_KEYS, Provenance, read_artifact, read_json_artifact, write_artifact
from pendtrack.cli import cli
from pendtrack.config import Config
from pendtrack.errors import FitError
from pendtrack.fitting.joint import default_scopes, resolve_scopes, sharing_from_lists
from pendtrack.fitting.models_fit import observation_from
from pendtrack.models import get_model, simulate
from pendtrack.stages.kinematics import kinematics_stage

pytestmark = pytest.mark.integration  # joint fits of several runs, through the fit stage, the CLI and the door

DRAG = {"C1": 0.02, "C0": 0.05, "C2": 0.002}
OMEGA0 = {"03": 5.0, "06": 4.8}  # rad/s per tile
RUNS = {"03na1": 2.8, "03na2": 1.4, "06na1": 2.3, "06na2": 1.0}  # run -> release angle [rad]
STARTS = ("--starts", "3", "--workers", "1")


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory):
    """kinematics.parquet of each run, in a folder named by its run code."""
    root = tmp_path_factory.mktemp("series")
    t = np.arange(15 * 60) / 60.0
    files = []
    for i, (run, theta0) in enumerate(RUNS.items()):
        truth = {"Omega0": OMEGA0[run[:2]], **DRAG}
        sim = simulate(get_model("standard"), truth, t, theta0=theta0, omega0=0.0)
        theta = sim.theta + np.random.default_rng(10 + i).normal(0.0, 3e-3, t.size)
        d = root / run
        d.mkdir()
        write_artifact(pd.DataFrame({"t": t, "theta": theta, "ok": np.ones(t.size, bool)}), d / "angle.parquet",
                       "angle", provenance=Provenance(stage="test"))
        files.append(str(kinematics_stage(d / "angle.parquet", out_dir=d, config=Config(), progress=False).path))
    return files


@pytest.fixture(scope="module")
def joint(runs, tmp_path_factory: pytest.TempPathFactory):
    """`pendtrack fit` over the four runs: its exit, output, fit_standard.json and output folder."""
    out = tmp_path_factory.mktemp("joint")
    res = CliRunner().invoke(cli, ["fit", *runs, "--model", "standard", *STARTS, "-q", "--out", str(out),
                                   "--config", str(_config_file(out))])
    rec = read_json_artifact(out / "fit_standard.json", required=FIT_JSON_KEYS) if res.exit_code == 0 else None
    return res, rec, out


def _config_file(folder) -> object:
    path = folder / "fit.toml"
    path.write_text("[fit]\nprofile = false\njoint_starts = 2\n")
    return path


def test_default_scopes_follow_the_run_codes():
    model = get_model("classic")
    coded = default_scopes(model, run_codes=True)
    assert coded["Omega0"] == ("tile",) and coded["C0"] == () and coded["Ca"] == ("tile", "alley")
    assert coded["C3"] == coded["p"] == ("tile", "alley") and coded["theta0"] == coded["omega0"] == ("run",)
    plain = default_scopes(model, run_codes=False)
    assert all(plain[n] == () for n in model.param_names) and plain["theta0"] == ("run",)
    opa = default_scopes(get_model("opa"), run_codes=True)
    assert opa["t0"] == ("run",) and opa["C5"] == () and opa["C4"] == ("tile", "alley")


@pytest.mark.parametrize("sharing, words", [
    ({"C9": "shared"}, "'C9' is not a parameter of model 'standard'"),
    ({"theta0": "shared"}, "initial state"),
    ({"Omega0": "tile"}, "needs a run code"),
    ({"Omega0": "colour"}, "unknown scope 'colour'"),
])
def test_bad_sharing_is_a_one_line_fit_error(sharing, words):
    with pytest.raises(FitError) as info:
        resolve_scopes(get_model("standard"), sharing, labels={"a": {}, "b": {}})
    assert words in str(info.value) and "\n" not in str(info.value)


def test_a_parameter_declared_twice_is_an_error():
    with pytest.raises(FitError, match="declared twice"):
        sharing_from_lists(shared=["C0"], per_run=["C0"])


def test_joint_fit_recovers_the_shared_and_the_per_tile_values(joint):
    res, rec, _ = joint
    assert res.exit_code == 0, res.output
    assert "standard (joint, 4 runs): converged" in res.output
    assert rec["joint"] is True and rec["n_runs"] == 4 and rec["converged"] is True
    assert rec["sharing"] == {"Omega0": "tile", "C1": "tile+alley", "C0": "shared", "C2": "tile+alley",
                              "theta0": "run", "omega0": "run"}
    # C0, the rig's, within 2 joint standard errors of the truth (a Gaussian 95 % interval)
    c0 = rec["params"]["C0"]
    assert abs(c0["value"] - DRAG["C0"]) <= 2.0 * c0["stderr"], c0
    for tile, omega0 in OMEGA0.items():
        est = rec["groups"]["Omega0"][f"tile={tile}"]
        assert abs(est["value"] - omega0) <= 2.0 * est["stderr"], (tile, est)
        assert est["runs"] == [r for r in RUNS if r.startswith(tile)]
    # the two tiles' frequencies differ as simulated, by far more than their errors
    g = rec["groups"]["Omega0"]
    assert g["tile=03"]["value"] - g["tile=06"]["value"] > 10 * max(g["tile=03"]["stderr"], g["tile=06"]["stderr"])
    for run, theta0 in RUNS.items():  # each run keeps its own release angle (SG filter's edge: ~mrad)
        own = rec["runs"][run]
        assert own["columns"]["theta0"] == f"theta0@{run}" and own["columns"]["C0"] == "C0"
        assert abs(own["initial_state"]["theta0"]["value"] - theta0) < 0.01
        assert own["n"] > 0 and own["rms"] < 0.01 and own["xi2"] > 0


def test_the_order_of_the_records_does_not_change_the_fit(joint, runs, tmp_path):
    # the same records listed in another order: the same fit (the runs are fitted in the order of their ids)
    _, rec, _ = joint
    res = CliRunner().invoke(cli, ["fit", *reversed(runs), "--model", "standard", *STARTS, "-q", "--out", str(tmp_path),
                                   "--config", str(_config_file(tmp_path))])
    assert res.exit_code == 0, res.output
    other = read_json_artifact(tmp_path / "fit_standard.json", required=FIT_JSON_KEYS)
    for key in ("params", "groups", "runs", "xi2_min", "converged", "message", "start_costs", "covariance"):
        assert other[key] == rec[key], key


def test_provenance_hashes_every_run(joint, runs):
    """Every run's record is an input, by run id: all four files are named kinematics.parquet."""
    from pendtrack.artifacts import file_sha256

    _, rec, _ = joint
    assert rec["provenance"]["inputs"] == {run: file_sha256(path) for run, path in zip(RUNS, runs)}


def test_shared_standard_error_beats_the_single_runs(joint):
    _, rec, _ = joint
    c0 = rec["params"]["C0"]["stderr"]
    singles = [r["single"]["params"]["C0"]["stderr"] for r in rec["runs"].values()]
    assert c0 < min(singles)
    # four runs: independent errors would give 1/sqrt(4) of the mean single error; the spread of amplitudes
    # separates C0 from the velocity-dependent drag, so the joint error may be smaller still (issue #29: <= 1.5/sqrt(n))
    assert rec["stderr_ratio"]["C0"] <= 1.5 / math.sqrt(4)
    assert rec["stderr_ratio"]["C0"] == pytest.approx(c0 / np.mean(singles))
    # what to quote, as a single fit says it: the sandwich standard error of every joint parameter that has one
    assert set(rec["quote"]) == set(rec["covariance"]["names"])
    assert rec["quote"]["C0"] == "stderr"


def test_joint_fit_writes_each_runs_curves(joint, runs):
    res, rec, out = joint
    assert res.exit_code == 0, res.output
    curves = read_artifact(out / "fit_runs.parquet", "joint_fit").data
    assert set(curves["model"]) == {"standard"} and list(dict.fromkeys(curves["run"])) == list(RUNS)
    for run, path in zip(RUNS, runs):
        rows = curves[curves["run"] == run]
        kin = read_artifact(path, "kinematics")
        np.testing.assert_array_equal(rows["t"], kin.data["t"])  # the run's own times and measured angle
        np.testing.assert_array_equal(rows["theta"], kin.data["theta"])
        np.testing.assert_array_equal(rows["residual"], rows["theta"] - rows["theta_model"])
        assert float(np.sqrt(np.mean(rows["residual"] ** 2))) < 0.01  # 3 mrad noise, smoothed: ~1 mrad
        # the fit's own residual: these curves seen through the data's Savitzky-Golay filter from the start of
        # the run's window, on its samples after the filter's first half-window, give the run's rms in
        # fit_standard.json (same simulation; the window already ends a half-window before the record)
        own = rec["runs"][run]
        h = float(np.median(np.diff(rows["t"])))
        after = rows[rows["t"] >= own["window"][0] - h / 2]
        obs = observation_from(kin.provenance.extra, kin.provenance.config, kin.data["t"].to_numpy())
        seen, _ = obs.apply(after["theta_model"].to_numpy(), after["omega_model"].to_numpy(), h)
        cost = np.arange(len(after)) >= obs.trim
        cost &= after["t"].to_numpy() <= own["window"][1] + h / 2
        assert cost.sum() == own["n"]
        rms = float(np.sqrt(np.mean((after["theta"].to_numpy()[cost] - seen[cost]) ** 2)))
        # the fit steps RK4 with sub-steps of Omega h <= [fit] substep_phase (0.025 rad), the curves (as a single
        # fit's fit.parquet, pendtrack.fitting.predict) with the simulation's own: ~1e-7 rad apart on theta, which
        # moves the rms by ~1e-6 of itself (measured <= 1e-6); the run's own single-fit values instead of the
        # joint ones move it by ~7e-3 of itself
        assert rms == pytest.approx(own["rms"], rel=1e-5, abs=0), (run, rms, own["rms"])


def test_library_door_gives_the_cli_numbers(joint, runs, tmp_path):
    import pendtrack as pt

    _, rec, out = joint
    fits = pt.fit(runs, "standard", config=_config_file(tmp_path), starts=3, workers=1)
    lib = fits["standard"].to_dict()
    assert lib["params"] == rec["params"] and lib["groups"] == rec["groups"]
    assert {r: v["params"] for r, v in lib["runs"].items()} == {r: v["params"] for r, v in rec["runs"].items()}
    # its curves are the CLI's fit_runs.parquet rows (the same joint fit, the same simulation)
    cli_curves = read_artifact(out / "fit_runs.parquet", "joint_fit").data
    pd.testing.assert_frame_equal(fits["standard"].curves, cli_curves[cli_curves["model"] == "standard"]
                                  .reset_index(drop=True))


def test_per_run_declaration_fits_a_value_per_run(runs, tmp_path):
    import pendtrack as pt

    fits = pt.fit(runs[:2], "standard", config=_config_file(tmp_path), starts=3, workers=1, shared=["Omega0"],
                  per_run=["C2"])
    rec = fits["standard"].to_dict()
    assert rec["sharing"]["Omega0"] == "shared" and rec["sharing"]["C2"] == "run"
    assert set(rec["params"]) == {"Omega0", "C0"} and "C2" not in rec["params"]
    assert {r["columns"]["C2"] for r in rec["runs"].values()} == {"C2@03na1", "C2@03na2"}


@pytest.mark.parametrize("flags, words", [
    (["--shared", "C0,C9"], "'C9' is not a parameter of model 'standard'"),
    (["--per-group", "Ca"], "--per-group expects NAME=FIELDS"),
    (["--shared", "C0", "--per-run", "C0"], "declared twice"),
])
def test_bad_sharing_flag_is_one_line_exit_2_and_no_file(runs, tmp_path, flags, words):
    out = tmp_path / "bad"
    res = CliRunner().invoke(cli, ["fit", *runs[:2], "--model", "standard", *STARTS, *flags, "-q", "--out", str(out)])
    assert res.exit_code == 2, res.output
    lines = [line for line in res.output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: ") and words in lines[0], res.output
    assert not out.exists() or not any(out.iterdir())


def test_one_record_with_sharing_flags_is_an_error(runs, tmp_path):
    res = CliRunner().invoke(cli, ["fit", runs[0], "--model", "standard", "--shared", "C0", "-q", "--out",
                                   str(tmp_path)])
    assert res.exit_code == 2 and "need several records" in res.output


def test_a_record_given_twice_is_an_error(runs, tmp_path):
    res = CliRunner().invoke(cli, ["fit", runs[0], runs[0], "--model", "standard", "-q", "--out", str(tmp_path)])
    assert res.exit_code == 2 and "given twice" in res.output and not (tmp_path / "fit.json").exists()


def test_batch_joint_fits_the_runs_of_a_batch_folder(runs, tmp_path):
    # a batch folder holds DIR/<run id>/kinematics.parquet; `batch --joint` fits them into DIR/joint/
    from pathlib import Path

    from pendtrack.stages.series import batch_joint_fit

    batch_dir = Path(runs[0]).parent.parent
    config = Config().replace("fit", n_starts=3, workers=1, profile=False, joint_starts=2)
    res = batch_joint_fit(batch_dir, ["03na1", "06na2"], config=config, models=("standard",))
    rec = read_json_artifact(batch_dir / "joint" / "fit_standard.json", required=FIT_JSON_KEYS)
    assert res.facts["runs"] == ["03na1", "06na2"] and set(rec["runs"]) == {"03na1", "06na2"}
    with pytest.raises(FitError, match="at least two runs"):
        batch_joint_fit(batch_dir, ["03na1"], config=config, models=("standard",))


def test_joint_curves_observe_each_runs_own_offset(runs):
    # two runs of one tile (every model parameter shared) whose camera zeros differ by 30 mrad: each run's curve
    # is its observed angle, the model's theta plus the run's own theta_off
    from pendtrack.fitting.joint import fit_joint, joint_curves
    from pendtrack.fitting.leastsq.samples import Record
    from pendtrack.models import compose

    shift = {"03na1": 0.0, "03na2": 0.03}  # rad
    records = {}
    for run, path in zip(RUNS, runs):
        if run in shift:
            kin = read_artifact(path, "kinematics")
            df = kin.data
            obs = observation_from(kin.provenance.extra, kin.provenance.config, df["t"].to_numpy())
            records[run] = Record(df["t"].to_numpy(), df["theta"].to_numpy() + shift[run], df["omega"].to_numpy(),
                                  ok=df["ok"].to_numpy(bool), observation=obs)
    model = compose(get_model("standard"), ["offset"])
    config = Config().replace("fit", n_starts=3, workers=1, profile=False, joint_starts=2)
    fit = fit_joint(model, records, options=config.fit, sharing={"theta_off": "run"})
    times = {r: (rec.t, rec.theta) for r, rec in records.items()}
    curves = joint_curves({"standard": fit}, times)  # the model by its name, "standard+offset", as the stage does
    given = joint_curves({"standard": fit}, times, models={"standard": model})
    assert all(np.array_equal(curves[k], given[k]) for k in ("t", "theta_model", "omega_model", "run"))
    offsets = {run: fit.runs[run].params["theta_off"] for run in records}
    # the shift comes back (standard errors ~0.1 mrad each; 1 mrad: what the curves below need to tell it from 0)
    assert offsets["03na2"].value - offsets["03na1"].value == pytest.approx(0.03, abs=1e-3)
    for run in records:
        rows = curves["run"] == run
        assert np.array_equal(curves["theta"][rows], records[run].theta)
        # without its theta_off a curve would miss by the 30-mrad shift; with it, by the noise
        assert np.sqrt(np.mean(curves["residual"][rows] ** 2)) < 0.01


def test_report_of_a_joint_fit_shows_every_scope_and_every_run(joint, tmp_path):
    # `pendtrack report` on the joint fit's folder: the values by scope, the gain, each run's residual and one
    # figure of every run's curves (fit_runs.parquet); none of a single run's sections, which need a video
    import re

    from pendtrack.stages.report import REPORT_NAME

    res, rec, out = joint
    assert res.exit_code == 0, res.output
    rep = CliRunner().invoke(cli, ["report", str(out), "-q"])
    assert rep.exit_code == 0, rep.output
    page = (out / REPORT_NAME).read_text()

    def rows(key: str) -> list[str]:
        table = re.search(rf'<table data-table="{key}">.*?</table>', page, re.S)
        assert table, key
        return re.findall(r"<tr>(.*?)</tr>", table.group(0).split("<tbody>")[1], re.S)

    # one row per value: C0 shared, Omega0 per tile (2), C1 and C2 per tile and alley (2 each), the initial
    # state per run (4 x 2)
    scopes = [re.findall(r"<td[^>]*>(.*?)</td>", r)[2] for r in rows("joint-params-standard")]
    assert scopes.count("shared by every run") == 1 and scopes.count("per tile") == 2
    assert scopes.count("per tile and alley") == 4 and scopes.count("per run") == 2 * len(RUNS)
    assert len(rows("joint-gain-standard")) == len(rec["stderr_ratio"]) == 1
    assert [re.findall(r"<td[^>]*>(.*?)</td>", r)[0] for r in rows("joint-runs-standard")] == list(RUNS)
    assert 'data-figure="joint-standard"' in page and "data-figure-error" not in page
    assert "track.parquet is missing" not in page and "kinematics.parquet is missing" not in page
    # a batch folder holding the joint fit (`batch --joint`) links its report from the overview
    import shutil

    batch = tmp_path / "batch"
    shutil.copytree(out, batch / "joint")
    (batch / "batch.json").write_text(json.dumps({"counts": {"ok": len(RUNS)}}))
    assert CliRunner().invoke(cli, ["report", str(batch), "-q"]).exit_code == 0
    table = re.search(r'<table data-table="joint-reports">.*?</table>', (batch / REPORT_NAME).read_text(), re.S)
    assert table and 'href="joint/report.html"' in table.group(0)


def test_axle_shares_move_the_joint_standard_errors_as_a_refit_moves_the_values(runs):
    # theta's scale and zero are known only as well as each run's axle: one error for every sample of the run,
    # which the residuals cannot show. The joint covariance carries it as the minimum's first-order shift; the
    # refit of the rescaled record is the exact shift it stands for.
    from dataclasses import replace

    from pendtrack.fitting.joint import fit_joint
    from pendtrack.models import compose

    records = _two_runs(runs)
    model = compose(get_model("standard"), ["offset"])
    options = Config().replace("fit", n_starts=3, workers=1, profile=False, joint_starts=2).fit
    sharing = {"theta_off": "run"}
    base = fit_joint(model, records, options=options, sharing=sharing)
    assert all(v.stderr_scale == 0.0 for v in base.estimates.values())  # no axle uncertainty given: none added

    # a 2e-3 scale uncertainty on one run: big enough that the refit's shift stands far above its convergence
    # tolerance, small enough for the first order (the shift's second-order part is ~2e-3 of it)
    scale, zero = 2e-3, 1e-3
    given = dict(records, **{"03na1": replace(records["03na1"], theta_scale_rel=scale, zero_sigma_rad=zero)})
    with_axle = fit_joint(model, given, options=options, sharing=sharing)
    rec = records["03na1"]
    moved = dict(records, **{"03na1": replace(rec, theta=rec.theta * (1 + scale), omega=rec.omega * (1 + scale))})
    refit = fit_joint(model, moved, options=options, sharing=sharing)
    for label, est in with_axle.estimates.items():
        assert est.value == base.estimates[label].value  # the shares change the errors, never the fit
        assert est.stderr == pytest.approx(math.hypot(base.estimates[label].stderr, est.stderr_scale), rel=1e-9)
        if label.startswith("theta_off"):
            continue
        shift = abs(refit.estimates[label].value - base.estimates[label].value)
        # 5 %: the first-order step of a smooth least-squares minimum against the refit's exact shift
        assert est.stderr_scale == pytest.approx(shift, rel=0.05), label
    # the zero moves only that run's own theta_off, by the zero's uncertainty itself (with its scale's share)
    off = with_axle.estimates["theta_off@03na1"]
    assert off.stderr_scale >= zero and with_axle.estimates["theta_off@03na2"].stderr_scale < 0.1 * zero
    omega0 = next(k for k in with_axle.estimates if k.startswith("Omega0"))
    assert with_axle.estimates[omega0].stderr_scale > 0
    assert with_axle.to_dict()["stderr_axle"][omega0] == pytest.approx(with_axle.estimates[omega0].stderr_scale)


def _two_runs(runs) -> dict:
    from pendtrack.fitting.leastsq.samples import Record

    records = {}
    for run, path in zip(RUNS, runs):
        if run in ("03na1", "03na2"):
            kin = read_artifact(path, "kinematics")
            df = kin.data
            obs = observation_from(kin.provenance.extra, kin.provenance.config, df["t"].to_numpy())
            records[run] = Record(df["t"].to_numpy(), df["theta"].to_numpy(), df["omega"].to_numpy(),
                                  ok=df["ok"].to_numpy(bool), observation=obs)
    return records


def test_a_held_joint_column_is_held_in_every_run_that_uses_it(runs):
    from pendtrack.fitting.estimate import estimate
    from pendtrack.fitting.joint.stacked import stack

    records = _two_runs(runs)
    model = get_model("standard")
    config = Config()
    problems = [estimate(model, records[r], options=config.fit, model_options=config.models).problem
                for r in sorted(records)]
    labels_of = [{n: (n if n in ("C0", "C1", "C2", "Omega0") else f"{n}@{r}") for n in p.names}
                 for r, p in zip(sorted(records), problems)]
    stacked = stack(tuple(sorted(records)), tuple(problems), labels_of)
    x = np.array([0.5 * (lo + hi) if np.isfinite(lo + hi) else 1.0 for lo, hi in zip(stacked.lower, stacked.upper)])
    x[stacked.names.index("Omega0")] = 5.0
    j = stacked.names.index("C0")
    held = stacked.with_fixed({"C0": float(x[j])})
    assert "C0" not in held.names and [n for n in stacked.names if n != "C0"] == list(held.names)
    rest = np.delete(x, j)
    assert np.array_equal(held.residuals(rest), stacked.residuals(x))  # the same runs, C0 held where it was
    with pytest.raises(ValueError, match="unknown"):
        stacked.with_fixed({"Q9": 1.0})


def test_joint_profile_sigmas_match_the_sandwich_where_the_cost_is_quadratic(runs):
    # two 15-s runs of one tile (2.8 and 1.4 rad) determine Omega0 and the three drags well (C0 0.049 +- 0.002 for
    # 0.05): the cost is close to quadratic in each, so the profile's two sides agree with the sandwich (a linear
    # model's exactly; they are within 1 % here; 5 %: the profile's secant stops within 10 % of its own step)
    from pendtrack.fitting.joint import fit_joint

    records = _two_runs(runs)
    options = Config().replace("fit", n_starts=3, workers=1, profile=True, joint_starts=2).fit
    fit = fit_joint(get_model("standard"), records, options=options)
    for label, est in fit.estimates.items():
        if label.split("@")[0] in ("theta0", "omega0"):
            assert math.isnan(est.stderr_low) and math.isnan(est.stderr_high)
            continue
        for side in (est.stderr_low, est.stderr_high):
            assert side == pytest.approx(est.stderr, rel=0.05), (label, est.stderr, est.stderr_low, est.stderr_high)
    rec = fit.to_dict()
    assert rec["stderr_low"]["Omega0"] == pytest.approx(fit.estimates["Omega0"].stderr_low)
