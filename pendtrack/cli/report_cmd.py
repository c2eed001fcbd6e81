"""`pendtrack report DIR`: the paper's figures for a run or a batch folder, as DIR/report.html."""

from __future__ import annotations

import click

from pendtrack.cli.common import CommonArgs, common_options

_BESIDE_INPUT = "<DIR>"  # --out default: write report.html into DIR itself


@click.command("report")
@click.argument("folder", metavar="DIR", type=click.Path())
@common_options(default_out=_BESIDE_INPUT)
def report(folder: str, common: CommonArgs) -> None:
    """Write DIR/report.html: one self-contained page (figures embedded, works offline).

    DIR is a run folder (from `pendtrack run`) or a batch folder (from `pendtrack batch`);
    for a batch, every run folder gets its own report too, linked from the batch page.
    """
    from pendtrack.stages.report import report_stage

    out = None if str(common.out) == _BESIDE_INPUT else common.out
    result = report_stage(folder, out_dir=out, config=common.config, force=common.force, progress=common.progress)
    state = "up to date" if result.skipped else "written"
    extra = ""
    if result.facts.get("kind") == "batch":
        extra = f" ({len(result.paths) - 1} run reports, {result.facts.get('run_reports', 0)} written)"
    click.echo(f"report {state}: {result.path}{extra}")
