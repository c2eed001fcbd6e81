"""The record as discovery analyses it: a uniform grid, its kinematics and the held-out split.

Records faster than ``analysis_rate_hz`` are analysed at an integer fraction of their rate
(every k-th sample): at 60 Hz an oscillation of ~1 s still has ~60 samples, far more than
the physics needs, and every simulation, fit and diagnostic costs half as much as at 120 Hz.
A record whose times are not uniform (jittered time stamps, dropped frames) is linearly
interpolated onto the uniform grid of its median step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pendtrack.discovery.inputs import AngleSeries
from pendtrack.errors import FitError
from pendtrack.fitting.leastsq.samples import slow_frames
from pendtrack.kinematics import savgol_uniform, window_points

UNIFORM_RTOL = 1e-6  # spacing spread below which a record counts as uniform (as pendtrack.models)
MIN_TRAINING = 100  # samples fitted: the few periods a fit of the baseline and a candidate need
MIN_HELDOUT = 50  # samples held out: enough to judge a prediction error against the noise


@dataclass(frozen=True, eq=False)
class AnalysisData:
    """A record ready for fitting and diagnosis.

    Attributes
    ----------
    t : ndarray
        Uniform times [s].
    theta : ndarray
        Angle [rad].
    omega, alpha : ndarray
        Savitzky-Golay angular velocity [rad/s] and acceleration [rad/s^2].
    t_split : float
        End of the training part [s]: held-out samples have ``t > t_split``.
    savgol_window : int
        Savitzky-Golay window [samples] (odd).
    savgol_order : int
    smoothed : bool
        ``theta`` is itself Savitzky-Golay smoothed (kinematics input).
    decimation : int
        Every ``decimation``-th input sample was kept.
    interpolated : bool
        The input was interpolated onto a uniform grid.
    source : str
        Name of the input, for messages.
    cost_out : ndarray of bool or None
        A tracked video's slow frames, left out of every fit's cost
        (:attr:`pendtrack.fitting.leastsq.samples.Record.cost_out`); the diagnostics and the held-out
        predictions keep them. None: none.
    """

    t: np.ndarray
    theta: np.ndarray
    omega: np.ndarray
    alpha: np.ndarray
    t_split: float
    savgol_window: int
    savgol_order: int
    smoothed: bool
    decimation: int
    interpolated: bool
    source: str
    cost_out: np.ndarray | None = None

    @property
    def dt(self) -> float:
        """Grid step [s]."""
        return float((self.t[-1] - self.t[0]) / (self.t.size - 1))

    @property
    def heldout(self) -> np.ndarray:
        """Mask of the held-out samples."""
        return self.t > self.t_split

    @property
    def train_window(self) -> tuple[float, float]:
        """``(t_start, t_split)`` [s]."""
        return float(self.t[0]), float(self.t_split)

    def to_dict(self) -> dict[str, object]:
        return {"n": int(self.t.size), "rate_hz": 1.0 / self.dt, "duration_s": float(self.t[-1] - self.t[0]),
                "t_split": self.t_split, "n_heldout": int(self.heldout.sum()), "savgol_window": self.savgol_window,
                "savgol_order": self.savgol_order, "decimation": self.decimation, "interpolated": self.interpolated,
                "smoothed_input": self.smoothed,
                "slow_frames": int(np.count_nonzero(self.cost_out)) if self.cost_out is not None else 0}


def prepare(series: AngleSeries, *, analysis_rate_hz: float, train_fraction: float, savgol_window_s: float,
            savgol_order: int, slow_motion_px: float = 0.0) -> AnalysisData:
    """Uniform grid, decimation, Savitzky-Golay kinematics and the train/held-out split.

    Parameters
    ----------
    series : AngleSeries
        The record as read.
    analysis_rate_hz : float
        Records faster than this are decimated by the largest integer keeping at least
        this rate [1/s]; 0 keeps every sample.
    train_fraction : float
        Share of the duration fitted when judging held-out error, in (0, 1).
    savgol_window_s, savgol_order : float, int
        Savitzky-Golay filter ([kinematics] section) [s], [1].
    slow_motion_px : float
        A tracked video's frames in which the marker moves less than this leave the fits' cost
        (``[fit] slow_motion_px``, :func:`pendtrack.fitting.leastsq.samples.slow_frames`) [px]; 0: none.

    Raises
    ------
    FitError
        The record is too short for a training part and a held-out part.
    """
    t = series.t - 0.0
    theta = series.theta
    dt = float(np.median(np.diff(t)))
    n_grid = int(round((t[-1] - t[0]) / dt)) + 1
    grid = t[0] + dt * np.arange(n_grid)
    interpolated = not (t.size == n_grid and float(np.max(np.abs(t - grid))) <= UNIFORM_RTOL * dt)
    if interpolated:
        theta = np.interp(grid, t, theta)
    t = grid
    k = 1
    if analysis_rate_hz > 0:
        k = max(1, int(math.floor((1.0 / dt) / analysis_rate_hz + 1e-9)))
    t = t[::k]
    theta = np.asarray(theta[::k], dtype=float)
    h = float((t[-1] - t[0]) / (t.size - 1))
    win = window_points(savgol_window_s, h, savgol_order)
    _, omega, alpha = savgol_uniform(theta, h=h, window=win, order=savgol_order)
    t_split = float(t[0] + train_fraction * (t[-1] - t[0]))
    n_train, n_held = np.count_nonzero(t <= t_split), np.count_nonzero(t > t_split)
    if n_held < MIN_HELDOUT or n_train < MIN_TRAINING:
        raise FitError(f"record too short for a training part and a held-out part ({t.size} samples: "
                       f"{n_train} to train on and {n_held} held out at {1.0 / h:.4g} Hz; discovery needs at least "
                       f"{MIN_TRAINING} and {MIN_HELDOUT})", path=series.source)
    # the marker's motion a frame is the video's (the input's step), not the decimated grid's
    slow = slow_frames({"marker_radius_px": series.marker_radius_px, "h": dt}, omega, min_px=slow_motion_px,
                       reach=win // 2)
    return AnalysisData(t=t, theta=theta, omega=omega, alpha=alpha, t_split=t_split, savgol_window=win,
                        savgol_order=savgol_order, smoothed=series.smoothed, decimation=k,
                        interpolated=interpolated, source=str(series.source), cost_out=slow)
