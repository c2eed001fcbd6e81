"""`pendtrack discover INPUT --out DIR [--baseline standard] [--effects LIST]`."""

from __future__ import annotations

import click

from pendtrack.cli.common import CommonArgs, common_options
from pendtrack.cli.kinematics_cmd import table_options, table_spec


def _effects(value: str | None) -> tuple[str, ...] | None:
    if value is None:
        return None
    return tuple(x for x in value.replace(",", " ").split() if x)


@click.command("discover")
@click.argument("source", metavar="INPUT", type=click.Path(dir_okay=False))
@table_options
@click.option("--baseline", default=None, help="Model to start from (default: [discover] baseline, 'standard').")
@click.option("--effects", default=None, metavar="LIST",
              help="Comma-separated effects to try (added_mass, time_varying_damping, memory, power_drag, ...); "
                   "default: every catalogue effect the baseline lacks.")
@common_options(default_out="results")
def discover(source: str, baseline: str | None, effects: str | None, columns: tuple[str, ...] | None,
             pivot: tuple[float, float] | None, track: str | None, common: CommonArgs) -> None:
    """Show what the baseline model gets wrong, name the cause, extend the model, measure the gain.

    INPUT is an angle or kinematics Parquet file, a Parquet file or CSV/whitespace table of
    t [s], theta [rad] (or t, x, y with a pivot) read as `kinematics` and `fit` read it, or a
    video (the video stages run first into --out).
    Writes discovery.json and discovery.md.
    """
    from pendtrack.stages.discover import discover_stage

    out = discover_stage(source, out_dir=common.out, config=common.config, baseline=baseline,
                         effects=_effects(effects), table=table_spec(columns, pivot, track), force=common.force,
                         progress=common.progress)
    facts = out.facts
    state = "up to date" if out.skipped else "done"
    added = ", ".join(facts.get("effects") or []) or "none"
    partial = ", ".join(facts.get("partial") or [])
    click.echo(f"discover   {state:<10} baseline {facts.get('baseline')}; causes named: {added}"
               + (f"; improving the fit (not causes): {partial}" if partial else ""))
    for p in out.paths:
        click.echo(f"  {p}")
