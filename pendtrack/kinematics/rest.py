"""Samples at rest at the start of a series: how many, at what level, within what band.

The level is the samples' median and the band :data:`BAND_SIGMAS` times their noise (from their
first differences, robustly: a slow drift does not enter), and at least :data:`BAND_QUANTA` times
the series' smallest step (an encoder in whole degrees rests at one value, flickering by a step).
Used for a hold before the release and a catch at the end (:mod:`pendtrack.kinematics.free_swing`).
"""

from __future__ import annotations

import math

import numpy as np

MIN_REST_SAMPLES = 5  # the noise and level of a rest come from at least this many samples
BAND_SIGMAS = 6.0  # the band around the level, in the resting samples' noise (1 in 1e9 for Gaussian noise)
BAND_QUANTA = 1.5  # ... and at least 1.5 steps of a quantised record (one step of flicker stays inside)


def _level_and_band(theta: np.ndarray, quantum: float) -> tuple[float, float]:
    """Median and band of samples at rest (MAD of first differences: a drift-free noise estimate)."""
    d = np.diff(theta)
    sigma = 1.4826 * float(np.median(np.abs(d - np.median(d)))) / math.sqrt(2.0) if d.size else 0.0
    return float(np.median(theta)), max(BAND_SIGMAS * sigma, BAND_QUANTA * quantum)


def departure(theta: np.ndarray, level: float, band: float) -> int:
    """Index of the first of two samples in a row outside ``level +- band`` (len(theta) if none)."""
    out = np.abs(theta - level) > band
    both = out[:-1] & out[1:]
    return int(np.argmax(both)) if both.any() else theta.size


def smallest_step(theta: np.ndarray) -> float:
    """The smallest non-zero step between samples [rad]: a quantised record's quantum (0 if none)."""
    steps = np.abs(np.diff(theta))
    steps = steps[steps > 0]
    return float(steps.min()) if steps.size else 0.0


def leading_rest(theta: np.ndarray, quantum: float, first: int) -> tuple[int, float, float] | None:
    """Samples at rest at the start of ``theta``: their number, level and band, or None.

    The level and band come first from the ``first`` samples, then from all those at rest. None when
    fewer than :data:`MIN_REST_SAMPLES` are at rest, or all but a few are (a record at rest throughout
    has no swing to free).
    """
    level, band = _level_and_band(theta[:first], quantum)
    dep = departure(theta, level, band)
    if dep >= MIN_REST_SAMPLES:  # the level and noise again from the whole stretch at rest
        level, band = _level_and_band(theta[:dep], quantum)
        dep = departure(theta, level, band)
    if dep < MIN_REST_SAMPLES or dep >= theta.size - 2 * MIN_REST_SAMPLES or not band > 0:
        return None
    return dep, level, band
