"""The library door (``import pendtrack as pt``): the CLI's pipeline, the same results, objects for a notebook."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from factory import swing

import pendtrack as pt
from pendtrack.cli import cli
from pendtrack.errors import ConfigError, PendtrackError
from pendtrack.models import get_model, simulate

STANDARD = {"Omega0": 5.0, "C1": 0.02, "C0": 0.02, "C2": 0.002}
CONFIG = "[fit]\nn_starts = 3\nworkers = 1\nprofile = false\n"  # few starts: the test is about sameness, not fits
# what may differ between two runs of one fit: the wall time and the provenance (file hashes, creation time)
RUN_DEPENDENT = ("runtime_s", "provenance")


@pytest.fixture(scope="module")
def record(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A 12-s standard-model swing from 2.5 rad with 3 mrad noise as a two-column table, and a config."""
    d = tmp_path_factory.mktemp("door")
    t, theta = swing("standard", STANDARD, seconds=12.0, theta0=2.5, noise=3e-3)
    table = d / "swing.csv"
    table.write_text("t,theta\n" + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(t, theta)), encoding="utf-8")
    config = d / "few.toml"
    config.write_text(CONFIG, encoding="utf-8")
    return {"table": table, "config": config, "dir": d}


@pytest.fixture(scope="module")
def cli_fit(record: dict[str, Path]) -> Path:
    """`pendtrack kinematics` then `pendtrack fit` on the table, as a user runs them."""
    out = record["dir"] / "cli"
    runner = CliRunner()
    res = runner.invoke(cli, ["kinematics", str(record["table"]), "-q", "--out", str(out)])
    assert res.exit_code == 0, res.output
    res = runner.invoke(cli, ["fit", str(out / "kinematics.parquet"), "--model", "standard", "--model", "classic",
                              "--config", str(record["config"]), "-q", "--out", str(out)])
    assert res.exit_code in (0, 1), res.output  # 1: a fit flagged, still written
    return out


@pytest.fixture(scope="module")
def door_fit(record: dict[str, Path]) -> pt.FitSet:
    kin = pt.kinematics(pt.read_record(record["table"]))
    return pt.fit(kin, ["standard", "classic"], config=record["config"])


def _without_run_dependent(rec: dict) -> dict:
    return {k: v for k, v in rec.items() if k not in RUN_DEPENDENT}


@pytest.mark.integration
def test_import_is_free() -> None:
    code = ("import sys, pendtrack; heavy = [m for m in ('numpy', 'pandas', 'numba', 'cv2', 'av', 'scipy', "
            "'matplotlib') if m in sys.modules]; print(','.join(heavy))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""


@pytest.mark.integration
def test_door_fits_equal_the_cli_files_to_the_last_digit(cli_fit: Path, door_fit: pt.FitSet) -> None:
    for name in ("standard", "classic"):
        written = json.loads((cli_fit / f"fit_{name}.json").read_text(encoding="utf-8"))
        assert _without_run_dependent(door_fit[name].to_dict()) == _without_run_dependent(written), name
        params = door_fit[name].params
        assert list(params.columns) == ["value", "stderr", "low95", "high95", "u_paper", "flags"]
        assert params.loc["Omega0", "value"] == written["params"]["Omega0"]["value"]  # exact, not approximate
        assert [params.loc["Omega0", "low95"], params.loc["Omega0", "high95"]] == written["interval95"]["Omega0"]
    combined = json.loads((cli_fit / "fit.json").read_text(encoding="utf-8"))
    assert door_fit.selected == combined["selected"] and door_fit.selected in ("standard", "classic")


@pytest.mark.integration
def test_results_render_as_html_tables_and_plot_figures(door_fit: pt.FitSet) -> None:
    from matplotlib.figure import Figure

    html = door_fit._repr_html_()
    assert html.count("<table") == 3 and "Omega0" in html  # the summary and one table per model
    assert "<table" in door_fit["classic"]._repr_html_()
    assert isinstance(door_fit.plot(), Figure) and isinstance(door_fit["standard"].plot(), Figure)


@pytest.mark.integration
def test_load_round_trips_a_cli_folder(cli_fit: Path, door_fit: pt.FitSet) -> None:
    run = pt.load(cli_fit)
    assert run.fits.to_dict() == json.loads((cli_fit / "fit.json").read_text(encoding="utf-8"))
    assert run.fits["classic"].to_dict() == json.loads((cli_fit / "fit_classic.json").read_text(encoding="utf-8"))
    assert run.kinematics is not None and run.kinematics.attrs["provenance"]["stage"] == "kinematics"
    assert list(run.fits) == list(door_fit)


@pytest.mark.integration
def test_out_writes_what_the_cli_writes(record: dict[str, Path], door_fit: pt.FitSet, tmp_path: Path) -> None:
    kin = pt.kinematics(pt.read_record(record["table"]))
    again = pt.fit(kin, "standard", config=record["config"], out=tmp_path)
    assert (tmp_path / "fit_standard.json").is_file() and (tmp_path / "fit.parquet").is_file()
    assert pt.load(tmp_path).fits["standard"].to_dict() == again["standard"].to_dict()
    assert _without_run_dependent(again["standard"].to_dict()) == _without_run_dependent(door_fit["standard"].to_dict())


@pytest.mark.integration
def test_a_path_is_fitted_as_the_cli_fits_it(record: dict[str, Path], cli_fit: Path, door_fit: pt.FitSet) -> None:
    # pt.fit("kinematics.parquet") took the string for several records, one per character: "/: the record is
    # given twice"
    by_path = pt.fit(str(cli_fit / "kinematics.parquet"), "standard", config=record["config"])
    assert _without_run_dependent(by_path["standard"].to_dict()) == _without_run_dependent(
        json.loads((cli_fit / "fit_standard.json").read_text(encoding="utf-8")))
    # the residual against the record's noise reaches the library door too (the model of the data: near 1)
    assert by_path["standard"].rms_over_noise == pytest.approx(door_fit["standard"].rms_over_noise)
    assert 0.5 < by_path["standard"].rms_over_noise < 2.0


@pytest.mark.integration
def test_user_errors_are_the_cli_one_line_errors(record: dict[str, Path], tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="starts") as exc:
        pt.fit(pt.read_record(record["table"]), "standard", starts=0)
    assert "\n" not in str(exc.value)
    with pytest.raises(ConfigError, match="unknown option n_start "):
        pt.fit(pt.read_record(record["table"]), "standard", n_start=3)
    missing = tmp_path / "nope.csv"
    with pytest.raises(PendtrackError, match="nope.csv"):
        pt.read_record(missing)
    res = CliRunner().invoke(cli, ["fit", str(missing), "-q", "--out", str(tmp_path)])
    assert res.exit_code == 2 and str(missing) in res.output
    with pytest.raises(PendtrackError, match="no such folder"):
        pt.load(tmp_path / "none")


def test_simulate_is_the_models_simulation() -> None:
    t = np.arange(240) / 120.0
    df = pt.simulate("standard", STANDARD, t, theta0=1.0)
    ref = simulate(get_model("standard"), STANDARD, t, theta0=1.0, omega0=0.0)
    assert np.array_equal(df["theta"].to_numpy(), ref.theta) and list(df.columns) == ["t", "theta", "omega", "alpha"]
    assert df.attrs["provenance"]["extra"]["model"] == "standard"
