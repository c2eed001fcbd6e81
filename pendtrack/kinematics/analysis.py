"""The paper's model-free initial analysis, as pure functions on kinematic series.

* turning points: omega = 0 crossings, linearly interpolated, optionally with a hysteresis
  band against noise, and the direction of each (:func:`turning_points`);
* ``alpha(omega = 0) ~ -Omega0^2 sin(theta_ext)`` (eq. straightline) fitted through the
  origin -> model-free Omega0 with its standard error (:func:`estimate_omega0`);
* ``Delta alpha = alpha + Omega0^2 sin(theta)`` (eq. lobulosprovados);
* normalised energy ``A_theta^2 + A_omega^2`` with ``A_theta = sin(theta/2)``,
  ``A_omega = omega/(2 Omega0)`` (eqs. amplitudes, amplitudesobservable);
* phase ``phi`` with ``tan(phi) = A_theta/A_omega`` (eq. phasephi) and phase speed
  ``d phi/dt`` (eq. phasespeed);
* negative damping ``Delta alpha * omega > 0`` (eq. negativedampingdefinition) per sample
  (:func:`negative_damping`, :func:`negative_damping_flags`) and as a fraction of chosen
  samples (:func:`negative_damping_fraction`).

These are the package's only implementations of these facts; discovery and report use them.

Caveat: Delta alpha is a small difference of large numbers. The dissipative accelerations
are ~0.01-0.1 rad/s^2, while a 0.1 % error in Omega0 or the 1-2 % bias of the paper's
25-point Savitzky-Golay alpha moves ``Omega0^2 sin(theta)`` (~25 rad/s^2) by more than
that. On simulated records of purely dissipative models the per-sample negative-damping
flag is then set on a large fraction of samples by the filter alone; compare data with a
model seen through the same filter before reading physics into it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pendtrack.errors import FitError

MIN_TURNING_POINTS = 3
OUTLIER_MADS = 5.0  # residuals beyond this many (scaled) MADs are dropped, then refit
CENTRE_SHARE = 0.05  # turning angles centred further from 0 than this share of their amplitude are centred first
# omega's sign below 1e-4 of its largest |omega| is no swing (one 1e-4 of the largest is below any
# record's precision), but a cubic spline's ringing after a bob stops: a jittered encoder log put on a
# grid gave 157 such "turning points" at the rest beside 81 real ones
OMEGA_FLOOR = 1e-4
MIN_SPAN = 0.5  # the turning points kept reach half the largest |sin theta| (else a rest, not the swing, sets the slope)


@dataclass(frozen=True)
class TurningPoints:
    """Where omega crosses zero (the turning points of theta).

    Attributes
    ----------
    t : numpy.ndarray
        Crossing times [s] (linear interpolation between samples).
    theta : numpy.ndarray
        theta_ext there [rad] (linear interpolation).
    alpha : numpy.ndarray
        alpha there [rad/s^2] (NaN when no alpha was given).
    index : numpy.ndarray of int64
        Index of the sample just before each crossing.
    direction : numpy.ndarray of int64
        +1 where omega turns from negative to positive (a minimum of theta), -1 where it
        turns from positive to negative (a maximum).
    """

    t: np.ndarray
    theta: np.ndarray
    alpha: np.ndarray
    index: np.ndarray
    direction: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    def __len__(self) -> int:
        return int(self.t.size)

    def to_dict(self) -> dict[str, Any]:
        return {"t": self.t.tolist(), "theta": self.theta.tolist(), "alpha": self.alpha.tolist(),
                "index": self.index.tolist(), "direction": self.direction.tolist()}


@dataclass(frozen=True)
class Omega0Estimate:
    """Model-free natural frequency from eq. straightline.

    Attributes
    ----------
    omega0 : float
        Omega0 [rad/s].
    stderr : float
        Its standard error [rad/s] (from the least-squares slope's standard error).
    n_points : int
        Turning points used (after outlier rejection).
    n_rejected : int
        Turning points rejected as outliers or for being at a segment edge.
    rms : float
        RMS residual of ``alpha + Omega0^2 sin(theta_ext)`` [rad/s^2].
    """

    omega0: float
    stderr: float
    n_points: int
    n_rejected: int
    rms: float

    def to_dict(self) -> dict[str, Any]:
        return {"omega0": self.omega0, "stderr": self.stderr, "n_points": self.n_points,
                "n_rejected": self.n_rejected, "rms": self.rms}


def turning_points(t: np.ndarray, theta: np.ndarray, omega: np.ndarray, alpha: np.ndarray | None = None,
                   ok: np.ndarray | None = None, segment: np.ndarray | None = None, *,
                   edge_s: float = 0.0, threshold: float = 0.0) -> TurningPoints:
    """Turning points: where omega changes sign, with optional hysteresis.

    Each usable sample is in a state: +1 where ``omega > threshold``, -1 where
    ``omega < -threshold``, 0 otherwise (inside the band, or not usable). A turning point
    is a change between two consecutive non-zero states; it is placed at the last sign
    change of omega between them, linearly interpolated. With ``threshold = 0`` every
    sign change of omega is one (a sample exactly at 0 that omega leaves on the side it
    came from is no turning point) down to :data:`OMEGA_FLOOR` of the largest ``|omega|``;
    a threshold of a few times the noise of omega keeps noise from making extra ones.

    Parameters
    ----------
    t, theta, omega : numpy.ndarray
        Times [s], angle [rad], angular velocity [rad/s].
    alpha : numpy.ndarray, optional
        Angular acceleration [rad/s^2], interpolated at the turning points; None gives NaN.
    ok : numpy.ndarray of bool, optional
        Usable samples; every sample from one non-zero state to the next must be usable
        (and finite) for a turning point between them. Default: finite ones.
    segment : numpy.ndarray of int, optional
        Segment labels; a turning point must not straddle two segments.
    edge_s : float
        Ignore crossings closer than this to a segment's first/last sample [s] (the
        Savitzky-Golay edge windows are less accurate; use half the window).
    threshold : float
        Hysteresis band [rad/s], >= 0.

    Returns
    -------
    TurningPoints
    """
    t = np.asarray(t, dtype=np.float64)
    theta = np.asarray(theta, dtype=np.float64)
    omega = np.asarray(omega, dtype=np.float64)
    good = np.isfinite(theta) & np.isfinite(omega)
    if alpha is None:
        alpha = np.full(t.size, np.nan)
    else:
        alpha = np.asarray(alpha, dtype=np.float64)
        good &= np.isfinite(alpha)
    if ok is not None:
        good &= np.asarray(ok, dtype=bool)
    seg = np.zeros(t.size, dtype=np.int64) if segment is None else np.asarray(segment, dtype=np.int64)
    if good.any():
        threshold = max(threshold, OMEGA_FLOOR * float(np.max(np.abs(omega[good]))))
    state = np.zeros(t.size, dtype=np.int64)
    state[good & (omega > threshold)] = 1
    state[good & (omega < -threshold)] = -1
    nz = np.flatnonzero(state)
    change = np.flatnonzero(state[nz[1:]] != state[nz[:-1]])
    lo, hi = nz[change], nz[change + 1]
    # every sample from lo to hi usable and in one segment
    n_bad = np.concatenate(([0], np.cumsum(~good)))
    keep = (n_bad[hi + 1] == n_bad[lo]) & (seg[lo] == seg[hi])
    lo, hi = lo[keep], hi[keep]
    direction = state[hi]
    # the last sign change of omega in [lo, hi]: between i and i + 1
    flips = np.flatnonzero(np.signbit(omega[:-1]) != np.signbit(omega[1:]))
    i = flips[np.searchsorted(flips, hi) - 1] if flips.size else np.zeros(0, dtype=np.int64)
    if edge_s > 0 and i.size:
        keep = np.ones(i.size, dtype=bool)
        for s in np.unique(seg[i]):
            rows = np.flatnonzero(seg == s)
            lo_t, hi_t = t[rows[0]] + edge_s, t[rows[-1]] - edge_s
            sel = seg[i] == s
            keep[sel] &= (t[i[sel]] >= lo_t) & (t[i[sel] + 1] <= hi_t)
        i, direction = i[keep], direction[keep]
    denom = omega[i] - omega[i + 1]
    with np.errstate(invalid="ignore", divide="ignore"):
        f = np.where(denom != 0.0, omega[i] / denom, 0.5)
    f = np.clip(f, 0.0, 1.0)
    lerp = lambda x: x[i] + f * (x[i + 1] - x[i])  # noqa: E731
    return TurningPoints(t=lerp(t), theta=lerp(theta), alpha=lerp(alpha), index=i.astype(np.int64),
                         direction=direction.astype(np.int64))


def turning_values(t: np.ndarray, theta: np.ndarray, alpha: np.ndarray, tp: TurningPoints,
                   ok: np.ndarray | None = None, segment: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(theta_ext, alpha_ext)`` at each turning point of ``tp``, for eq. straightline [rad], [rad/s^2].

    Taken at the middle of the two crossings of the swing's centre around the turning point (a swing is
    symmetric about its turning time, to second order in the damping), where :func:`turning_points` places
    it at the last sign change of omega. On a noisy record the two differ: omega's last sign change falls
    where the noise makes omega steepest, so alpha there is biased away from the curve's (8 mrad of noise
    at 30 fps on a 0.2-rad swing: Omega0 +4.5 %, against -0.7 % from the crossings; within 1e-4 on a clean
    record). The crossings lie a quarter period away, outside the filter's window at the turning point. A
    turning point without two crossings around it in its segment (the record's first and last, a gap) keeps
    ``tp``'s values. Several turning points between the same two crossings are one half swing's, the others
    made by the noise where the bob is slow (8 mrad at 30 fps: 123-129 for 111 half swings): the first stands
    for it, with the crossings' midpoint, and the others are left out of the returned arrays.

    Parameters
    ----------
    t, theta, alpha : ndarray
        Times [s], the filtered angle [rad] and angular acceleration [rad/s^2].
    tp : TurningPoints
        :func:`turning_points` of the same record.
    ok, segment : ndarray, optional
        Usable samples and segment labels, as given to :func:`turning_points`.
    """
    th_ext = np.array(tp.theta, dtype=np.float64)
    al_ext = np.array(tp.alpha, dtype=np.float64)
    if th_ext.size < 3:
        return th_ext, al_ext
    t = np.asarray(t, dtype=np.float64)
    theta = np.asarray(theta, dtype=np.float64)
    alpha = np.asarray(alpha, dtype=np.float64)
    good = np.isfinite(theta) & np.isfinite(alpha)
    if ok is not None:
        good &= np.asarray(ok, dtype=bool)
    seg = np.zeros(t.size, dtype=np.int64) if segment is None else np.asarray(segment, dtype=np.int64)
    level = float(np.median(0.25 * (th_ext[:-2] + 2.0 * th_ext[1:-1] + th_ext[2:])))  # the swing's centre
    x = theta - level
    i = np.flatnonzero((np.signbit(x[:-1]) != np.signbit(x[1:])) & good[:-1] & good[1:] & (seg[:-1] == seg[1:]))
    if i.size < 2:
        return th_ext, al_ext
    tz = t[i] + (t[i + 1] - t[i]) * x[i] / (x[i] - x[i + 1])
    k = np.searchsorted(tz, tp.t)
    inside = (k > 0) & (k < tz.size)
    k = np.clip(k, 1, tz.size - 1)
    same = (seg[i[k - 1]] == seg[i[k]]) & (seg[i[k]] == seg[np.asarray(tp.index, dtype=np.int64)])
    inside &= same
    repeat = np.zeros(k.size, dtype=bool)  # a later turning point between the same two crossings
    repeat[1:] = inside[1:] & inside[:-1] & (k[1:] == k[:-1])
    use = inside & ~repeat
    mid = 0.5 * (tz[k - 1] + tz[k])
    j = np.clip(np.searchsorted(t, mid) - 1, 0, t.size - 2)
    use &= good[j] & good[j + 1] & (seg[j] == seg[j + 1])
    f = (mid - t[j]) / (t[j + 1] - t[j])
    th_ext[use] = (theta[j] + f * (theta[j + 1] - theta[j]))[use]
    al_ext[use] = (alpha[j] + f * (alpha[j + 1] - alpha[j]))[use]
    return th_ext[~repeat], al_ext[~repeat]


def savgol_bias_moments(window_points: int, order: int, h: float) -> tuple[float, float]:
    """Fourth-order moments ``(b4, e4)`` of the Savitzky-Golay 2nd-derivative and smoothing filters.

    A ``t^4/24`` term in theta makes the centred filters return ``b4`` (second
    derivative, exact value 0) and ``e4`` (smoothed value, exact 0): the leading bias of
    a polynomial-order-3 filter. [s^2] and [s^4].
    """
    from scipy.signal import savgol_coeffs

    k = (np.arange(window_points) - window_points // 2) * h
    c2 = savgol_coeffs(window_points, order, deriv=2, delta=h, use="dot")
    c0 = savgol_coeffs(window_points, order, deriv=0, use="dot")
    return float(np.dot(c2, k ** 4) / 24.0), float(np.dot(c0, k ** 4) / 24.0)


def estimate_omega0(theta_ext: np.ndarray, alpha_ext: np.ndarray, *,
                    sg_moments: tuple[float, float] | None = None) -> Omega0Estimate:
    """Fit ``alpha_ext = -Omega0^2 sin(theta_ext)`` (eq. straightline) through the origin.

    Least squares for the slope ``k = -Omega0^2`` on ``x = sin(theta_ext)``; points whose
    residual exceeds :data:`OUTLIER_MADS` scaled MADs are dropped and the fit repeated
    (until none is dropped). ``stderr(Omega0) = stderr(k) / (2 Omega0)`` with
    ``stderr(k) = s / sqrt(sum x^2)``, ``s^2 = sum r^2 / (n - 1)``.

    Smoothing bias: the paper's 25-point cubic Savitzky-Golay filter at 120 fps biases
    alpha at the turning points by 1-2 % (measured on simulations: Omega0 5.005 instead
    of 5.05 for small swings, 5.10 for swings from theta = 3). With ``sg_moments`` (from
    :func:`savgol_bias_moments`) the leading term is removed: at a turning point of the
    undamped pendulum ``alpha'' = -Omega0^2 cos(theta) alpha``, so the filters return
    ``alpha (1 - Omega0^2 cos(theta) b4)`` and ``theta + alpha'' e4``; both are undone
    with the current Omega0 and the fit repeated to convergence (measured residual
    bias <= 0.1 %).

    Parameters
    ----------
    theta_ext : numpy.ndarray
        Angles at the turning points [rad].
    alpha_ext : numpy.ndarray
        Accelerations there [rad/s^2].
    sg_moments : tuple of float, optional
        ``(b4, e4)`` of the filter that produced theta and alpha; None: no correction.

    Returns
    -------
    Omega0Estimate

    Raises
    ------
    FitError
        Fewer than :data:`MIN_TURNING_POINTS` usable turning points, or no restoring
        slope (the data do not oscillate about theta = 0).
    """
    theta_ext = np.asarray(theta_ext, dtype=np.float64)
    alpha_ext = np.asarray(alpha_ext, dtype=np.float64)
    theta_ext = theta_ext - swing_centre_shift(theta_ext)
    est = _fit_through_origin(np.sin(theta_ext), alpha_ext)
    if sg_moments is None:
        return est
    b4, e4 = sg_moments
    for _ in range(50):
        w2 = est.omega0 ** 2
        cos_t = np.cos(theta_ext)
        alpha = alpha_ext / (1.0 - w2 * cos_t * b4)
        theta = theta_ext + w2 * cos_t * alpha * e4
        new = _fit_through_origin(np.sin(theta), alpha)
        done = abs(new.omega0 - est.omega0) <= 1e-12 * est.omega0
        est = new
        if done:
            break
    return est


def swing_centre_shift(theta_ext: Any) -> float:
    """The centre of a swing's turning angles ``theta_ext`` [rad], in time order, when it is further
    than :data:`CENTRE_SHARE` of the swing's amplitude from 0, else 0.

    An angle from another zero (a sensor's atan2, an angle from the x axis) swings about its centre
    ``c``, and eq. straightline holds for theta less it. Through the origin, turning angles ``c +- A``
    give the slope ``k / (1 + (c/A)^2)`` (small angles): a factor 2 at ``c = A``, and no slope at all
    about an 88-degree centre. Below ``c/A = 0.05`` the bias is under 0.13 % of Omega0 (a tenth of the
    starts' spread) and a record whose zero was measured is left as it was; so is a centre the turning
    angles do not agree on within 3 standard errors. The centre of three
    successive turning angles ``(a + 2 b + c) / 4`` cancels a steady decay; their median.
    """
    th = np.asarray(theta_ext, dtype=np.float64)
    th = th[np.isfinite(th)]
    if th.size < 3:
        return 0.0
    centres = 0.25 * (th[:-2] + 2.0 * th[1:-1] + th[2:])
    centre = float(np.median(centres))
    spread = 1.4826 * float(np.median(np.abs(centres - centre))) / math.sqrt(centres.size)
    amplitude = 0.5 * float(np.median(np.abs(np.diff(th))))
    # only a centre the turning angles agree on (3 standard errors): angles that do not alternate are no swing
    return centre if abs(centre) > max(CENTRE_SHARE * amplitude, 3.0 * spread) else 0.0


def _fit_through_origin(x: np.ndarray, y: np.ndarray) -> Omega0Estimate:
    """Slope through the origin of ``y`` on ``x`` with iterated outlier rejection.

    A point is an outlier when its residual is more than :data:`OUTLIER_MADS` scaled MADs
    from the residuals' median (not from 0: residuals that share an offset, e.g. from a
    zero of theta off the rest position, are not outliers). Rejection never leaves fewer
    than :data:`MIN_TURNING_POINTS` points. When the points kept lie within :data:`MIN_SPAN` of
    the reach (a rest's turning points of the noise set the slope), the turning points beyond
    :data:`MIN_SPAN` of the reach alone are fitted; FitError if they do not agree either.
    """
    finite = np.isfinite(x) & np.isfinite(y)
    n_total = int(x.size)
    if finite.sum() < MIN_TURNING_POINTS:
        why = f", {n_total - int(finite.sum())} of them not finite" if n_total > finite.sum() else ""
        raise FitError(f"only {int(finite.sum())} usable turning points ({n_total} omega = 0 crossings found{why}): "
                       f"need at least {MIN_TURNING_POINTS} to estimate Omega0 by eq. straightline "
                       "(does the record hold one and a half oscillations?)")
    try:
        return _slope_through_origin(x, y, finite)
    except _RestSetsTheSlope as exc:
        # a record that ends at rest (a swing that fades by dry friction, then seconds of still bob): the rest's
        # many turning points of the noise agree on a slope of their own and the swings' are rejected as
        # outliers from it. The swings above half the reach, alone, set the slope; when even they do not agree
        # on one, the record is refused as before
        large = finite & (np.abs(x) >= MIN_SPAN * float(np.max(np.abs(x[finite]))))
        if large.sum() < MIN_TURNING_POINTS:
            raise FitError(str(exc)) from None
        try:
            return _slope_through_origin(x, y, large)
        except _RestSetsTheSlope:
            raise FitError(str(exc)) from None


MIN_SLOPE_SIGMAS = 3.0  # -Omega0^2 is this many standard errors below 0 at least (Omega0 to 1/6 of itself)


class NoRestoringTorque(FitError):
    """At the turning points alpha does not oppose sin(theta): the record is no pendulum's swing about its zero."""


class _RestSetsTheSlope(FitError):
    """The turning points that agree on a slope lie within :data:`MIN_SPAN` of the swing's reach."""


def _slope_through_origin(x: np.ndarray, y: np.ndarray, finite: np.ndarray) -> Omega0Estimate:
    """:func:`_fit_through_origin` on the points ``finite`` (at least :data:`MIN_TURNING_POINTS`)."""
    use = finite
    n_total = int(x.size)
    for _ in range(10):
        xs, ys = x[use], y[use]
        sxx = float(np.dot(xs, xs))
        if sxx <= 0.0:
            raise FitError("all turning points are at theta = 0: cannot estimate Omega0")
        k = float(np.dot(xs, ys)) / sxx
        r = y - k * x
        med = float(np.median(r[use]))
        mad = 1.4826 * float(np.median(np.abs(r[use] - med)))
        new = use & (np.abs(r - med) <= OUTLIER_MADS * mad) if mad > 0 else use
        if new.sum() == use.sum() or new.sum() < MIN_TURNING_POINTS:
            break
        use = new
    reach = float(np.max(np.abs(x[finite])))
    if float(np.max(np.abs(x[use]))) < MIN_SPAN * reach:
        raise _RestSetsTheSlope(f"the turning points that agree on a slope lie within "
                                f"{math.asin(min(1.0, float(np.max(np.abs(x[use]))))):.3g} rad of theta = 0, while "
                                f"the swing reaches {math.asin(min(1.0, reach)):.3g} rad: too few swings above the "
                                "noise to estimate Omega0 (does the record come to rest after a few swings?)")
    if k >= 0.0:
        raise NoRestoringTorque(f"alpha at the turning points does not oppose sin(theta) (slope {k:.3g} >= 0): "
                                "no restoring torque, cannot estimate Omega0")
    n = int(use.sum())
    res = y[use] - k * x[use]
    s2 = float(np.dot(res, res)) / (n - 1)
    se_k = math.sqrt(s2 / sxx)
    if -k < MIN_SLOPE_SIGMAS * se_k:
        # turning points of a tracker that held still places in turn (their noise's): a slope of either sign
        raise NoRestoringTorque(f"alpha at the turning points does not measurably oppose sin(theta) (slope "
                                f"{k:.3g} +- {se_k:.2g}, within {MIN_SLOPE_SIGMAS:g} standard errors of 0): no "
                                "restoring torque, cannot estimate Omega0")
    w0 = math.sqrt(-k)
    return Omega0Estimate(omega0=w0, stderr=se_k / (2.0 * w0), n_points=n, n_rejected=n_total - n,
                          rms=math.sqrt(float(np.mean(res ** 2))))


def delta_alpha(theta: np.ndarray, alpha: np.ndarray, omega0: float) -> np.ndarray:
    """What is left of the acceleration once gravity is taken away (eq. lobulosprovados).

    Parameters
    ----------
    theta : numpy.ndarray
        Angle [rad] (0 hanging down).
    alpha : numpy.ndarray
        Angular acceleration [rad/s^2].
    omega0 : float
        Natural angular frequency Omega0 [rad/s].

    Returns
    -------
    numpy.ndarray
        ``Delta alpha = alpha + Omega0^2 sin(theta)`` [rad/s^2]: the dissipative and
        inertial accelerations.
    """
    return np.asarray(alpha) + omega0 ** 2 * np.sin(np.asarray(theta))


def amplitudes(theta: np.ndarray, omega: np.ndarray, omega0: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``A_theta = sin(theta/2)``, ``A_omega = omega/(2 Omega0)`` and ``A_theta^2 + A_omega^2``.

    Dimensionless (eqs. amplitudes, amplitudesobservable).
    """
    a_th = np.sin(0.5 * np.asarray(theta))
    a_om = np.asarray(omega) / (2.0 * omega0)
    return a_th, a_om, a_th ** 2 + a_om ** 2


def phase(theta: np.ndarray, omega: np.ndarray, omega0: float, segment: np.ndarray | None = None) -> np.ndarray:
    """Phase phi [rad], ``tan(phi) = A_theta/A_omega`` (eq. phasephi).

    ``phi = atan2(A_theta, A_omega)`` (0 at the bottom moving forward, pi/2 at a
    positive turning point), unwrapped within each segment so that it grows by 2 pi per
    oscillation; NaN samples stay NaN and restart the unwrapping.
    """
    a_th, a_om, _ = amplitudes(theta, omega, omega0)
    phi = np.arctan2(a_th, a_om)
    seg = np.zeros(phi.size, dtype=np.int64) if segment is None else np.asarray(segment)
    out = np.full(phi.size, np.nan)
    finite = np.isfinite(phi)
    # runs of finite samples with the same segment label
    starts = np.flatnonzero(finite & ~np.r_[False, finite[:-1] & (seg[1:] == seg[:-1])])
    for s in starts:
        e = s
        while e + 1 < phi.size and finite[e + 1] and seg[e + 1] == seg[s]:
            e += 1
        out[s:e + 1] = np.unwrap(phi[s:e + 1])
    return out


def phase_speed(theta: np.ndarray, omega: np.ndarray, alpha: np.ndarray, omega0: float) -> np.ndarray:
    """``d phi/dt`` [rad/s] (eq. phasespeed); NaN where A_theta = A_omega = 0."""
    theta = np.asarray(theta)
    omega = np.asarray(omega)
    alpha = np.asarray(alpha)
    num = np.cos(0.5 * theta) * omega ** 2 / (4.0 * omega0) - np.sin(0.5 * theta) * alpha / (2.0 * omega0)
    den = np.sin(0.5 * theta) ** 2 + (omega / (2.0 * omega0)) ** 2
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, num / np.where(den > 0, den, 1.0), np.nan)


def negative_damping_flags(omega: np.ndarray, dalpha: np.ndarray) -> np.ndarray:
    """Per sample: ``Delta alpha`` pushes with the motion, ``Delta alpha * omega > 0``.

    The definition of negative damping (eq. negativedampingdefinition).

    Parameters
    ----------
    omega : numpy.ndarray
        Angular velocity [rad/s].
    dalpha : numpy.ndarray
        ``Delta alpha`` [rad/s^2] (:func:`delta_alpha`).

    Returns
    -------
    numpy.ndarray of bool
        True where negative; NaN samples are False.
    """
    d = np.asarray(dalpha) * np.asarray(omega)
    return np.nan_to_num(d, nan=0.0) > 0.0


def negative_damping(theta: np.ndarray, omega: np.ndarray, alpha: np.ndarray, omega0: float) -> np.ndarray:
    """Per sample negative damping from the kinematics (eq. negativedampingdefinition).

    Parameters
    ----------
    theta, omega, alpha : numpy.ndarray
        Angle [rad], angular velocity [rad/s], angular acceleration [rad/s^2].
    omega0 : float
        Natural angular frequency [rad/s] taken away with gravity (:func:`delta_alpha`).

    Returns
    -------
    numpy.ndarray of bool
        :func:`negative_damping_flags` of ``omega`` and ``Delta alpha``; NaN samples are False.
    """
    return negative_damping_flags(omega, delta_alpha(theta, alpha, omega0))


def negative_damping_fraction(flags: np.ndarray, ok: np.ndarray | None = None) -> float:
    """Fraction of the selected samples with negative damping.

    Parameters
    ----------
    flags : numpy.ndarray of bool
        Per-sample negative damping (:func:`negative_damping`, :func:`negative_damping_flags`).
    ok : numpy.ndarray of bool, optional
        The samples counted (usable ones, or those near a turning point); default all.

    Returns
    -------
    float
        Share in [0, 1] [1]; NaN when no sample is selected.
    """
    flags = np.asarray(flags, dtype=bool)
    if ok is not None:
        flags = flags[np.asarray(ok, dtype=bool)]
    return float(flags.mean()) if flags.size else math.nan
