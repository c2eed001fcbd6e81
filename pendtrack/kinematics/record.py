"""A record's kinematics table: Savitzky-Golay theta, omega, alpha and the initial analysis.

:func:`differentiate_record` differentiates an angle series with ``[kinematics]``;
:func:`kinematics_table` adds the paper's initial analysis and gives the columns and facts the
kinematics stage writes (and ``pt.kinematics`` returns). No files here.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pandas as pd
from scipy.signal import savgol_coeffs

from pendtrack.config import KinematicsConfig
from pendtrack.kinematics.differentiate import KinematicsError, KinematicsResult, savgol_kinematics
from pendtrack.kinematics.initial import analyse, omega0_from_kinematics
from pendtrack.kinematics.free_swing import free_swing
from pendtrack.kinematics.rest import BAND_QUANTA, BAND_SIGMAS, smallest_step

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class KinematicsTable:
    """What the kinematics stage writes.

    Attributes
    ----------
    frame : DataFrame
        t [s], theta [rad], omega [rad/s], alpha [rad/s^2], ok, segment, and the analysis
        columns when Omega0 could be estimated (A_theta, A_omega, energy, phase, ...).
    facts : dict
        Omega0, Omega0_stderr, Omega0_raw [rad/s], Omega0_reason, theta_centre [rad] (the angle the
        analysis columns are taken about: the swing's centre when the zero is far from it, else 0), n_turning_points,
        negative_damping_fraction, ok_fraction, noise_rad [rad] (the samples' noise about the curve,
        :func:`sample_noise`) and the differentiation facts (``kin.info``).
    """

    frame: pd.DataFrame
    facts: dict[str, Any]


def differentiate_record(t: np.ndarray, theta: np.ndarray, ok: np.ndarray, *, options: KinematicsConfig,
                         source: Any = None) -> KinematicsResult:
    """:func:`savgol_kinematics` with ``[kinematics]``'s window [s], order, gap bridging and minimum
    segment; a failure names ``source``. A record too sparse to follow its swing (:func:`too_sparse`) is a
    KinematicsError.

    A hold before the release and a catch at the end (:mod:`pendtrack.kinematics.free_swing`) are
    no free swing: their samples get ``ok = False`` (their rows stay) and the derivatives start at
    the release and end before the catch, as at any record's ends. ``info`` gains ``held_until_s``
    (the first sample after the hold [s], or None), ``n_held``, ``free_until_s`` (the first sample
    of the catch [s], or None) and ``n_caught``.
    """
    sparse = too_sparse(np.asarray(theta, dtype=float)[np.asarray(ok, dtype=bool)])
    if sparse:
        raise KinematicsError(f"theta is sampled too sparsely to follow the swing: {sparse}", path=source)
    ok, hold, catch = free_swing(t, theta, ok, source=source)
    try:
        kin = savgol_kinematics(t, theta, ok, window_s=options.savgol_window_s, order=options.savgol_order,
                                max_gap_s=options.max_gap_s, min_segment_s=options.min_segment_s)
    except KinematicsError as exc:
        raise KinematicsError(str(exc), path=source) from None
    held = {"held_until_s": None if hold is None else hold.release_s, "n_held": 0 if hold is None else hold.n,
            "free_until_s": None if catch is None else catch.free_until_s,
            "n_caught": 0 if catch is None else int(np.asarray(t).size - catch.n)}
    return replace(kin, info={**kin.info, **held})


def centre_weight(kin: KinematicsResult) -> float:
    """The Savitzky-Golay filter's weight c0 on the sample at its centre [1] (0 if the window is unknown).

    A white noise of variance s^2 keeps ``(1 - c0) s^2`` about the smooth curve and ``c0 s^2`` in it.
    """
    w, order = int(kin.info.get("window_points", 0)), int(kin.info.get("order", 3))
    return float(savgol_coeffs(w, order)[w // 2]) if w > order + 1 and w % 2 else 0.0


def sample_noise(theta: np.ndarray, kin: KinematicsResult) -> float:
    """The noise of the usable samples of ``theta`` about their Savitzky-Golay curve [rad] (robust, MAD).

    Taken about the smooth curve, not from sample-to-sample steps: a swing sampled 10 times a period
    steps by a third of its amplitude, which would pass for noise. Corrected by :func:`centre_weight`
    for the part of the noise the curve follows. NaN without usable samples.
    """
    use = kin.ok & np.isfinite(theta) & np.isfinite(kin.theta)
    if not use.any():
        return math.nan
    resid = theta[use] - kin.theta[use]
    return 1.4826 * float(np.median(np.abs(resid - np.median(resid)))) / math.sqrt(1.0 - centre_weight(kin))


MIN_SAMPLES_PER_PERIOD = 8  # below, the 5-point Savitzky-Golay window spans most of a period: Omega0 read
# +0.3 % at 8 samples a period, +0.9 % at 7, +8 % at 5.5 (a clean swing), its standard error 0.01 %
# share of theta_{k+1} + theta_{k-1} that c theta_k explains: a sampled oscillation (0.92-0.99 on tables of turning
# points and hand-picked points); noise alone ~0. Noise on a swing also pulls c towards 0, i.e. towards fewer
# samples a period: a 0.02-rad swing in 10 mrad of noise at 30 fps (32 samples a period) explains 0.52 with c for 7.3
SAMPLED_OSCILLATION_R2 = 0.8


def too_sparse(theta: np.ndarray) -> str:
    """Why ``theta`` is sampled too sparsely to follow its swing, or "" when it is not.

    A swing sampled every h at angular frequency w obeys ``theta_{k+1} + theta_{k-1} = 2 cos(w h) theta_k``
    (about its centre; exactly for a sinusoid): the least-squares ``c`` of that relation gives the samples
    per period, ``2 pi / arccos(c / 2)``, where it explains most of the left side (noise does not). Under
    :data:`MIN_SAMPLES_PER_PERIOD` (a table of turning points, points picked by hand every few frames) the
    Savitzky-Golay derivatives, and every number from them, are biased.
    """
    x = np.asarray(theta, dtype=float)
    x = x[np.isfinite(x)]
    if x.size < 8:
        return ""
    x = x - float(np.median(x))
    y = x[2:] + x[:-2]
    z = x[1:-1]
    zz = float(z @ z)
    if zz <= 0.0:
        return ""
    c = float(z @ y) / zz
    explained = 1.0 - float(np.sum((y - c * z) ** 2)) / max(float(y @ y), 1e-300)
    n = 2.0 * math.pi / math.acos(min(max(0.5 * c, -1.0), 1.0)) if c < 2.0 else math.inf
    if explained < SAMPLED_OSCILLATION_R2 or n >= MIN_SAMPLES_PER_PERIOD:
        return ""
    return (f"about {n:.1f} samples a period ({x.size} samples that follow theta[k+1] + theta[k-1] = "
            f"{c:.2f} theta[k], a sampled oscillation), fewer than {MIN_SAMPLES_PER_PERIOD}: its derivatives and "
            "Omega0 would be biased (a table of turning points, or points picked every few frames?); pendtrack "
            "needs the angle sampled through each swing: track every frame")


def no_swing(theta: np.ndarray, kin: KinematicsResult, *, n_turning: int) -> str:
    """Why ``theta`` holds no swing, or "" when it does.

    A record holds no swing when its usable samples stay within the band a rest stays in (half
    their range at most :data:`~pendtrack.kinematics.rest.BAND_SIGMAS` times their noise about the
    Savitzky-Golay curve, :func:`sample_noise`, or :data:`~pendtrack.kinematics.rest.BAND_QUANTA` of
    a quantised record's steps: a constant, a static marker's jitter, an encoder flickering by a
    step), or when it moves but never turns back (no turning point: a ramp, a column of times).

    Parameters
    ----------
    theta : ndarray
        The angle as read [rad], at ``kin.t``.
    kin : KinematicsResult
        Its Savitzky-Golay kinematics.
    n_turning : int
        Turning points the initial analysis found.
    """
    use = kin.ok & np.isfinite(theta) & np.isfinite(kin.theta)
    if not use.any():
        return ""
    raw = theta[use]
    half_range = 0.5 * float(np.ptp(raw))
    band = max(BAND_SIGMAS * sample_noise(theta, kin), BAND_QUANTA * smallest_step(raw))
    if half_range <= band:
        return (f"it stays within {half_range:.3g} rad of {0.5 * (raw.max() + raw.min()):.4g} rad over "
                f"{raw.size} samples, inside its own noise band ({band:.3g} rad)")
    if n_turning == 0:
        turns = float(np.ptp(raw)) / (2.0 * np.pi)
        # a pendulum launched over the top (a double pendulum's first arm) rotates without a turning point:
        # the angle is right, but no model here has a swing to fit until it swings back
        rotation = (f"; if the pendulum turns over the top ({turns:.1f} turns), record it until it swings back"
                    if turns > 1.0 else "")
        return (f"it goes from {raw[0]:.4g} to {raw[-1]:.4g} rad and never turns back ({raw.size} samples, "
                f"no turning point{rotation})")
    return ""


def kinematic_columns(kin: KinematicsResult) -> pd.DataFrame:
    """The differentiated columns t, theta, omega, alpha, ok, segment of ``kin``."""
    return pd.DataFrame({"t": kin.t, "theta": kin.theta, "omega": kin.omega, "alpha": kin.alpha, "ok": kin.ok,
                         "segment": kin.segment})


def kinematics_table(t: np.ndarray, theta: np.ndarray, ok: np.ndarray, *, options: KinematicsConfig,
                     source: Any = None) -> KinematicsTable:
    """Differentiate an angle series and run the paper's initial analysis on it.

    Parameters
    ----------
    t, theta, ok : ndarray
        Times [s] on a uniform grid, angle [rad], usable samples.
    options : KinematicsConfig
        ``[kinematics]``.
    source : path-like, optional
        Named in errors and warnings.

    Returns
    -------
    KinematicsTable

    Raises
    ------
    KinematicsError
        The series cannot be differentiated (bad time axis, nothing long enough).
    """
    kin = differentiate_record(t, theta, ok, options=options, source=source)
    ana = analyse(kin)
    still = no_swing(np.asarray(theta, dtype=float), kin, n_turning=len(ana.turning))
    if still:
        # a constant column read as theta, a static "marker": every number derived from it is meaningless
        raise KinematicsError(f"theta does not swing: {still}; the column read as theta is not the angle "
                              "(--columns, e.g. t,theta[deg]), or the tracked point is not the bob (track again "
                              "with --roi X,Y,W,H around it)", path=source)
    if not ana.restoring:
        # every fit of such a record is meaningless (it ended in "too few gap-free stretches" or a fit far off)
        raise KinematicsError(f"theta is no pendulum's swing: {ana.reason}; the tracked point is "
                              "not the bob (track again with --roi X,Y,W,H around it), or the angle is not theta from "
                              "the vertical in radians (--columns with its unit, e.g. t,theta[deg])", path=source)
    raw = omega0_from_kinematics(kin, correct_smoothing=False) if ana.omega0 is not None else None
    if ana.omega0 is None:
        log.warning("%s: no model-free Omega0 (%s); analysis columns left out", source, ana.reason)
    frame = kinematic_columns(kin)
    for name, values in ana.columns.items():
        frame[name] = values
    facts: dict[str, Any] = {
        "Omega0": None if ana.omega0 is None else ana.omega0.omega0,
        "Omega0_stderr": None if ana.omega0 is None else ana.omega0.stderr,
        "Omega0_raw": None if raw is None else raw.omega0,
        "Omega0_reason": ana.reason,
        "theta_centre": ana.centre,
        # one per half swing: those eq. straightline took (noise-made ones between the same crossings left out)
        "n_turning_points": len(ana.turning) if ana.omega0 is None else ana.omega0.n_points + ana.omega0.n_rejected,
        "negative_damping_fraction": None if math.isnan(ana.negative_damping_fraction)
        else ana.negative_damping_fraction,
        "ok_fraction": float(np.mean(kin.ok)) if kin.ok.size else 0.0,
        "noise_rad": _finite_or_none(sample_noise(np.asarray(theta, dtype=float), kin)),
        **kin.info,
    }
    return KinematicsTable(frame, facts)


def _finite_or_none(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None
