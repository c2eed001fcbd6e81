"""Closed-form solutions used to check the solvers."""

from __future__ import annotations

import numpy as np


def inertial_speed(theta: np.ndarray, theta0: float, omega0_nat: float, ca: float) -> np.ndarray:
    """|omega| of the pure-inertial model from rest at ``theta0`` (eq. pureinertialsolut).

    ``alpha + (Omega0^2 - Ca omega^2) sin(theta) = 0`` gives
    ``omega/Omega0 = sqrt((1 - exp(2 (cos theta0 - cos theta) Ca)) / Ca)``; for ``Ca -> 0``
    energy conservation ``sqrt(2 (cos theta - cos theta0))``.

    Parameters
    ----------
    theta : numpy.ndarray
        Angles [rad] reached on the swing.
    theta0 : float
        Release angle [rad] (at rest).
    omega0_nat : float
        Omega0 [rad/s].
    ca : float
        Added-mass coefficient Ca >= 0.

    Returns
    -------
    numpy.ndarray
        Speed |omega| [rad/s].
    """
    theta = np.asarray(theta, dtype=np.float64)
    d = np.cos(theta0) - np.cos(theta)
    if ca == 0.0:
        val = -2.0 * d
    else:
        val = -np.expm1(2.0 * d * ca) / ca
    return omega0_nat * np.sqrt(np.maximum(val, 0.0))


def damped_linear(t: np.ndarray, theta0: float, omega0: float, omega_nat: float,
                  c1: float) -> tuple[np.ndarray, np.ndarray]:
    """Underdamped ``theta'' + C1 theta' + Omega0^2 theta = 0`` from ``(theta0, omega0)`` at t = 0.

    Parameters
    ----------
    t : numpy.ndarray
        Times [s] from the initial state.
    theta0, omega0 : float
        Initial angle [rad] and angular velocity [rad/s].
    omega_nat : float
        Omega0 [rad/s].
    c1 : float
        Viscous coefficient C1 [1/s], ``C1 < 2 Omega0``.

    Returns
    -------
    theta, omega : numpy.ndarray
        [rad], [rad/s].
    """
    t = np.asarray(t, dtype=np.float64)
    g = 0.5 * c1
    wd = np.sqrt(omega_nat ** 2 - g * g)
    a = theta0
    b = (omega0 + g * theta0) / wd
    e = np.exp(-g * t)
    cs, sn = np.cos(wd * t), np.sin(wd * t)
    theta = e * (a * cs + b * sn)
    omega = e * ((-g * a + b * wd) * cs + (-g * b - a * wd) * sn)
    return theta, omega
