"""`pendtrack kinematics ANGLE --out DIR`, and the table flags it shares with `fit` and `discover`."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

import click

from pendtrack.cli.common import CommonArgs, apply_flags, common_options

F = TypeVar("F", bound=Callable[..., Any])

def _columns(ctx: click.Context, param: click.Parameter, value: str | None) -> tuple[str, ...] | None:
    from pendtrack.errors import PendtrackError
    from pendtrack.tables import parse_columns

    if value is None:
        return None
    try:
        return parse_columns(value, check_roles=False)  # the roles with --rate known: TableSpec
    except PendtrackError as exc:
        raise click.BadParameter(str(exc)) from None


def table_options(fn: F) -> F:
    """``--columns``, ``--pivot``, ``--track`` and ``--rate`` (:class:`pendtrack.tables.TableSpec`):
    keywords ``columns, pivot, track, rate_hz``."""
    fn = click.option("--rate", "rate_hz", type=float, default=None, metavar="HZ",
                      help="Sampling rate of a table without a time column (a logger's angles at a fixed rate): "
                           "row k at t = k / HZ.")(fn)
    fn = click.option("--track", default=None, metavar="NAME",
                      help="The point-mass track of a Tracker project (.trk) with several.")(fn)
    fn = click.option("--pivot", type=float, nargs=2, default=None, metavar="X Y",
                      help="Pivot of a t, x, y table, in its units (x right, y up; a column y_down points down). "
                           "Default: the centre of a robust circle fit to the path.")(fn)
    return click.option("--columns", callback=_columns, default=None, metavar="NAMES",
                        help="What a table's columns are, comma-separated, _ to ignore one: t,theta,_ or t,x,y, "
                             "with units: t[ms],theta[deg] (s, ms, us, min; rad, deg, mrad; m, cm, mm, px). "
                             "Needed for a table of more than two columns without a header; overrides a "
                             "header.")(fn)


def table_spec(columns: tuple[str, ...] | None, pivot: tuple[float, float] | None, track: str | None = None,
               rate_hz: float | None = None) -> Any:
    """The :class:`pendtrack.tables.TableSpec` of the table flags (None if none is given)."""
    from pendtrack.tables import TableSpec

    if columns is None and not pivot and track is None and rate_hz is None:
        return None
    return TableSpec(columns=columns, pivot=tuple(pivot) if pivot else None, track=track, rate_hz=rate_hz)


@click.command("kinematics")
@click.argument("angle_file", metavar="ANGLE", type=click.Path(dir_okay=False))
@table_options
@click.option("--window-s", "savgol_window_s", type=float, default=None,
              help="Savitzky-Golay window [s] (config [kinematics] savgol_window_s; paper: 25 frames at 120 fps).")
@click.option("--order", "savgol_order", type=int, default=None, help="Savitzky-Golay polynomial order (3).")
@click.option("--max-gap-s", type=float, default=None, help="Bridge gaps of not-ok samples up to this long [s] (0.05).")
@click.option("--min-segment-s", type=float, default=None, help="Drop segments shorter than this [s] (1.0).")
@common_options()
def kinematics(angle_file: str, savgol_window_s: float | None, savgol_order: int | None, max_gap_s: float | None,
               min_segment_s: float | None, columns: tuple[str, ...] | None, pivot: tuple[float, float] | None,
               track: str | None, rate_hz: float | None, common: CommonArgs) -> None:
    """Savitzky-Golay omega, alpha and the initial analysis of ANGLE -> OUT/kinematics.parquet.

    ANGLE is angle.parquet, a Parquet file, a text table of t, theta (or t, x, y with a pivot:
    CSV, tab or space separated; Tracker, Vernier and phyphox exports), a Tracker project
    (.trk), a Logger Pro or Graphical Analysis file (.cmbl, .gambl) or a MATLAB file (.mat), read
    by its column names and units; uneven time stamps are resampled onto a uniform grid (recorded in the provenance
    with the error bound).
    """
    from pendtrack.stages.kinematics import kinematics_stage

    values: dict[str, Any] = {"savgol_window_s": savgol_window_s, "savgol_order": savgol_order,
                              "max_gap_s": max_gap_s, "min_segment_s": min_segment_s}
    config = apply_flags(common.config, "kinematics", **values)
    res = kinematics_stage(angle_file, out_dir=common.out, config=config, table=table_spec(columns, pivot, track, rate_hz),
                           force=common.force, progress=common.progress)
    if res.skipped:
        click.echo(f"{res.path} is up to date")
        return
    f = res.facts
    w0 = (f"Omega0 = {f['Omega0']:.5f} +- {f['Omega0_stderr']:.5f} rad/s from {f['n_turning_points']} turning points"
          if f.get("Omega0") is not None else f"no Omega0 ({f.get('Omega0_reason')})")
    neg = f.get("negative_damping_fraction")
    neg_text = f", negative damping {100 * neg:.1f} % of samples" if neg is not None else ""
    centre = f.get("theta_centre") or 0.0
    centre_text = f", swinging about {centre:.4g} rad (amplitudes and energy taken about it)" if centre else ""
    click.echo(f"{res.path}: {f['n_segments']} segment(s), window {f['window_points']} points "
               f"({f['window_s']:.4f} s), {w0}{centre_text}{neg_text}")
