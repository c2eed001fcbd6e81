"""The HTML report: content, robustness to missing/broken inputs, up-to-date skipping, CLI errors.

Built on synthetic run and batch folders (test_report_synthetic); the browser test is in
test_report_browser.py.
"""

from __future__ import annotations

import io
import re

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from PIL import Image

from pendtrack.cli import cli
from pendtrack.config import Config
from pendtrack.errors import ArtifactError
from pendtrack.report import figures as F
from pendtrack.report.html import read_provenance
from pendtrack.report.style import to_png
from pendtrack.stages.report import REPORT_NAME, report_stage, write_batch_report, write_run_report
from test_report_synthetic import write_batch, write_run

RUN_FIGURES = ("track-score", "circle-fit", "S1", "ozsin", "lobolusdecaras", "dissipativehysteresis",
               "theta-classic", "theta-opa", "theta-fractional", "first-swings", "schluck", "nyquist")
BATCH_FIGURES = ("fittexOmegaZer", "params-classic", "params-fractional")


def figures_of(html: str) -> dict[str, bytes]:
    """data-figure key -> decoded PNG bytes of every embedded figure."""
    import base64

    found = re.findall(r'<figure data-figure="([^"]+)"[^>]*><img src="data:image/png;base64,([^"]+)"', html)
    return {key: base64.b64decode(data) for key, data in found}


def not_blank(png: bytes) -> bool:
    """More than 2 % of the pixels differ clearly from the background."""
    img = np.asarray(Image.open(io.BytesIO(png)).convert("L"), dtype=float)
    return img.size > 0 and float(np.mean(np.abs(img - np.median(img)) > 30)) > 0.02


@pytest.fixture(scope="module")
def run_report(tmp_path_factory):
    run = write_run(tmp_path_factory.mktemp("r") / "24la1", seconds=15.0)
    out = report_stage(run, config=Config(), progress=False)
    return run, out, out.path.read_text(encoding="utf-8")


@pytest.mark.integration
def test_run_report_has_every_figure_drawn_and_not_blank(run_report):
    run, out, html = run_report
    assert out.path == run / REPORT_NAME and not out.skipped
    figs = figures_of(html)
    assert set(RUN_FIGURES) <= set(figs), set(RUN_FIGURES) - set(figs)
    assert "data-figure-error" not in html
    for key, png in figs.items():
        assert not_blank(png), key


@pytest.mark.integration
def test_run_report_is_self_contained(run_report):
    _, _, html = run_report
    assert 'http-equiv="Content-Security-Policy"' in html and "default-src 'none'" in html
    # no resource can be fetched: no src/href to anything but data: URIs and in-page anchors
    for attr, value in re.findall(r'\s(src|href)="([^"]*)"', html):
        assert value.startswith("data:image/png;base64,") or value.startswith("#"), (attr, value[:60])
    assert "<link" not in html and "@import" not in html and "url(" not in html
    assert "<script" not in html.replace('<script type="application/json" id="pendtrack-provenance">', "")


@pytest.mark.integration
def test_run_report_tables_and_narrative(run_report):
    _, _, html = run_report
    for key in ("fit-quality", "params-classic", "params-opa", "params-fractional", "relations", "discovery-steps",
                "discovery-evidence", "discovery-ranking", "discovery-runners-up", "discovery-final", "inputs"):
        assert f'data-table="{key}"' in html, key
    assert "u_paper" in html and "stderr" in html
    assert "&lt;evidence&gt;" in html and "<evidence>" not in html  # data text is escaped
    assert "77.3 %" in html  # held-out gain of the first discovery step: 1 - 5/22
    assert "<h3>Discovery</h3>" in html and "<code>power_drag</code>" in html  # discovery.md rendered


@pytest.mark.integration
def test_run_report_provenance_and_up_to_date(run_report, tmp_path):
    run, out, html = run_report
    record = read_provenance(html)
    assert record["stage"] == "report" and "kinematics.parquet" in record["inputs"]
    again = report_stage(run, config=Config(), progress=False)
    assert again.skipped and again.path.read_text(encoding="utf-8") == html
    forced = report_stage(run, out_dir=tmp_path, config=Config(), force=True, progress=False)
    assert forced.path == tmp_path / REPORT_NAME and not forced.skipped


@pytest.mark.integration
def test_changed_input_makes_report_stale(tmp_path):
    run = write_run(tmp_path / "06nn2", seconds=6.0, models=("classic",), discovery=False, stages=("fit",))
    report_stage(run, config=Config(), progress=False)
    (run / "fit_opa.json").write_text((run / "fit_classic.json").read_text().replace('"classic"', '"opa"'))
    out = report_stage(run, config=Config(), progress=False)
    assert not out.skipped and 'data-table="params-opa"' in out.path.read_text(encoding="utf-8")


def test_missing_stages_are_said_not_failed(tmp_path):
    run = write_run(tmp_path / "12na1", seconds=8.0, stages=("track", "angle"), discovery=False)
    html = write_run_report(run).read_text(encoding="utf-8")
    assert set(figures_of(html)) == {"track-score", "circle-fit"}
    assert "kinematics.parquet is missing" in html
    assert "fit.parquet (the fit stage&#x27;s output) is missing" in html or "fit.parquet" in html
    assert "No fit results" in html and "Discovery did not run" in html
    assert "data-figure-error" not in html


@pytest.mark.parametrize("alarm", [True, False])
def test_template_drift_alarm_is_stated_and_prominent_when_it_fired(tmp_path, alarm):
    from pendtrack.artifacts import Provenance, read_artifact, write_artifact

    run = write_run(tmp_path / "12na1", seconds=8.0, stages=("track", "angle"), discovery=False)
    track = read_artifact(run / "track.parquet", "track")
    drift = {"max_px": 4.2 if alarm else 1.1, "reanchors": 3 if alarm else 0, "limit_px": 3.0, "alarm": alarm}
    write_artifact(track.data, run / "track.parquet", "track", provenance=Provenance(
        stage="track", config={"track": {"min_score": 0.6, "evolution_rate": 0.2}, "lens": {}},
        extra={**track.provenance.extra, "template_drift": drift}))
    html = write_run_report(run).read_text(encoding="utf-8")
    assert "template drift" in html
    if alarm:
        assert "Template drift alarm" in html and "4.20 px" in html and "3 time" in html
        # the alarm note comes first in the overview, before the facts
        assert html.index("Template drift alarm") < html.index("template drift</")
    else:
        assert "Template drift alarm" not in html and "at most 1.10 px" in html


def test_kinematics_without_omega0_says_why(tmp_path):
    from pendtrack.artifacts import Provenance, read_artifact, write_artifact

    run = write_run(tmp_path / "00nn1", seconds=8.0, stages=("kinematics",), discovery=False)
    kin = read_artifact(run / "kinematics.parquet", "kinematics").data
    bare = kin[["t", "theta", "omega", "alpha", "ok"]].copy()
    bare["alpha"] = np.nan  # nothing to find turning points in
    write_artifact(bare, run / "kinematics.parquet", "kinematics", provenance=Provenance(stage="kinematics"))
    html = write_run_report(run).read_text(encoding="utf-8")
    assert set(figures_of(html)) == {"S1"}
    assert "No turning-point analysis" in html and "No amplitudes" in html and "no Omega0 to compute" in html
    assert "data-figure-error" not in html


def test_fit_without_kinematics_and_broken_artifact(tmp_path):
    run = write_run(tmp_path / "03na1", seconds=8.0, stages=("fit",), discovery=False)
    (run / "kinematics.parquet").write_bytes(b"PAR1 not really parquet")
    html = write_run_report(run).read_text(encoding="utf-8")
    assert {"theta-classic", "first-swings"} <= set(figures_of(html))
    assert "Could not read" in html and "kinematics.parquet" in html
    assert "data-figure-error" not in html


def test_report_write_is_atomic_on_failure(tmp_path, monkeypatch):
    run = write_run(tmp_path / "09la1", seconds=6.0, stages=("track",), discovery=False)
    (run / REPORT_NAME).write_text("old", encoding="utf-8")
    import pendtrack.report.html as H

    monkeypatch.setattr(H, "render_page", lambda page: 12345)  # not text: fails inside the atomic write
    with pytest.raises(TypeError):
        write_run_report(run)
    assert (run / REPORT_NAME).read_text(encoding="utf-8") == "old"
    assert not list(run.glob(".report.html.*"))


@pytest.mark.integration
def test_bad_folders_raise_pendtrack_errors(tmp_path):
    with pytest.raises(ArtifactError, match="folder not found"):
        report_stage(tmp_path / "nope", config=Config(), progress=False)
    (tmp_path / "empty").mkdir()
    with pytest.raises(ArtifactError, match="nothing to report"):
        report_stage(tmp_path / "empty", config=Config(), progress=False)
    (tmp_path / "file.txt").write_text("x")
    with pytest.raises(ArtifactError, match="not a folder"):
        report_stage(tmp_path / "file.txt", config=Config(), progress=False)
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "track.parquet").write_bytes(b"garbage")
    with pytest.raises(ArtifactError, match="nothing to report"):
        write_run_report(bad)


@pytest.mark.integration
@pytest.mark.parametrize("case", ["missing", "empty"])
def test_cli_bad_input_is_one_line_error_exit_2(tmp_path, case):
    folder = tmp_path / case
    if case == "empty":
        folder.mkdir()
    res = CliRunner().invoke(cli, ["report", str(folder), "-q"])
    assert res.exit_code == 2
    lines = [line for line in res.output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith(f"error: {folder}: "), res.output


@pytest.mark.integration
def test_cli_writes_and_prints_the_path(tmp_path):
    run = write_run(tmp_path / "18la1", seconds=6.0, stages=("track", "angle"), discovery=False)
    res = CliRunner().invoke(cli, ["report", str(run), "-q"])
    assert res.exit_code == 0, res.output
    assert res.output.strip() == f"report written: {run / REPORT_NAME}"
    res = CliRunner().invoke(cli, ["report", str(run), "-q", "--out", str(tmp_path / "elsewhere")])
    assert res.exit_code == 0 and (tmp_path / "elsewhere" / REPORT_NAME).is_file()
    res = CliRunner().invoke(cli, ["report", str(run), "-q"])
    assert res.output.strip() == f"report up to date: {run / REPORT_NAME}"


@pytest.fixture(scope="module")
def batch_report(tmp_path_factory):
    batch = write_batch(tmp_path_factory.mktemp("b") / "batch", run_dirs=2)
    out = report_stage(batch, config=Config(), progress=False)
    return batch, out, out.path.read_text(encoding="utf-8")


@pytest.mark.integration
def test_batch_report_figures_and_links(batch_report):
    batch, out, html = batch_report
    assert out.facts["kind"] == "batch" and out.facts["run_reports"] == 2
    figs = figures_of(html)
    assert set(BATCH_FIGURES) <= set(figs) and "data-figure-error" not in html
    assert all(not_blank(png) for png in figs.values())
    links = re.findall(r'href="([^"#]+)"', html)
    assert sorted(links) == ["00la1/report.html", "06la1/report.html"]
    assert all((batch / link).is_file() for link in links)
    assert "two cuboids (eq. consistencycheck): X = 1.48 ± 0.05, l₀ = 54.0 ± 0.4 cm" in html
    assert 'data-table="runs"' in html and html.count("<tr>") >= 20
    assert "notes.mp4" in html  # skipped file listed


@pytest.mark.integration
def test_batch_report_up_to_date_until_a_run_report_appears(batch_report):
    batch, _, _ = batch_report
    assert report_stage(batch, config=Config(), progress=False).skipped
    write_run(batch / "12la1", seconds=6.0, stages=("track",), discovery=False)
    out = report_stage(batch, config=Config(), progress=False)
    assert not out.skipped and "12la1/report.html" in out.path.read_text(encoding="utf-8")


def test_batch_report_from_a_minimal_csv(tmp_path):
    batch = tmp_path / "b"
    batch.mkdir()
    pd.DataFrame({"code": ["00nn1", "12nn1", "24nn1", "12la1"], "l1_m": [0.0, 0.12, 0.24, 0.12],
                  "launched": [False, False, False, True], "alley": [False, False, False, True],
                  "classic__Omega0__value": [5.3, 5.0, 4.7, 4.98], "classic__C3__value": [0.1, 0.3, 0.5, 0.31],
                  "classic__C3__stderr": [0.01, 0.01, 0.02, 0.01]}).to_csv(batch / "summary.csv", index=False)
    html = write_batch_report(batch).read_text(encoding="utf-8")
    assert {"fittexOmegaZer", "params-classic"} <= set(figures_of(html))
    assert "No two-cuboid line" in html and "data-figure-error" not in html


def test_figure_functions_tolerate_edge_cases():
    t = np.arange(200) / 120.0
    fig = F.track_quality_figure(t, np.full(t.size, 0.9), np.ones(t.size, bool))
    assert not_blank(to_png(fig))
    fig = F.circle_fit_figure(t, 600 + 100 * np.sin(t), 300 + 100 * np.cos(t), np.ones(t.size, bool), axle=None,
                              radius=None)
    assert not_blank(to_png(fig))
    theta = np.where(t < 1, np.nan, np.sin(5 * t))
    fig = F.theta_fit_figure(t, theta, {"classic": theta}, {"classic": theta * 0}, title="")
    assert not_blank(to_png(fig))


def test_markdown_is_escaped_and_structured():
    from pendtrack.report.markdown import to_html

    out = to_html("# Title\n\nText with **bold**, `a_b` and <script>x</script>.\n\n- one\n- two\n\n"
                  "| a | b |\n|---|---|\n| 1 | 2 |\n")
    assert "<h3>Title</h3>" in out and "<b>bold</b>" in out and "<code>a_b</code>" in out
    assert "<script>" not in out and "&lt;script&gt;" in out
    assert "<ul><li>one</li><li>two</li></ul>" in out and "<td class=\"text\">2</td>" in out
