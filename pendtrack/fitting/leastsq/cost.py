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

import math
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
        theta = np.ascontiguousarray(theta, dtype=float)
        smoothed = theta.copy()
        om = np.array(omega, dtype=float)
        # both filters in one pass (numba): np.convolve twice cost ~0.25 ms per 10^4 samples,
        # a third of a fit's time per model evaluation
        filter_kernel()(theta, _reversed_coeffs(w, self.savgol_order, 0, 1.0),
                        _reversed_coeffs(w, self.savgol_order, 1, h), smoothed, om)
        return (smoothed if self.smooth_theta else theta), om


    def apply_columns(self, theta: np.ndarray, omega: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`apply` to every column of ``(n, P)`` arrays (the filter is linear: sensitivities).

        Parameters
        ----------
        theta, omega : ndarray
            ``(n, P)``: e.g. d theta/d p_j [rad/unit] and d omega/d p_j [rad/s/unit] on the grid.
        h : float
            Grid step [s].

        Returns
        -------
        theta_obs, omega_obs : ndarray
            ``(n, P)``, column j what :meth:`apply` returns for column j.
        """
        w = self.savgol_window
        if not w or theta.shape[0] < w:
            return theta, omega
        th_t = np.ascontiguousarray(theta.T)
        sm = th_t.copy()
        om = np.array(omega.T, dtype=float, order="C")
        cs = _reversed_coeffs(w, self.savgol_order, 0, 1.0)
        cd = _reversed_coeffs(w, self.savgol_order, 1, h)
        kern = filter_kernel()
        for j in range(th_t.shape[0]):
            kern(th_t[j], cs, cd, sm[j], om[j])
        return (sm if self.smooth_theta else th_t).T, om.T


def savgol_pair_py(x, c_smooth, c_deriv, out_smooth, out_deriv):  # noqa: ANN001, ANN201
    """Two FIR filters of ``x`` in one pass ("valid" part, centred); ends of the outputs untouched.

    ``out_smooth[i + k] = sum_j c_smooth[j] x[i + j]`` (likewise ``out_deriv``), ``k = w // 2``,
    ``w = len(c_smooth)`` -- a correlation, i.e. ``np.convolve(x, c[::-1], "valid")``. The numba
    version (:func:`filter_kernel`) is this function compiled; they agree to rounding.
    """
    w = c_smooth.shape[0]
    k = w // 2
    for i in range(x.shape[0] - w + 1):
        a = 0.0
        b = 0.0
        for j in range(w):
            a += c_smooth[j] * x[i + j]
            b += c_deriv[j] * x[i + j]
        out_smooth[i + k] = a
        out_deriv[i + k] = b


_FILTER: dict[str, object] = {}


def filter_kernel():  # noqa: ANN201
    """The numba-compiled :func:`savgol_pair_py` (compiled, or loaded from cache, on first call)."""
    if "pair" not in _FILTER:
        from numba import njit

        # fastmath: the two 25-term sums may be reassociated (vectorised); rounding-level differences
        _FILTER["pair"] = njit(cache=True, fastmath=True)(savgol_pair_py)
    return _FILTER["pair"]


PI_1 = 3.14159265346825122834e00  # pi = PI_1 + PI_1T to ~86 bits; PI_1 has 33 significant bits,
PI_1T = 1.21542010130123852029e-10  # so k PI_1 is exact for |k| < 2^20 (fdlibm's pio2_1, pio2_1t, doubled)
INV_PI = 3.18309886183790671538e-01
SIN_TAYLOR = tuple((-1) ** n / math.factorial(2 * n + 1) for n in range(12))  # sin r = r sum_n c_n r^2n


def half_angle_sine_py(theta, out):  # noqa: ANN001, ANN201
    """``out[i] = sin(theta[i] / 2)`` (``A_theta``, eq. amplitudes) [1]; theta [rad], |theta| < 6e6.

    ``x = theta/2`` reduced to ``r = x - k pi`` (``|r| <= pi/2``, Cody-Waite with pi in two
    parts), then ``(-1)^k r (1 - r^2/3! + ... - r^22/23!)``; the first omitted term is below
    4e-18 at ``|r| = pi/2``. Branch-free, so the numba version (:func:`half_sine_kernel`)
    vectorises: ~1 ns a sample against ~13 ns for ``np.sin`` (a libm call each), which was
    a seventh of a fit's time per model evaluation. Agrees with ``np.sin`` to ~2e-16.
    """
    for i in range(theta.shape[0]):
        x = 0.5 * theta[i]
        k = math.floor(x * INV_PI + 0.5)
        r = (x - k * PI_1) - k * PI_1T
        sign = 1.0 - 4.0 * (0.5 * k - math.floor(0.5 * k))  # (-1)^k
        z = r * r
        c = SIN_TAYLOR
        p = c[0] + z * (c[1] + z * (c[2] + z * (c[3] + z * (c[4] + z * (c[5] + z * (c[6] + z * (c[7] + z * (
            c[8] + z * (c[9] + z * (c[10] + z * c[11]))))))))))
        out[i] = sign * r * p


_SINE: dict[str, object] = {}


def half_sine_kernel():  # noqa: ANN201
    """The numba-compiled :func:`half_angle_sine_py` (compiled, or loaded from cache, on first call)."""
    if "half" not in _SINE:
        from numba import njit

        _SINE["half"] = njit(cache=True, error_model="numpy", fastmath={"contract"})(half_angle_sine_py)
    return _SINE["half"]


@lru_cache(maxsize=32)
def _coeffs(window: int, order: int, deriv: int, delta: float) -> np.ndarray:
    """Savitzky-Golay convolution coefficients (cached: the fit calls the filter thousands of times)."""
    c = savgol_coeffs(window, order, deriv=deriv, delta=delta, use="conv")
    c.setflags(write=False)
    return c


@lru_cache(maxsize=32)
def _reversed_coeffs(window: int, order: int, deriv: int, delta: float) -> np.ndarray:
    """:func:`_coeffs` reversed and contiguous (the filter kernel's correlation order). Writable, so the
    numba kernel keeps its one signature; nothing writes to it."""
    return _coeffs(window, order, deriv, delta)[::-1].copy()


def residual_vector(theta_mod: np.ndarray, omega_mod: np.ndarray, theta_exp: np.ndarray,
                    omega_exp: np.ndarray, *, cost: str, omega_scale: float,
                    a_theta_exp: np.ndarray | None = None) -> np.ndarray:
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
    a_theta_exp : ndarray, optional
        ``sin(theta_exp / 2)`` if already known (a fit evaluates thousands of models on one record).

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
        r = np.empty(2 * n)
        half_sine_kernel()(np.ascontiguousarray(theta_mod, dtype=np.float64), r[:n])
        r[:n] -= np.sin(0.5 * theta_exp) if a_theta_exp is None else a_theta_exp
        np.subtract(omega_mod, omega_exp, out=r[n:])
        r[n:] *= omega_scale
        r *= norm
        return r
    if cost == "theta":
        return (theta_mod - theta_exp) * norm
    raise ValueError(f"unknown cost {cost!r}; expected one of {COSTS}")


def channels(r: np.ndarray, n: int) -> np.ndarray:
    """Split a residual vector (or Jacobian rows) into its channels, shape ``(n_channels, n, ...)``."""
    return r.reshape((r.shape[0] // n, n) + r.shape[1:])
