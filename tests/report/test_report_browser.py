"""The reports open in headless Chromium: every figure rendered and not blank, no network request.

The pages are real pipeline output: a video from the ``rendered_run`` fixture goes through
``run_pipeline`` (track, angle, kinematics, fit of classic/opa/fractional with a few starts);
the batch is the real batch stage over three run codes whose job copies that run folder (the
batch's own pipeline is tested elsewhere; here the summary, batch.json and links are real).

Driver: Playwright (PyPI ``playwright``) on the system Chromium (``/usr/bin/chromium``, or
``$PENDTRACK_CHROMIUM``) via ``executable_path``, so no browser is downloaded. Each page gets a
fresh ``--user-data-dir`` (a persistent context on a temporary folder). Every request the page
makes is recorded; only the ``file://`` page itself and ``data:`` URIs are allowed. Each
figure is checked twice: in the page (the <img> decoded: ``complete`` and ``naturalWidth`` >
0) and as an element screenshot whose pixels must not be blank.

Without Chromium or Playwright the test is skipped, unless ``PENDTRACK_REQUIRE_BROWSER=1``
(CI), where it fails.
"""

from __future__ import annotations

import io
import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from pendtrack.config import Config
from pendtrack.stages.report import report_stage
from test_report import RUN_FIGURES

pytestmark = [pytest.mark.video, pytest.mark.integration]  # a rendered video through the pipeline, opened in Chromium

CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--no-first-run"]


def _unavailable(reason: str) -> None:
    if os.environ.get("PENDTRACK_REQUIRE_BROWSER") == "1":
        pytest.fail(f"PENDTRACK_REQUIRE_BROWSER=1 but {reason}")
    pytest.skip(reason)


def find_chromium() -> str:
    """Chromium's path; skip (or fail under PENDTRACK_REQUIRE_BROWSER=1) without it or Playwright."""
    path = os.environ.get("PENDTRACK_CHROMIUM") or shutil.which("chromium") or "/usr/bin/chromium"
    if not Path(path).is_file():
        _unavailable("Chromium is not installed (apt-get install chromium, or set PENDTRACK_CHROMIUM)")
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        _unavailable("the Python package playwright is not installed (pip install -e '.[test]')")
    return path


def _blank(png: bytes) -> bool:
    img = np.asarray(Image.open(io.BytesIO(png)).convert("L"), dtype=float)
    return img.size == 0 or float(np.mean(np.abs(img - np.median(img)) > 30)) < 0.02


def open_in_chromium(chromium: str, page_path: Path, profile: Path) -> dict:
    """Load a page; return its requests, console errors, per-figure checks and the page title."""
    from playwright.sync_api import sync_playwright

    result: dict = {"requests": [], "errors": [], "figures": {}}
    with sync_playwright() as p:
        ctx = p.chromium.launch_persistent_context(str(profile), executable_path=chromium, args=CHROMIUM_ARGS,
                                                   headless=True, viewport={"width": 1200, "height": 900})
        try:
            page = ctx.new_page()
            page.on("request", lambda r: result["requests"].append(r.url))
            page.on("console", lambda m: m.type == "error" and result["errors"].append(m.text))
            page.on("pageerror", lambda e: result["errors"].append(str(e)))
            page.goto(page_path.as_uri(), wait_until="load", timeout=60_000)
            result["title"] = page.title()
            for fig in page.locator("figure[data-figure]").all():
                key = fig.get_attribute("data-figure")
                img = fig.locator("img")
                decoded = img.evaluate("el => el.complete && el.naturalWidth > 0 && el.naturalHeight > 0")
                size = img.evaluate("el => [el.naturalWidth, el.naturalHeight]")
                result["figures"][key] = {"decoded": decoded, "size": size, "blank": _blank(img.screenshot())}
            result["links"] = page.eval_on_selector_all("a[href]", "els => els.map(e => e.getAttribute('href'))")
        finally:
            ctx.close()
    return result


def _check(result: dict, page_path: Path, expected: tuple[str, ...]) -> None:
    page_url = page_path.as_uri()
    foreign = [u for u in result["requests"] if u != page_url and not u.startswith("data:")]
    assert foreign == [], f"the page made network/file requests: {foreign[:5]}"
    assert result["errors"] == [], result["errors"]
    missing = set(expected) - set(result["figures"])
    assert not missing, f"figures missing from the rendered page: {sorted(missing)}"
    for key, fig in result["figures"].items():
        assert fig["decoded"], f"figure {key} did not decode"
        assert fig["size"][0] >= 300 and fig["size"][1] >= 150, (key, fig["size"])
        assert not fig["blank"], f"figure {key} renders blank"


def copy_job(video, *, out_dir, config, models, force, discover):
    """Batch job stand-in: the 'video' is a JSON pointer to a finished run folder, copied as the run's output.

    Module level so that the batch's spawned workers import it by name.
    """
    src = Path(json.loads(Path(video).read_text())["run"])
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    for path in src.iterdir():
        if path.is_file():
            shutil.copy2(path, out / path.name)


@pytest.fixture(scope="module")
def pipeline_run(rendered_run, tmp_path_factory):
    """A rendered video (24 cm tile, alley) through the real pipeline (few fit starts) and the report."""
    from pendtrack.stages.run import run_pipeline

    video = rendered_run(seconds=5.0, seed=1, width=640, height=360, theta0=2.5, tile_length_m=0.24,
                         alley=True) / "video.mp4"
    out = tmp_path_factory.mktemp("pipeline") / "24la1"
    run_pipeline(video, out_dir=out, config=Config().replace("fit", n_starts=6, workers=1), progress=False)
    report_stage(out, config=Config(), progress=False)  # up to date if the pipeline already wrote it
    return out


@pytest.fixture(scope="module")
def pipeline_batch(pipeline_run, tmp_path_factory):
    """The real batch stage over three run codes whose runs are copies of ``pipeline_run``."""
    from pendtrack.stages.batch import batch_stage

    videos = tmp_path_factory.mktemp("videos")
    for code in ("00nn1", "12na1", "24la1"):
        (videos / f"{code}.mp4").write_text(json.dumps({"run": str(pipeline_run)}))
    out = videos.parent / (videos.name + "-out")
    batch_stage(videos, out_dir=out, config=Config(), scheduler="processes", workers=1, job=copy_job,
                progress=False)
    report_stage(out, config=Config(), progress=False)
    return out


@pytest.mark.timeout(600)
def test_run_and_batch_reports_render_in_chromium(request, tmp_path):
    chromium = find_chromium()  # first: skip (or fail) before paying for the pipeline
    pipeline_run = request.getfixturevalue("pipeline_run")
    pipeline_batch = request.getfixturevalue("pipeline_batch")
    run_page = pipeline_run / "report.html"
    batch_page = pipeline_batch / "report.html"
    for page in (run_page, batch_page):
        assert "data-figure-error" not in page.read_text(encoding="utf-8")

    res = open_in_chromium(chromium, run_page, tmp_path / "profile-run")
    assert res["title"] == "Run 24la1"
    _check(res, run_page, RUN_FIGURES)

    # the batch draws a model's parameters only from converged fits (a few starts may not converge)
    converged = [m for m in ("classic", "opa", "fractional")
                 if json.loads((pipeline_run / f"fit_{m}.json").read_text())["converged"]]
    assert converged, "no model fit converged on the rendered run"
    res = open_in_chromium(chromium, batch_page, tmp_path / "profile-batch")
    assert res["title"] == f"Batch {pipeline_batch.name}"
    _check(res, batch_page, ("fittexOmegaZer", *(f"params-{m}" for m in converged)))
    files = sorted(h for h in res["links"] if not h.startswith("#"))
    assert files == ["00nn1/report.html", "12na1/report.html", "24la1/report.html"]
    assert all((pipeline_batch / h).is_file() for h in files)
