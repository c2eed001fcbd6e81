"""Geometry of the virtual apparatus: camera, lens and the pendulum's parts.

Frames
------
*World (lateral) coordinates* ``(X, Y)`` in metres, measured parallel to the pendulum's
plane from the axle, ``X`` to the image's right and ``Y`` down (along gravity). Every flat
object lies in a plane parallel to the pendulum's; its *depth* ``d`` [m] is its distance
behind the pendulum's plane (negative = in front, towards the camera).

*Camera*: a pinhole at lateral position ``camera_offset_m`` (the point where the optical
axis meets the pendulum's plane, relative to the axle), at ``distance_m`` in front of the
plane, looking perpendicular to it, upright (image x along ``X``, image y along ``Y``).
The axle is deliberately off the optical axis: if it were on it, the fisheye would map the
spot's circle to a circle for any field of view.

*Roll*: the camera may be rolled by ``roll_deg`` about its optical axis. The image is then
the upright image rotated about its centre so that a direction at angle ``theta`` from
the vertical (``atan2(X, Y)``) appears at ``theta + roll`` in the image
(``atan2(dx, dy)`` of image offsets, y down): the truth stays physical and
``theta_image = theta + roll`` (:attr:`Scene.roll_rad`).

*Lens*: a ray at angle ``phi`` from the optical axis lands at normalised radius
``rho = rho_from_angle(phi, projection, fov)`` (:mod:`pendtrack.lens.fisheye`), i.e. at
pixel ``centre + R * rho * direction`` with ``centre = ((w - 1) / 2, (h - 1) / 2)`` and
``R`` the half diagonal -- the same conventions as :class:`pendtrack.lens.fisheye.Fisheye`,
so ``Fisheye(...).undistort_points`` maps the pendulum's plane to the corrected image by a
similarity and the corrected angle equals the true angle (plus the roll). Projection
``"none"`` is a normal lens: a pinhole (rectilinear) camera of diagonal field of view
``fov``, which needs no correction (``Fisheye(projection="none")`` is the identity).

*Pendulum frame* ``(a, c)``: ``a`` along the bar from the axle outwards, ``c`` across it.
With the angle convention ``theta = atan2(dx, dy)`` (0 hanging down, + to the right) a
point at ``(a, c)`` is at ``X = a sin(theta) + c cos(theta)``,
``Y = a cos(theta) - c sin(theta)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pendtrack.config import RenderConfig
from pendtrack.lens.fisheye import Fisheye, angle_from_rho, rho_from_angle

ArrayLike = np.ndarray | float

# Part kinds in the parts table.
RECT = 0.0
CIRCLE = 1.0
BALL = 2.0  # a disc shaded as a sphere lit from the upper left (world-fixed light)
SHINY_BALL = 3.0  # a ball with a glossy finish: a small highlight that saturates

# Reflectances in [0, 1], BGR order (as the frames).
SPOT_BGR = (0.70, 0.40, 0.98)  # pink
MARKER_BGR = {  # the bob's named looks (render.marker_color, render.sticker_color)
    "pink": SPOT_BGR,
    "dark": (0.09, 0.09, 0.10),  # a dark grey ball
    "blue": (0.80, 0.28, 0.10),  # a blue ball: RGB (26, 71, 204) at full light
}
STRING_BGR = (0.88, 0.90, 0.90)  # a pale cord
STRING_HALF_WIDTH_M = 0.0008  # a 1.6 mm cord
HOOK_RADIUS_M = 0.004  # the string's hook at the axle
BAR_BGR = (0.36, 0.35, 0.33)  # grey anodised square bar
ROD_BGR = (0.50, 0.50, 0.52)  # threaded steel rod
DISC_BGR = (0.86, 0.86, 0.82)  # acrylic disc (partly transparent)
DISC_OPACITY = 0.55
BEARING_BGR = (0.22, 0.22, 0.24)
AXLE_BGR = (0.62, 0.62, 0.64)
TILE_BGR = (0.42, 0.58, 0.70)  # cardboard

ROD_HALF_WIDTH_M = 0.003  # the 6 mm threaded rod
BEARING_RADIUS_M = 0.0125  # the 2.5 cm roller bearing
AXLE_RADIUS_M = 0.005


@dataclass(frozen=True, kw_only=True)
class Scene:
    """The static camera and the pendulum's shape (everything but its angle).

    Parameters
    ----------
    width, height : int
        Image size [px].
    projection : str
        Fisheye projection of the camera (see :mod:`pendtrack.lens.fisheye`).
    fov_deg : float
        Diagonal field of view [deg].
    distance_m : float
        Camera (pinhole) to the pendulum's plane [m].
    offset_m : tuple of float
        ``(X, Y)`` of the optical axis' point in the pendulum's plane, relative to the axle [m].
    l0_m : float
        Axle to the bar's far end (the pendulum's extreme) [m].
    bar_length_m, bar_width_m : float
        The square bar [m]; it spans ``a`` in ``[l0 - bar_length, l0]``.
    disc_radius_m : float
        The acrylic disc at the axle [m].
    spot_distance_m, spot_radius_m : float
        The pink tracking spot: centre at ``a = spot_distance`` on the bar's axis [m].
    tile_length_m, tile_width_m : float
        The tile at the bar's end (``l1``; 0 = no tile) [m].
    roll_deg : float
        Camera roll about the optical axis [deg] (see the module docstring).
    marker_bgr : tuple of float
        The bob's reflectance, BGR in [0, 1] (default: the paper's pink spot).
    marker_shape : str
        ``"spot"`` (a flat disc), ``"ball"`` (shaded as a sphere) or ``"shiny"`` (a ball
        with a glossy finish: a small saturated highlight).
    rig : str
        ``"bar"`` (the paper's bar, acrylic disc and tile) or ``"string"`` (a thin cord
        from the axle to the bob, nothing else moves).
    sticker_bgr : tuple of float or None
        A small sticker on the bob (reflectance), None for none. It sits on the bar's axis,
        ``sticker_offset`` bob radii beyond the bob's centre, and turns with the pendulum.
    sticker_radius_m : float
        The sticker's radius [m].
    """

    width: int
    height: int
    projection: str = "equisolid"
    fov_deg: float = 120.0
    distance_m: float = 0.58
    offset_m: tuple[float, float] = (0.05, 0.02)
    l0_m: float = 0.54
    bar_length_m: float = 0.52
    bar_width_m: float = 0.02
    disc_radius_m: float = 0.03
    spot_distance_m: float = 0.26
    spot_radius_m: float = 0.012
    tile_length_m: float = 0.0
    tile_width_m: float = 0.18
    roll_deg: float = 0.0
    marker_bgr: tuple[float, float, float] = SPOT_BGR
    marker_shape: str = "spot"
    rig: str = "bar"
    sticker_bgr: tuple[float, float, float] | None = None
    sticker_radius_m: float = 0.004

    #: the sticker's centre beyond the bob's, in bob radii (off centre, so it shows the bob's turning)
    sticker_offset = 0.45

    @property
    def roll_rad(self) -> float:
        """Camera roll [rad]: ``theta_image = theta + roll_rad``."""
        return float(np.radians(self.roll_deg))

    @property
    def _ray_projection(self) -> str:
        return "rectilinear" if self.projection == "none" else self.projection

    @property
    def fisheye(self) -> Fisheye:
        """The matching correction (pixel conventions shared with the tracker)."""
        return Fisheye(width=self.width, height=self.height, projection=self.projection, fov_deg=self.fov_deg)

    @property
    def _fov(self) -> float:
        return float(np.radians(self.fov_deg))

    def project(self, x: ArrayLike, y: ArrayLike, depth: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Lateral world coordinates [m] on the plane at ``depth`` [m] -> raw pixel ``(u, v)`` [px]."""
        fe = self.fisheye
        (cx, cy), big_r = fe.centre, fe.half_diagonal
        dx = np.asarray(x, dtype=float) - self.offset_m[0]
        dy = np.asarray(y, dtype=float) - self.offset_m[1]
        s = np.hypot(dx, dy)
        phi = np.arctan2(s, self.distance_m + depth)
        r_px = big_r * rho_from_angle(phi, self._ray_projection, self._fov)
        with np.errstate(invalid="ignore", divide="ignore"):
            scale = np.where(s > 0, r_px / np.where(s > 0, s, 1.0), 0.0)
        du, dv = self._rotate(dx * scale, dy * scale, self.roll_rad)
        return cx + du, cy + dv

    @staticmethod
    def _rotate(dx: np.ndarray, dy: np.ndarray, angle: float) -> tuple[np.ndarray, np.ndarray]:
        """Rotate offsets so that ``atan2(dx, dy)`` grows by ``angle`` [rad] (y down)."""
        if angle == 0.0:
            return dx, dy
        c, s = np.cos(angle), np.sin(angle)
        return dx * c + dy * s, dy * c - dx * s

    def unproject(self, u: ArrayLike, v: ArrayLike, depth: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Raw pixel ``(u, v)`` [px] -> lateral world coordinates [m] on the plane at ``depth`` [m]."""
        fe = self.fisheye
        (cx, cy), big_r = fe.centre, fe.half_diagonal
        du, dv = self._rotate(np.asarray(u, dtype=float) - cx, np.asarray(v, dtype=float) - cy, -self.roll_rad)
        r_px = np.hypot(du, dv)
        phi = angle_from_rho(r_px / big_r, self._ray_projection, self._fov)
        s = (self.distance_m + depth) * np.tan(np.minimum(phi, np.radians(89.9)))
        with np.errstate(invalid="ignore", divide="ignore"):
            scale = np.where(r_px > 0, s / np.where(r_px > 0, r_px, 1.0), 0.0)
        return self.offset_m[0] + du * scale, self.offset_m[1] + dv * scale

    def pixel_world_maps(self, depth: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For every pixel: world ``X``, ``Y`` [m] on the plane at ``depth`` and its size [m/px].

        Returns
        -------
        x, y : ndarray, shape (height, width), float64
            Lateral coordinates seen through each pixel centre [m].
        size : ndarray, shape (height, width), float64
            Square root of the area of the pixel's footprint on that plane [m/px], the
            scale that turns a signed distance [m] into pixels for anti-aliasing.
        """
        v, u = np.mgrid[0:self.height, 0:self.width].astype(float)
        x, y = self.unproject(u, v, depth)
        dxdv, dxdu = np.gradient(x)
        dydv, dydu = np.gradient(y)
        size = np.sqrt(np.abs(dxdu * dydv - dxdv * dydu))
        return x, y, size

    def to_world(self, a: ArrayLike, c: ArrayLike, theta: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Pendulum-frame ``(a, c)`` [m] at angle ``theta`` [rad] -> lateral world ``(X, Y)`` [m]."""
        s, co = np.sin(theta), np.cos(theta)
        return a * s + c * co, a * co - c * s

    def spot_centre(self, theta: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """World position [m] of the spot's centre at angle ``theta`` [rad]."""
        return self.to_world(self.spot_distance_m, 0.0, theta)

    def spot_centre_px(self, theta: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Raw pixel position [px] of the image of the spot's centre (not its blob's centroid)."""
        return self.project(*self.spot_centre(theta))

    @property
    def axle_px(self) -> tuple[float, float]:
        """Raw pixel position of the axle [px]."""
        u, v = self.project(0.0, 0.0)
        return float(u), float(v)

    @property
    def px_per_m_max(self) -> float:
        """Largest image scale on the pendulum's plane [px/m] (at the optical axis)."""
        eps = 1e-6
        u0, v0 = self.project(self.offset_m[0], self.offset_m[1])
        u1, v1 = self.project(self.offset_m[0] + eps, self.offset_m[1])
        return float(np.hypot(u1 - u0, v1 - v0) / eps)

    def parts(self) -> np.ndarray:
        """The pendulum's parts, back to front, as a table for the raster kernel.

        Returns
        -------
        ndarray, shape (n_parts, 8), float64
            Columns ``kind, p0, p1, p2, b, g, r, opacity``. For ``kind == RECT``:
            ``a`` in ``[p0, p1]``, ``|c| <= p2`` [m]. For ``kind == CIRCLE`` and
            ``kind == BALL`` or ``SHINY_BALL``: centre ``(a, c) = (p0, 0)``, radius ``p1``
            [m] (a ball is shaded as a sphere). ``b, g, r`` reflectance in [0, 1].
        """
        rows = []
        if self.rig == "string":
            rows.append((RECT, -HOOK_RADIUS_M, self.spot_distance_m, STRING_HALF_WIDTH_M, *STRING_BGR, 1.0))
            rows.append((CIRCLE, 0.0, HOOK_RADIUS_M, 0.0, *AXLE_BGR, 1.0))
        else:
            bar_start = self.l0_m - self.bar_length_m
            if self.tile_length_m > 0:
                rows.append((RECT, self.l0_m - self.tile_length_m, self.l0_m, self.tile_width_m / 2, *TILE_BGR, 1.0))
            rows.append((RECT, -0.01, bar_start + 0.01, ROD_HALF_WIDTH_M, *ROD_BGR, 1.0))
            rows.append((RECT, bar_start, self.l0_m, self.bar_width_m / 2, *BAR_BGR, 1.0))
            rows.append((CIRCLE, 0.0, self.disc_radius_m, 0.0, *DISC_BGR, DISC_OPACITY))
            rows.append((CIRCLE, 0.0, BEARING_RADIUS_M, 0.0, *BEARING_BGR, 1.0))
            rows.append((CIRCLE, 0.0, AXLE_RADIUS_M, 0.0, *AXLE_BGR, 1.0))
        kind = {"ball": BALL, "shiny": SHINY_BALL}.get(self.marker_shape, CIRCLE)
        rows.append((kind, self.spot_distance_m, self.spot_radius_m, 0.0, *self.marker_bgr, 1.0))
        if self.sticker_bgr is not None:
            rows.append((CIRCLE, self.spot_distance_m + self.sticker_offset * self.spot_radius_m,
                         self.sticker_radius_m, 0.0, *self.sticker_bgr, 1.0))
        return np.array(rows, dtype=np.float64)

    def outline(self, n_edge: int = 8) -> tuple[np.ndarray, np.ndarray]:
        """Points ``(a, c)`` [m] on the outline of every part (for bounding boxes)."""
        pa, pc = [], []
        t = np.linspace(0.0, 1.0, n_edge + 1)
        ring = np.linspace(0.0, 2 * np.pi, 4 * n_edge, endpoint=False)
        for kind, p0, p1, p2, *_ in self.parts():
            if kind == RECT:
                for (a_s, c_s), (a_e, c_e) in (((p0, -p2), (p1, -p2)), ((p1, -p2), (p1, p2)),
                                               ((p1, p2), (p0, p2)), ((p0, p2), (p0, -p2))):
                    pa.append(a_s + (a_e - a_s) * t)
                    pc.append(c_s + (c_e - c_s) * t)
            else:
                pa.append(p0 + p1 * np.cos(ring))
                pc.append(p1 * np.sin(ring))
        return np.concatenate(pa), np.concatenate(pc)

    def bbox_px(self, thetas: np.ndarray, *, pad: int = 3) -> tuple[int, int, int, int]:
        """Pixel box ``(x0, y0, x1, y1)`` (half-open) holding the pendulum at all ``thetas``.

        Clipped to the image; ``x0 >= x1`` or ``y0 >= y1`` when nothing is visible.
        """
        a, c = self.outline()
        th = np.asarray(thetas, dtype=float)[:, None]
        u, v = self.project(*self.to_world(a[None, :], c[None, :], th))
        x0 = max(int(np.floor(u.min())) - pad, 0)
        y0 = max(int(np.floor(v.min())) - pad, 0)
        x1 = min(int(np.ceil(u.max())) + pad + 1, self.width)
        y1 = min(int(np.ceil(v.max())) + pad + 1, self.height)
        return x0, y0, x1, y1


def scene_from_config(cfg: RenderConfig) -> Scene:
    """Build the :class:`Scene` a :class:`~pendtrack.config.RenderConfig` describes."""
    return Scene(
        width=cfg.width,
        height=cfg.height,
        projection=cfg.lens_projection,
        fov_deg=cfg.lens_fov_deg,
        distance_m=cfg.camera_distance_m,
        offset_m=(float(cfg.camera_offset_m[0]), float(cfg.camera_offset_m[1])),
        l0_m=cfg.two_cuboid_l0_m,
        bar_length_m=cfg.bar_length_m,
        bar_width_m=cfg.bar_width_m,
        disc_radius_m=cfg.disc_diameter_m / 2,
        spot_distance_m=cfg.spot_distance_m,
        spot_radius_m=cfg.spot_radius_m,
        tile_length_m=cfg.tile_length_m,
        tile_width_m=cfg.tile_width_m,
        roll_deg=cfg.camera_roll_deg,
        marker_bgr=marker_reflectance(cfg.marker_color),
        marker_shape=cfg.marker_shape,
        rig=cfg.rig,
        sticker_bgr=marker_reflectance(cfg.sticker_color) if cfg.sticker_color else None,
        sticker_radius_m=cfg.sticker_radius_m,
    )


def marker_reflectance(colour: str) -> tuple[float, float, float]:
    """BGR reflectance in [0, 1] of a bob or sticker colour: a name of :data:`MARKER_BGR` or ``#RRGGBB``.

    Raises
    ------
    ValueError
        Any other text.
    """
    key = colour.strip().lower()
    if key in MARKER_BGR:
        return MARKER_BGR[key]
    if len(key) == 7 and key[0] == "#":
        try:
            r, g, b = (int(key[i:i + 2], 16) / 255.0 for i in (1, 3, 5))
        except ValueError:
            pass
        else:
            return b, g, r
    raise ValueError(f"unknown colour {colour!r}; expected {', '.join(MARKER_BGR)} or #RRGGBB")
