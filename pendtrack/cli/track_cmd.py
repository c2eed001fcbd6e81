"""`pendtrack track`, `pendtrack angle` and `pendtrack undistort`."""

from __future__ import annotations

from typing import Any

import click

from pendtrack.cli.common import CommonArgs, common_options
from pendtrack.config import Config


def _numbers(n: int, kind: type) -> Any:
    def parse(ctx: click.Context, param: click.Parameter, value: str | None) -> tuple | None:
        if value is None:
            return None
        parts = [p for p in value.replace(" ", "").split(",") if p]
        try:
            nums = tuple(kind(p) for p in parts)
        except ValueError:
            nums = ()
        if len(nums) != n:
            raise click.BadParameter(f"expected {n} comma-separated {kind.__name__}s, got {value!r}")
        return nums

    return parse


def _lens_options(fn: Any) -> Any:
    for opt in reversed([
        click.option("--fov", "fov_deg", type=float, default=None,
                     help="Input diagonal field of view [deg] (config [lens] fov_deg; paper 120)."),
        click.option("--fixed-pixels", type=float, default=None,
                     help="Radius of the circle that does not move, fraction of the half diagonal (paper 0.48)."),
        click.option("--projection", type=click.Choice(["equisolid", "equidistant", "stereographic",
                                                        "orthographic", "none"]), default=None,
                     help="Input lens projection (none: no correction)."),
        click.option("--fps", type=float, default=None,
                     help="Frame rate override [1/s]; default: the container's timestamps."),
    ]):
        fn = opt(fn)
    return fn


def _apply(config: Config, section: str, **values: Any) -> Config:
    given = {k: v for k, v in values.items() if v is not None}
    return config.replace(section, **given) if given else config


def _with_lens(config: Config, fov_deg: float | None, fixed_pixels: float | None, projection: str | None,
               fps: float | None) -> Config:
    config = _apply(config, "lens", fov_deg=fov_deg, fixed_pixels=fixed_pixels, projection=projection)
    return _apply(config, "video", fps=fps)


@click.command("track")
@click.argument("video", type=click.Path(dir_okay=False))
@click.option("--roi", callback=_numbers(4, int), default=None, metavar="X,Y,W,H",
              help="The marker's rectangle in the first frame [px]; its colour is learned from it.")
@click.option("--marker-color", default=None, metavar="pink|dark|blue|#RRGGBB",
              help="Find the marker in the first frame by this colour (default pink).")
@click.option("--min-score", type=float, default=None, help="Acceptance threshold of the match score (0.6).")
@click.option("--evolution-rate", type=float, default=None, help="Template evolution per frame (0).")
@click.option("--search-margin", "search_margin_px", type=int, default=None,
              help="Margin of the wide search window around the prediction [px] (48).")
@click.option("--corrected/--raw", "track_in_corrected", default=None,
              help="Track in lens-corrected frames instead of raw frames (default raw, coordinates corrected after).")
@_lens_options
@common_options()
def track(video: str, roi: tuple[int, ...] | None, marker_color: str | None, min_score: float | None,
          evolution_rate: float | None, search_margin_px: int | None, track_in_corrected: bool | None,
          fov_deg: float | None, fixed_pixels: float | None, projection: str | None, fps: float | None,
          common: CommonArgs) -> None:
    """Track the marker in VIDEO -> OUT/track.parquet."""
    from pendtrack.stages.track import track_stage

    config = _with_lens(common.config, fov_deg, fixed_pixels, projection, fps)
    config = _apply(config, "track", roi=roi, marker_color=marker_color, min_score=min_score,
                    evolution_rate=evolution_rate, search_margin_px=search_margin_px,
                    track_in_corrected=track_in_corrected)
    res = track_stage(video, out_dir=common.out, config=config, force=common.force, progress=common.progress)
    if res.skipped:
        click.echo(f"{res.path} is up to date")
    else:
        f = res.facts
        click.echo(f"{res.path}: {f['frames']} frames, {100 * f['ok_fraction']:.2f} % ok, {f['fps']:.0f} frames/s")


@click.command("angle")
@click.argument("track_file", metavar="TRACK", type=click.Path(dir_okay=False))
@click.option("--axle", callback=_numbers(2, float), default=None, metavar="X,Y",
              help="Axle in corrected px; default: robust circle fit to the track.")
@click.option("--rest-seconds", type=float, default=None,
              help="Final still stretch whose median angle is theta's zero [s] (2).")
@common_options()
def angle(track_file: str, axle: tuple[float, ...] | None, rest_seconds: float | None, common: CommonArgs) -> None:
    """Axle and theta(t) from TRACK (track.parquet) -> OUT/angle.parquet."""
    from pendtrack.stages.angle import angle_stage

    config = _apply(common.config, "angle", axle=axle, rest_seconds=rest_seconds)
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
@_lens_options
@common_options()
def undistort(video: str, fov_deg: float | None, fixed_pixels: float | None, projection: str | None,
              fps: float | None, common: CommonArgs) -> None:
    """Write the lens-corrected VIDEO -> OUT/undistorted.mp4."""
    from pendtrack.stages.undistort import undistort_stage

    config = _with_lens(common.config, fov_deg, fixed_pixels, projection, fps)
    res = undistort_stage(video, out_dir=common.out, config=config, force=common.force, progress=common.progress)
    if res.skipped:
        click.echo(f"{res.path} is up to date")
    else:
        click.echo(f"{res.path}: {res.facts['frames']} frames, output field of view "
                   f"{res.facts['output_fov_deg']:.1f} deg")
