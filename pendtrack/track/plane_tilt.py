"""A swing filmed obliquely: the tilt of its plane from the camera's, read from the marker's path.

A swing plane turned by ``psi`` from the image plane shows the marker's circle as an ellipse of axes ratio
``cos psi`` (a camera far from the swing), and theta read about a circle fitted to that ellipse is wrong by a
pattern at twice the swing's frequency: a classic swing from 2 rad filmed 10 deg off square read up to 18 mrad
wrong, its model-free Omega0 +0.58 % (30 deg: +6.2 %), and its classic fit left 4.9 mrad of residual instead of
0.24, structure that points a user at physics rather than at the camera.

The path is fitted as a stretched circle, ``|S (p - c)| = R`` with ``S = [[1 + a, b], [b, 1 - a]]``: ``a = b = 0``
is the circle, and ``S``'s eigenvalues ``1 +- e`` (``e = hypot(a, b)``) make the axes ratio ``(1 - e) / (1 + e)``.
``S (p - c)`` is the swing seen square to its plane, up to a scale that ``atan2`` ignores, so theta is read from
it about ``c``. The path is taken as tilted only where it says so (:func:`find_plane_tilt`): an arc of at least
:data:`MIN_ARC_DEG` (a 122-deg phone track fits an ellipse of axes 0.69 barely better than its circle), ``e``
above :data:`E_SIGMAS` block-jackknife standard errors (tracking errors are correlated from frame to frame), and
an axes ratio below :data:`MAX_AXES_RATIO`. Units are those of the points.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import optimize

from pendtrack.track.circle import (BLOCK_CORRELATION_LENGTHS, JACKKNIFE_BLOCKS, MIN_BLOCK_POINTS, CircleFit,
                                    correlation_length)

MIN_ARC_DEG = 180.0  # the path's arc about its centre: a shorter one does not tell an ellipse from a circle
E_SIGMAS = 5.0  # e beyond this many standard errors: a tilt the path shows, not its noise
# axes ratio below which the tilt is corrected: a ratio q moves theta by up to (1 - q) / 2 rad, here 2 mrad; the
# tracked renders, filmed square through the fisheye, read 0.9997-0.9999
MAX_AXES_RATIO = 0.996


@dataclass(frozen=True)
class PlaneTilt:
    """The swing plane's tilt from the image plane, as the marker's path shows it.

    Attributes
    ----------
    xc, yc : float
        Centre of the path's ellipse: the axle [units of the points].
    a, b : float
        The stretch ``S = [[1 + a, b], [b, 1 - a]]`` that makes the path a circle.
    radius : float
        The circle's radius after the stretch [units of the points].
    axes_ratio : float
        The path's short axis over its long one, ``cos`` of the tilt.
    axes_ratio_sigma : float
        Its standard uncertainty (block jackknife).
    short_axis_deg : float
        Direction of the short axis in the points' frame, from +x towards +y [deg], in (-90, 90].
    rms, circle_rms : float
        Radial residual of the stretched circle and of the plain one [units of the points].
    arc_deg : float
        The arc the path spans about the centre [deg].
    """

    xc: float
    yc: float
    a: float
    b: float
    radius: float
    axes_ratio: float
    axes_ratio_sigma: float
    short_axis_deg: float
    rms: float
    circle_rms: float
    arc_deg: float

    @property
    def tilt_deg(self) -> float:
        """The angle between the swing plane and the image plane [deg] (a camera far from the swing)."""
        return math.degrees(math.acos(min(max(self.axes_ratio, -1.0), 1.0)))

    def square(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Positions as seen square to the swing plane: ``c + S (p - c)`` [units of the points]."""
        dx = np.asarray(x, float) - self.xc
        dy = np.asarray(y, float) - self.yc
        return self.xc + (1.0 + self.a) * dx + self.b * dy, self.yc + self.b * dx + (1.0 - self.a) * dy

    def to_dict(self) -> dict[str, float]:
        return {"xc": self.xc, "yc": self.yc, "stretch": [[1.0 + self.a, self.b], [self.b, 1.0 - self.a]],
                "radius": self.radius, "axes_ratio": self.axes_ratio, "axes_ratio_sigma": self.axes_ratio_sigma,
                "tilt_deg": self.tilt_deg, "short_axis_deg": self.short_axis_deg, "rms": self.rms,
                "circle_rms": self.circle_rms, "arc_deg": self.arc_deg}


def _fit(x: np.ndarray, y: np.ndarray, start: np.ndarray, f_scale: float) -> np.ndarray:
    """Least-squares ``(xc, yc, R, a, b)`` of the stretched circle from ``start`` (robust loss as the circle's)."""

    def resid(p: np.ndarray) -> np.ndarray:
        dx, dy = x - p[0], y - p[1]
        return np.hypot((1.0 + p[3]) * dx + p[4] * dy, p[4] * dx + (1.0 - p[3]) * dy) - p[2]

    def jac(p: np.ndarray) -> np.ndarray:
        dx, dy = x - p[0], y - p[1]
        u = (1.0 + p[3]) * dx + p[4] * dy
        v = p[4] * dx + (1.0 - p[3]) * dy
        d = np.hypot(u, v)
        d = np.where(d > 0, d, 1.0)
        ud, vd = u / d, v / d
        return np.column_stack([-(ud * (1.0 + p[3]) + vd * p[4]), -(ud * p[4] + vd * (1.0 - p[3])), -np.ones_like(d),
                                ud * dx - vd * dy, ud * dy + vd * dx])

    sol = optimize.least_squares(resid, start, jac=jac, loss="soft_l1", f_scale=f_scale, method="trf",
                                 x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-12)
    return sol.x


def _ratio(a: float, b: float) -> float:
    e = math.hypot(a, b)
    return (1.0 - e) / (1.0 + e)


def find_plane_tilt(x: np.ndarray, y: np.ndarray, circle: CircleFit, *, f_scale: float = 1.0) -> PlaneTilt | None:
    """The swing plane's tilt where the marker's path shows one, else None (module docstring).

    Parameters
    ----------
    x, y : ndarray
        The marker's positions in time order (finite), those the circle was fitted to.
    circle : CircleFit
        Their circle (:func:`pendtrack.track.circle.fit_circle`): the start of the fit.
    f_scale : float
        Residual size beyond which the robust loss flattens [units of the points] (the circle's).

    Returns
    -------
    PlaneTilt or None
        None where the arc is short, or the path is a circle within its noise or within :data:`MAX_AXES_RATIO`.
    """
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    if x.size < 2 * MIN_BLOCK_POINTS or math.degrees(circle.arc_span) < MIN_ARC_DEG:
        return None
    start = np.array([circle.xc, circle.yc, circle.radius, 0.0, 0.0])
    p = _fit(x, y, start, f_scale)
    q = _ratio(p[3], p[4])
    if not q < MAX_AXES_RATIO:
        return None
    u = (1.0 + p[3]) * (x - p[0]) + p[4] * (y - p[1])
    v = p[4] * (x - p[0]) + (1.0 - p[3]) * (y - p[1])
    res = np.hypot(u, v) - p[2]
    # delete-one-block jackknife over consecutive blocks (time): each block holds whole swings, so every one
    # spans the arc, and the spread sees the frame-to-frame correlation of tracking errors
    block = max(BLOCK_CORRELATION_LENGTHS * correlation_length(res), MIN_BLOCK_POINTS)
    blocks = min(JACKKNIFE_BLOCKS, x.size // block)
    if blocks < 2:
        return None
    edges = np.linspace(0, x.size, blocks + 1).round().astype(int)
    ratios = np.empty(blocks)
    for k in range(blocks):
        keep = np.ones(x.size, bool)
        keep[edges[k]:edges[k + 1]] = False
        pk = _fit(x[keep], y[keep], p, f_scale)
        ratios[k] = _ratio(pk[3], pk[4])
    sigma = math.sqrt((blocks - 1) / blocks * float(np.sum((ratios - ratios.mean()) ** 2)))
    if not 1.0 - q > E_SIGMAS * sigma:
        return None
    # the short axis is S's stretched eigenvector: (a, b) = e (cos 2 phi, sin 2 phi)
    short = math.degrees(0.5 * math.atan2(p[4], p[3]))
    return PlaneTilt(xc=float(p[0]), yc=float(p[1]), a=float(p[3]), b=float(p[4]), radius=float(abs(p[2])),
                     axes_ratio=q, axes_ratio_sigma=sigma, short_axis_deg=short,
                     rms=float(np.sqrt(np.mean(res * res))), circle_rms=circle.rms,
                     arc_deg=math.degrees(circle.arc_span))


__all__ = ["MAX_AXES_RATIO", "MIN_ARC_DEG", "PlaneTilt", "find_plane_tilt"]
