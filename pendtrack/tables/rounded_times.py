"""Times written more coarsely than the rows are spaced: the rows re-timed on the uniform grid they fit.

A spreadsheet that saves a Tracker export in a scientific format of three significant digits
(``1.00E+01``) writes every time from 10 s on to 0.1 s while the rows are a frame (33 ms) apart:
three rows share each written time, and the time column no longer increases. The rows are still
the video's consecutive frames. :func:`retime_rounded` tests that: if a uniform grid
``t_k = origin + step * k`` (k the row) passes within every written time's rounding -- half the unit
of its last written digit, widened by the grid's own uncertainty at that row -- the rows are taken
at the grid's times. Otherwise (a logger's duplicated rows, real jitter, a dropped frame) it
returns None and the caller judges the times as written.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

#: The grid's allowance beyond a time's half unit, in standard errors of the grid at that row: the
#: 99.99 % Working-Hotelling band of a fitted line is ~4.3 of them, so a true grid is not refused.
GRID_SIGMAS = 5.0
_DECIMAL_RE = re.compile(r"^[+-]?\d*(?:\.(\d*))?(?:[eE]([+-]?\d+))?$")


def digit_unit(cell: str) -> float:
    """The unit of a written number's last digit (``"1.00E+01"``: 0.1; ``"0.033"``: 0.001; ``"12"``: 1).

    NaN for a cell that is no plain decimal number (``nan``, ``inf``, empty).
    """
    m = _DECIMAL_RE.match(cell.strip())
    if not m or not any(ch.isdigit() for ch in cell):
        return float("nan")
    decimals = len(m.group(1) or "")
    exponent = int(m.group(2) or 0)
    return 10.0 ** (exponent - decimals)


@dataclass(frozen=True)
class Retimed:
    """Rows re-timed on the uniform grid their rounded times fit.

    Attributes
    ----------
    t : ndarray
        The grid's times, one per row [s].
    step, origin : float
        The grid ``t_k = origin + step * k`` [s].
    step_se : float
        The step's standard error [s] (the written times' rounding as uniform errors).
    n_repeated : int
        Rows whose written time repeats the one before.
    coarsest : float
        The coarsest last-digit unit of a written time [s].
    worst : float
        The largest distance of a written time from the grid, in shares of its half unit (<= 1
        plus the grid's allowance).
    """

    t: np.ndarray
    step: float
    origin: float
    step_se: float
    n_repeated: int
    coarsest: float
    worst: float

    def describe(self) -> dict[str, float | int | str]:
        """Provenance facts."""
        return {"step_s": self.step, "step_se_s": self.step_se, "origin_s": self.origin, "n_repeated": self.n_repeated,
                "coarsest_unit_s": self.coarsest, "worst_half_units": self.worst,
                "rule": "row k at origin + step k, the weighted least-squares line through the written times, "
                        f"each within half its last digit's unit plus {GRID_SIGMAS:g} standard errors of the line"}


def retime_rounded(t: np.ndarray, unit: np.ndarray) -> Retimed | None:
    """The rows re-timed on a uniform grid, if their repeated times are rounding; else None.

    Parameters
    ----------
    t : ndarray
        Times as written, in row order [s].
    unit : ndarray
        Each time's last-digit unit [s] (:func:`digit_unit`, scaled to s).

    Returns
    -------
    Retimed or None
        None unless the times repeat (never going back), every unit is known, and the weighted
        least-squares line through them (weights: the inverse variance ``unit^2 / 12`` of a
        rounding) passes within ``unit / 2`` plus :data:`GRID_SIGMAS` of its own standard errors of
        every written time.
    """
    t = np.asarray(t, dtype=float)
    unit = np.asarray(unit, dtype=float)
    if t.size < 3 or unit.shape != t.shape or not np.all(np.isfinite(unit) & (unit > 0)) or not np.all(np.isfinite(t)):
        return None
    steps = np.diff(t)
    if np.any(steps < 0) or not np.any(steps == 0):
        return None
    k = np.arange(t.size, dtype=float)
    design = np.column_stack([np.ones_like(k), k])
    weight = 12.0 / unit ** 2
    normal = design.T @ (design * weight[:, None])
    cov = np.linalg.inv(normal)
    origin, step = cov @ (design.T @ (weight * t))
    if not step > 0:
        return None
    se = np.sqrt(np.einsum("ij,jk,ik->i", design, cov, design))
    miss = np.abs(t - (origin + step * k))
    if np.any(miss > 0.5 * unit + GRID_SIGMAS * se):
        return None
    return Retimed(t=origin + step * k, step=float(step), origin=float(origin), step_se=float(np.sqrt(cov[1, 1])),
                   n_repeated=int(np.count_nonzero(steps == 0)), coarsest=float(np.max(unit)),
                   worst=float(np.max(miss / (0.5 * unit))))
