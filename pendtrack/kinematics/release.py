"""The hold before a release: leading samples at rest for longer than a free pendulum could stay.

A record often begins before the bob is let go: a hand or a pin holds it at an angle ``theta_h``
while the logger (Logger Pro, Tracker, an encoder) already runs. Those samples are not a free
swing, and no model of one can follow them: a standard fit of a 30-s record at 30 fps whose
first 1.5 s hold the bob at 1 rad ended 0.44 rad rms from the data ("the model does not follow
the oscillation").

A free pendulum at rest at ``theta_h`` accelerates at ``Omega0^2 |sin theta_h|`` and leaves a
band ``b`` around ``theta_h`` within ``t_free = sqrt(2 b / (Omega0^2 |sin theta_h|))``. The
leading samples are a hold when they stay within the band for longer than :data:`HOLD_FACTOR`
``t_free`` and :data:`MIN_HOLD_S`: no free swing does. A release near the top (``sin theta_h``
small) or a bob at rest at the bottom is left alone: there a long stay is what a free pendulum
does too.

The band is :data:`BAND_SIGMAS` times the noise of the held samples (from their first
differences, robustly), and at least :data:`BAND_QUANTA` times the record's smallest step (an
encoder in whole degrees holds at one value). ``Omega0`` comes from theta's strongest spectral
peak (:func:`~pendtrack.kinematics.differentiate.dominant_period`): at large amplitude it is
below the small-swing value, which only lengthens ``t_free`` (fewer holds, never more).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from pendtrack.kinematics.differentiate import dominant_period

log = logging.getLogger(__name__)

HOLD_FACTOR = 3.0  # a hold lasts longer than 3 x the time a free bob takes to leave the band
MIN_HOLD_S = 0.2  # ... and at least this long [s]: a free release's first samples never are a hold
MIN_HOLD_SAMPLES = 5  # the noise and level of a hold come from at least this many samples
BAND_SIGMAS = 6.0  # the band around the held angle, in the held samples' noise (1 in 1e9 for Gaussian noise)
BAND_QUANTA = 1.5  # ... and at least 1.5 steps of a quantised record (one step of flicker stays inside)


@dataclass(frozen=True)
class Hold:
    """A hold found at the start of a record.

    Attributes
    ----------
    n : int
        Samples before the release (the first ``n`` rows are not a free swing).
    release_s : float
        Time of the first sample after the hold [s].
    theta_h : float
        The held angle [rad].
    t_free : float
        How long a free pendulum at ``theta_h`` would stay within the band [s].
    """

    n: int
    release_s: float
    theta_h: float
    t_free: float


def _level_and_band(theta: np.ndarray, quantum: float) -> tuple[float, float]:
    """Median and band of samples at rest (MAD of first differences: a drift-free noise estimate)."""
    d = np.diff(theta)
    sigma = 1.4826 * float(np.median(np.abs(d - np.median(d)))) / math.sqrt(2.0) if d.size else 0.0
    return float(np.median(theta)), max(BAND_SIGMAS * sigma, BAND_QUANTA * quantum)


def _departure(theta: np.ndarray, level: float, band: float) -> int:
    """Index of the first of two samples in a row outside ``level +- band`` (len(theta) if none)."""
    out = np.abs(theta - level) > band
    both = out[:-1] & out[1:]
    return int(np.argmax(both)) if both.any() else theta.size


def find_hold(t: np.ndarray, theta: np.ndarray, ok: np.ndarray) -> Hold | None:
    """The hold at the start of a record, or None.

    Parameters
    ----------
    t : ndarray
        Sample times [s], increasing.
    theta : ndarray
        Angle [rad].
    ok : ndarray of bool
        Usable samples (the hold is looked for in the usable ones).

    Returns
    -------
    Hold or None
        None when the record does not start at rest, or stays there no longer than a free
        pendulum could (module docstring).
    """
    idx = np.flatnonzero(np.asarray(ok, dtype=bool) & np.isfinite(theta))
    if idx.size < 4 * MIN_HOLD_SAMPLES:
        return None
    tt, th = np.asarray(t, dtype=np.float64)[idx], np.asarray(theta, dtype=np.float64)[idx]
    steps = np.abs(np.diff(th))
    steps = steps[steps > 0]
    quantum = float(steps.min()) if steps.size else 0.0
    level, band = _level_and_band(th[:MIN_HOLD_SAMPLES], quantum)
    dep = _departure(th, level, band)
    if dep >= MIN_HOLD_SAMPLES:  # the level and noise again from the whole stretch at rest
        level, band = _level_and_band(th[:dep], quantum)
        dep = _departure(th, level, band)
    if dep < MIN_HOLD_SAMPLES or dep >= th.size - 2 * MIN_HOLD_SAMPLES or not band > 0:
        return None
    h = float(np.median(np.diff(tt)))
    period = dominant_period(th[dep:], h)
    accel = (2.0 * math.pi / period) ** 2 * abs(math.sin(level)) if math.isfinite(period) else 0.0
    if not accel > 0:
        return None
    t_free = math.sqrt(2.0 * band / accel)
    stay = float(tt[dep] - tt[0])
    if stay <= max(HOLD_FACTOR * t_free, MIN_HOLD_S):
        return None
    return Hold(n=int(idx[dep]), release_s=float(tt[dep]), theta_h=level, t_free=t_free)


def without_hold(t: np.ndarray, theta: np.ndarray, ok: np.ndarray, *, source: Any = None
                 ) -> tuple[np.ndarray, Hold | None]:
    """``ok`` with a hold's samples (:func:`find_hold`) set False, and the hold; a hold is logged, naming ``source``.

    The rows stay: nothing of the record is lost, the held samples are only not a free swing.
    """
    ok = np.asarray(ok, dtype=bool)
    hold = find_hold(np.asarray(t, dtype=np.float64), np.asarray(theta, dtype=np.float64), ok)
    if hold is None:
        return ok, None
    ok = ok.copy()
    ok[:hold.n] = False
    log.warning("%s: the bob is at rest at %.3g rad until t = %.4g s, longer than a free pendulum stays there "
                "(%.2g s): the %d samples before are a hold, not fitted", source, hold.theta_h, hold.release_s,
                hold.t_free, hold.n)
    return ok, hold
