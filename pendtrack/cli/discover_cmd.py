"""`pendtrack discover INPUT --out DIR [--baseline standard] [--effects LIST]`."""

from __future__ import annotations

import click

from pendtrack.cli.common import CommonArgs, common_options


def _effects(value: str | None) -> tuple[str, ...] | None:
    if value is None:
        return None
    return tuple(x for x in value.replace(",", " ").split() if x)


@click.command("discover")
@click.argument("source", metavar="INPUT", type=click.Path(dir_okay=False))
@click.option("--baseline", default=None, help="Model to start from (default: [discover] baseline, 'standard').")
@click.option("--effects", default=None, metavar="LIST",
              help="Comma-separated effects to try (added_mass, time_varying_damping, memory, power_drag, ...); "
                   "default: every catalogue effect the baseline lacks.")
@common_options(default_out="results")
def discover(source: str, baseline: str | None, effects: str | None, common: CommonArgs) -> None:
    """Show what the baseline model gets wrong, name the cause, extend the model, measure the gain.

    INPUT is an angle or kinematics Parquet file, a CSV/whitespace table whose first two
    columns are t [s] and theta [rad], or a video (the video stages run first into --out).
    Writes discovery.json and discovery.md.
    """
    from pendtrack.stages.discover import discover_stage

    out = discover_stage(source, out_dir=common.out, config=common.config, baseline=baseline,
                         effects=_effects(effects), force=common.force, progress=common.progress)
    facts = out.facts
    state = "up to date" if out.skipped else "done"
    added = ", ".join(facts.get("effects") or []) or "none"
    click.echo(f"discover   {state:<10} baseline {facts.get('baseline')}; effects added: {added}")
    for p in out.paths:
        click.echo(f"  {p}")
