"""Time stamps: real sample times onto the uniform grid the kinematics and the fits work on.

Every strictly increasing set of times is used; only non-finite, repeated or decreasing
times are errors (by the caller). Four cases, decided by :func:`time_layout`:

* **on a grid** (every time within :data:`GRID_RTOL` of a step of the grid of the median spacing): kept
  as it is;
* **rounded** (every time within :data:`GRID_RTOL` of a step of the least-squares grid, not of the
  median spacing's: times written with too few decimals, 0.03333 for 1/30 s, whose rounded spacing
  drifts off the grid over the record): each row's time is its grid point's (the rows and angles stay);
* **jittered** (every sample within :data:`JITTER_MAX_STEPS` of a step of the least-squares
  grid, e.g. a phone's time stamps): each sample is moved to its grid point, theta taken
  there from a cubic spline through its run of usable samples (the rows stay the rows);
* **irregular** (anything else: an encoder log's real sampling jitter, a logger's uneven
  loop): the grid is the mean spacing (gaps left out) from the first sample, and theta at each grid point
  inside a run of usable samples comes from the cubic spline through that run
  (:func:`resample_irregular`); a spacing above :data:`IRREGULAR_GAP_STEPS` steps is a gap
  whose grid points are missing rows.

  A **change-driven** log (:func:`change_count`: an encoder logger that writes a row each time its
  count changes, so every row moves one or two counts) is irregular with a meaning: a long spacing
  is the bob dwelling within one count near a turning point, not a missing sample, and each row's
  time is when the bob crossed the edge between two counts. Its rows are taken at that edge
  (:func:`at_count_edges`: half a count back against the motion, the same angle whichever way the
  bob crossed it) and only a spacing over which the count moved more than
  :data:`CHANGE_GAP_COUNTS` counts (changes the logger missed), or longer than a period
  (:func:`dwell_gaps`: no swinging bob dwells so long within a count), is a gap.

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
CHANGE_MIN_ROWS = 100  # a change-driven log is recognised on at least this many rows ...
CHANGE_SHARE = 0.99  # ... of which this share move the angle by a whole one or two counts (none by zero)
CHANGE_GAP_COUNTS = 2  # a change-driven log's spacing over which the count moved more than this is a gap
COUNT_RTOL = 0.01  # a step is a whole number of counts to this share of a count (values written to ~1e-16)


@dataclass(frozen=True)
class Grid:
    """The uniform grid of jittered times: ``t_k = origin + step * index_k``."""

    origin: float
    step: float
    index: np.ndarray  # grid index of each row (strictly increasing; jumps > 1 at gaps)
    max_offset: float  # largest |t - grid| [steps]
    rms_offset: float  # [steps]


def time_layout(t: np.ndarray) -> tuple[str, Grid | None]:
    """``("grid", None)``, ``("rounded", grid)``, ``("jittered", grid)`` or ``("irregular", None)``: how times
    sit on a uniform grid (module docstring).

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
    if worst > JITTER_MAX_STEPS:
        return "irregular", None
    return "rounded" if worst <= GRID_RTOL else "jittered", Grid(origin=float(origin), step=float(step), index=index, max_offset=worst,
                            rms_offset=float(np.sqrt(np.mean(offset ** 2))))


def uniform_grid(t: np.ndarray) -> Grid | None:
    """The least-squares uniform grid of jittered times (:func:`time_layout`), else None."""
    layout, grid = time_layout(t)
    return grid if layout == "jittered" else None


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


def change_count(theta: np.ndarray, ok: np.ndarray) -> float | None:
    """The count [rad] of a change-driven log, or None: every usable row moves the angle by a whole count.

    A logger sampling on a clock repeats its value while the bob dwells within a count (a step of zero
    counts) or moves several counts per row when the bob is fast; a logger writing on each change of
    the count moves one count per row, two when two changes fall within its loop.
    """
    th = np.asarray(theta, dtype=float)[np.asarray(ok, dtype=bool)]
    if th.size < CHANGE_MIN_ROWS:
        return None
    step = np.abs(np.diff(th))
    if not np.all(np.isfinite(step)) or np.any(step == 0.0):
        return None
    count = float(step.min())
    counts = step / count
    whole = (np.abs(counts - np.round(counts)) <= COUNT_RTOL) & (np.round(counts) <= CHANGE_GAP_COUNTS)
    return count if float(np.mean(whole)) >= CHANGE_SHARE else None


def at_count_edges(theta: np.ndarray, ok: np.ndarray, count: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A change-driven log's rows at the count edges the bob crossed, and where its gaps are.

    A row's time is when the count changed, i.e. when the bob crossed the edge between the count before
    and the count written; moving up it writes the count above that edge, moving down the count below.
    Half a count back against the motion is that edge, the same angle whichever way the bob crossed it (up
    to a constant half count, by how the logger labels its counts: a zero offset); as written, the record
    carries a hysteresis of one count between its rising and falling halves.

    Returns
    -------
    theta : ndarray
        The angle at each row's time [rad]; the first row, whose motion is unknown, is not usable.
    ok : ndarray of bool
    gap_after : ndarray of bool, shape (n - 1,)
        Spacings over which the count moved more than :data:`CHANGE_GAP_COUNTS` counts.
    """
    th = np.asarray(theta, dtype=float)
    step = np.diff(th)
    edge = th.copy()
    edge[1:] -= 0.5 * count * np.sign(step)
    ok = np.asarray(ok, dtype=bool).copy()
    ok[0] = False
    with np.errstate(invalid="ignore"):
        gap_after = np.abs(step) > (CHANGE_GAP_COUNTS + 0.5) * count
    return edge, ok, gap_after


def dwell_gaps(t: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, float]:
    """A change-driven log's spacings too long for a dwell within one count, and that limit [s].

    A bob that swings across a count's edge at all crosses one at least once a period (at the edge
    nearest its centre), so a spacing longer than a period is a bob at rest within a count, or a logger
    that paused, about which a spline through the rows either side would invent a swing (over 30 s
    without a row, a cubic's bump of 10 rad). The period is twice the median spacing of the rows'
    turning points (:func:`turning_points`); without three of them no spacing is judged so (limit inf).

    Returns
    -------
    gap_after : ndarray of bool, shape (n - 1,)
    limit : float
    """
    t = np.asarray(t, dtype=float)
    turns = turning_points(theta)
    limit = 2.0 * float(np.median(np.diff(t[turns]))) if turns.size >= 3 else math.inf
    with np.errstate(invalid="ignore"):
        return np.diff(t) > limit, limit


def _runs(t: np.ndarray, ok: np.ndarray, gap: float, gap_after: np.ndarray | None = None) -> list[np.ndarray]:
    """Runs of consecutive usable rows with no spacing above ``gap`` (or, given ``gap_after``, none it marks)."""
    breaks = (np.diff(t) > gap) if gap_after is None else gap_after
    brk = np.flatnonzero(~ok[1:] | ~ok[:-1] | breaks) + 1
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
                       path: str | Path | None = None, gap_after: np.ndarray | None = None
                       ) -> tuple[np.ndarray, dict[str, np.ndarray], np.ndarray, dict[str, Any]]:
    """theta (and the carried columns) on a uniform grid from irregular times: the step is the mean
    spacing of consecutive samples (gaps left out), the origin the first sample.

    Grid points inside a run of at least :data:`MIN_RUN` usable samples (no spacing above
    :data:`IRREGULAR_GAP_STEPS` median steps, or none that ``gap_after`` marks: a change-driven log's,
    :func:`at_count_edges`) get the run's cubic spline; the others are missing rows.

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
    if gap_after is None:
        median = float(np.median(diffs))
        step = float(np.mean(diffs[diffs <= IRREGULAR_GAP_STEPS * median]))
    else:
        step = float(np.mean(diffs[~gap_after]))
    origin = float(t[0])
    runs = [r for r in _runs(t, ok, IRREGULAR_GAP_STEPS * step, gap_after) if r.size >= MIN_RUN]
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
              "n_samples_unused": int(np.count_nonzero(ok)) - used,
              "gap_steps": IRREGULAR_GAP_STEPS if gap_after is None else None,
              **spline_error_bound(t[ok], theta[ok], spacing)}
    return out["theta"], carried, new_t, record
