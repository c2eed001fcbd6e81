"""`pendtrack run VIDEO --out DIR`."""

from __future__ import annotations

import click

from pendtrack.cli.common import CommonArgs, common_options


@click.command("run")
@click.argument("video", type=click.Path(dir_okay=False))
@click.option("--model", "models", multiple=True,
              help="Model to fit (repeatable); default: the config's [fit] models (classic, opa, fractional).")
@common_options(default_out="results")
def run(video: str, models: tuple[str, ...], common: CommonArgs) -> None:
    """Run the whole pipeline on VIDEO: track, angle, kinematics, fit."""
    from pendtrack.stages.run import run_pipeline

    result = run_pipeline(video, out_dir=common.out, config=common.config, models=models or None,
                          force=common.force, progress=common.progress)
    for name, stage in result.stages.items():
        state = "up to date" if stage.skipped else "done"
        click.echo(f"{name:<11} {state:<10} {', '.join(str(p) for p in stage.paths)}")
    click.echo(f"results in {result.out_dir}/")
