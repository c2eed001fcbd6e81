"""The fit's cost: the paper's Xi^2 (eq. leastsquarescostfunction) or plain least squares on theta.

Both are written as a residual vector ``r`` with ``sum(r**2)`` equal to the cost, so that
:func:`scipy.optimize.least_squares` can minimise them:

* ``"xi2"``: ``r = [A_theta_mod - A_theta_exp, A_omega_mod - A_omega_exp] / sqrt(N)`` with
  ``A_theta = sin(theta/2)`` and ``A_omega = omega/(2 Omega0)`` (eq. amplitudes), so that
  ``sum(r**2)`` is exactly the paper's Xi^2.
* ``"theta"``: ``r = (theta_mod - theta_exp) / sqrt(N)``, the mean squared angle residual [rad^2].

Which Omega0 goes into ``A_omega``
----------------------------------
The same, *fixed*, data-derived Omega0 (the turning-point estimate, eq. straightline) scales
both the data and the model: ``A_omega_mod - A_omega_exp = (omega_mod - omega_exp)/(2 Omega0_hat)``.
With the *fitted* Omega0 in the denominator the optimiser could lower Xi^2 by inflating Omega0
(every omega residual shrinks as 1/Omega0^2), a bias in the very parameter the paper measures
best; with the fitted Omega0 on the model side only, model and data would be compared on
different scales. A fixed scale makes Xi^2 an ordinary weighted least-squares cost (weight
``1/(2 Omega0_hat)^2`` on omega); since Omega0_hat agrees with the fitted Omega0 to ~0.1 %, the
value of Xi^2 is the paper's to that precision.

Matched observation
-------------------
The data's omega (and, in ``kinematics.parquet``, theta too) come out of a Savitzky-Golay
filter. At 120 fps with the paper's 25-frame cubic window that filter is biased on a pendulum
released near the top: about 0.2 mrad rms on theta and 1 mrad/s rms on omega, which is
comparable to the statistical precision of a 60 s record and would bias the fit by several
standard errors. :class:`Observation` therefore passes the simulated theta through the *same*
filter (smoothing for theta, first derivative for omega) before the comparison, so that data
and model are seen through one instrument; the half-window at each end of the fit window,
where the data's filter saw samples the simulation does not have, is left out of the cost.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.signal import savgol_coeffs

COSTS = ("xi2", "theta")


@dataclass(frozen=True)
class Observation:
    """How the data were filtered, so that the model can be filtered the same way.

    Parameters
    ----------
    savgol_window : int
        Savitzky-Golay window of the data's derivatives [samples], odd; 0 means the data's
        omega is an exact derivative (no filter is applied to the model).
    savgol_order : int
        Polynomial order of that filter.
    smooth_theta : bool
        True if the data's theta is the filter's smoothed angle (as in ``kinematics.parquet``),
        False if it is the raw measured angle.
    """

    savgol_window: int = 0
    savgol_order: int = 3
    smooth_theta: bool = True

    def __post_init__(self) -> None:
        w = self.savgol_window
        if w and (w < 3 or w % 2 == 0 or self.savgol_order >= w):
            raise ValueError(f"savgol_window must be odd, >= 3 and > savgol_order, got {w}")

    @property
    def trim(self) -> int:
        """Samples at each end of a window that the filter makes unreliable [samples]."""
        return self.savgol_window // 2

    def apply(self, theta: np.ndarray, omega: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
        """Filter a uniformly sampled model curve the way the data were filtered.

        Parameters
        ----------
        theta, omega : ndarray
            Simulated angle [rad] and angular velocity [rad/s] on a uniform grid.
        h : float
            Grid step [s].

        Returns
        -------
        theta_obs, omega_obs : ndarray
            What the filter would have returned [rad], [rad/s]. Values within :attr:`trim`
            samples of either end are not meaningful (the filter is applied in "valid" mode
            and the ends are copied from the unfiltered curves).
        """
        w = self.savgol_window
        if not w or theta.size < w:
            return theta, omega
        k = w // 2
        th = theta.copy()
        om = omega.copy()
        if self.smooth_theta:
            th[k:-k] = np.convolve(theta, _coeffs(w, self.savgol_order, 0, 1.0), mode="valid")
        om[k:-k] = np.convolve(theta, _coeffs(w, self.savgol_order, 1, h), mode="valid")
        return th, om


@lru_cache(maxsize=32)
def _coeffs(window: int, order: int, deriv: int, delta: float) -> np.ndarray:
    """Savitzky-Golay convolution coefficients (cached: the fit calls the filter thousands of times)."""
    c = savgol_coeffs(window, order, deriv=deriv, delta=delta, use="conv")
    c.setflags(write=False)
    return c


def residual_vector(theta_mod: np.ndarray, omega_mod: np.ndarray, theta_exp: np.ndarray,
                    omega_exp: np.ndarray, *, cost: str, omega_scale: float) -> np.ndarray:
    """Residual vector whose sum of squares is the cost.

    Parameters
    ----------
    theta_mod, omega_mod : ndarray
        Model angle [rad] and angular velocity [rad/s] at the N data samples.
    theta_exp, omega_exp : ndarray
        Measured angle [rad] and angular velocity [rad/s] at the same samples.
    cost : {"xi2", "theta"}
        The paper's Xi^2 or the mean squared angle residual.
    omega_scale : float
        ``1/(2 Omega0_hat)`` [s/rad], the fixed scale of ``A_omega`` (see module docstring).

    Returns
    -------
    ndarray
        Length 2N for ``"xi2"`` (theta part then omega part), N for ``"theta"``; dimensionless
        for ``"xi2"``, [rad] for ``"theta"``, already divided by sqrt(N).
    """
    n = theta_exp.size
    if n == 0:
        raise ValueError("no data sample in the cost")
    norm = 1.0 / np.sqrt(n)
    if cost == "xi2":
        r_theta = np.sin(0.5 * theta_mod) - np.sin(0.5 * theta_exp)
        r_omega = omega_scale * (omega_mod - omega_exp)
        return np.concatenate((r_theta, r_omega)) * norm
    if cost == "theta":
        return (theta_mod - theta_exp) * norm
    raise ValueError(f"unknown cost {cost!r}; expected one of {COSTS}")


def channels(r: np.ndarray, n: int) -> np.ndarray:
    """Split a residual vector (or Jacobian rows) into its channels, shape ``(n_channels, n, ...)``."""
    return r.reshape((r.shape[0] // n, n) + r.shape[1:])
