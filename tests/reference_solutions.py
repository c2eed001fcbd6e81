"""Reference solutions the solver tests compare against (test-only; not part of pendtrack).

* closed forms: the pure-inertial speed (eq. pureinertialsolut) and the linearly damped
  linear oscillator;
* the one-parameter Mittag-Leffler function E_beta(z) on the negative real axis;
* an implicit Grunwald-Letnikov solver of ``D^beta y = rhs(t, y)``.

Mittag-Leffler: ``E_beta(z) = sum_k z^k / Gamma(beta k + 1)``; ``E_beta(-lambda t^beta)`` solves the
fractional relaxation ``D^beta y = -lambda y``, ``y(0) = 1`` (Caputo), the classic test of
fractional solvers. For ``0 < beta < 1`` and ``x = -z > 0`` two methods:

* the power series while ``x^(1/beta) <= SERIES_MAX`` (the largest term is then about
  ``e^SERIES_MAX``, so cancellation costs at most ~2 digits);
* otherwise the Laplace-type representation (Gorenflo-Mainardi), after the substitution
  ``r = v^(1/beta)`` which removes the integrable singularity::

      E_beta(-x) = sin(beta pi)/(beta pi) * int_0^inf exp(-(x v)^(1/beta)) / (v^2 + 2 v cos(beta pi) + 1) dv

  evaluated with scipy ``quad`` (smooth, monotone integrand).

``beta = 1`` gives ``exp(-x)``. Accuracy ~1e-12 absolute (checked against each other where
both apply and against the asymptote ``x^-1/Gamma(1 - beta)``).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from pendtrack.errors import ModelError
from pendtrack.models.gl import gl_weights


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


SERIES_MAX = 3.0  # the series is used while x^(1/beta) <= this (largest term ~ e^3)


def _series(beta: float, z: float) -> float:
    total = 0.0
    lx = math.log(abs(z)) if z != 0.0 else -math.inf
    sign = -1.0 if z < 0 else 1.0
    for k in range(2000):
        term = (sign ** k) * math.exp(k * lx - math.lgamma(beta * k + 1.0)) if k else 1.0
        total += term
        if k > 5 and abs(term) < 1e-17 * max(1.0, abs(total)):
            break
    return total


def _integral(beta: float, x: float) -> float:
    from scipy.integrate import quad

    c = math.cos(beta * math.pi)
    inv = 1.0 / beta

    def f(w: float) -> float:  # after w = x v: x/(w^2 + 2 w x c + x^2) exp(-w^(1/beta))
        return x * math.exp(-(w ** inv)) / (w * w + 2.0 * w * x * c + x * x)

    # exp(-w^(1/beta)) is negligible beyond w_max
    w_max = 40.0 ** beta
    val, _ = quad(f, 0.0, w_max, epsabs=1e-15, epsrel=1e-13, limit=400, points=[min(x, w_max / 2)])
    return math.sin(beta * math.pi) / (beta * math.pi) * val


def mittag_leffler(beta: float, z: float | np.ndarray) -> float | np.ndarray:
    """E_beta(z) for real ``z <= 0`` and ``0 < beta <= 1``.

    Parameters
    ----------
    beta : float
        Order, in (0, 1].
    z : float or numpy.ndarray
        Argument(s), <= 0 (dimensionless).

    Returns
    -------
    float or numpy.ndarray
        E_beta(z), same shape as ``z``.
    """
    if not 0.0 < beta <= 1.0:
        raise ModelError(f"mittag_leffler: beta must be in (0, 1], got {beta!r}")
    arr = np.asarray(z, dtype=np.float64)
    if np.any(arr > 0) or not np.all(np.isfinite(arr)):
        raise ModelError("mittag_leffler: only finite z <= 0 are supported")
    out = np.empty_like(arr)
    for idx, val in np.ndenumerate(arr):
        x = -float(val)
        if beta == 1.0:
            out[idx] = math.exp(-x)
        elif x ** (1.0 / beta) <= SERIES_MAX:
            out[idx] = _series(beta, -x)
        else:
            out[idx] = _integral(beta, x)
    return float(out) if out.ndim == 0 else out


def solve_gl_fde(rhs: Callable[[float, float], float], beta: float, y0: float, h: float, n_steps: int, *,
                 tol: float = 1e-13, max_iter: int = 100) -> np.ndarray:
    """Solve ``D^beta y = rhs(t, y)``, ``0 < beta <= 1``, ``y(0) = y0`` by the implicit GL scheme.

    Caputo sense (constant past, full history): ``sum_{k<=i} W_k (y_{i-k} - y0) =
    h^beta rhs(t_i, y_i)``; each step solved by fixed-point iteration from the explicit
    prediction (contracts when ``h^beta |d rhs/dy| < 1``). First order in h.

    Returns
    -------
    numpy.ndarray
        ``y`` at ``t_i = i h``, i = 0 .. n_steps.
    """
    w = gl_weights(beta, n_steps)
    hb = h ** beta
    y = np.empty(n_steps + 1)
    y[0] = y0
    dev = np.zeros(n_steps + 1)  # y - y0
    for i in range(1, n_steps + 1):
        hist = float(np.dot(w[1:i + 1], dev[i - 1::-1])) if i > 1 else w[1] * dev[0]
        ti = i * h
        yi = y[i - 1]
        for _ in range(max_iter):
            new = y0 - hist + hb * rhs(ti, yi)
            done = abs(new - yi) <= tol * (1.0 + abs(new))
            yi = new
            if done:
                break
        y[i] = yi
        dev[i] = yi - y0
    return y
