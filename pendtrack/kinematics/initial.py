"""The whole initial analysis on a differentiated record (what the kinematics stage writes)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pendtrack.config import KinematicsConfig
from pendtrack.errors import FitError
from pendtrack.kinematics.analysis import (
    NoRestoringTorque, Omega0Estimate, TurningPoints, amplitudes, delta_alpha, estimate_omega0, negative_damping,
    negative_damping_fraction, phase, phase_speed, savgol_bias_moments, swing_centre_shift, turning_points,
    turning_values,
)
from pendtrack.kinematics.differentiate import KinematicsResult, savgol_kinematics


@dataclass(frozen=True)
class InitialAnalysis:
    """Model-free analysis of a record.

    Attributes
    ----------
    omega0 : Omega0Estimate or None
        None when it cannot be estimated (``reason`` says why); the columns are then absent.
    turning : TurningPoints
        The omega = 0 crossings used.
    columns : dict of str to numpy.ndarray
        Per-sample analysis columns named as in the kinematics schema: ``A_theta``,
        ``A_omega``, ``energy``, ``phase``, ``phase_speed``, ``delta_alpha``,
        ``negative_damping``.
    negative_damping_fraction : float
        Fraction of usable samples with negative damping (NaN without Omega0).
    reason : str
        Empty, or why Omega0 could not be estimated.
    centre : float
        The angle the columns are taken about [rad]: the swing's centre when the record's zero is far from
        it (:func:`swing_centre_shift`: a sensor's or an axis' zero), else 0.
    restoring : bool
        False when alpha at the turning points does not oppose sin(theta) (:class:`NoRestoringTorque`):
        the record is no pendulum's swing.
    """

    omega0: Omega0Estimate | None
    turning: TurningPoints
    columns: dict[str, np.ndarray] = field(default_factory=dict)
    negative_damping_fraction: float = math.nan
    reason: str = ""
    centre: float = 0.0
    restoring: bool = True

    def to_dict(self) -> dict[str, Any]:
        return {"omega0": None if self.omega0 is None else self.omega0.to_dict(),
                "turning": self.turning.to_dict(),
                "columns": {k: v.tolist() for k, v in self.columns.items()},
                "negative_damping_fraction": self.negative_damping_fraction, "reason": self.reason,
                "centre": self.centre, "restoring": self.restoring}


def record_turning_points(kin: KinematicsResult) -> TurningPoints:
    """Turning points of a differentiated record's usable samples, segment by segment.

    Crossings within half a Savitzky-Golay window (``kin.info["window_s"]`` [s]) of a
    segment's ends are left out: the edge windows are less accurate.
    """
    edge = 0.5 * float(kin.info.get("window_s", 0.0))
    return turning_points(kin.t, kin.theta, kin.omega, kin.alpha, kin.ok, kin.segment, edge_s=edge)


def record_turning_values(kin: KinematicsResult, tp: TurningPoints) -> tuple[np.ndarray, np.ndarray]:
    """:func:`~pendtrack.kinematics.analysis.turning_values` of a differentiated record: ``(theta_ext, alpha_ext)``
    for eq. straightline [rad], [rad/s^2]."""
    return turning_values(kin.t, kin.theta, kin.alpha, tp, kin.ok, kin.segment)


def smoothing_moments(info: Mapping[str, Any]) -> tuple[float, float] | None:
    """:func:`~pendtrack.kinematics.analysis.savgol_bias_moments` of the filter an ``info`` describes.

    ``info`` holds ``window_points``, ``order`` and ``h`` [s] (:attr:`KinematicsResult.info`,
    or the kinematics stage's provenance); None when one is missing.
    """
    if not {"window_points", "order", "h"} <= set(info):
        return None
    return savgol_bias_moments(int(info["window_points"]), int(info["order"]), float(info["h"]))


def omega0_from_kinematics(kin: KinematicsResult, *, correct_smoothing: bool = True) -> Omega0Estimate:
    """Omega0 from eq. straightline on the turning points of a differentiated record.

    Turning points within half a window of a segment's ends are skipped (edge fits).
    ``correct_smoothing`` removes the Savitzky-Golay bias (see :func:`estimate_omega0`).

    Raises
    ------
    FitError
        Too few turning points or no restoring slope.
    """
    th_ext, al_ext = record_turning_values(kin, record_turning_points(kin))
    return estimate_omega0(th_ext, al_ext, sg_moments=smoothing_moments(kin.info) if correct_smoothing else None)


def estimate_omega0_from_angle(t: Any, theta: Any, ok: Any = None, *,
                               window_s: float = KinematicsConfig.savgol_window_s,
                               order: int = KinematicsConfig.savgol_order, max_gap_s: float = KinematicsConfig.max_gap_s,
                               min_segment_s: float = KinematicsConfig.min_segment_s) -> Omega0Estimate:
    """Omega0 [rad/s] straight from theta(t): Savitzky-Golay, turning points, eq. straightline.

    Convenience for initial estimates of a fit; same parameters as :func:`savgol_kinematics`.
    """
    kin = savgol_kinematics(t, theta, ok, window_s=window_s, order=order, max_gap_s=max_gap_s,
                            min_segment_s=min_segment_s)
    return omega0_from_kinematics(kin)


def analyse(kin: KinematicsResult, *, omega0: float | None = None, correct_smoothing: bool = True) -> InitialAnalysis:
    """Turning points, Omega0 and the per-sample analysis columns.

    Parameters
    ----------
    kin : KinematicsResult
        Output of :func:`savgol_kinematics`.
    omega0 : float, optional
        Use this Omega0 [rad/s] for the columns instead of the estimate (the estimate is
        still computed and reported when possible).
    correct_smoothing : bool
        Remove the Savitzky-Golay bias from the Omega0 estimate (see :func:`estimate_omega0`).

    Returns
    -------
    InitialAnalysis
    """
    tp = record_turning_points(kin)
    est: Omega0Estimate | None
    reason, restoring = "", True
    try:
        th_ext, al_ext = record_turning_values(kin, tp)
        est = estimate_omega0(th_ext, al_ext, sg_moments=smoothing_moments(kin.info) if correct_smoothing else None)
    except NoRestoringTorque as exc:
        est, reason, restoring = None, str(exc), False
    except FitError as exc:
        est, reason = None, str(exc)
    w0 = omega0 if omega0 is not None else (None if est is None else est.omega0)
    if w0 is None:
        return InitialAnalysis(omega0=None, turning=tp, reason=reason, restoring=restoring)
    # amplitudes, energy, phase and delta_alpha are about the hanging position: the swing's centre, as Omega0's
    # estimate takes it, when the record's zero is not there
    centre = swing_centre_shift(tp.theta)
    theta = kin.theta - centre
    a_th, a_om, energy = amplitudes(theta, kin.omega, w0)
    neg = negative_damping(theta, kin.omega, kin.alpha, w0)
    cols = {
        "A_theta": a_th,
        "A_omega": a_om,
        "energy": energy,
        "phase": phase(theta, kin.omega, w0, kin.segment),
        "phase_speed": phase_speed(theta, kin.omega, kin.alpha, w0),
        "delta_alpha": delta_alpha(theta, kin.alpha, w0),
        "negative_damping": neg & kin.ok,
    }
    return InitialAnalysis(omega0=est, turning=tp, columns=cols, centre=centre,
                           negative_damping_fraction=negative_damping_fraction(neg, kin.ok), reason=reason)
