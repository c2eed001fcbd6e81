"""Does a tracked point swing? Its displacement along the swing and the zero-crossing period.

A pendulum's marker goes back and forth along its arc: its positions spread along one
direction (the principal axis of the ok positions) and cross their middle again and again.
A static look-alike (a dark corner, a shadow, a poster) stays within its tracking noise; a
track that does not cross its middle (the median position) at least :data:`MIN_CROSSINGS` times shows no swing
either, and nor does a track that stays in one place for most of its frames
(:data:`MAX_STILL_SHARE`): a tracker that lost the bob and then held a static patch swung only
before it lost it. Nor does a track whose crossings come at no steady rhythm (:data:`MIN_REGULAR_SHARE`):
a tracker that took a hand, a knot and pieces of the scenery for the marker in turn crosses its middle
whenever it jumps from one to the next. Such a track is no result (:func:`swing_of_track`, used by the
track stage).

The crossings are counted with hysteresis: the displacement ``d`` (about its median) must go
from below ``-h`` to above ``+h`` (or back), ``h`` the larger of :data:`MIN_HYSTERESIS_PX`
and :data:`NOISE_SIGMAS` times the position noise (robust, from second differences).
Each crossing's time is interpolated linearly where ``d`` changes sign; the period is twice
the slope of a straight line through the crossing times against their count (every
half-period weighs alike, a missed crossing does not halve the period: a gap of more than
1.5 half-periods is counted as the half-periods it spans).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MIN_CROSSINGS = 2  # fewer crossings of the middle: no swing seen (across and back: a thing carried past crosses once)
MIN_AMPLITUDE_PX = 2.0  # a swing's displacement reaches at least this far from the middle [px]
MIN_HYSTERESIS_PX = 0.5  # the crossing hysteresis is at least this [px] ...
NOISE_SIGMAS = 4.0  # ... and this many standard deviations of the position noise
AMPLITUDE_PERCENTILE = 99.0  # the amplitude: half the spread between this and its complement (one jump is not it)
# a swinging point passes its middle quickly: within 2 px of its median position in <= 9 % of its frames on every
# real take tried (0.1-9 %), while a tracker that held a static patch after losing the bob stays there in 87-91 %
MAX_STILL_SHARE = 0.5
# a pendulum crosses its middle at a steady rhythm: on every real take tried 92-100 % of the intervals between
# crossings lie within a factor REGULAR_FACTOR of their median (synthetic swings released up to 3.13 rad, or held
# for 30 s before a 30-s swing: 80-100 %); a tracker that hopped between a hand, a knot and the scenery for 14 s:
# 1 of 4. Judged with MIN_REGULAR_INTERVALS intervals or more
REGULAR_FACTOR = 2.0
MIN_REGULAR_SHARE = 0.5
MIN_REGULAR_INTERVALS = 3


@dataclass(frozen=True)
class Swing:
    """How a track's point moves.

    Attributes
    ----------
    swings : bool
        It goes back and forth: amplitude >= :data:`MIN_AMPLITUDE_PX`, >= :data:`MIN_CROSSINGS`
        crossings, within the hysteresis band (at least :data:`MIN_AMPLITUDE_PX`) of its median
        position in at most :data:`MAX_STILL_SHARE` of its frames, and at least
        :data:`MIN_REGULAR_SHARE` of the intervals between its crossings within a factor
        :data:`REGULAR_FACTOR` of their median (:func:`regular_share`).
    reason : str
        One sentence (what it does when it does not swing).
    centre : (float, float)
        Median position [px].
    amplitude_px : float
        Half the robust spread along the principal axis [px].
    noise_px : float
        Position noise (robust standard deviation from second differences / sqrt(6)) [px].
    crossings : int
        Crossings of the middle (with hysteresis).
    period_s : float
        Zero-crossing period [s] (NaN with fewer than 3 crossings).
    """

    swings: bool
    reason: str
    centre: tuple[float, float]
    amplitude_px: float
    noise_px: float
    crossings: int
    period_s: float

    def to_dict(self) -> dict[str, object]:
        return {"swings": self.swings, "reason": self.reason, "centre_px": list(self.centre),
                "amplitude_px": self.amplitude_px, "noise_px": self.noise_px, "crossings": self.crossings,
                "period_s": self.period_s if np.isfinite(self.period_s) else None}


def crossing_times(t: np.ndarray, d: np.ndarray, *, hysteresis: float) -> np.ndarray:
    """Times [s] where ``d`` crosses 0, each after a swing beyond ``-h`` to beyond ``+h`` (or back).

    Parameters
    ----------
    t, d : ndarray
        Sample times [s] (increasing) and displacement; NaN samples are skipped.
    hysteresis : float
        ``h`` [units of d], >= 0.

    Returns
    -------
    ndarray
        Interpolated crossing times [s], increasing; a crossing inside a gap of more than
        three median sample intervals is left out.
    """
    keep = np.isfinite(t) & np.isfinite(d)
    t, d = np.asarray(t, float)[keep], np.asarray(d, float)[keep]
    out: list[float] = []
    # a sign change across a gap of lost frames has no time to interpolate: it is left out (the period counts
    # the half-periods a gap spans)
    max_step = 3.0 * float(np.median(np.diff(t))) if t.size > 1 else 0.0
    side = 0  # the side last seen beyond the hysteresis: -1, +1 (0: none yet)
    last_sign_change = -1  # index of the last sample before d changed sign since leaving that side
    for i in range(1, d.size):
        if np.sign(d[i]) != np.sign(d[i - 1]) and d[i - 1] != 0:
            last_sign_change = i - 1
        s = 1 if d[i] > hysteresis else -1 if d[i] < -hysteresis else 0
        if s == 0:
            continue
        if side != 0 and s != side and last_sign_change >= 0:
            j = last_sign_change
            if t[j + 1] - t[j] <= max_step:
                out.append(float(t[j] + (t[j + 1] - t[j]) * d[j] / (d[j] - d[j + 1])))
        if s != side or side == 0:
            side = s
            last_sign_change = -1
    return np.asarray(out, float)


def period_from_crossings(tc: np.ndarray) -> float:
    """Twice the half-period [s] of crossing times ``tc`` (a straight line through them; gaps of more than
    1.5 median half-periods count as the half-periods they span); NaN with fewer than 3."""
    if tc.size < 3:
        return float("nan")
    gaps = np.diff(tc)
    half = float(np.median(gaps))
    n = np.concatenate(([0.0], np.cumsum(np.maximum(1.0, np.round(gaps / half)))))
    slope = np.polyfit(n, tc, 1)[0]
    return float(2.0 * slope)


def regular_share(tc: np.ndarray) -> float:
    """Share of the intervals between crossing times ``tc`` [s] within a factor :data:`REGULAR_FACTOR` of
    their median [1]; NaN with fewer than :data:`MIN_REGULAR_INTERVALS` intervals.

    A swing's half-periods are alike (they change slowly as it decays; a middle off the swing's centre
    alternates a short and a long one); crossings made by a tracker jumping between objects are not.
    """
    gaps = np.diff(np.asarray(tc, float))
    if gaps.size < MIN_REGULAR_INTERVALS:
        return float("nan")
    mid = float(np.median(gaps))
    return float(np.mean((gaps >= mid / REGULAR_FACTOR) & (gaps <= REGULAR_FACTOR * mid)))


def swing_of_track(t: np.ndarray, x: np.ndarray, y: np.ndarray, ok: np.ndarray) -> Swing:
    """Does the ok part of a track swing? (see the module docstring).

    Parameters
    ----------
    t : ndarray
        Times [s].
    x, y : ndarray
        Positions [px].
    ok : ndarray of bool
        Frames to use.

    Returns
    -------
    Swing
    """
    ok = np.asarray(ok, bool) & np.isfinite(x) & np.isfinite(y)
    t, x, y = np.asarray(t, float)[ok], np.asarray(x, float)[ok], np.asarray(y, float)[ok]
    if t.size < 5:
        return Swing(False, f"only {t.size} ok frames", (float("nan"), float("nan")), 0.0, 0.0, 0, float("nan"))
    cx, cy = float(np.median(x)), float(np.median(y))
    q = np.column_stack([x - cx, y - cy])
    _, vecs = np.linalg.eigh(q.T @ q)
    d = q @ vecs[:, -1]
    lo, hi = np.percentile(d, [100 - AMPLITUDE_PERCENTILE, AMPLITUDE_PERCENTILE])
    amplitude = 0.5 * float(hi - lo)
    dd = np.diff(d, 2)
    noise = 1.4826 * float(np.median(np.abs(dd - np.median(dd)))) / np.sqrt(6.0) if dd.size else 0.0
    h = max(MIN_HYSTERESIS_PX, NOISE_SIGMAS * noise)
    # the middle: the median (the rest position of a record that comes to rest; the centre of a swing, which is
    # symmetric about it; the midrange is neither once the swing decays)
    tc = crossing_times(t, d - float(np.median(d)), hysteresis=h)
    period = period_from_crossings(tc)
    where = f"the tracked point at ({cx:.0f}, {cy:.0f}) px"
    if amplitude < max(MIN_AMPLITUDE_PX, h):
        return Swing(False, f"{where} does not swing: it moves {amplitude:.1f} px either way", (cx, cy), amplitude,
                     noise, int(tc.size), period)
    band = max(MIN_AMPLITUDE_PX, h)
    still = float(np.mean(np.hypot(x - cx, y - cy) <= band))
    if still > MAX_STILL_SHARE:
        return Swing(False, f"{where} does not swing: it stays within {band:.1f} px of one place in "
                     f"{100 * still:.0f} % of its frames (swinging {amplitude:.1f} px either way only in the others)",
                     (cx, cy), amplitude, noise, int(tc.size), period)
    if tc.size < MIN_CROSSINGS:
        return Swing(False, f"{where} does not swing back and forth: it crosses the middle of its path "
                     f"{tc.size} times (a swing needs {MIN_CROSSINGS})", (cx, cy), amplitude, noise, int(tc.size),
                     period)
    regular = regular_share(tc)
    if regular < MIN_REGULAR_SHARE:
        return Swing(False, f"{where} does not swing at a steady rhythm: only {100 * regular:.0f} % of the "
                     f"{tc.size - 1} intervals between its crossings of the middle are within a factor "
                     f"{REGULAR_FACTOR:g} of their median (a pendulum's half-periods are alike): it followed other "
                     "things in turn", (cx, cy), amplitude, noise, int(tc.size), period)
    return Swing(True, f"{where} swings {amplitude:.1f} px either way, {tc.size} crossings", (cx, cy), amplitude,
                 noise, int(tc.size), period)
