"""`pendtrack track`, `pendtrack angle` and `pendtrack undistort`."""

from __future__ import annotations

import click

from pendtrack.cli.common import (CommonArgs, apply_flags, axle_option, common_options, lens_options, marker_options,
                                  video_options, with_lens_and_video)


@click.command("track")
@click.argument("video", type=click.Path(dir_okay=False))
@marker_options
@click.option("--evolution-rate", type=float, default=None, help="Template evolution per frame (0).")
@click.option("--search-margin", "search_margin_px", type=int, default=None,
              help="Margin of the wide search window around the prediction [px] (48).")
@click.option("--corrected/--raw", "track_in_corrected", default=None,
              help="Track in lens-corrected frames instead of raw frames (default raw, coordinates corrected after).")
@lens_options
@video_options
@common_options()
def track(video: str, roi: tuple[int, ...] | None, marker_color: str | None, min_score: float | None,
          evolution_rate: float | None, search_margin_px: int | None, track_in_corrected: bool | None,
          fov_deg: float | None, fixed_pixels: float | None, projection: str | None, fps: float | None,
          start: float | None, end: float | None, common: CommonArgs) -> None:
    """Track the marker in VIDEO -> OUT/track.parquet."""
    from pendtrack.stages.track import track_stage

    config = with_lens_and_video(common.config, fov_deg=fov_deg, fixed_pixels=fixed_pixels, projection=projection,
                                 fps=fps, start=start, end=end)
    config = apply_flags(config, "track", roi=roi, marker_color=marker_color, min_score=min_score,
                         evolution_rate=evolution_rate, search_margin_px=search_margin_px,
                         track_in_corrected=track_in_corrected)
    res = track_stage(video, out_dir=common.out, config=config, force=common.force, progress=common.progress)
    if res.skipped:
        click.echo(f"{res.path} is up to date")
    else:
        f = res.facts
        found = f", marker found at {f['acquired_t']:.3f} s" if f.get("acquired_t") else ""
        drift = ", template drift alarm (see the provenance)" if f.get("drift_alarm") else ""
        click.echo(f"{res.path}: {f['frames']} frames, {100 * f['ok_fraction']:.2f} % ok, {f['fps']:.0f} frames/s"
                   f"{found}{drift}")


@click.command("angle")
@click.argument("track_file", metavar="TRACK", type=click.Path(dir_okay=False))
@axle_option
@click.option("--rest-seconds", type=float, default=None,
              help="Final still stretch whose median angle is theta's zero [s] (2).")
@common_options()
def angle(track_file: str, axle: tuple[float, ...] | None, rest_seconds: float | None, common: CommonArgs) -> None:
    """Axle and theta(t) from TRACK (track.parquet) -> OUT/angle.parquet."""
    from pendtrack.stages.angle import angle_stage

    config = apply_flags(common.config, "angle", axle=axle, rest_seconds=rest_seconds)
    res = angle_stage(track_file, out_dir=common.out, config=config, force=common.force, progress=common.progress)
    if res.skipped:
        click.echo(f"{res.path} is up to date")
    else:
        f = res.facts
        rms = f["circle_rms_px"]
        fit = f", circle fit rms {rms:.3f} px" if rms is not None else ""
        click.echo(f"{res.path}: axle ({f['axle'][0]:.2f}, {f['axle'][1]:.2f}) px{fit}, zero = {f['zero_reference']}")


@click.command("undistort")
@click.argument("video", type=click.Path(dir_okay=False))
@lens_options
@video_options
@common_options()
def undistort(video: str, fov_deg: float | None, fixed_pixels: float | None, projection: str | None,
              fps: float | None, start: float | None, end: float | None, common: CommonArgs) -> None:
    """Write the lens-corrected VIDEO -> OUT/undistorted.mp4."""
    from pendtrack.stages.undistort import undistort_stage

    config = with_lens_and_video(common.config, fov_deg=fov_deg, fixed_pixels=fixed_pixels, projection=projection,
                                 fps=fps, start=start, end=end)
    res = undistort_stage(video, out_dir=common.out, config=config, force=common.force, progress=common.progress)
    if res.skipped:
        click.echo(f"{res.path} is up to date")
    else:
        click.echo(f"{res.path}: {res.facts['frames']} frames, output field of view "
                   f"{res.facts['output_fov_deg']:.1f} deg")
