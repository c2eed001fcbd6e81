"""`pendtrack kinematics ANGLE --out DIR`."""

from __future__ import annotations

from typing import Any

import click

from pendtrack.cli.common import CommonArgs, common_options


@click.command("kinematics")
@click.argument("angle_file", metavar="ANGLE", type=click.Path(dir_okay=False))
@click.option("--window-s", "savgol_window_s", type=float, default=None,
              help="Savitzky-Golay window [s] (config [kinematics] savgol_window_s; paper: 25 frames at 120 fps).")
@click.option("--order", "savgol_order", type=int, default=None, help="Savitzky-Golay polynomial order (3).")
@click.option("--max-gap-s", type=float, default=None, help="Bridge gaps of not-ok samples up to this long [s] (0.05).")
@click.option("--min-segment-s", type=float, default=None, help="Drop segments shorter than this [s] (1.0).")
@common_options()
def kinematics(angle_file: str, savgol_window_s: float | None, savgol_order: int | None, max_gap_s: float | None,
               min_segment_s: float | None, common: CommonArgs) -> None:
    """Savitzky-Golay omega, alpha and the initial analysis of ANGLE (angle.parquet) -> OUT/kinematics.parquet."""
    from pendtrack.stages.kinematics import kinematics_stage

    values: dict[str, Any] = {"savgol_window_s": savgol_window_s, "savgol_order": savgol_order,
                              "max_gap_s": max_gap_s, "min_segment_s": min_segment_s}
    given = {k: v for k, v in values.items() if v is not None}
    config = common.config.replace("kinematics", **given) if given else common.config
    res = kinematics_stage(angle_file, out_dir=common.out, config=config, force=common.force,
                           progress=common.progress)
    if res.skipped:
        click.echo(f"{res.path} is up to date")
        return
    f = res.facts
    w0 = (f"Omega0 = {f['Omega0']:.5f} +- {f['Omega0_stderr']:.5f} rad/s from {f['n_turning_points']} turning points"
          if f.get("Omega0") is not None else f"no Omega0 ({f.get('Omega0_reason')})")
    neg = f.get("negative_damping_fraction")
    neg_text = f", negative damping {100 * neg:.1f} % of samples" if neg is not None else ""
    click.echo(f"{res.path}: {f['n_segments']} segment(s), window {f['window_points']} points "
               f"({f['window_s']:.4f} s), {w0}{neg_text}")
