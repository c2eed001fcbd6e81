"""`pendtrack render --seconds S --out DIR [...]`: film a virtual pendulum."""

from __future__ import annotations

import re
from typing import Any

import click

from pendtrack.cli.common import CommonArgs, common_options, numbers
from pendtrack.errors import ConfigError


def _parse_size(text: str) -> tuple[int, int]:
    match = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if not match:
        raise ConfigError(f"--size must look like WIDTHxHEIGHT (e.g. 1280x720), got {text!r}")
    return int(match.group(1)), int(match.group(2))


@click.command("render")
@click.option("--seconds", type=float, default=None, help="Length of the video [s] (config: render.seconds, 10).")
@click.option("--model", default=None, help="Model driving the pendulum (config: render.model, 'standard').")
@click.option("--param", "params", multiple=True, metavar="NAME=VALUE",
              help="Model parameter (repeatable), e.g. --param C0=0.02; the others take defaults.")
@click.option("--theta0", type=float, default=None, help="Initial angle [rad] at t = 0 (config: render.theta0).")
@click.option("--omega0", type=float, default=None, help="Initial angular velocity [rad/s]; != 0 means launched.")
@click.option("--seed", type=int, default=None, help="Seed of the wall texture and the sensor noise.")
@click.option("--size", default=None, metavar="WxH", help="Frame size [px], e.g. 1280x720 (even numbers).")
@click.option("--fps", type=float, default=None, help="Frame rate [1/s] (config: render.fps, 120).")
@click.option("--tile", "tile_cm", type=float, default=None, metavar="CM",
              help="Tile length l1 [cm] at the bar's end (default none); Omega0 defaults to "
                   "two_cuboid_omega0(l1) unless --param Omega0=... is given.")
@click.option("--alley/--no-alley", default=None, help="Draw the alley's slabs near the bottom of the swing.")
@click.option("--trial", type=int, default=None, help="Trial number, the run code's last digit (default 1).")
@click.option("--projection", "lens_projection",
              type=click.Choice(["equisolid", "equidistant", "stereographic", "orthographic", "rectilinear", "none"]),
              default=None, help="The camera's lens (config: render.lens_projection, equisolid as the paper's "
                                 "fisheye); none (or rectilinear): a normal lens, tracked with --projection none.")
@click.option("--fov", "lens_fov_deg", type=float, default=None,
              help="The camera's diagonal field of view [deg] (config: render.lens_fov_deg, 120).")
@click.option("--camera-offset", "camera_offset_m", callback=numbers(2, float), default=None, metavar="X,Y",
              help="Where the optical axis meets the pendulum's plane, minus the axle [m], x right, y down "
                   "(config: render.camera_offset_m, 0.05,0.02); e.g. 0,0.3 with --fov 70 puts the axle "
                   "above the frame.")
@click.option("--camera-distance", "camera_distance_m", type=float, default=None,
              help="Camera to the axle [m] (config: render.camera_distance_m, 0.58).")
@click.option("--roll", "camera_roll_deg", type=float, default=None,
              help="Camera roll about its optical axis [deg]; theta in the image reads theta + roll "
                   "(config: render.camera_roll_deg, 0).")
@click.option("--marker-color", default=None, metavar="pink|dark|blue|#RRGGBB",
              help="The bob's colour (config: render.marker_color, pink: the paper's spot).")
@click.option("--marker-shape", type=click.Choice(["spot", "ball", "shiny"]), default=None,
              help="A flat spot on the bar, a shaded ball or a shiny ball with a saturated highlight "
                   "(config: render.marker_shape, spot).")
@click.option("--rig", type=click.Choice(["bar", "string"]), default=None,
              help="The paper's bar or a ball on a thin string, Omega0 = sqrt(g L / (L^2 + 2 R^2 / 5)) unless "
                   "--param Omega0 (config: render.rig, bar).")
@click.option("--sticker", "sticker_color", default=None, metavar="pink|dark|blue|#RRGGBB",
              help="A small sticker of this colour on the bob, off its centre (config: render.sticker_color).")
@click.option("--hand-release", "hand_release_s", type=float, default=None, metavar="S",
              help="A hand holds the bob at theta0 until S seconds, then lets go; the truth holds theta0 and "
                   "omega = 0 until then (config: render.hand_release_s, 0 = no hand).")
@click.option("--name-by-run-code", is_flag=True,
              help="Name the outputs by run code (e.g. 06na1.mp4 + 06na1.truth.parquet) instead of video.mp4 + "
                   "truth.parquet.")
@common_options(default_out=".")
def render(seconds: float | None, model: str | None, params: tuple[str, ...], theta0: float | None,
           omega0: float | None, seed: int | None, size: str | None, fps: float | None, tile_cm: float | None,
           alley: bool | None, trial: int | None, lens_projection: str | None, lens_fov_deg: float | None,
           camera_offset_m: tuple[float, ...] | None, camera_distance_m: float | None,
           camera_roll_deg: float | None, marker_color: str | None, marker_shape: str | None, rig: str | None,
           sticker_color: str | None, hand_release_s: float | None, name_by_run_code: bool,
           common: CommonArgs) -> None:
    """Film a virtual pendulum: OUT/video.mp4 (H.264) and OUT/truth.parquet (t, theta, omega).

    Field conditions (what users film) are flags too: a normal lens (--projection none),
    --fps 30 or 60 and --size 1920x1080, a dark or blue ball (--marker-color, --marker-shape
    ball, --rig string), the axle above the frame (--camera-offset, --fov), a hand holding
    the bob at first (--hand-release), a rolled camera (--roll) and a sticker on the bob
    (--sticker). The truth's provenance records each (its "extra": camera_roll_rad,
    hand_release_s, axle_in_frame, marker).
    """
    from pendtrack.stages.render import render_stage

    values: dict[str, Any] = {}
    if size is not None:
        values["width"], values["height"] = _parse_size(size)
    if tile_cm is not None:
        values["tile_length_m"] = tile_cm / 100.0
    if params:  # a flag overrides the same name in the config file
        from pendtrack.render.physics import parse_params

        merged = parse_params(common.config.render.params) | parse_params(params)
        values["params"] = tuple(f"{k}={v!r}" for k, v in merged.items())
    for key, value in (("seconds", seconds), ("model", model), ("theta0", theta0), ("omega0", omega0),
                       ("seed", seed), ("fps", fps), ("alley", alley), ("trial", trial),
                       ("lens_projection", lens_projection), ("lens_fov_deg", lens_fov_deg),
                       ("camera_offset_m", camera_offset_m), ("camera_distance_m", camera_distance_m),
                       ("camera_roll_deg", camera_roll_deg), ("marker_color", marker_color),
                       ("marker_shape", marker_shape), ("rig", rig), ("sticker_color", sticker_color),
                       ("hand_release_s", hand_release_s)):
        if value is not None:
            values[key] = value
    config = common.config.replace("render", **values)
    out = render_stage(out_dir=common.out, config=config, force=common.force, progress=common.progress,
                       name_by_run_code=name_by_run_code)
    video, truth = out.paths
    if out.skipped:
        click.echo(f"up to date: {video} {truth}")
        return
    f = out.facts
    code = f" run {f['run_code']}," if f.get("run_code") else ""
    click.echo(f"wrote {video} ({f['frames']} frames, {f['size']} @ {f['fps']:g} fps,{code} model {f['model']}, "
               f"{f['render_fps']:.1f} frames/s) and {truth}")
