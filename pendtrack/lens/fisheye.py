"""Tracker-compatible radial distortion ("Fisheye" filter) as pure functions.

Conventions
-----------
Image coordinates in px, x to the right, y down, pixel centres at integer coordinates;
the optical centre is the image centre ``((w - 1) / 2, (h - 1) / 2)``. Radii are
normalised, ``rho = r / R`` with ``R`` the half diagonal ``hypot(w, h) / 2``. A projection
maps the ray angle ``phi`` (rad, from the optical axis) to ``rho``; the field of view
``fov`` is the full diagonal angle, so ``rho = 1`` at ``phi = fov / 2``:

=============  ==========================  ==================================
projection     r(phi)                      rho(phi)
=============  ==========================  ==================================
equisolid      2 L sin(phi / 2)            sin(phi/2) / sin(fov/4)
equidistant    L phi                       phi / (fov/2)
stereographic  2 L tan(phi / 2)            tan(phi/2) / tan(fov/4)
orthographic   L sin(phi)                  sin(phi) / sin(fov/2)
rectilinear    L tan(phi)                  tan(phi) / tan(fov/2)
=============  ==========================  ==================================

Correction (Tracker's filter): the input is in ``projection`` with diagonal field of view
``fov_deg``; the output is rectilinear, same size, with the field of view chosen so that
the circle ``rho = fixed_pixels`` does not move (95.3 deg for 120 deg / 48 %).
``projection = "none"`` is the identity.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from pendtrack.config import LENS_PROJECTIONS

if TYPE_CHECKING:
    from pendtrack.config import LensConfig

PROJECTIONS = LENS_PROJECTIONS  # one list, in pendtrack.config (checked when a config is loaded)


def _check(projection: str, fov: float) -> None:
    if projection not in PROJECTIONS:
        raise ValueError(f"unknown projection {projection!r}; expected one of {', '.join(PROJECTIONS)}")
    if not 0 < fov < (np.pi if projection == "rectilinear" else 2 * np.pi):
        raise ValueError(f"field of view {np.degrees(fov):.6g} deg out of range for {projection}")
    if projection == "orthographic" and fov > np.pi:
        raise ValueError("orthographic field of view must be at most 180 deg")


def rho_from_angle(phi: np.ndarray | float, projection: str, fov: float) -> np.ndarray:
    """Normalised radius of a ray at angle ``phi`` [rad] for a diagonal field of view ``fov`` [rad]."""
    _check(projection, fov)
    phi = np.asarray(phi, dtype=float)
    if projection == "equisolid":
        return np.sin(phi / 2) / np.sin(fov / 4)
    if projection == "equidistant":
        return phi / (fov / 2)
    if projection == "stereographic":
        return np.tan(phi / 2) / np.tan(fov / 4)
    if projection == "orthographic":
        return np.sin(phi) / np.sin(fov / 2)
    if projection == "rectilinear":
        return np.tan(phi) / np.tan(fov / 2)
    raise ValueError("projection 'none' has no ray angle")


def angle_from_rho(rho: np.ndarray | float, projection: str, fov: float) -> np.ndarray:
    """Inverse of :func:`rho_from_angle`: ray angle [rad] at normalised radius ``rho``."""
    _check(projection, fov)
    rho = np.asarray(rho, dtype=float)
    if projection == "equisolid":
        return 2 * np.arcsin(np.clip(rho * np.sin(fov / 4), -1.0, 1.0))
    if projection == "equidistant":
        return rho * (fov / 2)
    if projection == "stereographic":
        return 2 * np.arctan(rho * np.tan(fov / 4))
    if projection == "orthographic":
        return np.arcsin(np.clip(rho * np.sin(fov / 2), -1.0, 1.0))
    if projection == "rectilinear":
        return np.arctan(rho * np.tan(fov / 2))
    raise ValueError("projection 'none' has no ray angle")


@dataclass(frozen=True, kw_only=True)
class Fisheye:
    """The correction for one image size; all angles in degrees at the interface.

    Parameters
    ----------
    width, height : int
        Image size [px].
    projection : str
        Input projection (see module docstring) or ``"none"``.
    fov_deg : float
        Input diagonal field of view [deg].
    fixed_pixels : float
        Radius of the circle that does not move, as a fraction of the half diagonal.
    """

    width: int
    height: int
    projection: str = "equisolid"
    fov_deg: float = 120.0
    fixed_pixels: float = 0.48

    def __post_init__(self) -> None:
        if self.projection != "none":
            _check(self.projection, np.radians(self.fov_deg))
        if not 0 < self.fixed_pixels <= 1:
            raise ValueError(f"fixed_pixels must be in (0, 1], got {self.fixed_pixels}")
        if self.width < 1 or self.height < 1:
            raise ValueError("image size must be positive")

    @property
    def centre(self) -> tuple[float, float]:
        return ((self.width - 1) / 2.0, (self.height - 1) / 2.0)

    @property
    def half_diagonal(self) -> float:
        return float(np.hypot(self.width, self.height) / 2.0)

    @property
    def output_fov_deg(self) -> float:
        """Diagonal field of view of the rectilinear output [deg] (keeps the fixed circle)."""
        if self.projection == "none":
            return self.fov_deg
        phi_fixed = angle_from_rho(self.fixed_pixels, self.projection, np.radians(self.fov_deg))
        return float(np.degrees(2 * np.arctan(np.tan(phi_fixed) / self.fixed_pixels)))

    def _radial(self, x: np.ndarray, y: np.ndarray, forward: bool) -> tuple[np.ndarray, np.ndarray]:
        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        if self.projection == "none":
            return x.copy(), y.copy()
        cx, cy = self.centre
        big_r = self.half_diagonal
        dx, dy = x - cx, y - cy
        rho = np.hypot(dx, dy) / big_r
        fov_in = np.radians(self.fov_deg)
        fov_out = np.radians(self.output_fov_deg)
        if forward:  # distorted -> corrected
            new_rho = rho_from_angle(angle_from_rho(rho, self.projection, fov_in), "rectilinear", fov_out)
        else:  # corrected -> distorted
            new_rho = rho_from_angle(angle_from_rho(rho, "rectilinear", fov_out), self.projection, fov_in)
        with np.errstate(invalid="ignore", divide="ignore"):
            scale = np.where(rho > 0, new_rho / rho, self._centre_gain(forward))
        return cx + dx * scale, cy + dy * scale

    def _centre_gain(self, forward: bool) -> float:
        # limit of new_rho / rho as rho -> 0, from a tiny radius (the maps are smooth there)
        eps = 1e-9
        fov_in = np.radians(self.fov_deg)
        fov_out = np.radians(self.output_fov_deg)
        if forward:
            return float(rho_from_angle(angle_from_rho(eps, self.projection, fov_in), "rectilinear", fov_out) / eps)
        return float(rho_from_angle(angle_from_rho(eps, "rectilinear", fov_out), self.projection, fov_in) / eps)

    def undistort_points(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Raw (fisheye) pixel coordinates -> corrected (rectilinear) pixel coordinates."""
        return self._radial(x, y, forward=True)

    def distort_points(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Corrected pixel coordinates -> raw pixel coordinates (inverse of undistort_points)."""
        return self._radial(x, y, forward=False)


def fisheye_from_config(lens: "LensConfig", *, width: int, height: int) -> Fisheye:
    """The :class:`Fisheye` correction for one image size from a ``[lens]`` config section.

    Parameters
    ----------
    lens : pendtrack.config.LensConfig
        Projection, input diagonal field of view [deg] and fixed-pixel fraction.
    width, height : int
        Image size [px].
    """
    return Fisheye(width=width, height=height, projection=lens.projection, fov_deg=lens.fov_deg,
                   fixed_pixels=lens.fixed_pixels)


def local_scale(fisheye: Fisheye, x: float, y: float) -> float:
    """Corrected px per raw px near raw point ``(x, y)``: square root of the Jacobian determinant."""
    d = 0.5
    cx, cy = fisheye.undistort_points(np.array([x, x + d, x]), np.array([y, y, y + d]))
    det = (cx[1] - cx[0]) * (cy[2] - cy[0]) - (cx[2] - cx[0]) * (cy[1] - cy[0])
    return float(np.sqrt(abs(det)) / d)


def _disc_quadrature(n_r: int = 6, n_a: int = 16) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points (u, v) and weights of a midpoint rule on the unit disc (weights sum to 1)."""
    r_edges = np.sqrt(np.linspace(0.0, 1.0, n_r + 1))  # equal-area rings
    r_mid = np.sqrt(0.5 * (r_edges[:-1] ** 2 + r_edges[1:] ** 2))
    a = (np.arange(n_a) + 0.5) * 2 * np.pi / n_a
    rr, aa = np.meshgrid(r_mid, a, indexing="ij")
    w = np.full(rr.size, 1.0 / rr.size)
    return (rr * np.cos(aa)).ravel(), (rr * np.sin(aa)).ravel(), w


def raw_centroid_offset(fisheye: Fisheye, x: np.ndarray, y: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Offset of a disc's raw-image centroid from the raw image of its centre [raw px].

    A uniform disc of ``radius`` [corrected px] centred at corrected ``(x, y)`` appears in
    the raw (fisheye) frame as a slightly egg-shaped blob whose area centroid is not
    ``distort_points(x, y)``: the lens' curvature shifts it by a second-order amount
    (about 0.1 px for the paper's 13 px spot). Returns ``centroid - distort(centre)``.

    Parameters
    ----------
    fisheye : Fisheye
    x, y : array_like
        Disc centres [corrected px].
    radius : float
        Disc radius [corrected px].
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if fisheye.projection == "none" or radius <= 0:
        return np.zeros_like(x), np.zeros_like(y)
    qu, qv, w = _disc_quadrature()
    px = x[..., None] + radius * qu
    py = y[..., None] + radius * qv
    sx, sy = fisheye.distort_points(px, py)
    h = 1e-3 * max(radius, 1.0)
    ax, ay = fisheye.distort_points(px + h, py)
    bx, by = fisheye.distort_points(px, py + h)
    jac = np.abs((ax - sx) * (by - sy) - (bx - sx) * (ay - sy)) / (h * h)  # raw area per corrected area
    wj = w * jac
    total = wj.sum(axis=-1)
    cx = (sx * wj).sum(axis=-1) / total
    cy = (sy * wj).sum(axis=-1) / total
    ox, oy = fisheye.distort_points(x, y)
    return cx - ox, cy - oy


def undistort_blob_centres(fisheye: Fisheye, x_raw: np.ndarray, y_raw: np.ndarray,
                           radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Corrected centres of discs (radius [corrected px]) from their raw-image centroids [raw px].

    Like :meth:`Fisheye.undistort_points`, but the point given is the centroid of the
    marker's raw blob, not the image of its centre: the centroid offset
    (:func:`raw_centroid_offset`) is removed first (two fixed-point iterations).
    """
    x_raw = np.asarray(x_raw, dtype=float)
    y_raw = np.asarray(y_raw, dtype=float)
    cx, cy = fisheye.undistort_points(x_raw, y_raw)
    for _ in range(2):
        ox, oy = raw_centroid_offset(fisheye, cx, cy, radius)
        cx, cy = fisheye.undistort_points(x_raw - ox, y_raw - oy)
    return cx, cy
