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

from pendtrack.config import KinematicsConfig
from pendtrack.kinematics.differentiate import KinematicsError, KinematicsResult, savgol_kinematics
from pendtrack.kinematics.initial import analyse, omega0_from_kinematics
from pendtrack.kinematics.free_swing import free_swing

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
        negative_damping_fraction, ok_fraction and the differentiation facts (``kin.info``).
    """

    frame: pd.DataFrame
    facts: dict[str, Any]


def differentiate_record(t: np.ndarray, theta: np.ndarray, ok: np.ndarray, *, options: KinematicsConfig,
                         source: Any = None) -> KinematicsResult:
    """:func:`savgol_kinematics` with ``[kinematics]``'s window [s], order, gap bridging and minimum
    segment; a failure names ``source``.

    A hold before the release and a catch at the end (:mod:`pendtrack.kinematics.free_swing`) are
    no free swing: their samples get ``ok = False`` (their rows stay) and the derivatives start at
    the release and end before the catch, as at any record's ends. ``info`` gains ``held_until_s``
    (the first sample after the hold [s], or None), ``n_held``, ``free_until_s`` (the first sample
    of the catch [s], or None) and ``n_caught``.
    """
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
        "n_turning_points": len(ana.turning),
        "negative_damping_fraction": None if math.isnan(ana.negative_damping_fraction)
        else ana.negative_damping_fraction,
        "ok_fraction": float(np.mean(kin.ok)) if kin.ok.size else 0.0,
        **kin.info,
    }
    return KinematicsTable(frame, facts)
