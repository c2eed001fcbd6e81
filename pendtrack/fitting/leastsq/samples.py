"""The record a fit sees: usable samples, checks, and their :class:`FitProblem` on the simulation grid.

Pure functions of arrays. :class:`Record` bundles what the data are (times, angle, angular
velocity, optional acceleration and ok flags, the fit window, the filter that made them);
:func:`build_problem` maps its usable samples onto the uniform simulation grid;
:func:`check_record` runs the checks a fit makes before any fitting, alone.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pendtrack.config import MEMORY_S
from pendtrack.errors import FitError
from pendtrack.fitting.leastsq.cost import Observation
from pendtrack.fitting.leastsq.equation_error import DataSummary, summarize
from pendtrack.fitting.leastsq.problem import FitProblem, Simulator, parameter_bounds

GRID_TOL = 1e-3  # data times may deviate from the uniform grid by this fraction of a step
# slow frames leave the cost, the slowest first, only while at least this share of the samples stays in it
# (slow_frames): at 3 px a frame the 8 renders of a series (640x360) would keep 50-53 %, a 0.25-rad swing 0 %
MIN_COST_SHARE = 0.5



def axle_shares(extra: dict[str, Any]) -> dict[str, float]:
    """A kinematics file's axle shares as :class:`Record`'s ``theta_scale_rel`` [1] and ``zero_sigma_rad`` [rad].

    ``extra`` is the file's provenance extra; a share it does not hold, or holds as no positive
    finite number (a given axle, a table), is 0.
    """
    out = {}
    for key in ("theta_scale_rel", "zero_sigma_rad"):
        v = extra.get(key)
        ok = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v > 0
        out[key] = float(v) if ok else 0.0
    return out

def slow_frames(extra: dict[str, Any], omega: np.ndarray, *, min_px: float, reach: int = 0) -> np.ndarray | None:
    """The frames of a tracked video in which the marker moved less than ``min_px`` pixels.

    A compressed video codes a slow marker's motion short: where it moves a few pixels a frame or less (the
    turning points), the encoder's motion compensation drops part of the difference and the tracked marker
    sticks (a render at crf 20 reads each turning point 0.3-1.1 mrad short, one frame late, and frames moving
    1-3 px still 0.4 mrad short on average, 0.2 at 3-8 px). Left out of a fit's cost
    (:attr:`Record.cost_out`), they and every sample whose filter window reaches them no longer pull the
    damping, nor Omega0 through the amplitude read short (docs/decisions.md, 2026-12-02).

    The record's first slow frames (a release from rest) stay in the cost: the fit's initial state is then at
    the release, where discovery's predictions start. A record slow throughout has no release.

    The slowest frames leave first, and at most so many that :data:`MIN_COST_SHARE` of the samples stay: a
    swing slow throughout (a small amplitude, a marker near the axle) would otherwise leave the cost a few
    fast samples each half-period, too few to fix the damping (a 0.25-rad render with every frame under
    1 px out: 82 % out, C0 17 standard errors off, p 44). Where ``min_px`` would leave fewer, the threshold
    is lowered until that share stays, so a swing a little slower loses a little less, never all of its
    protection at once.

    Parameters
    ----------
    extra : dict
        The kinematics file's provenance extra: ``marker_radius_px`` (the marker's distance from the axle
        [px], from the angle stage's circle) and ``h`` (the frame interval [s]). Without them (a table, a
        given axle, an older file) there are none.
    omega : ndarray
        Angular velocity of each sample [rad/s].
    min_px : float
        [px]; 0: none.
    reach : int
        Samples on each side of a slow frame that leave the cost with it (the filter's half window,
        :attr:`Observation.trim`).

    Returns
    -------
    ndarray of bool or None
        True for a slow frame; None when there are none to leave out.
    """
    radius, h = extra.get("marker_radius_px"), extra.get("h")
    numbers = all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v > 0
                  for v in (radius, h))
    if not (min_px > 0 and numbers):
        return None
    speed = np.abs(np.asarray(omega, dtype=float)) * float(radius) * float(h)  # [px per frame]

    def below(px: float) -> tuple[np.ndarray, float]:
        """The frames slower than ``px`` (a release from rest kept) and the share of samples they leave."""
        slow = speed < px
        # a release from rest stays: the fit's initial state is the release's (discovery simulates every fit
        # from the record's first sample), and a marker starting from rest lags by a frame once, which that
        # state absorbs
        if not slow.all():  # (a record slow throughout has no release: its frames are all slow)
            slow[: int(np.argmax(~slow))] = False
        reached = np.convolve(slow.astype(np.int64), np.ones(2 * reach + 1, np.int64), mode="same") > 0
        return slow, 1.0 - float(reached.mean())

    slow, kept = below(min_px)
    if kept < MIN_COST_SHARE:
        # the largest lower threshold (one of the samples' own speeds) that keeps the share: the kept share
        # only grows as the threshold falls, so bisect over the sorted speeds below min_px
        levels = np.unique(speed[np.isfinite(speed) & (speed < min_px)])
        lo, hi = 0, levels.size  # below(levels[0]) leaves nothing out: it always keeps the share
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if below(float(levels[mid]))[1] >= MIN_COST_SHARE:
                lo = mid
            else:
                hi = mid
        slow, kept = below(float(levels[lo])) if levels.size else (np.zeros(speed.size, bool), 1.0)
    return slow if slow.any() else None


@dataclass(frozen=True, eq=False)
class Record:
    """The data of one fit.

    Attributes
    ----------
    t : ndarray
        Sample times [s], uniformly spaced (samples may be missing or flagged).
    theta : ndarray
        Measured angle [rad] (in ``kinematics.parquet``: Savitzky-Golay smoothed).
    omega : ndarray
        Measured angular velocity [rad/s] (Savitzky-Golay derivative).
    alpha : ndarray or None
        Measured angular acceleration [rad/s^2], used only for the estimates; None:
        ``gradient(omega, t)``.
    ok : ndarray of bool or None
        Usable samples (None: every finite one).
    window : (float, float) or None
        Only samples with ``window[0] <= t <= window[1]`` enter the fit [s].
    observation : Observation
        How the data were filtered (the model is filtered alike).
    source : str
        Name of the data in error messages.
    theta_scale_rel, zero_sigma_rad : float
        How well the axle the angle was measured about fixes theta's scale [1] and zero [rad]
        (the angle stage's ``axle_uncertainty``; 0: not known or exact). The residuals cannot show
        either: every sample carries the same error. The joint fit adds their shares to its
        covariance; the single fit takes the scale as ``theta_scale_rel``.
    cost_out : ndarray of bool or None
        Samples left out of the cost, with every sample whose filter window reaches one
        (:func:`slow_frames`); the model-free estimates still use them. None: none.
    """

    t: np.ndarray
    theta: np.ndarray
    omega: np.ndarray
    alpha: np.ndarray | None = None
    ok: np.ndarray | None = None
    window: tuple[float, float] | None = None
    observation: Observation = field(default_factory=Observation)
    source: str = "the data"
    theta_scale_rel: float = 0.0
    zero_sigma_rad: float = 0.0
    cost_out: np.ndarray | None = None

    def __post_init__(self) -> None:
        for name in ("t", "theta", "omega"):
            object.__setattr__(self, name, np.asarray(getattr(self, name), dtype=float))
        if self.alpha is not None:
            object.__setattr__(self, "alpha", np.asarray(self.alpha, dtype=float))
        elif self.t.shape == self.omega.shape and self.t.ndim == 1:  # else usable() names the problem
            object.__setattr__(self, "alpha", np.gradient(self.omega, self.t))

    def usable(self) -> np.ndarray:
        """Mask of the samples that enter the fit: finite (alpha too), ok, inside the window."""
        mask = usable_mask(self.t, self.theta, self.omega, self.ok, self.window, self.source)
        return mask & np.isfinite(np.asarray(self.alpha, dtype=float))

    def cost_mask(self) -> np.ndarray:
        """:meth:`usable` less :attr:`cost_out`: the samples whose residuals enter the cost."""
        mask = self.usable()
        if self.cost_out is None:
            return mask
        out = np.asarray(self.cost_out, dtype=bool)
        if out.shape != mask.shape:
            raise FitError(f"cost_out has shape {out.shape}, expected {mask.shape}", path=self.source)
        return mask & ~out

    def summary(self, *, bias_corrected: bool = True) -> DataSummary:
        """Model-free facts of the usable samples (:func:`pendtrack.fitting.leastsq.equation_error.summarize`).

        With ``bias_corrected`` the Omega0 estimate is corrected for the record's
        Savitzky-Golay filter (``observation``).
        """
        mask = self.usable()
        moments = None
        obs = self.observation
        if bias_corrected and obs.savgol_window:
            from pendtrack.kinematics.analysis import savgol_bias_moments

            h_data = float(np.median(np.diff(self.t[mask]))) if mask.sum() > 1 else 1.0
            moments = savgol_bias_moments(obs.savgol_window, obs.savgol_order, h_data)
        return summarize(self.t[mask], self.theta[mask], self.omega[mask], self.alpha[mask], sg_moments=moments,
                         source=self.source)


def usable_mask(t: np.ndarray, theta: np.ndarray, omega: np.ndarray, ok: np.ndarray | None,
                window: tuple[float, float] | None, source: str) -> np.ndarray:
    """Finite, ok samples inside ``window``; FitError if there are none or the shapes disagree."""
    if not (t.shape == theta.shape == omega.shape) or t.ndim != 1:
        raise FitError(f"t, theta and omega must be 1-D arrays of one length, got {t.shape}, {theta.shape}, "
                       f"{omega.shape}", path=source)
    mask = np.isfinite(t) & np.isfinite(theta) & np.isfinite(omega)
    if ok is not None:
        ok = np.asarray(ok, dtype=bool)
        if ok.shape != t.shape:
            raise FitError(f"ok has shape {ok.shape}, expected {t.shape}", path=source)
        if not ok.any():
            raise FitError("no usable samples: every sample is flagged not ok", path=source)
        mask &= ok
    if window is not None:
        a, b = window
        mask &= (t >= a) & (t <= b)
    if not mask.any():
        raise FitError("no usable samples in the fit window", path=source)
    return mask


def grid_index(t: np.ndarray, h: float, source: str) -> np.ndarray:
    """Grid index of each time ``t`` on the grid ``t[0] + k h``; FitError if they are not on one."""
    k = np.rint((t - t[0]) / h).astype(np.int64)
    dev = np.max(np.abs(t - t[0] - k * h)) if t.size else 0.0
    if dev > GRID_TOL * h or np.any(np.diff(k) <= 0):
        raise FitError(f"time stamps are not on a uniform grid (off by up to {dev:.3g} s with step {h:.6g} s)",
                       path=source)
    return k


def interior(index: np.ndarray, n_grid: int, trim: int) -> np.ndarray:
    """Samples whose filter window lies on present samples only (no gap, no window edge)."""
    if trim == 0:
        return np.ones(index.size, bool)
    present = np.zeros(n_grid, np.int64)
    present[index] = 1
    csum = np.concatenate(([0], np.cumsum(present)))
    lo = index - trim
    hi = index + trim + 1
    inside = (lo >= 0) & (hi <= n_grid)
    full = np.zeros(index.size, bool)
    full[inside] = (csum[hi[inside]] - csum[lo[inside]]) == 2 * trim + 1
    return full


def build_problem(model: Any, t: np.ndarray, theta: np.ndarray, omega: np.ndarray, *, ok: np.ndarray | None = None,
                  window: tuple[float, float] | None = None, cost: str = "xi2", omega0_hat: float,
                  observation: Observation | None = None, memory_s: float = MEMORY_S,
                  full_history: bool = False, simulator: Simulator | None = None, method: str = "auto",
                  source: str = "the data", max_step_s: float | None = None, jacobian_method: str = "fd",
                  substep_phase: float = 0.0, steer_phase: float = 0.0, rung_phase: float = 0.0,
                  theta_zero: float = 0.0) -> FitProblem:
    """The :class:`FitProblem` of a record (usable samples mapped onto the simulation grid).

    Parameters
    ----------
    model : Model
    t, theta, omega, ok, window, observation, source
        As in :class:`Record`.
    cost : {"xi2", "theta"}
    omega0_hat : float
        Fixes the A_omega scale of Xi^2 [rad/s].
    memory_s : float
        Grunwald-Letnikov memory [s]; ``full_history``: the sum over the whole record.
    max_step_s : float, optional
        Largest predictor-corrector step [s] (``[models] max_step_s``; None: its default).
    simulator, method
        As in :func:`pendtrack.fitting.fit_model`.
    jacobian_method : {"fd", "sensitivity"}
        :attr:`FitProblem.jacobian_method` (``[fit] jacobian``; the estimate step passes the options' value).
    substep_phase, steer_phase, rung_phase : float
        :attr:`FitProblem.substep_phase`, :attr:`FitProblem.steer_phase`, :attr:`FitProblem.rung_phase`
        (``[fit]`` keys of those names) [rad].
    theta_zero : float
        The data's angle of the model's theta = 0 [rad]: the estimated ``theta_off`` of a model with the
        offset term, else 0. ``theta0`` is bounded within 1 rad of the first sample less it.
    """
    t = np.asarray(t, dtype=float)
    theta = np.asarray(theta, dtype=float)
    omega = np.asarray(omega, dtype=float)
    mask = usable_mask(t, theta, omega, ok, window, source)
    obs = observation or Observation()
    h = float(np.median(np.diff(t[np.isfinite(t)])))
    tu = t[mask]
    index = grid_index(tu, h, source)
    n_grid = int(index[-1]) + 1
    keep = interior(index, n_grid, obs.trim)
    lower, upper = parameter_bounds(model, float(tu[0]))
    # samples every h cannot show an oscillation faster than their Nyquist frequency pi/h (it aliases to a slower
    # one); above it the RK4 sub-steps (Omega h_sub <= substep_phase) grow without bound: a start that ran off to
    # Omega0 = 2e4 rad/s on a 30 fps record took 15172 sub-steps a sample, and its fit half an hour
    names = list(model.param_names)
    if "Omega0" in names:
        j = names.index("Omega0")
        upper[j] = min(upper[j], np.pi / h)
    th_init = float(theta[mask][0]) - float(theta_zero)
    om_init = float(omega[mask][0])
    lower = np.concatenate((lower, [th_init - 1.0, om_init - 2.0 * omega0_hat]))
    upper = np.concatenate((upper, [th_init + 1.0, om_init + 2.0 * omega0_hat]))
    return FitProblem(model=model, t_start=float(tu[0]), h=h, n_grid=n_grid, index=index[keep],
                      theta=theta[mask][keep], omega=omega[mask][keep], cost=cost,
                      omega_scale=1.0 / (2.0 * omega0_hat), observation=obs, memory_s=float(memory_s),
                      method=method, lower=lower, upper=upper, simulator=simulator, full_history=full_history,
                      max_step_s=max_step_s, jacobian_method=jacobian_method, substep_phase=float(substep_phase),
                      steer_phase=float(steer_phase), rung_phase=float(rung_phase))


def uniform_series(problem: FitProblem, t: np.ndarray, series: list[np.ndarray],
                   mask: np.ndarray) -> tuple[np.ndarray, list[np.ndarray], np.ndarray]:
    """Series on the whole simulation grid, gaps filled by linear interpolation; and which points are data."""
    grid = problem.grid()
    tu = t[mask]
    filled = [np.interp(grid, tu, s[mask]) for s in series]
    present = np.zeros(grid.size, bool)
    # the mask may reach beyond the cost's samples (Record.cost_out), on which the grid starts and ends
    k = np.rint((tu - problem.t_start) / problem.h).astype(np.int64)
    present[k[(k >= 0) & (k < grid.size)]] = True
    return grid, filled, present


def check_record(t: np.ndarray, theta: np.ndarray, omega: np.ndarray, *, alpha: np.ndarray | None = None,
                 ok: np.ndarray | None = None, window: tuple[float, float] | None = None,
                 source: str = "the data") -> DataSummary:
    """The checks :func:`pendtrack.fitting.fit_model` makes before any fitting, alone (cheap).

    Raises
    ------
    FitError
        The record cannot support a fit (no usable sample, too few, no oscillation).
    """
    rec = Record(t, theta, omega, alpha=alpha, ok=ok, window=window, source=source)
    return rec.summary(bias_corrected=False)
