"""Angle -> smoothed angle, angular velocity and acceleration, and the paper's initial analysis.

Pure functions (no files): :func:`savgol_kinematics` (Savitzky-Golay, gap-aware) and
:func:`savgol_uniform` (on a uniform grid), :func:`turning_points` (optionally with
hysteresis), :func:`estimate_omega0` (eq. straightline), :func:`delta_alpha`,
:func:`amplitudes`, :func:`phase`, :func:`phase_speed`, :func:`negative_damping`,
:func:`negative_damping_flags`, :func:`negative_damping_fraction`, :func:`find_hold`,
:func:`find_lift` and :func:`find_catch` (samples at rest or carried by a hand before the release, and
after a catch: no free swing), :func:`find_drive` (a swing that grows: no free swing at all), and :func:`analyse` which runs the whole initial analysis
on a :class:`KinematicsResult`. These are the only
implementations of these signal facts in pendtrack: discovery and report import them.
"""

from pendtrack.kinematics.analysis import (
    Omega0Estimate, TurningPoints, amplitudes, delta_alpha, estimate_omega0, negative_damping, swing_centre_shift,
    negative_damping_flags, negative_damping_fraction, phase, phase_speed, turning_points, turning_values,
)
from pendtrack.kinematics.differentiate import (
    KinematicsError, KinematicsResult, savgol_kinematics, savgol_uniform, window_points,
)
from pendtrack.kinematics.initial import (
    InitialAnalysis, analyse, estimate_omega0_from_angle, omega0_from_kinematics, record_turning_points,
    record_turning_values, smoothing_moments,
)
from pendtrack.kinematics.free_swing import Catch, Drive, Hold, Lift, find_catch, find_drive, find_hold, find_lift

__all__ = [
    "Omega0Estimate", "TurningPoints", "amplitudes", "delta_alpha", "estimate_omega0", "negative_damping",
    "swing_centre_shift",
    "negative_damping_flags", "negative_damping_fraction", "phase", "phase_speed", "turning_points",
    "turning_values",
    "KinematicsError", "KinematicsResult", "savgol_kinematics", "savgol_uniform", "window_points", "InitialAnalysis", "analyse",
    "omega0_from_kinematics", "estimate_omega0_from_angle", "record_turning_points", "record_turning_values",
    "smoothing_moments",
    "Catch", "Drive", "Hold", "Lift", "find_catch", "find_drive", "find_hold", "find_lift",
]
