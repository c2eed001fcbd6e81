"""Cycle by cycle: where the model loses the phase, the amplitude, or the period.

A residual ``r = theta - theta_model`` over one oscillation is, to first order in the model's
error, ``r = eps theta_m + delta omega_m + c``: ``eps`` is a relative amplitude error (the
model's envelope is wrong), ``delta`` a timing error [s] (the model runs ahead or behind:
``theta_m(t) = theta(t - delta)``), ``c`` an offset. Regressing the residual on the model's
own angle and velocity, one oscillation at a time, splits it into those parts with honest
standard errors. A *persistent dephasing* is a ``delta`` series that the noise cannot explain
(chi^2 per cycle >> 1); an envelope that decays at the wrong rate is an ``eps`` series that
drifts. The period of every oscillation, measured between turning points of the data and of
the model, gives the frequency-against-amplitude law of both. Turning points are
:func:`pendtrack.kinematics.turning_points` with a hysteresis threshold.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from pendtrack.kinematics import TurningPoints


@dataclass(frozen=True)
class CycleFit:
    """Per-oscillation decomposition of the residual (see module docstring).

    Attributes
    ----------
    t_mid : ndarray
        Centre of each oscillation [s].
    period : ndarray
        Its duration (model turning points) [s].
    amplitude : ndarray
        Mean |theta| at the model's turning points within it [rad].
    eps, eps_se : ndarray
        Relative amplitude error of the model and its standard error [1].
    delta, delta_se : ndarray
        Timing error [s] (positive: the model lags the data) and standard error [s].
    phase_err : ndarray
        ``2 pi delta / period`` [rad].
    rms : ndarray
        Residual RMS over each oscillation [rad].
    coherent_fraction : float
        Share of the residual's sum of squares the per-cycle (offset, amplitude, timing)
        terms explain, minus what they would explain in white noise [1].
    phase_chi2, amp_chi2 : float
        ``mean((delta/se)^2)`` and ``mean((eps/se)^2)`` over the cycles: 1 for noise [1].
    offset, offset_se : ndarray
        The residual's mean level ``c`` per oscillation [rad] and its standard error: a
        persistent offset means theta's zero is not the rest position (or a constant
        torque), which no term of the catalogue provides.
    """

    t_mid: np.ndarray
    period: np.ndarray
    amplitude: np.ndarray
    eps: np.ndarray
    eps_se: np.ndarray
    delta: np.ndarray
    delta_se: np.ndarray
    phase_err: np.ndarray
    rms: np.ndarray
    coherent_fraction: float
    phase_chi2: float
    amp_chi2: float
    offset: np.ndarray = field(default_factory=lambda: np.zeros(0))
    offset_se: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def n_cycles(self) -> int:
        return int(self.t_mid.size)

    def to_dict(self) -> dict[str, object]:
        return {k: getattr(self, k) for k in ("t_mid", "period", "amplitude", "eps", "eps_se", "delta", "delta_se",
                                               "phase_err", "rms", "coherent_fraction", "phase_chi2", "amp_chi2",
                                               "offset", "offset_se")}


def cycle_bounds(turn_index: np.ndarray, directions: np.ndarray) -> list[tuple[int, int]]:
    """Sample ranges ``[i0, i1)`` of full oscillations, from one minimum of theta to the next."""
    starts = turn_index[directions > 0]
    return [(int(a) + 1, int(b) + 1) for a, b in zip(starts[:-1], starts[1:])]


def cycle_fit(t: np.ndarray, r: np.ndarray, theta_m: np.ndarray, omega_m: np.ndarray,
              bounds: list[tuple[int, int]], *, sigma: float) -> CycleFit:
    """Regress the residual on ``(1, theta_m, omega_m)`` over each oscillation.

    Parameters
    ----------
    t : ndarray
        Times [s].
    r : ndarray
        Residual ``theta - theta_model`` [rad].
    theta_m, omega_m : ndarray
        Model angle [rad] and angular velocity [rad/s] (noise-free, unfiltered).
    bounds : list of (int, int)
        Oscillations as sample ranges (:func:`cycle_bounds`).
    sigma : float
        White-noise level of the residual [rad] (:func:`~pendtrack.discovery.residuals.noise_sigma`);
        the standard errors assume it.
    """
    cols = {k: [] for k in ("t_mid", "period", "amplitude", "eps", "eps_se", "delta", "delta_se", "rms", "offset",
                            "offset_se")}
    ss_tot = ss_res = expected = 0.0
    for i0, i1 in bounds:
        if i1 - i0 < 8:
            continue
        x = np.column_stack((np.ones(i1 - i0), theta_m[i0:i1], omega_m[i0:i1]))
        y = r[i0:i1]
        coef, *_ = np.linalg.lstsq(x, y, rcond=None)
        try:
            cov = np.linalg.inv(x.T @ x) * sigma * sigma
        except np.linalg.LinAlgError:
            continue
        res = y - x @ coef
        ss_tot += float(y @ y)
        ss_res += float(res @ res)
        expected += 3.0 * sigma * sigma
        cols["t_mid"].append(0.5 * (t[i0] + t[i1 - 1]))
        cols["period"].append(t[i1 - 1] - t[i0])
        cols["amplitude"].append(0.5 * (np.max(theta_m[i0:i1]) - np.min(theta_m[i0:i1])))
        cols["eps"].append(coef[1])
        cols["eps_se"].append(math.sqrt(max(cov[1, 1], 0.0)))
        cols["delta"].append(coef[2])
        cols["delta_se"].append(math.sqrt(max(cov[2, 2], 0.0)))
        cols["rms"].append(math.sqrt(float(y @ y) / y.size))
        cols["offset"].append(coef[0])
        cols["offset_se"].append(math.sqrt(max(cov[0, 0], 0.0)))
    a = {k: np.asarray(v, dtype=float) for k, v in cols.items()}
    off, off_se = a.pop("offset"), a.pop("offset_se")
    if a["t_mid"].size == 0:
        nan = float("nan")
        return CycleFit(**a, phase_err=np.zeros(0), coherent_fraction=nan, phase_chi2=nan, amp_chi2=nan,
                        offset=off, offset_se=off_se)
    phase_err = 2.0 * math.pi * a["delta"] / a["period"]
    coherent = (ss_tot - ss_res - expected) / ss_tot if ss_tot > 0 else 0.0
    return CycleFit(**a, phase_err=phase_err, coherent_fraction=float(max(coherent, 0.0)),
                    phase_chi2=float(np.mean((a["delta"] / a["delta_se"]) ** 2)),
                    amp_chi2=float(np.mean((a["eps"] / a["eps_se"]) ** 2)), offset=off, offset_se=off_se)


def trend(x: np.ndarray, y: np.ndarray, se: np.ndarray | None = None) -> tuple[float, float, float]:
    """Weighted straight line ``y = a + b x``: slope, its standard error and z = slope/se.

    The standard error is scaled by the fit's reduced chi^2 when that exceeds 1 (scatter the
    given errors do not explain makes a slope less certain, never more).
    """
    if x.size < 3:
        return 0.0, float("inf"), 0.0
    w = np.ones_like(y) if se is None else 1.0 / np.maximum(se, 1e-300) ** 2
    xm = np.sum(w * x) / np.sum(w)
    ym = np.sum(w * y) / np.sum(w)
    sxx = np.sum(w * (x - xm) ** 2)
    if sxx <= 0:
        return 0.0, float("inf"), 0.0
    b = float(np.sum(w * (x - xm) * (y - ym)) / sxx)
    res = y - ym - b * (x - xm)
    chi2 = float(np.sum(w * res * res) / max(x.size - 2, 1))
    scale = chi2 if se is None else max(chi2, 1.0)
    b_se = math.sqrt(scale / sxx)
    return b, b_se, (b / b_se if b_se > 0 else 0.0)


@dataclass(frozen=True)
class FrequencyAmplitude:
    """The oscillation period against amplitude, in the data and in the model.

    Attributes
    ----------
    amplitude : ndarray
        Mean |theta| at the turning points of each data oscillation [rad].
    period_data, period_model : ndarray
        Period of the data's oscillation (between turning points of its smoothed omega) and
        of the model's oscillation nearest in time [s] (for the figure).
    mismatch_amplitude : ndarray
        Amplitude at which each precise mismatch below is measured [rad].
    mismatch, mismatch_se : ndarray
        ``(period_data - period_model) / period_model`` [1] from the drift of the model's
        timing error between consecutive oscillations (:class:`CycleFit` ``delta``), and
        its standard error. Far more precise than differencing turning-point times, whose
        noise (~1 ms) hides mismatches below 1e-3.
    slope, slope_se, slope_z : float
        Weighted straight line of the mismatch against ``sin^2(amplitude/2)`` (the
        pendulum's energy variable): slope [1], standard error, z-score. Gravity's own
        period lengthening is in both data and model, so a slope means an
        amplitude-dependent frequency shift the model lacks (added mass lowers the
        frequency at large amplitude).
    mean_mismatch : float
        Weighted average mismatch [1].
    """

    amplitude: np.ndarray
    period_data: np.ndarray
    period_model: np.ndarray
    mismatch_amplitude: np.ndarray
    mismatch: np.ndarray
    mismatch_se: np.ndarray
    slope: float
    slope_se: float
    slope_z: float
    mean_mismatch: float

    def to_dict(self) -> dict[str, object]:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


def periods(turns: TurningPoints) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Start time, period [s] and amplitude [rad] of each full oscillation (minimum to minimum)."""
    amp_at = np.abs(turns.theta)
    starts = np.flatnonzero(turns.direction > 0)
    t0, per, amp = [], [], []
    for a, b in zip(starts[:-1], starts[1:]):
        t0.append(turns.t[a])
        per.append(turns.t[b] - turns.t[a])
        amp.append(float(np.mean(amp_at[a : b + 1])))
    return np.asarray(t0), np.asarray(per), np.asarray(amp)


def frequency_amplitude(data_turns: TurningPoints, model_turns: TurningPoints,
                        cycles: CycleFit) -> FrequencyAmplitude:
    """Period against amplitude in data and model, and the model's frequency mismatch law.

    Parameters
    ----------
    data_turns, model_turns : TurningPoints
        Turning points of the data (its smoothed angle and omega) and of the model
        (:func:`pendtrack.kinematics.turning_points`).
    cycles : CycleFit
        Per-oscillation timing errors of the model (their drift is the period mismatch).
    """
    td, pd_, ad = periods(data_turns)
    tm, pm, _ = periods(model_turns)
    empty = np.zeros(0)
    amp = per_d = per_m = empty
    if td.size >= 1 and tm.size >= 2:
        j = np.clip(np.searchsorted(tm, td), 1, tm.size - 1)
        j = np.where(np.abs(tm[j - 1] - td) < np.abs(tm[j] - td), j - 1, j)
        ok = np.abs(tm[j] - td) < 0.5 * pm[j]
        amp, per_d, per_m = ad[ok], pd_[ok], pm[j][ok]
    c = cycles
    if c.n_cycles < 4:
        return FrequencyAmplitude(amp, per_d, per_m, empty, empty, empty, 0.0, float("inf"), 0.0, float("nan"))
    # the model lags by delta; it grows by (T_model - T_data) per oscillation
    mis = -(c.delta[1:] - c.delta[:-1]) / c.period[:-1]
    se = np.hypot(c.delta_se[1:], c.delta_se[:-1]) / c.period[:-1]
    a_mid = 0.5 * (c.amplitude[1:] + c.amplitude[:-1])
    slope, slope_se, z = trend(np.sin(0.5 * a_mid) ** 2, mis, se)
    w = 1.0 / se ** 2
    return FrequencyAmplitude(amplitude=amp, period_data=per_d, period_model=per_m, mismatch_amplitude=a_mid,
                              mismatch=mis, mismatch_se=se, slope=slope, slope_se=slope_se, slope_z=z,
                              mean_mismatch=float(np.sum(w * mis) / np.sum(w)))
