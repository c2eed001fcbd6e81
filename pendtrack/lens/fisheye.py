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

import numpy as np

PROJECTIONS = ("equisolid", "equidistant", "stereographic", "orthographic", "rectilinear", "none")


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
