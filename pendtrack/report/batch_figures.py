"""The batch report's figures: parameters against tile length by series (pure functions).

A *series* is the run kind of the paper's Table kindofrun (``la``, ``ln``, ``na``, ``nn``:
launched or not, alley or not). Points are passed as a tidy :class:`pandas.DataFrame` with
columns ``kind``, ``l1_cm`` (tile length [cm]), ``value`` and ``err`` (error bar, same unit
as the value; NaN for none).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from pendtrack.report.style import SERIES_STYLE, new_figure, tidy

SERIES_LABEL = {"la": "la: launched, alley", "ln": "ln: launched, no alley", "na": "na: released, alley",
                "nn": "nn: released, no alley"}
_JITTER_CM = 0.35  # horizontal offset between series so their error bars do not hide each other [cm]


def _series(ax: Axes, points: pd.DataFrame) -> None:
    kinds = [k for k in SERIES_STYLE if k in set(points["kind"])] + sorted(
        k for k in set(points["kind"]) if k not in SERIES_STYLE)
    for i, kind in enumerate(kinds):
        sub = points[points["kind"] == kind].sort_values("l1_cm")
        color, marker = SERIES_STYLE.get(kind, ("0.4", "x"))
        offset = (i - (len(kinds) - 1) / 2) * _JITTER_CM
        err = sub["err"].to_numpy(float)
        ax.errorbar(sub["l1_cm"].to_numpy(float) + offset, sub["value"].to_numpy(float),
                    yerr=np.where(np.isfinite(err), err, 0.0), fmt=marker, color=color, markersize=4.5,
                    capsize=2, elinewidth=0.9, linewidth=0, label=SERIES_LABEL.get(kind, kind or "unknown"))


def params_figure(points: Mapping[str, pd.DataFrame], labels: Mapping[str, str], *, title: str = "") -> Figure:
    """One panel per parameter: value against tile length l1, by series, with error bars.

    Parameters
    ----------
    points : mapping
        Parameter name -> tidy points (``kind``, ``l1_cm``, ``value``, ``err``), in panel order.
    labels : mapping
        Parameter name -> y-axis label with unit (mathtext allowed).
    title : str
        Figure title.
    """
    names = list(points)
    ncols = 2 if len(names) > 1 else 1
    nrows = max(1, math.ceil(len(names) / ncols))
    fig = new_figure(10.0, 3.0 * nrows + 0.6)
    for i, name in enumerate(names):
        ax = tidy(fig.add_subplot(nrows, ncols, i + 1))
        _series(ax, points[name])
        ax.set_ylabel(labels.get(name, name))
        ax.set_xlabel("tile length $l_1$ [cm]")
        if i == 0:
            ax.legend(fontsize=7, loc="best")
    if title:
        fig.suptitle(title, fontsize=11)
    return fig


def omega0_figure(points: pd.DataFrame, *, curve: tuple[np.ndarray, np.ndarray] | None = None,
                  curve_label: str = "", model: str = "") -> Figure:
    """Paper's Fig. fittexOmegaZer: Omega0 against l1 by series, with the two-cuboid line.

    Parameters
    ----------
    points : DataFrame
        Tidy Omega0 points [rad/s].
    curve : (ndarray, ndarray), optional
        The fitted eq. consistencycheck: l1 [cm] and Omega0 [rad/s].
    curve_label : str
        Legend text of the curve (fitted X and l0).
    model : str
        Which model's Omega0 is shown (title).
    """
    fig = new_figure(8.0, 4.6)
    ax = tidy(fig.add_subplot())
    _series(ax, points)
    if curve is not None:
        ax.plot(curve[0], curve[1], color="0.15", linewidth=1.2, label=curve_label or "two cuboids")
    ax.set_xlabel("tile length $l_1$ [cm]")
    ax.set_ylabel(r"$\Omega_0$ [rad/s]")
    if model:
        ax.set_title(rf"$\Omega_0$ of the {model} model")
    ax.legend(fontsize=8, loc="best")
    return fig


def axis_label(name: str, unit: str) -> str:
    """A y-axis label for a parameter: its symbol as in the paper and the unit in brackets."""
    symbol = _SYMBOLS.get(name, name.replace("_", r"\_"))
    unit_text = _UNITS.get(unit, unit)
    return f"{symbol} [{unit_text}]"


_SYMBOLS = {"Omega0": r"$\Omega_0$", "Ca": r"$C_a$", "C0": r"$C_0$", "C1": r"$C_1$", "C2": r"$C_2$",
            "C3": r"$C_3$", "C4": r"$C_4$", "C5": r"$C_5$", "p": r"$p$", "t0": r"$t_0$", "G1": r"$G_1$",
            "G2": r"$G_2$", "beta": r"$\beta$", "p_f": r"$p_f$"}
_UNITS = {"rad/s^2": r"rad/s$^2$", "1": "1", "": "1"}


def finite_points(points: pd.DataFrame) -> pd.DataFrame:
    """Rows with a finite value and tile length."""
    keep = np.isfinite(points["value"].to_numpy(float)) & np.isfinite(points["l1_cm"].to_numpy(float))
    return points[keep]


def panel_order(params: Sequence[str], preferred: Sequence[str]) -> list[str]:
    """``preferred`` parameters first (those present), then the rest in their order."""
    return [p for p in preferred if p in params] + [p for p in params if p not in preferred]
