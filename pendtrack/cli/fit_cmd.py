"""`pendtrack fit KINEMATICS [KINEMATICS2 ...] --model NAME [--model NAME2 ...] [--shared ...] --out DIR`."""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any

import click

from pendtrack.cli.common import F, CommonArgs, _stack, apply_flags, common_options
from pendtrack.cli.kinematics_cmd import table_options, table_spec


def _fmt(x: Any, spec: str) -> str:
    return "n/a" if x is None else format(x, spec)


def _names(values: tuple[str, ...]) -> tuple[str, ...]:
    return tuple(n.strip() for v in values for n in v.split(",") if n.strip())


def sharing_options(fn: F) -> F:
    """``--shared``, ``--per-run``, ``--per-group`` (a joint fit's scopes): keywords ``shared, per_run, per_group``."""
    return _stack(fn, [
        click.option("--shared", multiple=True, metavar="NAMES",
                     help="Several records: parameters shared by every run (comma-separated, e.g. C0,Omega0)."),
        click.option("--per-run", "per_run", multiple=True, metavar="NAMES",
                     help="Several records: parameters fitted per run (comma-separated)."),
        click.option("--per-group", "per_group", multiple=True, metavar="NAME=FIELDS",
                     help="Several records: a parameter fitted per group of runs with equal run-code fields "
                          "(tile, launched, alley joined by +), e.g. Ca=tile+alley. Repeat for several."),
    ])


@click.command("fit")
@click.argument("kinematics_files", metavar="KINEMATICS...", nargs=-1, required=True,
                type=click.Path(dir_okay=False))
@table_options
@click.option("--model", "models", multiple=True,
              help="Model to fit (repeat for several): standard, classic, opa, fractional, inertial, or a "
                   "composed baseline+term+... (e.g. standard+memory, classic+offset). "
                   "Default: [fit] models of the config (classic, opa, fractional).")
@click.option("--cost", type=click.Choice(["xi2", "theta"]), default=None,
              help="xi2: the paper's Xi^2 on A_theta, A_omega; theta: least squares on theta.")
@click.option("--starts", "n_starts", type=int, default=None, help="Number of random starts (paper: 150).")
@click.option("--seed", type=int, default=None, help="Seed of the start draws.")
@click.option("--workers", type=int, default=None, help="Processes for the starts; 0 = all cores.")
@sharing_options
@common_options()
def fit(kinematics_files: tuple[str, ...], models: tuple[str, ...], cost: str | None, n_starts: int | None,
        seed: int | None, workers: int | None, shared: tuple[str, ...], per_run: tuple[str, ...],
        per_group: tuple[str, ...], columns: tuple[str, ...] | None, pivot: tuple[float, float] | None,
        track: str | None, rate_hz: float | None, common: CommonArgs) -> None:
    """Fit physical models to KINEMATICS -> OUT/fit.json, fit_<model>.json, fit.parquet.

    Several records (runs of one pendulum) are fitted jointly: OUT/fit_<model>.json holds the
    shared values, each group's and each run's values and each run's residual. Defaults follow
    the run codes in the records' names or folders (06na5): Omega0 per tile, C0 shared, drag and
    added mass per tile and alley, the initial state and theta_off per run; without run codes
    the physical parameters are shared. --shared, --per-run and --per-group override them.

    KINEMATICS is kinematics.parquet, or anything `pendtrack kinematics` reads (angle.parquet,
    a Parquet file or a CSV/whitespace table of t, theta or t, x, y), differentiated first with
    the [kinematics] settings.

    When theta's zero was not measured (angle.parquet's zero_reference "vertical", or a plain
    table), every model is fitted with the offset term and theta_off is reported ([fit] offset).

    Exit code: 0 every fit converged and no parameter is flagged; 1 the files are written but a
    fit did not converge or has a flagged parameter (fit.json "flags"); 2 a user error.
    """
    from pendtrack.stages.fit import fit_stage

    values = {"cost": cost, "n_starts": n_starts, "seed": seed, "workers": workers}
    config = apply_flags(common.config, "fit", **values)
    sharing = sharing_option(shared=shared, per_run=per_run, per_group=per_group)
    if len(kinematics_files) > 1:
        fit_series(kinematics_files, config=config, models=models, sharing=sharing, common=common,
                   table=table_spec(columns, pivot, track, rate_hz))
        return
    if sharing:
        raise click.UsageError("--shared, --per-run and --per-group need several records")
    kinematics_file = kinematics_files[0]
    res = fit_stage(kinematics_file, out_dir=common.out, config=config, models=models or None,
                    table=table_spec(columns, pivot, track, rate_hz), force=common.force, progress=common.progress)
    finish(res, echo_fit_summary)


def finish(res: Any, summary: Callable[[dict[str, Any]], None]) -> None:
    """A fit stage's output on the terminal (up to date, the summary, the files written), then the exit rule."""
    if res.skipped:
        click.echo(f"{res.path} is up to date")
    summary(res.facts)
    if not res.skipped:
        click.echo(f"wrote {', '.join(str(p) for p in res.paths)}")
    exit_on_fit_problems(res.facts)


def sharing_option(*, shared: tuple[str, ...], per_run: tuple[str, ...], per_group: tuple[str, ...]) -> dict[str, str]:
    """The sharing declared by --shared, --per-run and --per-group (``NAME=FIELDS``)."""
    from pendtrack.fitting.joint import sharing_from_lists

    groups = {}
    for item in per_group:
        name, sep, fields = item.partition("=")
        if not sep or not name.strip() or not fields.strip():
            raise click.UsageError(f"--per-group expects NAME=FIELDS (e.g. Ca=tile+alley), got {item!r}")
        groups[name.strip()] = fields.strip()
    return sharing_from_lists(shared=_names(shared), per_run=_names(per_run), per_group=groups)


def fit_series(files: tuple[str, ...], *, config: Any, models: tuple[str, ...], sharing: dict[str, str],
               common: CommonArgs, table: Any) -> None:
    """Several records: the joint fit (:func:`pendtrack.stages.series.series_fit_stage`), its summary, its exit code."""
    from pendtrack.stages.series import series_fit_stage

    res = series_fit_stage(files, out_dir=common.out, config=config, models=models or None, sharing=sharing,
                           table=table, force=common.force)
    finish(res, echo_series_summary)


def echo_series_summary(facts: dict[str, Any]) -> None:
    """One line per jointly fitted model: verdict, runs, Xi2_min, rms, the shared values."""
    runs = facts.get("runs") or []
    for name, f in (facts.get("models") or {}).items():
        shared = ", ".join(f"{k} = {_fmt(v, '.5g')} +- {_fmt(e, '.2g')}" for k, (v, e) in (f.get("shared") or {}).items())
        click.echo(f"{name} (joint, {len(runs)} runs): {fit_state(f)}, Xi2_min = {_fmt(f.get('xi2_min'), '.4g')}, "
                   f"rms = {_fmt(f.get('rms'), '.3g')} rad, BIC = {_fmt(f.get('bic'), '.1f')}"
                   + (f"; shared: {shared}" if shared else ""))


def echo_fit_summary(facts: dict[str, Any]) -> None:
    """One line per fitted model (the fit stage's facts): verdict, Xi2_min, rms, Omega0, theta_off, BIC."""
    for name, f in (facts.get("models") or {}).items():
        click.echo(f"{name}: {fit_state(f)}, Xi2_min = {_fmt(f.get('xi2_min'), '.4g')}, "
                   f"rms = {_fmt(f.get('rms'), '.3g')} rad{misfit_text(f)}, "
                   f"Omega0 = {_fmt(f.get('Omega0'), '.5f')} +- {_fmt(f.get('Omega0_stderr'), '.5f')} rad/s"
                   f"{'' if f.get('stderr_reliable', True) else ' (errors unreliable: the solver is not smooth there)'}, "
                   f"{offset_text(f)}BIC = {_fmt(f.get('bic'), '.1f')}, {_fmt(f.get('runtime_s'), '.1f')} s")


def misfit_text(f: dict[str, Any]) -> str:
    """`` (12.3 x the noise: ...)`` for a fit whose residual is structure the model misses, else ``""``."""
    if not f.get("misses_structure"):
        return ""
    return (f" ({_fmt(f.get('rms_over_noise'), '.1f')} x the noise: the model misses structure in the data; "
            "pendtrack discover looks for its cause)")


def offset_text(f: dict[str, Any]) -> str:
    """``"theta_off = 1.23 +- 0.05 mrad (fitted as classic+offset), "`` for a fit with the offset term, else ``""``."""
    if f.get("theta_off") is None:
        return ""
    se = f.get("theta_off_stderr")
    return (f"theta_off = {1e3 * f['theta_off']:.3f} +- {'n/a' if se is None else format(1e3 * se, '.3f')} mrad "
            f"(fitted as {f.get('fitted_model')}), ")


def fit_state(f: dict[str, Any]) -> str:
    """One model's verdict in words: only a converged fit without flags is called converged."""
    if not f.get("converged"):
        state = "NOT CONVERGED"
    elif f.get("flags"):
        state = f"FLAGGED ({', '.join(f['flags'])})"
    else:
        state = "converged"
    if f.get("findings"):
        state += f" (no {', no '.join(sorted({_effect(v) for v in f['findings'].values()}))} in the data)"
    return state


def _effect(finding: str) -> str:
    """The effect a finding names: "the data show no memory: ..." -> "memory"."""
    return finding.removeprefix("the data show no ").split(":", 1)[0]


def exit_on_fit_problems(facts: dict[str, Any]) -> None:
    """The exit rule of `fit` and `run`: exit 1, after one warning per model, if a fit is not
    trustworthy (not converged or a parameter flagged); return otherwise (exit 0)."""
    from pendtrack.fitting.models_fit import fit_problems

    problems = fit_problems(facts)
    for name, why in problems.items():
        click.echo(f"warning: the {name} fit {why} (see fit_{name}.json)", err=True)
    if problems:
        sys.exit(1)
