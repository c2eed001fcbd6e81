"""theta(t) -> smoothed theta, omega, alpha by Savitzky-Golay filters, gap-aware.

The paper (section "Experimental") differentiates theta with Savitzky-Golay filters:
cubic polynomials over windows of 25 frames at 120 fps. Here the window is a *duration*
(``KinematicsConfig.savgol_window_s``, the paper's 25 frames at 120 fps) so that a record at another frame rate
gets the window of the same length in time.

Procedure (:func:`savgol_kinematics`)

1. Usable samples: ``ok`` and a finite theta. The nominal step ``h`` is the median
   spacing of consecutive usable samples.
2. Segments: consecutive usable samples whose missing stretch (spacing minus ``h``) is
   longer than ``max_gap_s`` start a new segment; shorter holes are bridged. A segment
   shorter than ``max(min_segment_s, window)`` is dropped (segment -1, values NaN).
3. Each segment is put on a uniform grid of (about) ``h``: if its timestamps already are
   uniform and complete they are used as they are; otherwise theta is interpolated by a
   cubic spline through the usable samples (this bridges the short holes and handles
   jittered timestamps).
4. :func:`savgol_uniform` (``scipy.signal.savgol_filter``, ``mode="interp"``: the edge
   windows fit a polynomial to the first/last window, no padding) gives theta, omega and
   alpha with ``delta`` = the grid step. Segments are filtered separately, so a gap never smears into its
   neighbours.
5. Values are taken back to the original sample times (cubic spline of the smoothed
   series if the grid was not the samples themselves).

Output rows are the input rows. ``ok`` is True only for usable samples in a kept
segment; bridged samples get interpolated values but ``ok = False``.

The window is an odd number of points, at least ``order + 2``; and it is never more than
:data:`MAX_WINDOW_PERIOD_FRACTION` of the oscillation period (estimated from the spectrum
of theta): a longer window would flatten the swings, so it is clipped with a warning
(recorded in the result).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pendtrack.config import KinematicsConfig
from pendtrack.errors import PendtrackError
from pendtrack.models.timegrid import check_time
from pendtrack.tables.checks import MIN_HALF_PERIOD_SAMPLES, dominant_period, turning_points

log = logging.getLogger(__name__)

MAX_WINDOW_PERIOD_FRACTION = 0.25  # window <= this fraction of the oscillation period
UNIFORM_RTOL = 1e-9  # timestamps within this fraction of h of the grid count as on it


class KinematicsError(PendtrackError):
    """The angle series cannot be differentiated (bad time axis, too few samples...)."""


@dataclass(frozen=True)
class KinematicsResult:
    """Smoothed angle and derivatives at the input sample times.

    Attributes
    ----------
    t : numpy.ndarray
        Input times [s].
    theta, omega, alpha : numpy.ndarray
        Smoothed angle [rad], angular velocity [rad/s], acceleration [rad/s^2]; NaN
        outside kept segments.
    ok : numpy.ndarray of bool
        Usable input sample inside a kept segment.
    segment : numpy.ndarray of int64
        Kept-segment index (0, 1, ...) or -1 (long gap or dropped segment).
    info : dict
        Facts: ``h`` [s], ``order``, ``window_points``, ``window_s``, ``window_clipped``,
        ``n_segments``, ``n_dropped_segments``, ``n_bridged``, ``resampled``.
    """

    t: np.ndarray
    theta: np.ndarray
    omega: np.ndarray
    alpha: np.ndarray
    ok: np.ndarray
    segment: np.ndarray
    info: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {"t": self.t.tolist(), "theta": self.theta.tolist(), "omega": self.omega.tolist(),
                "alpha": self.alpha.tolist(), "ok": self.ok.tolist(), "segment": self.segment.tolist(),
                "info": dict(self.info)}


def window_points(window_s: float, h: float, order: int) -> int:
    """Odd number of points closest to ``window_s / h`` (ties upwards), at least ``order + 2``.

    Parameters
    ----------
    window_s : float
        Window duration [s].
    h : float
        Sample spacing [s].
    order : int
        Polynomial order.
    """
    ratio = window_s / h
    n = 2 * int(math.floor((ratio - 1.0) / 2.0 + 0.5 + 1e-9)) + 1  # closest odd, ties upwards
    n = max(n, order + 2)
    if n % 2 == 0:
        n += 1
    return n


def swing_period(theta: np.ndarray, h: float) -> float:
    """The swing's period [s] of a uniformly sampled theta: its spectral peak (:func:`dominant_period`),
    or twice the median time between its turning points when that is under half the peak's period.

    A record that stops after a few swings and rests for seconds (an encoder on a heavily damped
    rig) has its spectral peak at the rest's step; its turning points (a zigzag with a tenth of the
    range as hysteresis, :func:`pendtrack.tables.checks.turning_points`) still space half periods.
    """
    period = dominant_period(theta, h)
    turns = turning_points(theta)
    if turns.size >= 2:
        half = float(np.median(np.diff(turns)))
        # turning points a few samples apart are the noise's, not a swing's (a micro:bit's angle whose
        # sample-to-sample noise exceeds a tenth of its range, 1-3 samples apart): a swing is sampled 8 times a period
        if half >= MIN_HALF_PERIOD_SAMPLES and 2.0 * h * half < 0.5 * period:
            return 2.0 * h * half
    return period


def _check_inputs(t: Any, theta: Any, ok: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = np.asarray(t, dtype=np.float64)
    theta = np.asarray(theta, dtype=np.float64)
    ok = np.ones(t.shape, dtype=bool) if ok is None else np.asarray(ok, dtype=bool)
    if t.ndim != 1 or theta.shape != t.shape or ok.shape != t.shape:
        raise KinematicsError(f"t, theta and ok must be 1-D of the same length, got {t.shape}, {theta.shape}, {ok.shape}")
    check_time(t, what="t", error=KinematicsError, min_size=0)
    return t, theta, ok & np.isfinite(theta)


def split_segments(t: np.ndarray, usable: np.ndarray, h: float, max_gap_s: float) -> list[np.ndarray]:
    """Indices of usable samples grouped into segments split at holes longer than ``max_gap_s``."""
    idx = np.flatnonzero(usable)
    if idx.size == 0:
        return []
    hole = np.diff(t[idx]) - h  # missing duration between consecutive usable samples
    cuts = np.flatnonzero(hole > max_gap_s + 1e-9 * h) + 1
    return np.split(idx, cuts)


def savgol_uniform(theta: Any, *, h: float, window: int,
                   order: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Savitzky-Golay smoothed angle and its first two derivatives on a uniform grid.

    ``scipy.signal.savgol_filter`` with ``mode="interp"``: the first and last half windows
    take the polynomial fitted to the first/last whole window (no padding).

    Parameters
    ----------
    theta : array_like
        Angle [rad] at uniformly spaced times, no NaN.
    h : float
        Grid step [s].
    window : int
        Odd window length [samples] (:func:`window_points`), > ``order``.
    order : int
        Polynomial order.

    Returns
    -------
    theta, omega, alpha : numpy.ndarray
        Smoothed angle [rad], angular velocity [rad/s], angular acceleration [rad/s^2].
    """
    from scipy.signal import savgol_filter

    return (savgol_filter(theta, window, order, deriv=0, delta=h, mode="interp"),
            savgol_filter(theta, window, order, deriv=1, delta=h, mode="interp"),
            savgol_filter(theta, window, order, deriv=2, delta=h, mode="interp"))


def savgol_kinematics(t: Any, theta: Any, ok: Any = None, *, window_s: float = KinematicsConfig.savgol_window_s,
                      order: int = KinematicsConfig.savgol_order, max_gap_s: float = KinematicsConfig.max_gap_s,
                      min_segment_s: float = KinematicsConfig.min_segment_s) -> KinematicsResult:
    """Savitzky-Golay theta, omega, alpha, segment by segment (see the module docstring).

    Parameters
    ----------
    t : array_like
        Sample times [s], strictly increasing.
    theta : array_like
        Angle [rad] (unwrapped).
    ok : array_like of bool, optional
        Usable samples (default: all finite ones).
    window_s : float
        Window duration [s] (paper: 25/120 s).
    order : int
        Polynomial order (paper: 3).
    max_gap_s : float
        Holes up to this duration [s] are bridged by interpolation; longer ones split.
    min_segment_s : float
        Segments shorter than this (or than the window) are dropped [s].

    Returns
    -------
    KinematicsResult

    Raises
    ------
    KinematicsError
        Bad time axis, bad settings, or no segment long enough.
    """
    from scipy.interpolate import CubicSpline

    t, theta, usable = _check_inputs(t, theta, ok)
    if not (order >= 1 and window_s > 0 and max_gap_s >= 0 and min_segment_s >= 0):
        raise KinematicsError(f"bad Savitzky-Golay settings: window_s={window_s!r}, order={order!r}, "
                              f"max_gap_s={max_gap_s!r}, min_segment_s={min_segment_s!r}")
    idx_ok = np.flatnonzero(usable)
    if idx_ok.size < order + 2:
        raise KinematicsError(f"only {idx_ok.size} usable samples: too few to differentiate")
    h = float(np.median(np.diff(t[idx_ok])))
    n_win = window_points(window_s, h, order)
    segments = split_segments(t, usable, h, max_gap_s)

    # guard: the window must stay a small fraction of the oscillation period
    longest = max(segments, key=lambda s: t[s[-1]] - t[s[0]])
    clipped = False
    if longest.size >= 4 * n_win:
        grid = np.arange(t[longest[0]], t[longest[-1]] + 0.5 * h, h)
        period = swing_period(np.interp(grid, t[longest], theta[longest]), h)
        limit = MAX_WINDOW_PERIOD_FRACTION * period
        if n_win * h > limit:
            new = window_points(limit, h, order)
            if new < n_win:
                log.warning("Savitzky-Golay window %.3f s is more than %.0f%% of the oscillation period %.3f s: "
                            "clipped to %d points", n_win * h, 100 * MAX_WINDOW_PERIOD_FRACTION, period, new)
                n_win = new
                clipped = True

    n = t.size
    out_th = np.full(n, np.nan)
    out_om = np.full(n, np.nan)
    out_al = np.full(n, np.nan)
    seg_id = np.full(n, -1, dtype=np.int64)
    ok_out = np.zeros(n, dtype=bool)
    min_len = max(min_segment_s, n_win * h)
    kept = dropped = bridged = 0
    resampled = False
    for seg in segments:
        t0, t1 = t[seg[0]], t[seg[-1]]
        if t1 - t0 + h < min_len - 1e-9 * h or seg.size < n_win:
            dropped += 1
            continue
        rows = np.arange(seg[0], seg[-1] + 1)  # every input row the segment spans (incl. bridged)
        m = int(round((t1 - t0) / h)) + 1
        grid = np.linspace(t0, t1, m)
        hg = (t1 - t0) / (m - 1)
        on_grid = seg.size == m and rows.size == m and np.max(np.abs(t[seg] - grid)) <= UNIFORM_RTOL * h
        if on_grid:
            th_grid = theta[seg]
        else:
            resampled = True
            th_grid = CubicSpline(t[seg], theta[seg])(grid)
        sm, d1, d2 = savgol_uniform(th_grid, h=hg, window=n_win, order=order)
        if on_grid:
            out_th[rows], out_om[rows], out_al[rows] = sm, d1, d2
        else:
            out_th[rows] = CubicSpline(grid, sm)(t[rows])
            out_om[rows] = CubicSpline(grid, d1)(t[rows])
            out_al[rows] = CubicSpline(grid, d2)(t[rows])
        seg_id[rows] = kept
        ok_out[seg] = True
        bridged += rows.size - seg.size
        kept += 1
    if kept == 0:
        raise KinematicsError(f"no gap-free stretch of at least {min_len:.3g} s (min_segment_s / window): "
                              f"{len(segments)} segment(s), all too short")
    info = {"h": h, "order": order, "window_points": n_win, "window_s": n_win * h, "window_clipped": clipped,
            "n_segments": kept, "n_dropped_segments": dropped, "n_bridged": bridged, "resampled": resampled}
    return KinematicsResult(t=t.copy(), theta=out_th, omega=out_om, alpha=out_al, ok=ok_out, segment=seg_id, info=info)
