"""What the model gets wrong, in numbers: every diagnostic of one fitted model on one record.

:func:`diagnose` takes the data, the model's noise-free trajectory on the same uniform grid
and its Omega0, and returns a :class:`Diagnosis`: residual whiteness, the residual's order
spectrum (lines at the oscillation frequency and its harmonics), the per-oscillation
dephasing and amplitude error, the residual envelope's trend, the frequency-amplitude law
against the model's, and the Delta-alpha(omega) hysteresis / negative damping near the
turning points. :attr:`Diagnosis.evidence` condenses them into a few z-like scores, each 0
for a model that leaves only white noise, which the catalogue's signatures read.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pendtrack.discovery.cycles import CycleFit, FrequencyAmplitude, cycle_bounds, cycle_fit, frequency_amplitude, trend
from pendtrack.discovery.hysteresis import Hysteresis, hysteresis
from pendtrack.discovery.residuals import OrderSpectrum, Whiteness, noise_sigma, order_spectrum, welch_psd, whiteness
from pendtrack.kinematics import savgol_uniform, turning_points, window_points

EVIDENCE_KEYS = ("excess_rms", "whiteness", "dephasing", "harmonic_line", "envelope", "early_envelope",
                 "frequency_amplitude", "hysteresis", "negative_damping", "offset")


NOISE_Z = 3.0  # a diagnostic is "off" when its z-like evidence exceeds this (one-sided p ~ 0.0014)
#: Limits other than :data:`NOISE_Z`: the line's power over the spectrum's floor (a periodogram
#: bin of white noise exceeds 20 with p ~ e^-20), and a residual RMS 20 % above the noise level
#: (the synthetic hidden effects are drawn at least that large).
OFF_LIMITS = {"harmonic_line": 20.0, "excess_rms": 0.2}
# relative standard error of a MAD-based sigma times sqrt(n) (normal data: sqrt(1.36) = 1.166; noise_sigma's
# first differences are correlated, which this ignores)
MAD_REL_SE = 1.166


def off_diagnostics(evidence: dict[str, float] | Any) -> list[str]:
    """The diagnostics whose evidence says the model misses something, in :data:`EVIDENCE_KEYS` order."""
    return [k for k in EVIDENCE_KEYS if float(evidence.get(k, 0.0)) > OFF_LIMITS.get(k, NOISE_Z)]


def model_phase(theta_m: np.ndarray, omega_m: np.ndarray, omega0: float) -> np.ndarray:
    """The model's phase ``phi`` with ``tan phi = A_theta/A_omega`` (eq. phasephi), unwrapped [rad]."""
    return np.unwrap(np.arctan2(np.sin(0.5 * theta_m), omega_m / (2.0 * omega0)))


@dataclass(frozen=True)
class Envelope:
    """How the residual's size evolves over the run.

    Attributes
    ----------
    t_mid, rms : ndarray
        Per-oscillation residual RMS [rad] at the oscillation's centre time [s].
    early_over_noise, late_over_noise : float
        Residual RMS over the first and last thirds of the oscillations, in units of the
        noise level [1] (1 for a correct model).
    log_slope, log_slope_z : float
        Slope of ``log(rms)`` against time [1/s] and its z-score.
    amp_trend_z : float
        z-score of a straight-line trend of the per-oscillation amplitude error ``eps``
        over the whole run.
    early_amp_trend_z : float
        The same over the first third of the oscillations only: the baseline's envelope
        decaying at the wrong rate early in the run.
    """

    t_mid: np.ndarray
    rms: np.ndarray
    early_over_noise: float
    late_over_noise: float
    log_slope: float
    log_slope_z: float
    amp_trend_z: float
    early_amp_trend_z: float

    def to_dict(self) -> dict[str, object]:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


@dataclass(frozen=True)
class Diagnosis:
    """Every diagnostic of one model on one record (see module docstring).

    Attributes
    ----------
    model : str
        Name of the diagnosed model.
    sigma : float
        White-noise level of the residual [rad].
    rms : float
        Residual RMS [rad].
    whiteness : Whiteness
    spectrum : OrderSpectrum
    psd_f, psd : ndarray
        Welch spectrum of the residual [Hz], [rad^2/Hz].
    cycles : CycleFit
    envelope : Envelope
    frequency : FrequencyAmplitude
    hysteresis : Hysteresis
    evidence : dict
        Name -> z-like score, 0 for white noise (keys :data:`EVIDENCE_KEYS`).
    """

    model: str
    sigma: float
    rms: float
    whiteness: Whiteness
    spectrum: OrderSpectrum
    psd_f: np.ndarray
    psd: np.ndarray
    cycles: CycleFit
    envelope: Envelope
    frequency: FrequencyAmplitude
    hysteresis: Hysteresis
    evidence: dict[str, float] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {"model": self.model, "sigma": self.sigma, "rms": self.rms,
                "rms_over_noise": self.rms / self.sigma if self.sigma > 0 else float("nan"),
                "evidence": dict(self.evidence), "whiteness": self.whiteness.to_dict(),
                "spectrum": self.spectrum.to_dict(), "psd": {"f": self.psd_f, "psd": self.psd},
                "cycles": self.cycles.to_dict(), "envelope": self.envelope.to_dict(),
                "frequency_amplitude": self.frequency.to_dict(), "hysteresis": self.hysteresis.to_dict()}


def _chi2_z(chi2_per_dof: float, dof: int) -> float:
    """z-score of a mean chi^2 (1 dof each) over ``dof`` terms (Wilson-Hilferty)."""
    if dof <= 0 or not math.isfinite(chi2_per_dof):
        return 0.0
    k = float(dof)
    return ((chi2_per_dof ** (1.0 / 3.0)) - (1.0 - 2.0 / (9.0 * k))) / math.sqrt(2.0 / (9.0 * k))


def _offset_z(cyc: CycleFit) -> float:
    """|z| of the weighted mean residual level over the oscillations (a zero offset of theta)."""
    if cyc.offset.size == 0:
        return 0.0
    w = 1.0 / np.maximum(cyc.offset_se, 1e-300) ** 2
    mean = float(np.sum(w * cyc.offset) / np.sum(w))
    chi2 = float(np.sum(w * (cyc.offset - mean) ** 2) / max(cyc.offset.size - 1, 1))
    return abs(mean) / math.sqrt(max(chi2, 1.0) / float(np.sum(w)))


def _envelope(cyc: CycleFit, sigma: float) -> Envelope:
    n = cyc.n_cycles
    if n < 6:
        return Envelope(cyc.t_mid, cyc.rms, float("nan"), float("nan"), 0.0, 0.0, 0.0, 0.0)
    third = max(n // 3, 3)
    early = float(np.sqrt(np.mean(cyc.rms[:third] ** 2)) / sigma)
    late = float(np.sqrt(np.mean(cyc.rms[-third:] ** 2)) / sigma)
    slope, _, z = trend(cyc.t_mid, np.log(np.maximum(cyc.rms, 1e-12)))
    _, _, amp_z = trend(cyc.t_mid, cyc.eps, cyc.eps_se)
    _, _, early_z = trend(cyc.t_mid[:third], cyc.eps[:third], cyc.eps_se[:third])
    return Envelope(cyc.t_mid, cyc.rms, early, late, slope, z, amp_z, early_z)


def diagnose(t: np.ndarray, theta: np.ndarray, theta_m: np.ndarray, omega_m: np.ndarray, omega0: float, *,
             model: str = "", savgol_window_s: float, savgol_order: int = 3, n_replicas: int = 30, seed: int = 0,
             near_fraction: float = 0.25) -> Diagnosis:
    """Diagnose a fitted model against the data.

    Parameters
    ----------
    t : ndarray
        Uniform sample times [s].
    theta : ndarray
        Measured angle [rad].
    theta_m, omega_m : ndarray
        The model's noise-free angle [rad] and angular velocity [rad/s] at ``t``.
    omega0 : float
        The model's fitted natural angular frequency [rad/s].
    model : str
        Its name (for the record).
    savgol_window_s, savgol_order : float, int
        Savitzky-Golay filter for the data's omega and alpha ([kinematics] section) [s], [1].
    n_replicas : int
        Model + white-noise replicas calibrating the kinematic diagnostics.
    seed : int
        Seed of the replicas' noise.
    near_fraction : float
        "Near a turning point" for the negative-damping count (fraction of peak speed).
    """
    t = np.asarray(t, dtype=float)
    dt = float((t[-1] - t[0]) / (t.size - 1))
    r = np.asarray(theta, dtype=float) - theta_m
    sigma = noise_sigma(r)
    sigma = sigma if sigma > 0 else float(np.std(r)) or 1e-12
    period = 2.0 * math.pi / omega0
    white = whiteness(r, dt, period_s=period)
    spec = order_spectrum(r, model_phase(theta_m, omega_m, omega0))
    f, psd = welch_psd(r, dt)

    # the kinematics stage's window rule, so data and model are filtered as kinematics.parquet is
    win = window_points(savgol_window_s, dt, savgol_order)
    kin_d = savgol_uniform(theta, h=dt, window=win, order=savgol_order)
    kin_m = savgol_uniform(theta_m, h=dt, window=win, order=savgol_order)
    rng = np.random.default_rng(seed)
    replicas = [savgol_uniform(theta_m + rng.normal(0.0, sigma, theta_m.size), h=dt, window=win, order=savgol_order)
                for _ in range(max(n_replicas, 2))]
    # hysteresis on omega: a few noise sd of the filtered omega, and 2 % of the peak speed
    w_noise = float(np.std(replicas[0][1] - kin_m[1]))
    thr_m = 0.02 * float(np.max(np.abs(omega_m)))
    turns_m = turning_points(t, theta_m, omega_m, threshold=max(thr_m, 1e-9))
    turns_d = turning_points(t, kin_d[0], kin_d[1], threshold=max(4.0 * w_noise, thr_m))
    bounds = cycle_bounds(turns_m.index, turns_m.direction)
    cyc = cycle_fit(t, r, theta_m, omega_m, bounds, sigma=sigma)
    env = _envelope(cyc, sigma)
    freq = frequency_amplitude(turns_d, turns_m, cyc)
    hyst = hysteresis(t, kin_d, kin_m, replicas, omega0, bounds, near_fraction=near_fraction,
                      sigma_rel_se=MAD_REL_SE / math.sqrt(max(r.size - 1, 1)))

    rms = float(np.sqrt(np.mean(r * r)))
    n = cyc.n_cycles
    evidence = {
        "excess_rms": rms / sigma - 1.0,
        "whiteness": max(-white.runs_z, _chi2_z(white.ljung_box_q / max(white.ljung_box_lags, 1),
                                                 white.ljung_box_lags)),
        "dephasing": _chi2_z(cyc.phase_chi2, n),
        "harmonic_line": float(np.nanmax(spec.snr)) if np.isfinite(spec.snr).any() else 0.0,
        "envelope": max(_chi2_z(cyc.amp_chi2, n), abs(env.amp_trend_z)),
        "early_envelope": abs(env.early_amp_trend_z),
        "frequency_amplitude": abs(freq.slope_z),
        "hysteresis": abs(hyst.area_z),
        "negative_damping": hyst.nd_z,
        "offset": _offset_z(cyc),
    }
    evidence = {k: float(v) if math.isfinite(v) else 0.0 for k, v in evidence.items()}
    return Diagnosis(model=model, sigma=sigma, rms=rms, whiteness=white, spectrum=spec, psd_f=f, psd=psd,
                     cycles=cyc, envelope=env, frequency=freq, hysteresis=hyst, evidence=evidence)
