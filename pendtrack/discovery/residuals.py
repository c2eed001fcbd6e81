"""Is the residual noise? Whiteness tests and spectra of ``r = theta - theta_model``.

A model that captures the physics leaves a residual that is measurement noise: no
autocorrelation, as many sign changes as a coin gives, a flat spectrum. A missing effect
leaves structure; a *persistent dephasing* (the paper's complaint about the classic model,
section "Classic model results") is a coherent line at the oscillation frequency, which
:func:`order_spectrum` finds even while the frequency drifts with the amplitude (it
resamples the residual on the model's own phase, so a line stays a line).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import stats

# 1.4826 * MAD is the standard deviation of a Gaussian; diff() doubles white-noise variance.
_MAD_TO_SIGMA = 1.4826


def noise_sigma(r: np.ndarray) -> float:
    """White-noise level of a residual, robust to smooth model errors [same unit as ``r``].

    The first difference removes slowly varying structure (model error lives at the
    oscillation frequency, far below the sampling rate) and doubles the variance of white
    noise, so ``sigma = 1.4826 MAD(diff r) / sqrt(2)``.

    Parameters
    ----------
    r : ndarray
        Residual series [rad], uniformly sampled.
    """
    d = np.diff(np.asarray(r, dtype=float))
    if d.size == 0:
        return 0.0
    return float(_MAD_TO_SIGMA * np.median(np.abs(d - np.median(d))) / math.sqrt(2.0))


def autocorrelation(r: np.ndarray, max_lag: int) -> np.ndarray:
    """Sample autocorrelation ``rho_k`` for lags ``0..max_lag`` [1] (``rho_0 = 1``).

    Biased estimator (divides by ``n``), computed by FFT.
    """
    x = np.asarray(r, dtype=float) - float(np.mean(r))
    n = x.size
    max_lag = int(min(max_lag, n - 1))
    size = 1 << int(math.ceil(math.log2(2 * n)))
    f = np.fft.rfft(x, size)
    acov = np.fft.irfft(f * np.conj(f), size)[: max_lag + 1] / n
    return acov / acov[0] if acov[0] > 0 else np.zeros(max_lag + 1)


def effective_n(r: np.ndarray, *, max_lag: int | None = None) -> float:
    """Number of independent samples a correlated series is worth [1].

    ``n / (1 + 2 sum_k rho_k)`` with the sum over the initial positive sequence of the
    autocorrelation (Geyer's rule), so that white noise gives ``n`` and a smooth residual
    far fewer. Used to judge held-out gains on real data whose noise is not white.
    """
    n = int(np.asarray(r).size)
    if n < 4:
        return float(n)
    rho = autocorrelation(r, max_lag or min(n - 1, 2000))
    s = 0.0
    for k in range(1, rho.size - 1, 2):
        pair = rho[k] + rho[k + 1]
        if pair <= 0:
            break
        s += pair
    return float(max(1.0, n / (1.0 + 2.0 * s)))


def heldout_test(theta: np.ndarray, pred_a: np.ndarray, pred_b: np.ndarray) -> tuple[float, float]:
    """Test-sample RMS gain of prediction ``b`` over ``a`` and its z against noise.

    The statistic of :mod:`pendtrack.discovery.rules`'s held-out rule (its docstring derives
    it) and of the interleaved folds (:mod:`pendtrack.discovery.interleaved`).

    Parameters
    ----------
    theta : ndarray
        Held-out data [rad].
    pred_a, pred_b : ndarray
        Current and candidate predictions at the same samples [rad].

    Returns
    -------
    gain : float
        ``rms(theta - a) - rms(theta - b)`` [rad].
    z : float
        Significance of the mean-square gain [1].
    """
    if not (np.all(np.isfinite(pred_a)) and np.all(np.isfinite(pred_b))):
        return (-math.inf if not np.all(np.isfinite(pred_b)) else math.inf), (
            -math.inf if not np.all(np.isfinite(pred_b)) else math.inf)
    e_a = theta - pred_a
    e_b = theta - pred_b
    ms_a = float(np.mean(e_a * e_a))
    ms_b = float(np.mean(e_b * e_b))
    gain = math.sqrt(ms_a) - math.sqrt(ms_b)
    delta = pred_b - pred_a
    md2 = float(np.mean(delta * delta))
    if md2 <= 0:
        return gain, 0.0
    sd = 2.0 * math.sqrt(ms_b * md2 / effective_n(e_b))
    return gain, (ms_a - ms_b) / sd



@dataclass(frozen=True)
class Whiteness:
    """Whiteness of a residual.

    Attributes
    ----------
    lags_s : ndarray
        Lags at which the autocorrelation is reported [s].
    acf : ndarray
        Autocorrelation at those lags [1]; white noise gives ``|acf| < 2/sqrt(n)``.
    acf_band : float
        ``2/sqrt(n)``, the 95 % band of white noise [1].
    ljung_box_q, ljung_box_p : float
        Ljung-Box statistic over the first ``ljung_box_lags`` lags and its p-value.
    ljung_box_lags : int
    runs, runs_expected, runs_z, runs_p : float
        Wald-Wolfowitz runs test on the signs of ``r - median(r)``: observed and expected
        number of runs, z-score (negative: too few sign changes, i.e. structure) and
        two-sided p-value.
    """

    lags_s: np.ndarray
    acf: np.ndarray
    acf_band: float
    ljung_box_q: float
    ljung_box_p: float
    ljung_box_lags: int
    runs: float
    runs_expected: float
    runs_z: float
    runs_p: float

    @property
    def white(self) -> bool:
        """Both tests accept whiteness at the 1 % level."""
        return self.ljung_box_p > 0.01 and self.runs_p > 0.01

    def to_dict(self) -> dict[str, object]:
        return {"lags_s": self.lags_s, "acf": self.acf, "acf_band": self.acf_band,
                "ljung_box_q": self.ljung_box_q, "ljung_box_p": self.ljung_box_p,
                "ljung_box_lags": self.ljung_box_lags, "runs": self.runs, "runs_expected": self.runs_expected,
                "runs_z": self.runs_z, "runs_p": self.runs_p, "white": self.white}


def runs_test(r: np.ndarray) -> tuple[float, float, float, float]:
    """Wald-Wolfowitz runs test on the signs of ``r - median(r)``.

    Returns
    -------
    runs, expected, z, p : float
        Number of runs, its expectation under randomness, z-score, two-sided p-value.
    """
    x = np.asarray(r, dtype=float)
    s = x > np.median(x)
    n1 = float(np.count_nonzero(s))
    n2 = float(s.size - n1)
    n = n1 + n2
    runs = float(1 + np.count_nonzero(s[1:] != s[:-1]))
    if n1 == 0 or n2 == 0:
        return runs, runs, 0.0, 1.0
    mu = 2.0 * n1 * n2 / n + 1.0
    var = 2.0 * n1 * n2 * (2.0 * n1 * n2 - n) / (n * n * (n - 1.0))
    z = (runs - mu) / math.sqrt(var) if var > 0 else 0.0
    return runs, mu, z, float(2.0 * stats.norm.sf(abs(z)))


def whiteness(r: np.ndarray, dt: float, *, period_s: float, ljung_box_lags: int = 20) -> Whiteness:
    """Autocorrelation at short lags and at fractions of the period, Ljung-Box and runs test.

    Parameters
    ----------
    r : ndarray
        Residual [rad], uniformly sampled.
    dt : float
        Sampling interval [s].
    period_s : float
        Small-angle period ``2 pi / Omega0`` [s]; lags of 1/4, 1/2 and 1 period are reported.
    ljung_box_lags : int
        Lags in the Ljung-Box sum.
    """
    n = int(r.size)
    lag_samples = sorted({1, 2, 5, 10, *(max(1, int(round(f * period_s / dt))) for f in (0.25, 0.5, 1.0))})
    lag_samples = [k for k in lag_samples if k < n]
    rho = autocorrelation(r, max(max(lag_samples), ljung_box_lags))
    h = min(ljung_box_lags, rho.size - 1)
    k = np.arange(1, h + 1)
    q = float(n * (n + 2) * np.sum(rho[1 : h + 1] ** 2 / (n - k)))
    p = float(stats.chi2.sf(q, h))
    runs, mu, z, p_runs = runs_test(r)
    return Whiteness(lags_s=np.asarray(lag_samples) * dt, acf=rho[lag_samples], acf_band=2.0 / math.sqrt(n),
                     ljung_box_q=q, ljung_box_p=p, ljung_box_lags=h, runs=runs, runs_expected=mu, runs_z=z,
                     runs_p=p_runs)


@dataclass(frozen=True)
class OrderSpectrum:
    """Residual power against *order* (multiples of the instantaneous oscillation frequency).

    Attributes
    ----------
    orders : ndarray
        Order axis [1]: 1 is the oscillation frequency, 2 and 3 its harmonics.
    power : ndarray
        Residual power per order bin [rad^2] (periodogram, one-sided).
    harmonics : ndarray
        The orders examined (1, 2, 3, ...).
    line_power : ndarray
        Power in the bin nearest each harmonic [rad^2].
    floor : ndarray
        Median power of the bins around each harmonic (the noise floor there) [rad^2].
    snr : ndarray
        ``line_power / floor`` [1]; for noise it is exponentially distributed with mean ~1.44
        (median-normalised), so values above ~20 are lines (p < 1e-6 per harmonic).
    n_cycles : float
        Oscillations covered [1].
    """

    orders: np.ndarray
    power: np.ndarray
    harmonics: np.ndarray
    line_power: np.ndarray
    floor: np.ndarray
    snr: np.ndarray
    n_cycles: float

    def to_dict(self) -> dict[str, object]:
        return {"orders": self.orders, "power": self.power, "harmonics": self.harmonics,
                "line_power": self.line_power, "floor": self.floor, "snr": self.snr, "n_cycles": self.n_cycles}


def order_spectrum(r: np.ndarray, phase: np.ndarray, *, n_harmonics: int = 3, per_cycle: int = 16,
                   max_order: float = 6.0) -> OrderSpectrum:
    """Spectrum of the residual resampled uniformly in the oscillation phase.

    Parameters
    ----------
    r : ndarray
        Residual [rad].
    phase : ndarray
        The model's phase ``phi`` (eq. phasephi), unwrapped and non-decreasing [rad], at the
        same samples.
    n_harmonics : int
        Harmonics to examine.
    per_cycle : int
        Resampling points per oscillation (per 2 pi of phase).
    max_order : float
        Highest order kept in the returned spectrum (the figure's x range).
    """
    phi = np.maximum.accumulate(np.asarray(phase, dtype=float))
    n_cycles = (phi[-1] - phi[0]) / (2.0 * math.pi)
    harmonics = np.arange(1, n_harmonics + 1, dtype=float)
    if n_cycles < 4:
        empty = np.zeros(0)
        nan = np.full(n_harmonics, np.nan)
        return OrderSpectrum(empty, empty, harmonics, nan, nan, nan, float(n_cycles))
    m = int(n_cycles * per_cycle)
    grid = phi[0] + (np.arange(m) + 0.5) * (phi[-1] - phi[0]) / m
    keep = np.concatenate(([True], np.diff(phi) > 0))
    x = np.interp(grid, phi[keep], np.asarray(r, dtype=float)[keep])
    x = x - x.mean()
    spec = np.abs(np.fft.rfft(x * np.hanning(m))) ** 2 * (2.0 / (m * np.sum(np.hanning(m) ** 2) / m)) / m
    orders = np.fft.rfftfreq(m, d=1.0 / per_cycle)
    line = np.empty(n_harmonics)
    floor = np.empty(n_harmonics)
    for i, k in enumerate(harmonics):
        j = int(np.argmin(np.abs(orders - k)))
        lo, hi = np.searchsorted(orders, [k - 0.45, k + 0.45])
        band = np.r_[spec[lo : max(lo, j - 2)], spec[j + 3 : hi]]
        line[i] = spec[max(0, j - 1) : j + 2].max()
        floor[i] = float(np.median(band)) if band.size else np.nan
    keep_o = orders <= max_order
    return OrderSpectrum(orders=orders[keep_o], power=spec[keep_o], harmonics=harmonics, line_power=line,
                         floor=floor, snr=line / floor, n_cycles=float(n_cycles))


def welch_psd(r: np.ndarray, dt: float, *, segment_s: float = 16.0) -> tuple[np.ndarray, np.ndarray]:
    """Welch power spectral density of the residual (for the figure).

    Returns
    -------
    f, psd : ndarray
        Frequency [Hz] and one-sided PSD [rad^2/Hz].
    """
    from scipy.signal import welch

    nper = int(min(r.size, max(16, round(segment_s / dt))))
    return welch(np.asarray(r, dtype=float), fs=1.0 / dt, nperseg=nper)
