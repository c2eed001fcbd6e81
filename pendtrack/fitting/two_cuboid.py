"""Fit eq. consistencycheck (bar + tile as two cuboids) to (l1, Omega0) pairs from several runs.

``Omega0(l1) = sqrt(g/l0) sqrt((X/2 + r - r^2/2) / (X/3 + r - r^2 + r^3/3))``, ``r = l1/l0``
(:func:`pendtrack.apparatus.two_cuboid_omega0`); the paper found ``X ~ 1.48`` and
``l0 ~ 54 cm`` (actual 52 cm).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from pendtrack.apparatus import two_cuboid_omega0
from pendtrack.errors import FitError
from pendtrack.fitting.result import _num

X_STARTS = (0.3, 1.0, 3.0, 10.0)  # starts of X = lambda0/lambda1 (the cost has shallow valleys in X)


@dataclass(frozen=True)
class TwoCuboidFit:
    """Result of :func:`fit_two_cuboid`.

    Attributes
    ----------
    x, x_stderr : float
        X = lambda0/lambda1 [1] and its standard error.
    l0, l0_stderr : float
        Axle to the pendulum's extreme [m] and its standard error.
    covariance : ndarray, shape (2, 2)
        Covariance of (x, l0).
    chi2 : float
        Sum of squared (weighted) residuals [1 if weighted, (rad/s)^2 otherwise].
    dof : int
        n - 2.
    rms : float
        Rms of ``Omega0 - model`` [rad/s].
    n : int
        Number of (l1, Omega0) pairs.
    weighted : bool
        True if ``sigma`` was given (absolute uncertainties); else the covariance is scaled by
        ``chi2/dof`` as in :func:`scipy.optimize.curve_fit`.
    g : float
        Gravitational acceleration used [m/s^2].
    """

    x: float
    x_stderr: float
    l0: float
    l0_stderr: float
    covariance: np.ndarray = field(default_factory=lambda: np.full((2, 2), np.nan))
    chi2: float = math.nan
    dof: int = 0
    rms: float = math.nan
    n: int = 0
    weighted: bool = False
    g: float = 9.81

    def predict(self, l1: np.ndarray | float) -> np.ndarray:
        """Omega0 [rad/s] of the fitted two-cuboid model at tile lengths ``l1`` [m]."""
        return two_cuboid_omega0(l1, x=self.x, l0=self.l0, g=self.g)

    def to_dict(self) -> dict[str, Any]:
        return {"x": _num(self.x), "x_stderr": _num(self.x_stderr), "l0": _num(self.l0),
                "l0_stderr": _num(self.l0_stderr),
                "covariance": [[_num(v) for v in row] for row in np.asarray(self.covariance).tolist()],
                "chi2": _num(self.chi2), "dof": self.dof, "rms": _num(self.rms), "n": self.n,
                "weighted": self.weighted, "g": self.g}


def fit_two_cuboid(l1: np.ndarray, omega0: np.ndarray, sigma: np.ndarray | None = None, *,
                   g: float = 9.81) -> TwoCuboidFit:
    """Least-squares fit of X and l0 of eq. consistencycheck.

    Parameters
    ----------
    l1 : array_like
        Tile lengths [m] (0 = no tile), at least two distinct values.
    omega0 : array_like
        Fitted Omega0 of each run [rad/s].
    sigma : array_like, optional
        Standard uncertainties of ``omega0`` [rad/s] (e.g. the fits' stderr); then the
        residuals are weighted and the covariance is absolute.
    g : float
        Gravitational acceleration [m/s^2].

    Returns
    -------
    TwoCuboidFit

    Raises
    ------
    FitError
        Mismatched lengths, non-finite or non-positive values, or fewer than two distinct l1.
    """
    l1 = np.asarray(l1, dtype=float).ravel()
    w = np.asarray(omega0, dtype=float).ravel()
    if l1.shape != w.shape:
        raise FitError(f"two-cuboid fit: {l1.size} tile lengths but {w.size} Omega0 values")
    s = None if sigma is None else np.asarray(sigma, dtype=float).ravel()
    if s is not None and (s.shape != w.shape or np.any(~np.isfinite(s)) or np.any(s <= 0)):
        raise FitError("two-cuboid fit: sigma must be positive and finite, one per Omega0")
    if np.any(~np.isfinite(l1)) or np.any(~np.isfinite(w)) or np.any(l1 < 0) or np.any(w <= 0):
        raise FitError("two-cuboid fit: tile lengths must be >= 0 and Omega0 > 0, all finite")
    if np.unique(l1).size < 2:
        raise FitError("two-cuboid fit needs runs with at least two different tile lengths")
    weights = np.ones_like(w) if s is None else 1.0 / s

    def resid(p: np.ndarray) -> np.ndarray:
        return (two_cuboid_omega0(l1, x=p[0], l0=p[1], g=g) - w) * weights

    # l1 = 0 gives Omega0^2 = 1.5 g / l0: a start for l0 from the smallest tile
    l0_start = max(1.5 * g / float(w[np.argmin(l1)]) ** 2, 1.01 * float(l1.max()) / 2.0, 1e-3)
    lower = np.array([1e-6, max(float(l1.max()) / 2.0, 1e-6)])
    upper = np.array([1e6, 1e3])
    best = None
    for x_start in X_STARTS:
        x0 = np.clip([x_start, l0_start], lower * 1.0001, upper * 0.9999)
        res = least_squares(resid, x0, bounds=(lower, upper), method="trf", x_scale="jac",
                            ftol=1e-15, xtol=1e-15, gtol=1e-15, max_nfev=2000)
        if best is None or res.cost < best.cost:
            best = res
    assert best is not None
    n = w.size
    dof = n - 2
    chi2 = 2.0 * float(best.cost)
    jac = best.jac
    try:
        cov = np.linalg.inv(jac.T @ jac)
    except np.linalg.LinAlgError:
        cov = np.full((2, 2), np.nan)
    if s is None:
        cov = cov * (chi2 / dof) if dof > 0 else np.full((2, 2), np.nan)
    x, l0 = (float(v) for v in best.x)
    rms = float(np.sqrt(np.mean((two_cuboid_omega0(l1, x=x, l0=l0, g=g) - w) ** 2)))
    se = np.sqrt(np.abs(np.diag(cov)))
    return TwoCuboidFit(x=x, x_stderr=float(se[0]), l0=l0, l0_stderr=float(se[1]), covariance=cov, chi2=chi2,
                        dof=dof, rms=rms, n=n, weighted=s is not None, g=g)
