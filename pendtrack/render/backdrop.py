"""The static parts of the picture: wall, support board, alley slabs and the lighting.

Everything here is computed once per video, in world coordinates seen through the lens
(so straight edges bend like the real fisheye's), with soft signed-distance edges.
Arrays are (height, width[, 3]) float32, colours BGR reflectance in [0, 1].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pendtrack.render.scene import Scene

WALL_DEPTH_M = 0.30  # wall behind the pendulum's plane [m]
SUPPORT_DEPTH_M = 0.03  # the board carrying the axle [m]
ALLEY_GAP_M = 0.03  # the alley's front and back slabs, in front of / behind the pendulum [m]
ALLEY_HALF_LENGTH_M = 0.32  # half the slabs' horizontal extent [m]
ALLEY_CLEARANCE_M = 0.015  # slab top below the spot's lowest point (in the pendulum's plane) [m]

WALL_BGR = (0.64, 0.69, 0.73)
BENCH_BGR = (0.30, 0.36, 0.44)
POSTER_BGR = (0.62, 0.48, 0.34)
SUPPORT_BGR = (0.34, 0.46, 0.58)
SCREW_BGR = (0.55, 0.55, 0.56)
SLAB_BGR = (0.55, 0.50, 0.42)
SLAB_EDGE_BGR = (0.78, 0.78, 0.74)


@dataclass(frozen=True)
class Backdrop:
    """Static layers of one camera set-up.

    Attributes
    ----------
    back : ndarray, shape (H, W, 3)
        What is seen behind the pendulum (reflectance).
    front_alpha : ndarray, shape (H, W) or None
        Coverage of the alley's front slab (in front of the pendulum), None without alley.
    front : ndarray, shape (H, W, 3) or None
        Its reflectance.
    light : ndarray, shape (H, W)
        Illumination field (multiplies reflectance; about 0.5-1.1).
    """

    back: np.ndarray
    front_alpha: np.ndarray | None
    front: np.ndarray | None
    light: np.ndarray


def value_noise(x: np.ndarray, y: np.ndarray, cell_x: float, cell_y: float, rng: np.random.Generator,
                *, extent: float = 3.0) -> np.ndarray:
    """Smooth random field in about [-1, 1] evaluated at world points [m].

    A random lattice with spacing ``cell_x`` by ``cell_y`` [m] over ``[-extent, extent]``,
    interpolated with a smoothstep; seeded by ``rng``.
    """
    nx = int(np.ceil(2 * extent / cell_x)) + 2
    ny = int(np.ceil(2 * extent / cell_y)) + 2
    lattice = rng.uniform(-1.0, 1.0, size=(ny, nx))
    gx = np.clip((x + extent) / cell_x, 0, nx - 1.001)
    gy = np.clip((y + extent) / cell_y, 0, ny - 1.001)
    ix, iy = gx.astype(np.int64), gy.astype(np.int64)
    fx, fy = gx - ix, gy - iy
    fx = fx * fx * (3 - 2 * fx)
    fy = fy * fy * (3 - 2 * fy)
    top = lattice[iy, ix] * (1 - fx) + lattice[iy, ix + 1] * fx
    bottom = lattice[iy + 1, ix] * (1 - fx) + lattice[iy + 1, ix + 1] * fx
    return top * (1 - fy) + bottom * fy


def rect_coverage(x: np.ndarray, y: np.ndarray, size: np.ndarray, x0: float, x1: float, y0: float,
                  y1: float) -> np.ndarray:
    """Anti-aliased coverage of the rectangle ``[x0, x1] x [y0, y1]`` [m] (pixel footprint ``size``)."""
    qx = np.abs(x - 0.5 * (x0 + x1)) - 0.5 * (x1 - x0)
    qy = np.abs(y - 0.5 * (y0 + y1)) - 0.5 * (y1 - y0)
    sd = np.hypot(np.maximum(qx, 0), np.maximum(qy, 0)) + np.minimum(np.maximum(qx, qy), 0)
    return np.clip(0.5 - sd / size, 0.0, 1.0)


def disc_coverage(x: np.ndarray, y: np.ndarray, size: np.ndarray, xc: float, yc: float, r: float) -> np.ndarray:
    """Anti-aliased coverage of the disc of centre ``(xc, yc)`` and radius ``r`` [m]."""
    return np.clip(0.5 - (np.hypot(x - xc, y - yc) - r) / size, 0.0, 1.0)


def _over(dst: np.ndarray, cov: np.ndarray, colour: np.ndarray | tuple[float, float, float]) -> None:
    cov = cov[..., None]
    dst *= 1 - cov
    dst += cov * np.asarray(colour, dtype=np.float32)


def alley_top_m(scene: Scene, depth: float) -> float:
    """Height ``Y`` [m] of the alley slabs' top at ``depth``, kept clear of the spot.

    The top is chosen so that, seen from the camera, it lies ``ALLEY_CLEARANCE_M`` below
    the lowest point the spot reaches, so the slabs never hide the spot.
    """
    lowest = scene.spot_distance_m + scene.spot_radius_m + ALLEY_CLEARANCE_M
    oy = scene.offset_m[1]
    return oy + (lowest - oy) * (scene.distance_m + depth) / scene.distance_m


def build_backdrop(scene: Scene, *, alley: bool, gradient: float, vignetting: float,
                   rng: np.random.Generator) -> Backdrop:
    """Compute the static layers and the lighting for ``scene``.

    Parameters
    ----------
    scene : Scene
        Camera and apparatus.
    alley : bool
        Draw the alley's slabs.
    gradient : float
        Relative change of brightness across the half diagonal [1].
    vignetting : float
        Relative darkening at the image corners [1].
    rng : numpy.random.Generator
        Source of the wall's texture.
    """
    # wall: a painted plaster wall, a poster and a bench top at the bottom
    x, y, size = scene.pixel_world_maps(WALL_DEPTH_M)
    tex = (0.05 * value_noise(x, y, 0.25, 0.25, rng) + 0.025 * value_noise(x, y, 0.05, 0.05, rng)
           + 0.02 * value_noise(x, y, 0.004, 0.004, rng))
    back = np.empty((scene.height, scene.width, 3), dtype=np.float32)
    back[:] = np.asarray(WALL_BGR, dtype=np.float32)
    back *= (1 + tex)[..., None].astype(np.float32)
    _over(back, rect_coverage(x, y, size, -1.15, -0.72, -0.62, -0.12), POSTER_BGR)
    _over(back, rect_coverage(x, y, size, -1.09, -0.78, -0.56, -0.40), (0.80, 0.80, 0.80))
    bench = rect_coverage(x, y, size, -3.0, 3.0, 0.46, 3.0)
    _over(back, bench, np.asarray(BENCH_BGR) * 1.0)
    back *= (1 + 0.04 * bench * value_noise(x, y, 0.3, 0.01, rng))[..., None].astype(np.float32)

    # support board carrying the axle, with wood grain and two screws
    x, y, size = scene.pixel_world_maps(SUPPORT_DEPTH_M)
    board = rect_coverage(x, y, size, -0.045, 0.045, -2.0, 0.075)
    grain = 1 + 0.08 * value_noise(x, y, 0.004, 0.12, rng)
    _over(back, board, np.asarray(SUPPORT_BGR, dtype=np.float32) * grain[..., None].astype(np.float32))
    for ys in (-0.10, 0.05):
        _over(back, disc_coverage(x, y, size, 0.0, ys, 0.006), SCREW_BGR)

    front_alpha = front = None
    if alley:
        top = alley_top_m(scene, -ALLEY_GAP_M)  # both slabs equally high; the front one sets the clearance
        for depth, is_front in ((ALLEY_GAP_M, False), (-ALLEY_GAP_M, True)):
            x, y, size = scene.pixel_world_maps(depth)
            slab = rect_coverage(x, y, size, -ALLEY_HALF_LENGTH_M, ALLEY_HALF_LENGTH_M, top, 3.0)
            edge = rect_coverage(x, y, size, -ALLEY_HALF_LENGTH_M, ALLEY_HALF_LENGTH_M, top, top + 0.004)
            colour = np.empty_like(back)
            colour[:] = np.asarray(SLAB_BGR, dtype=np.float32)
            colour *= (1 + 0.05 * value_noise(x, y, 0.03, 0.03, rng))[..., None].astype(np.float32)
            _over(colour, edge, SLAB_EDGE_BGR)
            if is_front:
                front_alpha, front = slab.astype(np.float32), colour
            else:
                back = (back * (1 - slab[..., None]) + colour * slab[..., None]).astype(np.float32)

    return Backdrop(back=back, front_alpha=front_alpha, front=front,
                    light=illumination(scene, gradient=gradient, vignetting=vignetting))


HAND_DEPTH_M = -0.02  # the hand, in front of the pendulum's plane [m]
SKIN_BGR = (0.55, 0.66, 0.86)  # reflectance of a light skin


@dataclass(frozen=True)
class Hand:
    """A hand holding the bob (static while it holds), to composite over the frame.

    Attributes
    ----------
    box : tuple of int
        ``(x0, y0, x1, y1)``, half-open pixel box of the hand (empty when out of frame).
    alpha : ndarray, shape (y1 - y0, x1 - x0, 1), float32
        Coverage in [0, 1].
    colour : ndarray, shape (y1 - y0, x1 - x0, 3), float32
        Its reflectance, BGR (shaded: darker towards the fingers' and the palm's edges).
    """

    box: tuple[int, int, int, int]
    alpha: np.ndarray
    colour: np.ndarray


def _capsule_sd(a: np.ndarray, c: np.ndarray, a0: float, c0: float, a1: float, c1: float,
                r: float) -> np.ndarray:
    """Signed distance [m] to the capsule of radius ``r`` around the segment (a0, c0)-(a1, c1)."""
    da, dc = a1 - a0, c1 - c0
    h = np.clip(((a - a0) * da + (c - c0) * dc) / (da * da + dc * dc), 0.0, 1.0)
    return np.hypot(a - a0 - h * da, c - c0 - h * dc) - r


def build_hand(scene: Scene, theta: float) -> Hand:
    """A hand gripping the bob at angle ``theta`` [rad] from outside its swing.

    In the pendulum's frame (``a`` along the bar from the axle, ``c`` across it), with the bob
    at ``a = L`` of radius ``R``: the palm beyond the bob, four fingers wrapped over all of
    it (the marker is not visible while held), a thumb along its side, the forearm leaving
    outwards. Drawn in a plane 2 cm in front of the pendulum.
    """
    x, y, size = scene.pixel_world_maps(HAND_DEPTH_M)
    s, co = np.sin(theta), np.cos(theta)
    a, c = x * s + y * co, x * co - y * s
    big_l, big_r = scene.spot_distance_m, scene.spot_radius_m
    palm_a = big_l + big_r + 0.045
    sd = (np.hypot((a - palm_a) / 0.045, (c - 0.006) / 0.040) - 1.0) * 0.040  # palm (an ellipse)
    sd = np.minimum(sd, _capsule_sd(a, c, palm_a + 0.03, 0.0, big_l + 0.40, 0.0, 0.034))  # forearm
    finger = 0.54 * max(0.018, 0.6 * big_r)  # fingers overlap: no gap between them
    for k, across in enumerate(np.array((-1.5, -0.5, 0.5, 1.5)) * max(0.018, 0.6 * big_r)):
        tip = big_l - big_r - 0.006 + 0.003 * abs(k - 1.5)
        sd = np.minimum(sd, _capsule_sd(a, c, palm_a - 0.02, across, tip, across * 0.8, finger))
    sd = np.minimum(sd, _capsule_sd(a, c, palm_a - 0.01, 0.042, big_l + 0.3 * big_r, 0.036, 0.0095))  # thumb
    alpha = np.clip(0.5 - sd / size, 0.0, 1.0)
    rows, cols = np.flatnonzero(alpha.max(axis=1) > 0), np.flatnonzero(alpha.max(axis=0) > 0)
    if rows.size == 0:
        return Hand(box=(0, 0, 0, 0), alpha=np.zeros((0, 0, 1), np.float32), colour=np.zeros((0, 0, 3), np.float32))
    y0, y1, x0, x1 = int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1
    depth = np.clip(-sd[y0:y1, x0:x1] / 0.012, 0.0, 1.0)  # 0 at an edge, 1 deep inside [1]
    shade = (0.78 + 0.22 * np.sqrt(depth))[..., None]
    colour = (np.asarray(SKIN_BGR) * shade).astype(np.float32)
    return Hand(box=(x0, y0, x1, y1), alpha=alpha[y0:y1, x0:x1, None].astype(np.float32), colour=colour)


def illumination(scene: Scene, *, gradient: float, vignetting: float) -> np.ndarray:
    """Smooth static lighting: a linear gradient (lamp up-left), a soft hot spot, vignetting.

    Returns an (H, W) float32 field, 0.92 at the image centre when both effects are 0.
    """
    fe = scene.fisheye
    (cx, cy), big_r = fe.centre, fe.half_diagonal
    v, u = np.mgrid[0:scene.height, 0:scene.width].astype(float)
    du, dv = (u - cx) / big_r, (v - cy) / big_r
    rho2 = du * du + dv * dv
    light = 0.92 * (1 - gradient * (0.6 * du + 0.8 * dv))
    light *= 1 - vignetting * rho2
    if gradient > 0:
        light += 0.25 * gradient * np.exp(-((du - 0.45) ** 2 + (dv + 0.35) ** 2) / 0.08)
    return np.clip(light, 0.05, None).astype(np.float32)
