"""Is a column in the unit it is read in? Turning points, and the unit checks of undeclared columns.

A pendulum constrains what its record can look like, and that tells a wrong unit:

* **theta not in radians**: a pendulum that turns back cannot sweep more than a full turn
  between two turning points, so a larger swing is degrees (``Angle`` of an encoder log, a
  Tracker ``θ``); nor can one released from rest sweep more than a full turn to its first
  turning point (it never passes the top); so is a record that never turns back yet reaches
  beyond :data:`FAR_TURNS` full turns (a rotating pendulum then needs its unit declared).
* **time not in seconds**: a pendulum's period is between :data:`PERIOD_RANGE_S` (a
  period of 100 s is a 2.5 km pendulum); a record whose oscillation is slower in the time
  column's numbers is in ms or µs, as is one sampled more than :data:`MAX_STEP_S` apart.

Both are errors unless the unit is declared (a header or ``--columns`` unit): an angle read in
the wrong unit gives a meaningless artifact. A theta oscillating about a centre far from 0 is
only warned about (a zero offset is possible; a position given as theta is likely).
"""

from __future__ import annotations

import math

import numpy as np

TURN = 2.0 * math.pi  # no swing between two turning points exceeds a full turn
FAR_TURNS = 2.0  # a record without two turning points beyond this many turns is not in rad
AT_REST_STEP = 0.5  # a record starts at rest when its first step is under half its largest before turning back
CENTRE_WARN_RAD = 0.5  # an oscillation centred further than this from 0 (mod 2 pi) looks like a position
ZIGZAG_FRACTION = 0.1  # a turning point is confirmed after a retreat of this share of the 1-99 % range
ZIGZAG_MAX_SAMPLES = 20000  # the turning-point search runs on at most this many samples (decimated)
PERIOD_RANGE_S = (0.1, 100.0)  # pendulum periods [s]: a 2.5 mm to a 2.5 km pendulum
MAX_STEP_S = 10.0  # no pendulum record is sampled more than 10 s apart
TIME_GUESSES = (("ms", 1e-3), ("us", 1e-6), ("ns", 1e-9))
MIN_HALF_PERIOD_SAMPLES = 4  # turning points closer than this (median, in samples) are the noise's zigzag, not half swings


def turning_points(values: np.ndarray) -> np.ndarray:
    """Indices of the turning points of a series, by a zigzag: an extreme counts once the series
    has retreated from it by :data:`ZIGZAG_FRACTION` of its 1-99 % range (noise does not).

    Non-finite values are skipped; indices refer to ``values``.
    """
    x = np.asarray(values, float)
    where = np.flatnonzero(np.isfinite(x))
    if where.size < 3:
        return np.empty(0, np.int64)
    where = where[:: max(1, where.size // ZIGZAG_MAX_SAMPLES)]
    v = x[where]
    lo, hi = np.percentile(v, [1, 99])
    delta = ZIGZAG_FRACTION * (hi - lo)
    if delta <= 0:
        return np.empty(0, np.int64)
    out: list[int] = []
    start, ext, k_ext = v[0], v[0], 0
    direction = 0  # +1 rising, -1 falling, 0 not yet known
    for k in range(1, v.size):
        val = v[k]
        if direction == 0:
            if abs(val - start) >= delta:
                direction, ext, k_ext = (1 if val > start else -1), val, k
        elif direction * (val - ext) > 0:
            ext, k_ext = val, k
        elif direction * (ext - val) >= delta:
            out.append(k_ext)
            direction, ext, k_ext = -direction, val, k
    return where[np.asarray(out, np.int64)]


def dominant_period(theta: np.ndarray, h: float) -> float:
    """Period [s] of the strongest spectral peak of a uniformly sampled theta (inf if none)."""
    x = np.asarray(theta, dtype=np.float64)
    x = x - x.mean()
    if x.size < 8 or not np.any(x):
        return math.inf
    spec = np.abs(np.fft.rfft(x * np.hanning(x.size)))
    freqs = np.fft.rfftfreq(x.size, h)
    k = int(np.argmax(spec[1:])) + 1
    return math.inf if freqs[k] <= 0 else 1.0 / freqs[k]


def turning_values(theta: np.ndarray) -> np.ndarray:
    """Values of theta at its turning points (:func:`turning_points`)."""
    x = np.asarray(theta, float)
    return x[turning_points(x)]


def angle_impossible(theta: np.ndarray, *, from_rest: bool = True) -> str | None:
    """Why an angle series in rad cannot be a free pendulum's angle (a phrase), or None if it can be.

    Between two turning points a free pendulum cannot move by more than a full turn (2 pi rad): it starts
    from rest there, so it never passes the top (a reversal beyond the top is impossible: past it, gravity
    carries the bob on). Nor can one released from rest move by more than a full turn to its first turning
    point (``from_rest``; a hand that spins it first can, so a declared unit is not judged by this). Values
    that break the first rule are not a free swing's angle in any unit (pixels read as degrees, say).
    """
    travel = _travel_from_rest(theta) if from_rest else None
    if travel is not None and travel > TURN:
        return (f"theta moves by {travel:.4g} rad from its start at rest to its first turning point, more than a "
                "full turn, which no pendulum released from rest does")
    ext = turning_values(theta)
    if ext.size >= 2:
        swing = float(np.max(np.abs(np.diff(ext))))
        if swing > TURN:
            return (f"theta swings by up to {swing:.4g} rad between two turning points, more than a full turn, "
                    "which no free pendulum does (it cannot turn back beyond the top)")
    return None


def theta_not_radians(theta: np.ndarray) -> tuple[str, bool] | None:
    """Why an angle series read in rad cannot be in rad, and whether it can be in degrees; None if rad can be.

    Returns
    -------
    (str, bool) or None
        A sentence, and True where the same numbers read in degrees make a possible swing (the fix is
        to declare degrees), False where they do not either (not an angle: a position, say).
    """
    why = angle_impossible(theta)
    far_in_degrees = False  # never turning back twice, and beyond FAR_TURNS full turns even in degrees (a counter)
    if why is None:
        ext = turning_values(theta)
        finite = np.asarray(theta, float)[np.isfinite(theta)]
        if ext.size >= 2 or not (finite.size and float(np.max(np.abs(finite))) > FAR_TURNS * TURN):
            return None
        why = (f"theta reaches {float(np.max(np.abs(finite))):.4g} without turning back twice, beyond "
               f"{FAR_TURNS:g} full turns")
        far_in_degrees = math.radians(float(np.max(np.abs(finite)))) > FAR_TURNS * TURN
    why = why.replace(" rad ", " ", 1)  # the numbers as written: their unit is the question
    if far_in_degrees:
        return (f"{why}, in degrees too: not an angle (a count, a clock?); name the column that holds the angle "
                "with --columns"), False
    if angle_impossible(np.radians(np.asarray(theta, float))) is None:
        return f"{why}: not radians, it looks like degrees", True
    return (f"{why}; read as degrees the numbers do not make a pendulum's swing either: not an angle (a position "
            "in pixels or mm? then name the columns x and y)"), False


def _travel_from_rest(theta: np.ndarray) -> float | None:
    """How far theta moves from its first sample to its first turning point when it starts at rest
    (its first step under :data:`AT_REST_STEP` of the largest before the turning point); else None."""
    x = np.asarray(theta, float)
    x = x[np.isfinite(x)]
    turns = turning_points(x)
    if turns.size == 0 or turns[0] < 3:
        return None
    steps = np.abs(np.diff(x[:turns[0] + 1]))
    if not steps[0] < AT_REST_STEP * float(steps.max()):
        return None
    return float(abs(x[turns[0]] - x[0]))


def time_not_seconds(t: np.ndarray, signal: np.ndarray) -> tuple[str, str] | None:
    """Why times read in s cannot be in s, and the unit they look like; None if they can be.

    Parameters
    ----------
    t : ndarray
        Strictly increasing times, in the column's own numbers.
    signal : ndarray
        What oscillates (theta, or x of positions), for the period.
    """
    t = np.asarray(t, float)
    if t.size < 3:
        return None
    step = float(np.median(np.diff(t)))
    turns = turning_points(signal)
    lo, hi = PERIOD_RANGE_S
    if turns.size >= 3:
        value, what, plausible = 2.0 * float(np.median(np.diff(t[turns]))), "a swing period", (lo, hi)
        if float(np.median(np.diff(turns))) < MIN_HALF_PERIOD_SAMPLES:  # the noise's zigzag: the spectrum's peak
            value = dominant_period(np.asarray(signal, float), step)
        if value <= hi:
            return None
    elif step > MAX_STEP_S:
        value, what, plausible = step, "a sample step", (1e-5, 1.0)
    else:
        return None
    guess = next((u for u, f in TIME_GUESSES if plausible[0] <= value * f <= plausible[1]), "ms")
    why = f"the time column has {what} of {value:.4g}, too long for seconds"
    return why, guess


def theta_warnings(theta: np.ndarray) -> list[str]:
    """Warnings on an angle series that looks like a position: it oscillates about a centre more
    than :data:`CENTRE_WARN_RAD` from 0 (modulo full turns)."""
    ext = turning_values(theta)
    if ext.size < 2 or float(np.max(np.abs(np.diff(ext)))) > TURN:
        return []
    centre = float(np.median(0.5 * (ext[1:] + ext[:-1])))
    off = (centre + math.pi) % TURN - math.pi
    if abs(off) > CENTRE_WARN_RAD:
        return [f"theta oscillates about {centre:.4g} rad, not about 0 (hanging straight down): an angle from "
                "another zero (a sensor's; fit and discover fit that zero as theta_off, [fit] offset), or it looks "
                "like a position (x or y, e.g. in metres), not the angle; give positions as columns t, x, y (header "
                "or --columns), with --pivot X Y or a fitted pivot"]
    return []
