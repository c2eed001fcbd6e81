"""`pendtrack batch FOLDER --out DIR`."""

from __future__ import annotations

import sys

import click

from pendtrack.cli.common import CommonArgs, common_options
from pendtrack.cli.fit_cmd import echo_series_summary, exit_on_fit_problems, sharing_option, sharing_options


def _split_models(values: tuple[str, ...]) -> tuple[str, ...]:
    return tuple(m.strip() for v in values for m in v.split(",") if m.strip())


@click.command("batch")
@click.argument("folder", type=click.Path(file_okay=False))
@click.option("--models", "--model", "models", multiple=True,
              help="Models to fit: comma-separated or repeated; default: the config's [fit] models.")
@click.option("--scheduler", default=None,
              help="'processes' (local worker processes, the default) or a Dask scheduler address tcp://HOST:PORT.")
@click.option("--workers", type=click.IntRange(min=0), default=None,
              help="Local worker processes (0 = all cores); default: the config's [batch] workers.")
@click.option("--discover", is_flag=True, help="Also run model discovery on every run.")
@click.option("--joint", is_flag=True,
              help="Then fit each model jointly to every run that succeeded -> OUT/joint/fit_<model>.json "
                   "(scopes from the run codes; --shared, --per-run, --per-group override them).")
@sharing_options
@common_options(default_out="results")
def batch(folder: str, models: tuple[str, ...], scheduler: str | None, workers: int | None, discover: bool,
          joint: bool, shared: tuple[str, ...], per_run: tuple[str, ...], per_group: tuple[str, ...],
          common: CommonArgs) -> None:
    """Run the whole pipeline on every run-coded video of FOLDER into OUT/<run code>/.

    Video names start with a run code (paper's Table kindofrun): tile length in cm (two
    digits, 00 = none), l|n (launched), a|n (alley), trial; e.g. 06na5.mp4 or
    06na5_take2.mp4. Other names are listed as skipped. Complete runs (same video and
    config, artifacts intact) are not recomputed, so an interrupted batch resumes where it
    stopped. Writes OUT/summary.parquet, OUT/summary.csv and OUT/batch.json (counts,
    failures, two-cuboid fit of Omega0(l1)). Exit code 1 if any run failed.
    """
    from pendtrack.stages.batch import batch_stage

    sharing = sharing_option(shared=shared, per_run=per_run, per_group=per_group)
    if sharing and not joint:
        raise click.UsageError("--shared, --per-run and --per-group need --joint")
    result = batch_stage(folder, out_dir=common.out, config=common.config, models=_split_models(models) or None,
                         scheduler=scheduler, workers=workers, discover=discover, force=common.force,
                         progress=common.progress)
    for run in result.runs:
        state = "up to date" if run.resumed else run.status
        click.echo(f"{run.run_id:<14} {state:<10} {run.reason}".rstrip())
    for skip in result.skipped:
        click.echo(f"{skip.video.name:<14} skipped    {skip.reason}")
    c = result.counts
    click.echo(f"{c['runs']} run(s): {c['ok']} ok ({c['resumed']} up to date), {c['failed']} failed; "
               f"{c['skipped']} file(s) skipped")
    tc = result.two_cuboid
    if tc.get("status") == "ok":
        click.echo(f"two-cuboid fit of Omega0(l1) ({tc.get('model')}, {tc.get('n')} runs): {_two_cuboid_text(tc)}")
    else:
        click.echo(f"two-cuboid fit: {tc.get('status')}{': ' + tc['reason'] if tc.get('reason') else ''}")
    click.echo(f"summary in {result.summary} and {result.summary_csv}; {result.batch_json}")
    if joint:
        from pendtrack.stages.series import batch_joint_fit

        res = batch_joint_fit(result.out_dir, [r.run_id for r in result.runs if r.status == "ok"],
                              config=common.config, models=_split_models(models) or None, sharing=sharing,
                              force=common.force)
        echo_series_summary(res.facts)
        click.echo(f"joint fit in {res.path}")
    if result.failed:
        sys.exit(1)
    if joint:
        exit_on_fit_problems(res.facts)


def _two_cuboid_text(tc: dict) -> str:
    parts = []
    for key in ("x", "X", "l0", "l0_m"):
        value = tc.get(key)
        if isinstance(value, dict) and "value" in value:
            parts.append(f"{key} = {value['value']:.4g} +- {value.get('stderr') or float('nan'):.2g}")
        elif isinstance(value, (int, float)):
            err = tc.get(f"{key}_stderr", tc.get(f"u_{key}"))
            parts.append(f"{key} = {value:.4g}" + (f" +- {err:.2g}" if isinstance(err, (int, float)) else ""))
    return ", ".join(parts) or "see batch.json"
