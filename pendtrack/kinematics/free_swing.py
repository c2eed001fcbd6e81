"""Where the free swing begins and ends: a hold before the release, a catch at the end.

A record often begins before the bob is let go: a hand or a pin holds it at an angle ``theta_h``
while the logger (Logger Pro, Tracker, an encoder) already runs. And it often ends after the bob
is caught: the hand stops it and the logger runs on. Neither is a free swing, and no model of one
can follow them: a standard fit of a 30-s record at 30 fps whose first 1.5 s hold the bob at 1 rad
ended 0.44 rad rms from the data; one whose last 3 s hold it at rest after a 0.5-rad swing, 0.18 rad.

**The hold.** A free pendulum at rest at ``theta_h`` accelerates at ``Omega0^2 |sin theta_h|`` and
leaves a band ``b`` around ``theta_h`` within ``t_free = sqrt(2 b / (Omega0^2 |sin theta_h|))``. The
leading samples are a hold when they stay within the band for longer than :data:`HOLD_FACTOR`
``t_free`` and :data:`MIN_HOLD_S`: no free swing does. A release near the top (``sin theta_h``
small) or a bob at rest at the bottom is left alone: there a long stay is what a free pendulum
does too. The hold ends where the bob moves away as one let go does (:func:`_released`):
a tracker's jump by a pixel while the bob is held does not end it.

**The catch.** The trailing samples at rest (within a band, for at least :data:`MIN_HOLD_S`, a
period, and :data:`HOLD_FACTOR` times the time a free bob of the swing's amplitude stays within it
at a turning point, where a record may end) are a catch when the bob swung just before with an amplitude ``A`` that its own damping could not have
taken away within half a period: ``A`` above :data:`CATCH_FACTOR` times the amplitude it lost per
half period over the periods before, and above :data:`CATCH_BANDS` bands. A pendulum that comes to
rest by itself does not: Coulomb friction stops it once its amplitude is below one half period's
loss, and viscous or quadratic drag lets it fade into the band. The catch's half period before the
rest goes too (the hand takes part of a swing, which is no free swing either).

**The lift.** A record may also begin while a hand still carries the bob up (an encoder's logger that
starts when the bob passes an angle on its way up): the bob moves away from the bottom and reaches its
first turning point, where the hand lets go, with more energy ``omega^2/2 + Omega0^2 (1 - cos theta)``
than it had at the first sample. No free swing gains energy: damping only takes it away. The samples
before that turning point are a lift when its energy exceeds the first sample's by more than
:data:`LIFT_RISE`; the first sample's speed comes from a quadratic through the first tenth of a period.
``Omega0`` from the spectral peak errs by at most half a frequency bin, 1/(2 N) of a record of N
periods; the test needs :data:`LIFT_MIN_PERIODS` periods, where that error raises the ratio of the two
energies by at most 17 %, and a bob swinging freely from the first sample cannot gain 30 %.

**A drive.** No free swing gains energy after its release, so a record whose swing grows is not
one: a motor or a hand drives it (a controller's swing-up, a child's swing), or the bob does not swing
in the camera's plane (a conical or elliptical motion seen from the side). Each half swing's amplitude
is half the rise or fall between two turning points (no centre to estimate: an offset does not enter);
the level at each half swing is the median of :data:`DRIVE_HALF_SWINGS` in a row (a spike or a lost
turning point moves none of them). Two tops (or bottoms) are at least :data:`DRIVE_APART` of the dominant
period apart, and the band is at least the noise near the turning points (:data:`DRIVE_NEAR`, third
differences): a tracker that jitters where the bob is slow makes no half swings of its own. The record
is driven when a level's energy ``1 - cos A`` exceeds
an earlier level's by more than :data:`DRIVE_RISE` and its amplitude by more than :data:`DRIVE_BANDS`
bands: the record is refused (:class:`~pendtrack.kinematics.differentiate.KinematicsError`), since a
model of a free swing fitted to it means nothing. Half swings that reach the top (amplitude above
:data:`DRIVE_TOP` rad) are left out: over the top the amplitude no longer measures the energy.

The band is six times the noise of the samples at rest, and at least 1.5 of a quantised record's
steps (:mod:`pendtrack.kinematics.rest`). ``Omega0`` comes from theta's strongest spectral
peak (:func:`~pendtrack.kinematics.differentiate.dominant_period`): at large amplitude it is
below the small-swing value, which only lengthens ``t_free`` (fewer holds, never more).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from pendtrack.kinematics.analysis import swing_centre_shift
from pendtrack.kinematics.differentiate import KinematicsError, dominant_period
from pendtrack.kinematics.rest import BAND_QUANTA, BAND_SIGMAS, MIN_REST_SAMPLES, departure, leading_rest, smallest_step
from pendtrack.tables.checks import turning_values

log = logging.getLogger(__name__)

HOLD_FACTOR = 3.0  # a hold lasts longer than 3 x the time a free bob takes to leave the band
MIN_HOLD_S = 0.2  # ... and at least this long [s]: a free release's first samples never are a hold
RELEASE_BANDS = 4.0  # a bob let go is this many bands from its hold 2 t_free after it left the band (a free one: 9)
RELEASE_LOOK_S = 0.1  # ... and a quarter of its free path a t^2 / 2 from there this long after [s] (a pixel's jump is not)
RELEASE_TRIES = 8  # times the band may grow to hold a tracker's jitter before the hold's end is taken as found
CATCH_FACTOR = 4.0  # a catch stops a swing 4 x larger than one half period's loss (a Coulomb stop: < 2.5 x)
CATCH_BANDS = 4.0  # ... and 4 bands (24 noise sigmas) large: a swing fading into the band is no catch
CATCH_REST_PERIODS = 1.0  # the rest after a catch lasts a period at least (a short one may be noise)
CATCH_PERIODS = 3  # the loss per half period is measured over the 3 periods before the catch's half period
LIFT_RISE = 0.3  # a lift: the energy at the first turning point above 1.3 x the first sample's (module docstring)
LIFT_MIN_PERIODS = 6  # ... judged on records of this many periods at least (Omega0^2 within 17 %)
DRIVE_RISE = 0.3  # a drive: a later swing's energy above 1.3 x an earlier one's (the lift's bar)
DRIVE_BANDS = 4.0  # ... and its amplitude 4 bands (24 noise sigmas) above: a weak drive's beat is no drive
DRIVE_HALF_SWINGS = 5  # the amplitude's level: the median of 5 half swings in a row
DRIVE_PROMINENCE = 2.0  # a turning point stands out of the record by 2 bands (12 noise sigmas) at least
DRIVE_TOP = math.pi - 0.05  # half swings this large reach the top: left out [rad]
DRIVE_APART = 0.75  # two tops (or two bottoms) of the swing are at least this share of its period apart
DRIVE_NEAR = 0.1  # the noise of the amplitudes: of the samples within this share of a period of a turning point
LIFT_FIT_PERIODS = 0.1  # the first sample's angle and speed: a quadratic through this share of a period
NOISE_BLOCK_PERIODS = 4.0  # the sampled swing's relation (:func:`_swing_residuals`) is fitted over this many periods
NOISE_BLOCK_MIN = 16  # ... and at least this many samples


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


@dataclass(frozen=True)
class Catch:
    """A catch found at the end of a record.

    Attributes
    ----------
    n : int
        Index of the first row that is no free swing (rows ``n`` on are not fitted).
    free_until_s : float
        Time of that row [s]: half a period before the rest.
    rest_s : float
        Time of the first sample at rest [s].
    theta_c : float
        The angle at rest [rad].
    amplitude : float
        The swing's amplitude just before the catch [rad].
    loss : float
        The amplitude the swing lost per half period before the catch [rad].
    """

    n: int
    free_until_s: float
    rest_s: float
    theta_c: float
    amplitude: float
    loss: float


@dataclass(frozen=True)
class Lift:
    """A hand's lift found at the start of a record.

    Attributes
    ----------
    n : int
        Samples before the release (the first ``n`` rows are not a free swing).
    release_s : float
        Time of the first turning point, where the hand let go [s].
    theta_r : float
        The angle there [rad].
    energy_rise : float
        The energy there over the first sample's, minus 1.
    """

    n: int
    release_s: float
    theta_r: float
    energy_rise: float


@dataclass(frozen=True)
class Drive:
    """A swing that grows after its release (module docstring).

    Attributes
    ----------
    t_low, t_high : float
        Times of the lower level's and the higher later level's middle half swing [s].
    amplitude_low, amplitude_high : float
        Their amplitudes [rad].
    energy_rise : float
        ``(1 - cos amplitude_high) / (1 - cos amplitude_low) - 1``.
    """

    t_low: float
    amplitude_low: float
    t_high: float
    amplitude_high: float
    energy_rise: float


def _usable(t: np.ndarray, theta: np.ndarray, ok: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    idx = np.flatnonzero(np.asarray(ok, dtype=bool) & np.isfinite(theta))
    if idx.size < 4 * MIN_REST_SAMPLES:
        return None
    return idx, np.asarray(t, dtype=np.float64)[idx], np.asarray(theta, dtype=np.float64)[idx]


def _swing_residuals(th: np.ndarray, period_samples: float) -> np.ndarray:
    """Each sample's residual from the swing through its neighbours, in units of the samples' noise [rad].

    A swing sampled every h obeys ``theta_{k+1} + theta_{k-1} = c theta_k + b`` (``c = 2 cos(w h)``, ``b`` from
    its centre; exactly for a sinusoid of any amplitude), so the residual of that relation, fitted by least
    squares over every :data:`NOISE_BLOCK_PERIODS` periods (the frequency of a large swing changes as it decays
    or grows), holds the noise alone: white noise of sigma gives residuals of sigma ``sqrt(2 + c^2)``, divided
    out here. Second differences hold the swing's curvature as well, ``(w h)^2`` of its amplitude: at 120 Hz
    and 5 rad/s 0.2 %, at 20 Hz and 10 rad/s a quarter of it, which made a 1-rad swing's "noise" 0.1 rad.
    Element k is sample k's residual (0 at the two ends).
    """
    n = th.size
    out = np.zeros(n)
    block = max(NOISE_BLOCK_MIN, int(NOISE_BLOCK_PERIODS * period_samples)) if math.isfinite(period_samples) else n
    for start in range(0, n - 2, block):
        stop = min(n, start + block + 2)
        if stop - start < NOISE_BLOCK_MIN:  # a short tail joins the block before
            start = max(0, stop - NOISE_BLOCK_MIN)
        x = th[start:stop]
        y = x[2:] + x[:-2]
        a = np.column_stack([x[1:-1], np.ones(y.size)])
        coef, *_ = np.linalg.lstsq(a, y, rcond=None)
        c = float(coef[0])
        out[start + 1:stop - 1] = np.abs(y - a @ coef) / math.sqrt(2.0 + c * c)
    return out


def _noise(th: np.ndarray, residuals: np.ndarray) -> float:
    """The samples' noise [rad]: the smaller of two robust estimates (MAD), each of which white noise alone
    makes sigma and a swing only raises: second differences (:func:`_swing_residuals`' docstring: the swing's
    curvature at a low rate) and ``residuals``, those of the sampled swing (:func:`_swing_residuals`: its change
    of frequency, its harmonics)."""
    d2 = 1.4826 * float(np.median(np.abs(np.diff(th, 2)))) / math.sqrt(6.0)
    if th.size < NOISE_BLOCK_MIN:
        return d2
    return min(d2, 1.4826 * float(np.median(residuals[1:-1])))


def _first_window(tt: np.ndarray) -> int:
    """Samples in half of :data:`MIN_HOLD_S` (at least :data:`MIN_REST_SAMPLES`): the first guess of a
    rest's level and noise (at 120 Hz the noise of 5 samples alone is off by 4 x one time in 20)."""
    return max(MIN_REST_SAMPLES, int(0.5 * MIN_HOLD_S / float(np.median(np.diff(tt)))))


def _released(tt: np.ndarray, th: np.ndarray, dep: int, level: float, band: float,
              accel: float) -> tuple[int, float, float] | None:
    """The departure from the rest that is the release: ``(dep, level, band)``, or None if the bob never leaves.

    A bob let go leaves the band ``b`` with the acceleration ``accel``: ``2 t_free`` later
    (``t_free = sqrt(2 b / accel)``) it is ``9 b`` from its level, and ``T`` later at least a quarter of
    ``accel T^2 / 2`` (:data:`RELEASE_LOOK_S`). A tracker's jitter that leaves a band made from runs of
    one repeated value (whose differences are zero: no noise to see), a pixel's jump, stays near the
    level: then the band grows to hold every sample so far, and the departure is looked for again.
    """
    h = float(np.median(np.diff(tt)))
    for _ in range(RELEASE_TRIES):
        look = max(2.0 * math.sqrt(2.0 * band / accel), RELEASE_LOOK_S) + 2.0 * h
        end = int(np.searchsorted(tt, tt[dep] + look, side="right"))
        reach = float(np.max(np.abs(th[dep:end] - level)))
        if reach >= max(RELEASE_BANDS * band, 0.25 * 0.5 * accel * (look - 2.0 * h) ** 2):
            return dep, level, band
        band = 1.5 * float(np.max(np.abs(th[:end] - level)))
        dep = departure(th, level, band)
        if dep >= th.size - 2 * MIN_REST_SAMPLES:
            return None
    return dep, level, band


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
    usable = _usable(t, theta, ok)
    if usable is None:
        return None
    idx, tt, th = usable
    rest = leading_rest(th, smallest_step(th), _first_window(tt))
    if rest is None:
        return None
    dep, level, band = rest
    h = float(np.median(np.diff(tt)))
    period = dominant_period(th[dep:], h)
    accel = (2.0 * math.pi / period) ** 2 * abs(math.sin(level)) if math.isfinite(period) else 0.0
    if not accel > 0:
        return None
    released = _released(tt, th, dep, level, band, accel)
    if released is None:
        return None
    dep, level, band = released
    t_free = math.sqrt(2.0 * band / accel)
    stay = float(tt[dep] - tt[0])
    if stay <= max(HOLD_FACTOR * t_free, MIN_HOLD_S):
        return None
    return Hold(n=int(idx[dep]), release_s=float(tt[dep]), theta_h=level, t_free=t_free)


def find_lift(t: np.ndarray, theta: np.ndarray, ok: np.ndarray) -> Lift | None:
    """The lift at the start of a record, or None.

    Parameters
    ----------
    t, theta, ok : ndarray
        As for :func:`find_hold` (the lift is looked for in the usable samples).

    Returns
    -------
    Lift or None
        None when the first samples do not move away from the bottom, or the bob reaches its first
        turning point with no more energy than a free swing could have brought there (module docstring).
    """
    usable = _usable(t, theta, ok)
    if usable is None:
        return None
    idx, tt, th = usable
    h = float(np.median(np.diff(tt)))
    period = dominant_period(th, h)
    if not math.isfinite(period) or tt[-1] - tt[0] < LIFT_MIN_PERIODS * period:
        return None
    # "away from the bottom" is away from the swing's centre when the angle's zero is far from it (a tilted camera,
    # a sensor's zero): a free swing starting on its way out from a turning point off zero is no lift
    centre = swing_centre_shift(turning_values(th))
    th = th - centre
    m = max(MIN_REST_SAMPLES, int(LIFT_FIT_PERIODS * period / h))
    quad = np.polyfit(tt[:m] - tt[0], th[:m], 2)
    theta0, omega0 = float(quad[2]), float(quad[1])
    if not theta0 * omega0 > 0.0:  # at rest or on its way down: no lift
        return None
    side = math.copysign(1.0, theta0)
    # the first turning point: the farthest from the bottom before the bob comes back by more than the noise
    away = side * th
    noise = _noise(th, _swing_residuals(th, period / h))
    band = max(BAND_SIGMAS * noise, BAND_QUANTA * smallest_step(th))
    back = np.flatnonzero(np.maximum.accumulate(away) - away > band)
    if back.size == 0:
        return None
    k = int(np.argmax(away[:back[0]]))
    if k < m:
        return None
    w2 = (2.0 * math.pi / period) ** 2
    e_start = 0.5 * omega0 * omega0 + w2 * (1.0 - math.cos(theta0))
    e_turn = w2 * (1.0 - math.cos(float(th[k])))
    if not e_turn > (1.0 + LIFT_RISE) * e_start:
        return None
    return Lift(n=int(idx[k]), release_s=float(tt[k]), theta_r=float(th[k] + centre), energy_rise=e_turn / e_start - 1.0)


def find_drive(t: np.ndarray, theta: np.ndarray, ok: np.ndarray) -> Drive | None:
    """The largest growth of the swing after its release, or None when it does not grow (module docstring).

    Parameters
    ----------
    t, theta, ok : ndarray
        As for :func:`find_hold` (the turning points are looked for in the usable samples).
    """
    from scipy.signal import find_peaks

    usable = _usable(t, theta, ok)
    if usable is None:
        return None
    _, tt, th = usable
    h = float(np.median(np.diff(tt)))
    period = dominant_period(th, h)
    residuals = _swing_residuals(th, period / h)
    noise = _noise(th, residuals)
    band = max(BAND_SIGMAS * noise, BAND_QUANTA * smallest_step(th))
    if not band > 0:
        return None
    # two tops (or bottoms) of a swing are a period apart: within 3/4 of one the highest only, so that a tracker's
    # jitter where the bob is slow (noisier than the band, set by the fast samples) makes no turning points of its own:
    # a dip in the jitter at a top is half a period from the true bottoms on either side
    apart = max(1, int(DRIVE_APART * period / h)) if math.isfinite(period) else 1
    tops, _ = find_peaks(th, prominence=DRIVE_PROMINENCE * band, distance=apart)
    bottoms, _ = find_peaks(-th, prominence=DRIVE_PROMINENCE * band, distance=apart)
    turns = np.sort(np.concatenate([tops, bottoms]))
    if turns.size < DRIVE_HALF_SWINGS + 2:
        return None
    # the amplitudes are read at the turning points: a growth is judged against the noise there, which a tracker
    # that jitters where the bob is slow makes larger than the noise of the whole record (third differences: the
    # swing's curvature, largest at a turning point, cancels; white noise's have 20 times its variance)
    near = max(2, int(DRIVE_NEAR * period / h)) if math.isfinite(period) else 2
    around = np.unique(np.clip(turns[:, None] + np.arange(-near, near + 1)[None, :], 1, th.size - 3))
    # (or, the smaller, the sampled swing's residuals there: third differences too hold the swing at a low rate)
    d3 = np.abs(th[around + 2] - 3.0 * th[around + 1] + 3.0 * th[around] - th[around - 1])
    near_noise = 1.4826 * float(np.median(d3)) / math.sqrt(20.0)
    if th.size >= NOISE_BLOCK_MIN:
        near_noise = min(near_noise, 1.4826 * float(np.median(residuals[around])))
    band = max(band, BAND_SIGMAS * near_noise)
    half = 0.5 * np.abs(np.diff(th[turns]))
    mid = 0.5 * (tt[turns[1:]] + tt[turns[:-1]])
    w = DRIVE_HALF_SWINGS
    level = np.array([np.median(half[i:i + w]) for i in range(half.size - w + 1)])
    at = np.array([mid[i + w // 2] for i in range(half.size - w + 1)])
    below_top = np.array([np.max(half[i:i + w]) < DRIVE_TOP for i in range(half.size - w + 1)])
    energy = 1.0 - np.cos(level)
    best: Drive | None = None
    low = -1
    for k in range(level.size):
        if not below_top[k]:
            continue
        if low >= 0 and level[k] - level[low] > DRIVE_BANDS * band and energy[low] > 0:
            rise = float(energy[k] / energy[low] - 1.0)
            if rise > DRIVE_RISE and (best is None or rise > best.energy_rise):
                best = Drive(t_low=float(at[low]), amplitude_low=float(level[low]), t_high=float(at[k]),
                             amplitude_high=float(level[k]), energy_rise=rise)
        if low < 0 or level[k] < level[low]:
            low = k
    return best


def find_catch(t: np.ndarray, theta: np.ndarray, ok: np.ndarray) -> Catch | None:
    """The catch at the end of a record, or None.

    Parameters
    ----------
    t, theta, ok : ndarray
        As for :func:`find_hold` (the catch is looked for in the usable samples).

    Returns
    -------
    Catch or None
        None when the record does not end at rest, or the swing before could have faded or
        stopped there by itself (module docstring).
    """
    usable = _usable(t, theta, ok)
    if usable is None:
        return None
    idx, tt, th = usable
    rest = leading_rest(th[::-1], smallest_step(th), _first_window(tt))
    if rest is None:
        return None
    n_rest, level, band = rest
    k = th.size - n_rest  # the first sample at rest
    if tt[-1] - tt[k] < MIN_HOLD_S:
        return None
    h = float(np.median(np.diff(tt)))
    half = 0.5 * dominant_period(th[:k], h)
    if not math.isfinite(half) or tt[-1] - tt[k] < 2.0 * half * CATCH_REST_PERIODS:
        return None
    end = tt[k] - half  # the swing before the catch ends here; its amplitude is measured before it
    edges = end - 2.0 * half * np.arange(CATCH_PERIODS, -1, -1)
    edges = edges[edges >= tt[0]]
    if edges.size < 3:  # fewer than two periods to measure a loss on
        return None
    # each period's amplitude is half its peak to peak: no centre to estimate, an offset does not enter
    inside = (tt >= edges[0]) & (tt < end)
    period_of = np.searchsorted(edges, tt[inside], side="right") - 1
    top = np.full(edges.size - 1, -np.inf)
    bottom = np.full(edges.size - 1, np.inf)
    np.maximum.at(top, period_of, th[inside])
    np.minimum.at(bottom, period_of, th[inside])
    swing = 0.5 * (top - bottom)
    amplitude = float(swing[-1])
    loss = max(float(swing[0] - swing[-1]), 0.0) / (2.0 * (swing.size - 1))
    if amplitude <= max(CATCH_FACTOR * loss, CATCH_BANDS * band):
        return None
    # a record that ends at a turning point also ends at rest: no longer than a free bob stays there
    accel = (math.pi / half) ** 2 * abs(math.sin(min(amplitude, math.pi - 1e-3)))
    if tt[-1] - tt[k] <= HOLD_FACTOR * math.sqrt(2.0 * band / accel):
        return None
    n = int(np.searchsorted(tt, end))
    return Catch(n=int(idx[n]), free_until_s=float(tt[n]), rest_s=float(tt[k]), theta_c=level,
                 amplitude=amplitude, loss=loss)


def free_swing(t: np.ndarray, theta: np.ndarray, ok: np.ndarray, *, source: Any = None
               ) -> tuple[np.ndarray, Hold | Lift | None, Catch | None]:
    """``ok`` with a hold's (:func:`find_hold`), a lift's (:func:`find_lift`, after any hold) and a
    catch's (:func:`find_catch`) samples set False.

    The rows stay: nothing of the record is lost, those samples are only not a free swing. A hold,
    lift or catch found is logged as a warning naming ``source``.

    Returns
    -------
    ok : ndarray of bool
    start : Hold or Lift or None
        What precedes the free swing (a lift after a hold: the lift, which ends later).
    catch : Catch or None

    Raises
    ------
    KinematicsError
        The swing grows after the release (:func:`find_drive`): no free swing, nothing to fit.
    """
    t = np.asarray(t, dtype=np.float64)
    theta = np.asarray(theta, dtype=np.float64)
    ok = np.asarray(ok, dtype=bool).copy()
    hold = find_hold(t, theta, ok)
    if hold is not None:
        ok[:hold.n] = False
        log.warning("%s: the bob is at rest at %.3g rad until t = %.4g s, longer than a free pendulum stays there "
                    "(%.2g s): the %d samples before are a hold, not fitted", source, hold.theta_h, hold.release_s,
                    hold.t_free, hold.n)
    lift = find_lift(t, theta, ok)
    if lift is not None:
        ok[:lift.n] = False
        log.warning("%s: the bob moves away from the bottom and reaches its first turning point, %.3g rad at t = "
                    "%.4g s, with %.0f %% more energy than at the start, which no free swing gains: a hand carried "
                    "it there; the %d samples before are not fitted", source, lift.theta_r, lift.release_s,
                    100.0 * lift.energy_rise, lift.n)
    catch = find_catch(t, theta, ok)
    if catch is not None:
        ok[catch.n:] = False
        log.warning("%s: the bob is at rest at %.3g rad from t = %.4g s, half a period after swinging +- %.3g rad "
                    "(its damping took %.2g rad per half period): it was caught; the %d samples from t = %.4g s "
                    "are not fitted", source, catch.theta_c, catch.rest_s, catch.amplitude, catch.loss,
                    theta.size - catch.n, catch.free_until_s)
    drive = find_drive(t, theta, ok)
    if drive is not None:
        raise KinematicsError(
            f"not a free swing: its amplitude grows from {drive.amplitude_low:.3g} rad at t = {drive.t_low:.4g} s to "
            f"{drive.amplitude_high:.3g} rad at t = {drive.t_high:.4g} s ({100.0 * drive.energy_rise:.0f} % more "
            "energy), which no free pendulum does: it is driven (a motor, a hand), takes energy from a second "
            "pendulum coupled to it, or does not swing in the camera's plane; pendtrack's models are of free swings",
            path=source)
    return ok, (lift or hold), catch
