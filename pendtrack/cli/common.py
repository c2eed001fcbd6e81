"""Options every subcommand shares, and the glue from flags to a :class:`Config`."""

from __future__ import annotations

import logging
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import click

from pendtrack.config import Config, load_config
from pendtrack.errors import ConfigError

F = TypeVar("F", bound=Callable[..., Any])


@dataclass(frozen=True)
class CommonArgs:
    """The shared flags, parsed."""

    config: Config
    out: Path
    verbose: bool
    force: bool
    progress: bool


def common_options(default_out: str = ".") -> Callable[[F], F]:
    """Add --config, --out, -v/--verbose, --force and --quiet to a command.

    The command receives them folded into one ``common: CommonArgs`` keyword.
    """

    def decorate(fn: F) -> F:
        def wrapper(*args: Any, config: str | None, out: str, verbose: bool, force: bool, quiet: bool,
                    **kwargs: Any) -> Any:
            logging.basicConfig(
                level=logging.DEBUG if verbose else logging.WARNING,
                stream=sys.stderr,
                format="%(levelname)s %(name)s: %(message)s",
            )
            common = CommonArgs(
                config=load_config(config), out=Path(out), verbose=verbose, force=force, progress=not quiet
            )
            return fn(*args, common=common, **kwargs)

        wrapper.__name__ = fn.__name__
        wrapper.__doc__ = fn.__doc__
        options = [
            click.option("--config", "config", type=click.Path(dir_okay=False), default=None,
                         help="TOML config file (configs/default.toml documents every key); flags override it."),
            click.option("--out", "out", type=click.Path(file_okay=False), default=default_out, show_default=True,
                         help="Output folder."),
            click.option("-v", "--verbose", is_flag=True, help="Debug logging; tracebacks on errors."),
            click.option("--force", is_flag=True, help="Recompute even if the output is up to date."),
            click.option("-q", "--quiet", is_flag=True, help="No progress bars."),
        ]
        for opt in reversed(options):
            wrapper = opt(wrapper)
        return wrapper  # type: ignore[return-value]

    return decorate


def numbers(n: int, kind: type) -> Callable[[click.Context, click.Parameter, str | None], tuple | None]:
    """A click callback parsing ``n`` comma-separated numbers of type ``kind`` (None stays None)."""

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


def _stack(fn: F, options: list[Callable[[F], F]]) -> F:
    for opt in reversed(options):
        fn = opt(fn)
    return fn


def lens_options(fn: F) -> F:
    """``--fov``, ``--fixed-pixels``, ``--projection`` (config ``[lens]``): keywords ``fov_deg, fixed_pixels, projection``."""
    return _stack(fn, [
        click.option("--fov", "fov_deg", type=float, default=None,
                     help="Input diagonal field of view [deg] (config [lens] fov_deg; paper 120)."),
        click.option("--fixed-pixels", type=float, default=None,
                     help="Radius of the circle that does not move, fraction of the half diagonal (paper 0.48)."),
        click.option("--projection", type=click.Choice(["equisolid", "equidistant", "stereographic",
                                                        "orthographic", "none"]), default=None,
                     help="Input lens projection (none: no correction, a normal lens)."),
    ])


def video_options(fn: F) -> F:
    """``--fps``, ``--start``, ``--end`` (config ``[video]``): keywords ``fps, start, end``."""
    return _stack(fn, [
        click.option("--fps", type=float, default=None,
                     help="Frame rate override [1/s]; default: the container's timestamps."),
        click.option("--start", type=float, default=None,
                     help="First time read [s] (config [video] start); times stay the video's, 0 at its first frame."),
        click.option("--end", type=float, default=None,
                     help="Last time read [s] (config [video] end; default: to the last frame)."),
    ])


def marker_options(fn: F) -> F:
    """``--roi``, ``--marker-color``, ``--min-score`` (config ``[track]``): keywords ``roi, marker_color, min_score``."""
    return _stack(fn, [
        click.option("--roi", callback=numbers(4, int), default=None, metavar="X,Y,W,H",
                     help="The marker's rectangle [px] in the first frame where it stands out in it; "
                          "its colour is learned from it."),
        click.option("--marker-color", default=None, metavar="NAME|#RRGGBB",
                     help="Find the marker by this colour: pink (the default), red, orange, yellow, green, blue, "
                          "dark, or #RRGGBB."),
        click.option("--min-score", type=float, default=None, help="Acceptance threshold of the match score (0.6)."),
    ])


def axle_option(fn: F) -> F:
    """``--axle`` (config ``[angle]`` axle): keyword ``axle``."""
    return click.option("--axle", callback=numbers(2, float), default=None, metavar="X,Y",
                        help="Axle in corrected px; default: robust circle fit to the track.")(fn)


def apply_flags(config: Config, section: str, **values: Any) -> Config:
    """``config`` with the given (not None) values of one section replaced.

    A value the config refuses is reported under the flag that gave it (``--window-s``), not
    the config key (``'kinematics.savgol_window_s'``): the user typed the flag.
    """
    given = {k: v for k, v in values.items() if v is not None}
    if not given:
        return config
    try:
        return config.replace(section, **given)
    except ConfigError as exc:
        ctx = click.get_current_context(silent=True)
        flags = {p.name: p.opts[0] for p in ctx.command.params} if ctx is not None else {}
        text = str(exc).removeprefix("<flags>: ")
        for key in given:
            text = text.replace(f"'{section}.{key}'", flags.get(key, "--" + key.replace("_", "-")))
        raise ConfigError(text) from None


def with_lens_and_video(config: Config, *, fov_deg: float | None, fixed_pixels: float | None,
                        projection: str | None, fps: float | None, start: float | None,
                        end: float | None) -> Config:
    """``config`` with the flags of :func:`lens_options` and :func:`video_options` applied."""
    config = apply_flags(config, "lens", fov_deg=fov_deg, fixed_pixels=fixed_pixels, projection=projection)
    return apply_flags(config, "video", fps=fps, start=start, end=end)
