"""The ``pendtrack`` command line: parses arguments and calls stages, nothing else.

Subcommands live one per module in this package and are imported only when used, so
``pendtrack --help`` starts fast and a stage's heavy imports (numba, OpenCV) stay local.
Every user error ends as one line ``error: ...`` on stderr with exit code 2; ``-v`` shows
the traceback too.
"""

from __future__ import annotations

import importlib
import sys
from typing import Any

import click

from pendtrack.version import __version__
from pendtrack.errors import PendtrackError

# command name -> (module, function, one-line help shown by `pendtrack --help`)
COMMANDS: dict[str, tuple[str, str, str]] = {
    "render": ("pendtrack.cli.render_cmd", "render", "Film a virtual pendulum: video.mp4 + truth.parquet."),
    "undistort": ("pendtrack.cli.track_cmd", "undistort", "Write the lens-corrected video."),
    "track": ("pendtrack.cli.track_cmd", "track", "Track the marker: video -> track.parquet."),
    "angle": ("pendtrack.cli.track_cmd", "angle", "Axle and angle: track.parquet -> angle.parquet."),
    "kinematics": ("pendtrack.cli.kinematics_cmd", "kinematics", "Derivatives and initial analysis -> kinematics.parquet."),
    "fit": ("pendtrack.cli.fit_cmd", "fit", "Fit physical models -> fit.json + fit.parquet."),
    "run": ("pendtrack.cli.run_cmd", "run", "Whole pipeline on a video into an output folder."),
    "batch": ("pendtrack.cli.batch_cmd", "batch", "Whole pipeline over a folder of run-coded videos, resumable."),
    "report": ("pendtrack.cli.report_cmd", "report", "Self-contained HTML report of a run or batch folder."),
    "discover": ("pendtrack.cli.discover_cmd", "discover", "Name the physics the baseline misses, extend the model -> discovery.json/.md."),
}


class LazyGroup(click.Group):
    """A click group that imports a subcommand's module only when it is invoked."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return list(COMMANDS)

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name not in COMMANDS:
            return None
        module_name, attr, _ = COMMANDS[cmd_name]
        return getattr(importlib.import_module(module_name), attr)

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        rows = [(name, help_text) for name, (_, _, help_text) in COMMANDS.items()]
        with formatter.section("Commands"):
            formatter.write_dl(rows)

    def main(self, args: Any = None, prog_name: str | None = None, **extra: Any) -> Any:
        argv = list(sys.argv[1:] if args is None else args)
        verbose = "-v" in argv or "--verbose" in argv
        try:
            return super().main(args=argv, prog_name=prog_name or "pendtrack", standalone_mode=False, **extra)
        except click.exceptions.Exit as exc:
            sys.exit(exc.exit_code)
        except click.exceptions.Abort:
            click.echo("error: aborted", err=True)
            sys.exit(2)
        except click.UsageError as exc:
            click.echo(f"error: {_one_line(exc.format_message())}", err=True)
            sys.exit(2)
        except PendtrackError as exc:
            if verbose:
                import traceback

                traceback.print_exc()
            click.echo(f"error: {_one_line(str(exc))}", err=True)
            sys.exit(2)


def _one_line(text: str) -> str:
    return " ".join(text.split())


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, "--version", prog_name="pendtrack")
def cli() -> None:
    """pendtrack: from a fisheye video of a physical pendulum to fitted physical models.

    Stages hand Parquet files to each other: render -> (video) -> track -> angle ->
    kinematics -> fit. `pendtrack run VIDEO --out DIR` chains them.
    """


def main() -> None:
    """Console-script entry point."""
    cli.main()
