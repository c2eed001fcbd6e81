"""Shared look of the report's figures: colours, sizes, PNG export, a figure embedded as a page
block (:func:`draw`). No pyplot, no rcParams.

Every figure is a bare :class:`matplotlib.figure.Figure` attached to an Agg canvas, so that
drawing never touches matplotlib's global state (safe in threads and in a GUI session).
"""

from __future__ import annotations

import io
import logging
from collections.abc import Callable
from typing import Any

from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from pendtrack.report.html import FigureBlock

log = logging.getLogger(__name__)

DPI = 100  # [dots/inch] of the embedded PNGs: a 9-inch figure is 900 px wide
DATA_COLOR = "0.25"  # measured data: dark grey
FLAG_COLOR = "#d62728"  # flagged frames, negative damping: red
NEGATIVE_FILL = "#fde0dd"  # background of the negative-damping quadrants

# One colour per model name, stable across all figures of a report; unknown models cycle below.
MODEL_COLORS = {
    "classic": "#1f77b4",
    "opa": "#2ca02c",
    "fractional": "#9467bd",
    "power-law": "#ff7f0e",
}
_CYCLE = ("#8c564b", "#e377c2", "#17becf", "#bcbd22", "#7f7f7f")

# Series of a batch (run-code infix, paper's table kindofrun): colour and marker.
SERIES_STYLE = {
    "la": ("#1f77b4", "o"),
    "ln": ("#ff7f0e", "s"),
    "na": ("#2ca02c", "^"),
    "nn": ("#d62728", "D"),
}


def model_color(name: str, index: int = 0) -> str:
    """Colour of a model's curves; unknown names take a colour from a fixed cycle by ``index``."""
    return MODEL_COLORS.get(name, _CYCLE[index % len(_CYCLE)])


def new_figure(width: float, height: float) -> Figure:
    """A figure of ``width`` x ``height`` inches on its own Agg canvas, constrained layout."""
    fig = Figure(figsize=(width, height), dpi=DPI, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def tidy(ax: Axes, *, grid: bool = True) -> Axes:
    """The common axes look: light grid, ticks inside, small tick labels."""
    if grid:
        ax.grid(True, color="0.88", linewidth=0.6)
        ax.set_axisbelow(True)
    ax.tick_params(direction="in", labelsize=8, top=True, right=True)
    ax.xaxis.label.set_size(9)
    ax.yaxis.label.set_size(9)
    ax.title.set_size(10)
    return ax


def to_png(fig: Figure, *, dpi: int = DPI) -> bytes:
    """The figure as PNG bytes (white background, no metadata that changes between runs)."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, facecolor="white", metadata={"Software": None})
    return buf.getvalue()


def draw(key: str, caption: str, build: Callable[[], Any],
         on_progress: Callable[[int], None] | None = None) -> FigureBlock:
    """Call ``build()`` for a Figure and embed it; an exception becomes the block's error text."""
    try:
        fig = build()
        png = to_png(fig)
    except Exception as exc:  # a figure must never cost the whole report
        log.warning("report figure %s failed", key, exc_info=True)
        block = FigureBlock(key, caption, error=f"{type(exc).__name__}: {exc}")
    else:
        block = FigureBlock(key, caption, png=png)
    if on_progress is not None:
        on_progress(1)
    return block
