"""`pendtrack run VIDEO --out DIR`."""

from __future__ import annotations

import click

from pendtrack.cli.common import (CommonArgs, apply_flags, axle_option, common_options, lens_options, marker_options,
                                  video_options, with_lens_and_video)
from pendtrack.cli.kinematics_cmd import table_options, table_spec


@click.command("run")
@click.argument("video", type=click.Path(dir_okay=False))
@click.option("--model", "models", multiple=True,
              help="Model to fit (repeatable); default: the config's [fit] models (classic, opa, fractional).")
@marker_options
@lens_options
@video_options
@axle_option
@table_options
@click.option("--window-s", "savgol_window_s", type=float, default=None,
              help="Savitzky-Golay window [s] (config [kinematics] savgol_window_s; paper: 25 frames at 120 fps).")
@common_options(default_out="results")
def run(video: str, models: tuple[str, ...], roi: tuple[int, ...] | None, marker_color: str | None,
        min_score: float | None, fov_deg: float | None, fixed_pixels: float | None, projection: str | None,
        fps: float | None, start: float | None, end: float | None, axle: tuple[float, ...] | None,
        savgol_window_s: float | None, columns: tuple[str, ...] | None, pivot: tuple[float, float] | None,
        track: str | None, rate_hz: float | None, common: CommonArgs) -> None:
    """Run the whole pipeline on VIDEO: track, angle, kinematics, fit, report.

    VIDEO may also be a measured record of theta(t) or x, y(t) (a table, a Tracker project, a logger's file, as
    `kinematics` reads them): then kinematics, fit and report. The flags are those of `track`, `angle` and
    `kinematics` (and the config keys of the same names).

    Exit code (as `fit`): 0 every fit converged and no parameter is flagged; 1 every file is
    written but a fit did not converge or has a flagged parameter; 2 a user error.
    """
    from pendtrack.cli.fit_cmd import echo_fit_summary, exit_on_fit_problems
    from pendtrack.stages.run import run_pipeline

    config = with_lens_and_video(common.config, fov_deg=fov_deg, fixed_pixels=fixed_pixels, projection=projection,
                                 fps=fps, start=start, end=end)
    config = apply_flags(config, "track", roi=roi, marker_color=marker_color, min_score=min_score)
    config = apply_flags(config, "angle", axle=axle)
    config = apply_flags(config, "kinematics", savgol_window_s=savgol_window_s)
    result = run_pipeline(video, out_dir=common.out, config=config, models=models or None,
                          table=table_spec(columns, pivot, track, rate_hz), force=common.force,
                          progress=common.progress)
    for name, stage in result.stages.items():
        state = "up to date" if stage.skipped else "done"
        click.echo(f"{name:<11} {state:<10} {', '.join(str(p) for p in stage.paths)}")
    if "fit" in result.stages:
        echo_fit_summary(result.stages["fit"].facts)
    click.echo(f"results in {result.out_dir}/")
    if "fit" in result.stages:  # a pipeline without the fit stage has no fit to judge
        exit_on_fit_problems(result.stages["fit"].facts)
