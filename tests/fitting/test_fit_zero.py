"""theta's zero as a fitted nuisance in `fit` and `run` (issue #15): when and how it is fitted and reported.

The record: the standard model, 20 s at 120 Hz from 2.5 rad, 1 mrad noise, seen by a camera
whose zero is 10 mrad off. The zero reference is what the angle stage would have recorded
(``"vertical"``: the image vertical; ``"rest"``: a measured final rest) or a plain table.
"""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from factory import swing

from pendtrack.artifacts import FIT_JSON_KEYS, Provenance, read_json_artifact, write_artifact
from pendtrack.cli import cli
from pendtrack.config import Config
from pendtrack.fitting.models_fit import fits_offset
from pendtrack.models import get_model
from pendtrack.stages.fit import fit_stage
from pendtrack.tables import read_record

STANDARD = {"Omega0": 5.0, "C1": 0.02, "C0": 0.02, "C2": 0.002}
OFFSET = 0.01  # [rad]
FAST = Config().replace("fit", n_starts=2, workers=1, profile=False)


def _theta() -> tuple[np.ndarray, np.ndarray]:
    return swing("standard", STANDARD, seconds=20.0, theta0=2.5, noise=1e-3, seed=3, measured=lambda th: th + OFFSET)


def _angle(path, zero: str | None, **extra):  # noqa: ANN001, ANN003, ANN202
    t, theta = _theta()
    extra = extra if zero is None else {"zero_reference": zero, **extra}
    write_artifact(pd.DataFrame({"t": t, "theta": theta, "ok": np.ones(t.size, bool)}), path, "angle",
                   provenance=Provenance(stage="angle", extra=extra))
    return path


def test_the_offset_rule():
    assert fits_offset("auto", "vertical") and fits_offset("auto", "table")
    assert not fits_offset("auto", "rest") and not fits_offset("auto", "truth") and not fits_offset("auto", "unknown")
    assert fits_offset("always", "rest") and not fits_offset("never", "vertical")


def test_zero_reference_of_each_kind_of_input(tmp_path):
    t, theta = _theta()
    table = tmp_path / "lab.txt"
    np.savetxt(table, np.column_stack([t, theta]))
    assert read_record(table).zero_reference == "table"
    assert read_record(_angle(tmp_path / "v.parquet", "vertical")).zero_reference == "vertical"
    assert read_record(_angle(tmp_path / "r.parquet", "rest")).zero_reference == "rest"
    assert read_record(_angle(tmp_path / "u.parquet", None)).zero_reference == "unknown"


@pytest.fixture(scope="module")
def vertical_fit(tmp_path_factory):
    d = tmp_path_factory.mktemp("vertical")
    out = fit_stage(_angle(d / "angle.parquet", "vertical"), out_dir=d / "fit", config=FAST, models=("standard",),
                    progress=False)
    return d / "fit", out


@pytest.mark.integration
def test_a_vertical_zero_is_fitted_as_theta_off(vertical_fit):
    out_dir, out = vertical_fit
    rec = read_json_artifact(out_dir / "fit_standard.json", required=FIT_JSON_KEYS)
    # the requested name stays the record's "model" (file names, batch columns, the report key on it)
    assert rec["model"] == "standard" and rec["fitted_model"] == "standard+offset"
    assert rec["measurement"] == ["offset"]
    off = rec["params"]["theta_off"]
    assert abs(off["value"] - OFFSET) < 3.0 * off["stderr"], off
    assert rec["trustworthy"] is True, rec["flags"]
    facts = out.facts["models"]["standard"]
    assert facts["fitted_model"] == "standard+offset" and facts["theta_off"] == pytest.approx(off["value"])
    assert out.facts["zero_reference"] == "vertical"
    combined = read_json_artifact(out_dir / "fit.json", required=FIT_JSON_KEYS)
    assert combined["model"] == "standard" and "theta_off" in combined["params"]


@pytest.mark.integration
def test_theta_off_carries_the_axles_share_of_the_zero(vertical_fit, tmp_path):
    # the angle stage's axle off sideways turns theta's zero, the same in every sample: the fit's residuals cannot
    # see it, so theta_off's standard error adds it (in quadrature) to the fit's own
    zs = 2e-4  # [rad]
    path = _angle(tmp_path / "angle.parquet", "vertical", axle_uncertainty={"zero_sigma_rad": zs})
    assert read_record(path).zero_sigma_rad == zs
    assert read_record(_angle(tmp_path / "v.parquet", "vertical")).zero_sigma_rad is None  # a given axle: none
    out = fit_stage(path, out_dir=tmp_path / "fit", config=FAST, models=("standard",), progress=False)
    own = read_json_artifact(vertical_fit[0] / "fit_standard.json", required=FIT_JSON_KEYS)["params"]["theta_off"]
    off = json.loads((tmp_path / "fit" / "fit_standard.json").read_text())["params"]["theta_off"]
    assert off["value"] == pytest.approx(own["value"], abs=1e-12)  # the same fit ...
    assert off["stderr"] == pytest.approx(np.hypot(own["stderr"], zs), rel=1e-9)  # ... with the axle's share
    assert out.facts["zero_sigma_rad"] == zs and vertical_fit[1].facts["zero_sigma_rad"] is None


@pytest.mark.integration
def test_a_measured_rest_fits_as_before(tmp_path):
    path = _angle(tmp_path / "angle.parquet", "rest")
    fit_stage(path, out_dir=tmp_path / "fit", config=FAST, models=("standard",), progress=False)
    rec = json.loads((tmp_path / "fit" / "fit_standard.json").read_text())
    assert rec["fitted_model"] == "standard" and "theta_off" not in rec["params"] and rec["measurement"] == []
    # ... unless [fit] offset = "always"; and "never" turns the rule off for a vertical zero
    fit_stage(path, out_dir=tmp_path / "always", config=FAST.replace("fit", offset="always"), models=("standard",),
              progress=False)
    assert "theta_off" in json.loads((tmp_path / "always" / "fit_standard.json").read_text())["params"]
    vertical = _angle(tmp_path / "v.parquet", "vertical")
    fit_stage(vertical, out_dir=tmp_path / "never", config=FAST.replace("fit", offset="never"), models=("standard",),
              progress=False)
    assert "theta_off" not in json.loads((tmp_path / "never" / "fit_standard.json").read_text())["params"]


@pytest.mark.integration
def test_fit_cli_on_a_plain_table_reports_theta_off(tmp_path):
    t, theta = _theta()
    table = tmp_path / "lab.txt"
    np.savetxt(table, np.column_stack([t, theta, np.zeros(t.size)]))
    cfg = tmp_path / "fast.toml"
    cfg.write_text("[fit]\nn_starts = 2\nworkers = 1\nprofile = false\n")
    res = CliRunner().invoke(cli, ["fit", str(table), "--columns", "t,theta,_", "--model", "standard", "--config",
                                   str(cfg), "-q", "--out", str(tmp_path / "out")])
    assert res.exit_code == 0, res.output
    assert "theta_off = " in res.output and "(fitted as standard+offset)" in res.output
    rec = json.loads((tmp_path / "out" / "fit_standard.json").read_text())
    assert rec["fitted_model"] == "standard+offset"
    assert abs(rec["params"]["theta_off"]["value"] - OFFSET) < 3.0 * rec["params"]["theta_off"]["stderr"]


@pytest.mark.integration
def test_an_angle_measured_from_the_horizontal_is_fitted_about_its_own_zero(tmp_path):
    # a sensor's atan2 angle (a micro:bit's, ES2Spring2019-ComputinginEngineering/project-one-molitor-galuppo)
    # or Tracker's angle of a point from the x axis swings about ~90 degrees: Omega0's estimate through the
    # origin found no slope ("no restoring torque"), and theta0 was bounded within 1 rad of the first sample
    # as if the zero were the vertical, so the fit ended at rms 86 mrad on a 1-mrad record
    centre = 0.5 * np.pi - 0.08  # [rad] a hanging pendulum seen from a sensor's axis 85 degrees off
    t, theta = swing("standard", STANDARD, seconds=20.0, theta0=0.8, noise=1e-3, seed=3,
                     measured=lambda th: th + centre)
    table = tmp_path / "sensor.csv"
    np.savetxt(table, np.column_stack([t, theta]), delimiter=",", header="t,theta", comments="")
    fit_stage(table, out_dir=tmp_path / "fit", config=FAST, models=("standard",), progress=False)
    rec = json.loads((tmp_path / "fit" / "fit_standard.json").read_text())
    assert rec["converged"], rec["message"]
    assert rec["rms"] < 2e-3  # the 1-mrad noise, smoothed: the fit follows the record
    off = rec["params"]["theta_off"]
    assert abs(off["value"] - centre) < 3.0 * off["stderr"]
    assert abs(rec["params"]["Omega0"]["value"] - STANDARD["Omega0"]) < 3.0 * rec["params"]["Omega0"]["stderr"]


def test_run_report_states_the_fitted_zero():
    from pendtrack.report.run_report import zero_offsets

    fits = {"classic": {"params": {"Omega0": {"value": 5.0}, "theta_off": {"value": 0.0123, "stderr": 4e-5}}},
            "opa": {"params": {"Omega0": {"value": 5.0}}}}
    run = SimpleNamespace(fits=fits, extra=lambda kind: {"zero_reference": "vertical"} if kind == "kinematics" else {})
    assert zero_offsets(run) == "classic: 12.300 ± 0.040 mrad (zero reference: vertical)"
    assert zero_offsets(SimpleNamespace(fits={"opa": fits["opa"]}, extra=lambda kind: {})) == ""


def test_the_filter_comes_from_the_kinematics_provenance() -> None:
    # the data's Savitzky-Golay filter: the facts' window first, else the window in seconds of the
    # config at the record's step, else none (the model compared unfiltered)
    from pendtrack.fitting import Observation
    from pendtrack.fitting.models_fit import observation_from
    from pendtrack.kinematics import window_points

    t = np.arange(600) / 120.0
    obs = observation_from({"window_points": 31, "order": 3}, {}, t)
    assert (obs.savgol_window, obs.savgol_order, obs.smooth_theta) == (31, 3, True)
    obs = observation_from({}, {"kinematics": {"savgol_window_s": 0.2, "savgol_order": 2}}, t)
    assert (obs.savgol_window, obs.savgol_order) == (window_points(0.2, 1 / 120.0, 2), 2)
    assert obs.savgol_window != 31
    assert observation_from({}, {}, t).savgol_window == Observation().savgol_window


def test_the_scales_first_order_shift_is_the_refit_of_a_rescaled_record():
    # the axle off along the radius scales every theta by 1 + rel; released at 2.5 rad the period rests on the
    # amplitude (T ~ T0 (1 + theta0^2 / 16)), so a 1 % larger angle moves Omega0 by ~0.5 %: the first-order shift
    # must be what refitting the rescaled record from the minimum gives (within 5 %: second order in rel)
    from dataclasses import replace

    from pendtrack.fitting.estimate import estimate
    from pendtrack.fitting.fitter import fit_setup
    from pendtrack.fitting.leastsq.cost import Observation
    from pendtrack.fitting.leastsq.lm import levenberg_marquardt
    from pendtrack.fitting.leastsq.samples import Record
    from pendtrack.fitting.uncertainty import scale_shift
    from pendtrack.kinematics import savgol_kinematics

    t, theta = _theta()
    kin = savgol_kinematics(t, theta, np.ones(t.size, bool), window_s=25 / 120, order=3)
    rec = Record(kin.t, kin.theta, kin.omega, alpha=kin.alpha, ok=kin.ok,
                 observation=Observation(savgol_window=25, savgol_order=3))
    setup = estimate(get_model("standard"), rec, options=FAST.fit, model_options=FAST.models)
    fit = fit_setup(setup, options=FAST.fit, model_options=FAST.models, seed=0, workers=1, theta_scale_rel=0.01)
    pb = setup.problem
    x = np.array([{**fit.params, **fit.initial_state}[n].value for n in pb.names])
    scaled = replace(pb, theta=pb.theta * 1.01, omega=pb.omega * 1.01)
    refit = levenberg_marquardt(scaled.residuals, lambda xx, r: scaled.jacobian(xx, central=True, method="fd"), x,
                                lower=pb.lower, upper=pb.upper)
    j = pb.names.index("Omega0")
    assert refit.status > 0 and abs(refit.x[j] - x[j]) > 1e-3  # the amplitude's share of the period: it moves
    assert fit.params["Omega0"].stderr_scale == pytest.approx(abs(refit.x[j] - x[j]), rel=0.05)
    assert np.array_equal(scale_shift(pb, x, 0.0), np.zeros(x.size))


@pytest.mark.integration
def test_every_parameter_carries_the_axles_share_of_the_scale(vertical_fit, tmp_path):
    # the fit stage reads the angle's theta_scale_rel and adds each parameter's shift under it to its stderr
    rel = 0.01
    path = _angle(tmp_path / "angle.parquet", "vertical", axle_uncertainty={"theta_scale_rel": rel})
    assert read_record(path).theta_scale_rel == rel
    out = fit_stage(path, out_dir=tmp_path / "fit", config=FAST, models=("standard",), progress=False)
    own = read_json_artifact(vertical_fit[0] / "fit_standard.json", required=FIT_JSON_KEYS)
    rec = json.loads((tmp_path / "fit" / "fit_standard.json").read_text())
    shift, p = rec["stderr_scale"], rec["params"]
    assert shift["Omega0"] > 0 and all(v == 0.0 for v in own["stderr_scale"].values())
    for name in p:
        assert p[name]["value"] == pytest.approx(own["params"][name]["value"], abs=1e-12)  # the same fit ...
        assert p[name]["stderr"] == pytest.approx(np.hypot(own["params"][name]["stderr"], shift[name]), rel=1e-9)
    assert out.facts["theta_scale_rel"] == rel and vertical_fit[1].facts["theta_scale_rel"] == 0.0
