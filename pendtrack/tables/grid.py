"""Time stamps: real sample times onto the uniform grid the kinematics and the fits work on.

Every strictly increasing set of times is used; only non-finite, repeated or decreasing
times are errors (by the caller). Three cases, decided by :func:`uniform_grid`:

* **on a grid** (every time within :data:`GRID_RTOL` of a step of one): kept as it is;
* **jittered** (every sample within :data:`JITTER_MAX_STEPS` of a step of the least-squares
  grid, e.g. a phone's time stamps): each sample is moved to its grid point, theta taken
  there from a cubic spline through its run of usable samples (the rows stay the rows);
* **irregular** (anything else: an encoder log's real sampling jitter, a logger's uneven
  loop): the grid is the mean spacing (gaps left out) from the first sample, and theta at each grid point
  inside a run of usable samples comes from the cubic spline through that run
  (:func:`resample_irregular`); a spacing above :data:`IRREGULAR_GAP_STEPS` steps is a gap
  whose grid points are missing rows.

Cubic rather than linear: a pendulum record has tens of samples per period, where a cubic's
error (order h^4) is far below the tracking noise while linear interpolation flattens every
turning point by order h^2. The error is stated (:func:`spline_error_bound`): for a cubic
spline through samples at most ``H`` apart, ``|error| <= 5/384 H^4 max|theta''''|``
(Hall & Meyer 1976), with ``max|theta''''|`` bounded for a pendulum of the record's own
period and amplitude. Missing rows are gaps: the stages' gap handling (ok flags, segments).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from pendtrack.errors import ArtifactError
from pendtrack.tables.checks import TURN, turning_points

GRID_RTOL = 1e-3  # times within this fraction of a step of the grid are on it (the fitter's tolerance)
JITTER_MAX_STEPS = 0.25  # jittered: every time within this many steps of the grid (well below one)
GAP_STEPS = 1.5  # jittered times: a step longer than this many grid steps is a gap
IRREGULAR_GAP_STEPS = 3.0  # irregular times: a spacing longer than this many median steps is a gap
MIN_RUN = 4  # a cubic spline needs this many samples; shorter runs give no grid points
HALL_MEYER = 5.0 / 384.0  # cubic spline interpolation: |f - s| <= 5/384 H^4 max|f''''|
CARRIED = ("omega", "alpha")  # float columns of a kinematics artifact resampled with theta


@dataclass(frozen=True)
class Grid:
    """The uniform grid of jittered times: ``t_k = origin + step * index_k``."""

    origin: float
    step: float
    index: np.ndarray  # grid index of each row (strictly increasing; jumps > 1 at gaps)
    max_offset: float  # largest |t - grid| [steps]
    rms_offset: float  # [steps]


def time_layout(t: np.ndarray) -> tuple[str, Grid | None]:
    """``("grid", None)``, ``("jittered", grid)`` or ``("irregular", None)``: how times sit on a uniform grid.

    Parameters
    ----------
    t : ndarray
        Strictly increasing times [s].
    """
    t = np.asarray(t, float)
    if t.size < 3:
        return "grid", None
    steps = np.diff(t)
    h0 = float(np.median(steps))
    k0 = np.rint((t - t[0]) / h0)
    if float(np.max(np.abs(t - t[0] - k0 * h0))) <= GRID_RTOL * h0 and np.all(np.diff(k0) > 0):
        return "grid", None
    m = np.rint(steps / h0)  # grid steps between rows: 1, or >= 2 at a gap (a step >= GAP_STEPS h)
    if np.any(m < 1):
        return "irregular", None  # two samples closer than half a step
    index = np.concatenate(([0], np.cumsum(m))).astype(np.int64)
    step, origin = np.polyfit(index.astype(float), t, 1)
    offset = (t - origin - step * index) / step
    worst = float(np.max(np.abs(offset)))
    if worst <= GRID_RTOL:
        return "grid", None
    if worst > JITTER_MAX_STEPS:
        return "irregular", None
    return "jittered", Grid(origin=float(origin), step=float(step), index=index, max_offset=worst,
                            rms_offset=float(np.sqrt(np.mean(offset ** 2))))


def uniform_grid(t: np.ndarray) -> Grid | None:
    """The least-squares uniform grid of jittered times (:func:`time_layout`), else None."""
    return time_layout(t)[1]


def fourth_derivative_bound(t: np.ndarray, theta: np.ndarray) -> tuple[float | None, dict[str, Any]]:
    """A bound on |theta''''| [rad/s^4] from the record's own period and amplitude, and how.

    For a pendulum theta'' = -Omega0^2 sin(theta), so theta'''' = Omega0^2 (sin(theta) theta'^2 -
    cos(theta) theta'') and, with theta'^2 <= 2 Omega0^2 (1 - cos A) at amplitude A,
    ``|theta''''| <= Omega0^4 (2 (1 - cos A) + sin(min(A, pi/2)))``. A is the largest half
    swing between turning points, Omega0 the measured angular frequency corrected for the
    amplitude (the complete elliptic integral K). Damping is ignored (it changes the bound
    by its quality factor's inverse). None without three turning points (no period).
    """
    from scipy.special import ellipk

    turns = turning_points(theta)
    if turns.size < 3:
        return None, {"fourth_derivative": "not estimated: fewer than three turning points"}
    ext = theta[turns]
    amplitude = float(min(0.5 * np.max(np.abs(np.diff(ext))), TURN / 2 - 1e-6))
    omega = math.pi / float(np.median(np.diff(t[turns])))
    k = math.sin(amplitude / 2)
    omega0 = omega * 2.0 * float(ellipk(k * k)) / math.pi
    bound = omega0 ** 4 * (2 * (1 - math.cos(amplitude)) + math.sin(min(amplitude, math.pi / 2)))
    return bound, {"fourth_derivative_rad_s4": bound, "amplitude_rad": amplitude, "omega0_rad_s": omega0}


def spline_error_bound(t: np.ndarray, theta: np.ndarray, max_spacing: float) -> dict[str, Any]:
    """The stated error of a cubic spline through samples at most ``max_spacing`` [s] apart."""
    bound, facts = fourth_derivative_bound(t, theta)
    error = None if bound is None else HALL_MEYER * max_spacing ** 4 * bound
    return {"error_bound_rad": error, "max_spacing_s": max_spacing,
            "error_rule": "5/384 H^4 max|theta''''| (Hall & Meyer), theta'''' of a pendulum of the record's "
                          "period and amplitude", **facts}


def _runs(t: np.ndarray, ok: np.ndarray, gap: float) -> list[np.ndarray]:
    """Runs of consecutive usable rows with no spacing above ``gap``."""
    brk = np.flatnonzero(~ok[1:] | ~ok[:-1] | (np.diff(t) > gap)) + 1
    return [run[ok[run]] for run in np.split(np.arange(t.size), brk)]


def resample_jittered(t: np.ndarray, theta: np.ndarray, ok: np.ndarray, columns: dict[str, np.ndarray],
                      grid: Grid) -> tuple[np.ndarray, dict[str, np.ndarray], np.ndarray, dict[str, Any]]:
    """theta and the carried float columns at each row's grid time, by a cubic spline per run of
    usable rows (the rows stay the rows)."""
    from scipy.interpolate import CubicSpline

    new_t = grid.origin + grid.step * grid.index
    floats = {"theta": theta, **{c: columns[c] for c in CARRIED if c in columns}}
    out = {name: np.array(v, dtype=float) for name, v in floats.items()}
    spacing = 0.0
    brk = np.flatnonzero(~ok[1:] | ~ok[:-1] | (np.diff(grid.index) > 1)) + 1
    for run in np.split(np.arange(t.size), brk):
        run = run[ok[run]]
        if run.size < 2:
            continue
        spacing = max(spacing, float(np.max(np.diff(t[run]))))
        for name, v in floats.items():
            out[name][run] = CubicSpline(t[run], v[run])(new_t[run])
    carried = {**columns, **{c: out[c] for c in CARRIED if c in columns}}
    record = {"method": "cubic spline (not-a-knot) through each run of usable samples, each sample to its grid "
                        "point", "step_s": grid.step, "origin_s": grid.origin, "max_offset_steps": grid.max_offset,
              "rms_offset_steps": grid.rms_offset, "n": int(t.size), "n_out": int(t.size),
              **spline_error_bound(t[ok], theta[ok], spacing)}
    return out["theta"], carried, new_t, record


def resample_irregular(t: np.ndarray, theta: np.ndarray, ok: np.ndarray, columns: dict[str, np.ndarray], *,
                       path: str | Path | None = None
                       ) -> tuple[np.ndarray, dict[str, np.ndarray], np.ndarray, dict[str, Any]]:
    """theta (and the carried columns) on a uniform grid from irregular times: the step is the mean
    spacing of consecutive samples (gaps left out), the origin the first sample.

    Grid points inside a run of at least :data:`MIN_RUN` usable samples (no spacing above
    :data:`IRREGULAR_GAP_STEPS` median steps) get the run's cubic spline; the others are missing rows.

    Returns
    -------
    theta, columns, t, record
        On the grid (every row usable); ``record`` for the provenance.

    Raises
    ------
    ArtifactError
        No run long enough for a spline.
    """
    from scipy.interpolate import CubicSpline

    # the mean spacing within runs: for jitter about a grid it telescopes to the grid step (the
    # median of jittered spacings is off by its sampling noise, which accumulates along the grid)
    diffs = np.diff(t)
    median = float(np.median(diffs))
    step = float(np.mean(diffs[diffs <= IRREGULAR_GAP_STEPS * median]))
    origin = float(t[0])
    runs = [r for r in _runs(t, ok, IRREGULAR_GAP_STEPS * step) if r.size >= MIN_RUN]
    if not runs:
        raise ArtifactError(f"no {MIN_RUN} usable samples in a row without a gap: nothing to resample", path=path)
    floats = {"theta": theta, **{c: columns[c] for c in CARRIED if c in columns}}
    pieces: dict[str, list[np.ndarray]] = {name: [] for name in floats}
    grid_t: list[np.ndarray] = []
    nearest: list[np.ndarray] = []
    spacing = 0.0
    for run in runs:
        first, last = (t[run[0]] - origin) / step, (t[run[-1]] - origin) / step
        k = np.arange(math.ceil(first - 1e-9), math.floor(last + 1e-9) + 1)  # grid points inside the run
        if k.size == 0:
            continue
        tk = origin + step * k
        grid_t.append(tk)
        spacing = max(spacing, float(np.max(np.diff(t[run]))))
        for name, v in floats.items():
            pieces[name].append(CubicSpline(t[run], v[run])(tk))
        pos = np.clip(np.searchsorted(t[run], tk), 1, run.size - 1)
        left_closer = (tk - t[run[pos - 1]]) <= (t[run[pos]] - tk)
        nearest.append(np.where(left_closer, run[pos - 1], run[pos]))
    new_t = np.concatenate(grid_t)
    near = np.concatenate(nearest)
    out = {name: np.concatenate(p) for name, p in pieces.items()}
    carried = {c: (out[c] if c in out else np.asarray(v)[near]) for c, v in columns.items()}
    used = int(sum(r.size for r in runs))
    record = {"method": "cubic spline (not-a-knot) through each run of usable samples, onto a uniform grid of the "
                        "mean spacing within runs from the first sample", "step_s": step, "origin_s": origin,
              "max_offset_steps": None, "irregular": True, "n": int(t.size), "n_out": int(new_t.size),
              "n_samples_unused": int(np.count_nonzero(ok)) - used, "gap_steps": IRREGULAR_GAP_STEPS,
              **spline_error_bound(t[ok], theta[ok], spacing)}
    return out["theta"], carried, new_t, record
