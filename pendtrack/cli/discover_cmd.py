"""`pendtrack discover INPUT [INPUT2 ...] --out DIR [--baseline standard] [--effects LIST] [--shared ...]`."""

from __future__ import annotations

import click

from pendtrack.cli.common import CommonArgs, common_options
from pendtrack.cli.fit_cmd import sharing_option, sharing_options
from pendtrack.cli.kinematics_cmd import table_options, table_spec


def _effects(value: str | None) -> tuple[str, ...] | None:
    if value is None:
        return None
    return tuple(x for x in value.replace(",", " ").split() if x)


@click.command("discover")
@click.argument("sources", metavar="INPUT...", nargs=-1, required=True, type=click.Path(dir_okay=False))
@table_options
@click.option("--baseline", default=None, help="Model to start from (default: [discover] baseline, 'standard').")
@click.option("--effects", default=None, metavar="LIST",
              help="Comma-separated effects to try (added_mass, time_varying_damping, memory, power_drag, ...); "
                   "default: every catalogue effect the baseline lacks.")
@sharing_options
@common_options(default_out="results")
def discover(sources: tuple[str, ...], baseline: str | None, effects: str | None, columns: tuple[str, ...] | None,
             pivot: tuple[float, float] | None, track: str | None, rate_hz: float | None, shared: tuple[str, ...],
             per_run: tuple[str, ...],
             per_group: tuple[str, ...], common: CommonArgs) -> None:
    """Show what the baseline model gets wrong, name the cause, extend the model, measure the gain.

    INPUT is an angle or kinematics Parquet file, a Parquet file or CSV/whitespace table of
    t [s], theta [rad] (or t, x, y with a pivot) read as `kinematics` and `fit` read it, or a
    video (the video stages run first into --out).
    Writes discovery.json and discovery.md.

    Several records (runs of one pendulum, e.g. released from different angles): fitted jointly,
    each effect judged on later times and on whole runs held out, and reported as shared or per
    run. Scopes as in `pendtrack fit` with several records (--shared, --per-run, --per-group).
    """
    from pendtrack.stages.discover import discover_runs_stage, discover_stage

    sharing = sharing_option(shared=shared, per_run=per_run, per_group=per_group)
    if len(sources) > 1:
        out = discover_runs_stage(list(sources), out_dir=common.out, config=common.config, baseline=baseline,
                                  effects=_effects(effects), table=table_spec(columns, pivot, track, rate_hz),
                                  sharing=sharing, force=common.force, progress=common.progress)
        facts = out.facts
        state = "up to date" if out.skipped else "done"
        named = ", ".join(f"{e} ({facts.get('scopes', {}).get(e, '?')})" for e in facts.get("effects") or []) or "none"
        partial = ", ".join(facts.get("partial") or [])
        click.echo(f"discover   {state:<10} {len(sources)} runs, baseline {facts.get('baseline')}; causes named: "
                   f"{named}" + (f"; improving the fit (not causes): {partial}" if partial else ""))
        for p in out.paths:
            click.echo(f"  {p}")
        return
    if sharing:
        raise click.UsageError("--shared, --per-run and --per-group need several records")
    source = sources[0]
    out = discover_stage(source, out_dir=common.out, config=common.config, baseline=baseline,
                         effects=_effects(effects), table=table_spec(columns, pivot, track, rate_hz), force=common.force,
                         progress=common.progress)
    facts = out.facts
    state = "up to date" if out.skipped else "done"
    added = ", ".join(facts.get("effects") or []) or "none"
    partial = ", ".join(facts.get("partial") or [])
    click.echo(f"discover   {state:<10} baseline {facts.get('baseline')}; causes named: {added}"
               + (f"; improving the fit (not causes): {partial}" if partial else ""))
    for p in out.paths:
        click.echo(f"  {p}")
