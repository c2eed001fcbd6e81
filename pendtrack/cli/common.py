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
