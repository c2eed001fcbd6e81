"""Progress reporting for the edges (stages, CLI); the core only calls a callback.

Core functions take ``on_progress: Callable[[int], None] | None`` and call it with the
number of items just completed. Stages wrap their loops in :func:`progress_bar`, which
draws a click progress bar on standard error (never on stdout, so piped output stays clean).
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Callable, Iterator

import click

ProgressCallback = Callable[[int], None]


@contextlib.contextmanager
def progress_bar(total: int | None, label: str, *, enabled: bool = True) -> Iterator[ProgressCallback]:
    """Yield a callback ``advance(n)`` that moves a progress bar of ``total`` items.

    With ``enabled=False`` the callback does nothing (batch workers, tests).
    """
    if not enabled:
        yield lambda n: None
        return
    with click.progressbar(length=total, label=label, file=sys.stderr, show_pos=True) as bar:
        yield bar.update
