"""Raster kernel: the moving pendulum over the backdrop, averaged over the exposure.

The kernel works the trackpy way: plain arrays and scalars in, preallocated outputs
written. :func:`_raster_py` is the pure-Python reference; :func:`_raster_nb` is the same
source compiled by numba on first use (``cache=True``); :func:`raster_pendulum` picks one.

Anti-aliasing: a part covers a pixel by ``clip(0.5 - sd / size, 0, 1)`` with ``sd`` the
signed distance [m] from the pixel centre's world point to the part's edge (negative
inside) and ``size`` the pixel's footprint [m/px] -- a one-pixel linear ramp, which is
symmetric about the edge so it does not move a blob's centroid.

Motion blur: the output is the mean over the sub-sample angles of the exposure.

Balls (part kind 2): a disc whose reflectance is shaded as a sphere's, Lambert plus a small
white highlight, under a light fixed in the world (upper left, towards the camera), so the
shading does not turn with the pendulum. Shiny balls (part kind 3): the same with a glossy
finish, a small highlight that saturates the sensor (a lamp's reflection on a real ball).
"""

from __future__ import annotations

import functools
import math

import numpy as np

# unit vectors in the world (X right, Y down, Z towards the camera): light, and the half-way
# vector between it and the view direction (0, 0, 1), for the balls' shading
_L = np.array([-0.45, -0.55, 0.70]) / np.linalg.norm([-0.45, -0.55, 0.70])
_H = (_L + np.array([0.0, 0.0, 1.0])) / np.linalg.norm(_L + np.array([0.0, 0.0, 1.0]))
LIGHT_X, LIGHT_Y, LIGHT_Z = (float(v) for v in _L)
HALF_X, HALF_Y, HALF_Z = (float(v) for v in _H)
BALL_AMBIENT = 0.40  # shade of the ball's side turned away from the light
BALL_DIFFUSE = 0.75  # Lambert term's weight (0.4 + 0.75 cos: ~0.93 at the ball's centre)
BALL_SPECULAR = 0.30  # white highlight's peak reflectance
BALL_SHININESS = 24.0  # Blinn-Phong exponent
SHINY_SPECULAR = 2.5  # a shiny ball's highlight: well above white, so it clips at 255 in the frame
SHINY_SHININESS = 60.0  # ... and small (Blinn-Phong exponent of a glossy finish)


def _raster_py(xw, yw, size, light, back, x0, y0, sin_t, cos_t, parts, out_bgr, out_alpha):
    """The lit pendulum over the backdrop, and its coverage, mean over sub-samples.

    Parameters
    ----------
    xw, yw : ndarray, shape (H, W), float64
        World coordinates [m] of every pixel centre on the pendulum's plane.
    size : ndarray, shape (H, W), float64
        Pixel footprint [m/px].
    light : ndarray, shape (H, W, 1), float32
        Illumination in 8-bit levels per unit reflectance.
    back : ndarray, shape (H, W, 3), float32
        What is seen behind the pendulum, lit, in 8-bit levels (BGR).
    x0, y0 : int
        Top-left pixel of the box that ``out_bgr`` covers.
    sin_t, cos_t : ndarray, shape (n,), float64
        ``sin`` and ``cos`` of the sub-sample angles [rad], ascending or descending;
        ``n >= 1``; the span of the angles must be well below 1 rad (one exposure).
    parts : ndarray, shape (n_parts, 8), float64
        Parts back to front, see :meth:`pendtrack.render.scene.Scene.parts` (kind 0 a
        rectangle, 1 a disc, 2 a ball, 3 a shiny ball).
    out_bgr : ndarray, shape (h, w, 3), float32
        Written: mean over the sub-samples of the pendulum (reflectance x light) over
        ``back``, in 8-bit levels, BGR.
    out_alpha : ndarray, shape (h, w), float32
        Written: mean coverage in [0, 1].
    """
    h = out_bgr.shape[0]
    w = out_bgr.shape[1]
    n = sin_t.shape[0]
    n_parts = parts.shape[0]
    # extents of every part in the pendulum's frame: a in [lo_a, hi_a], |c| <= ext_c
    lo_a = np.empty(n_parts)
    hi_a = np.empty(n_parts)
    ext_c = np.empty(n_parts)
    active = np.zeros(n_parts, dtype=np.bool_)
    r_max = 0.0
    for k in range(n_parts):
        if parts[k, 0] == 0.0:
            lo_a[k] = parts[k, 1]
            hi_a[k] = parts[k, 2]
            ext_c[k] = parts[k, 3]
        else:
            lo_a[k] = parts[k, 1] - parts[k, 2]
            hi_a[k] = parts[k, 1] + parts[k, 2]
            ext_c[k] = parts[k, 2]
        r_max = max(r_max, math.sqrt(max(abs(lo_a[k]), abs(hi_a[k])) ** 2 + ext_c[k] ** 2))
    # angle swept during the exposure; between its ends a and c of a point move monotonically
    # except near an extremum, where they differ from the ends' values by at most r span^2 / 8
    span = abs(math.atan2(sin_t[n - 1] * cos_t[0] - cos_t[n - 1] * sin_t[0],
                          cos_t[n - 1] * cos_t[0] + sin_t[n - 1] * sin_t[0]))
    bulge = span * span / 8.0
    inv_n = 1.0 / n
    for j in range(h):
        for i in range(w):
            x = xw[y0 + j, x0 + i]
            y = yw[y0 + j, x0 + i]
            px = size[y0 + j, x0 + i]
            out_alpha[j, i] = 0.0
            out_bgr[j, i, 0] = back[y0 + j, x0 + i, 0]
            out_bgr[j, i, 1] = back[y0 + j, x0 + i, 1]
            out_bgr[j, i, 2] = back[y0 + j, x0 + i, 2]
            r = math.sqrt(x * x + y * y)
            pad = 1.5 * px + r * bulge
            if r > r_max + pad:
                continue
            a_first = x * sin_t[0] + y * cos_t[0]
            a_last = x * sin_t[n - 1] + y * cos_t[n - 1]
            c_first = x * cos_t[0] - y * sin_t[0]
            c_last = x * cos_t[n - 1] - y * sin_t[n - 1]
            a_lo = min(a_first, a_last) - pad
            a_hi = max(a_first, a_last) + pad
            c_lo = min(c_first, c_last) - pad
            c_hi = max(c_first, c_last) + pad
            any_active = False
            for k in range(n_parts):
                active[k] = a_hi >= lo_a[k] and a_lo <= hi_a[k] and c_hi >= -ext_c[k] and c_lo <= ext_c[k]
                any_active = any_active or active[k]
            if not any_active:
                continue
            acc_b = 0.0
            acc_g = 0.0
            acc_r = 0.0
            acc_a = 0.0
            for s in range(n):
                a = x * sin_t[s] + y * cos_t[s]
                c = x * cos_t[s] - y * sin_t[s]
                col_b = 0.0
                col_g = 0.0
                col_r = 0.0
                alpha = 0.0
                for k in range(n_parts):
                    if not active[k]:
                        continue
                    if parts[k, 0] == 0.0:
                        ac = 0.5 * (parts[k, 1] + parts[k, 2])
                        qa = abs(a - ac) - 0.5 * (parts[k, 2] - parts[k, 1])
                        qc = abs(c) - parts[k, 3]
                        sd = math.sqrt(max(qa, 0.0) ** 2 + max(qc, 0.0) ** 2) + min(max(qa, qc), 0.0)
                    else:
                        sd = math.sqrt((a - parts[k, 1]) ** 2 + c * c) - parts[k, 2]
                    cov = 0.5 - sd / px
                    if cov <= 0.0:
                        continue
                    if cov > 1.0:
                        cov = 1.0
                    cov *= parts[k, 7]
                    shade = 1.0
                    gloss = 0.0
                    if parts[k, 0] >= 2.0:  # ball: the sphere's normal from the world offset to its centre
                        da = (a - parts[k, 1]) / parts[k, 2]
                        dc = c / parts[k, 2]
                        nx = da * sin_t[s] + dc * cos_t[s]
                        ny = da * cos_t[s] - dc * sin_t[s]
                        nz = math.sqrt(max(1.0 - nx * nx - ny * ny, 0.0))
                        shade = BALL_AMBIENT + BALL_DIFFUSE * max(nx * LIGHT_X + ny * LIGHT_Y + nz * LIGHT_Z, 0.0)
                        cos_h = max(nx * HALF_X + ny * HALF_Y + nz * HALF_Z, 0.0)
                        if parts[k, 0] == 3.0:
                            gloss = SHINY_SPECULAR * cos_h ** SHINY_SHININESS
                        else:
                            gloss = BALL_SPECULAR * cos_h ** BALL_SHININESS
                    col_b = col_b * (1.0 - cov) + (parts[k, 4] * shade + gloss) * cov
                    col_g = col_g * (1.0 - cov) + (parts[k, 5] * shade + gloss) * cov
                    col_r = col_r * (1.0 - cov) + (parts[k, 6] * shade + gloss) * cov
                    alpha = alpha * (1.0 - cov) + cov
                acc_b += col_b
                acc_g += col_g
                acc_r += col_r
                acc_a += alpha
            lit = light[y0 + j, x0 + i, 0] * inv_n
            keep = 1.0 - acc_a * inv_n
            out_bgr[j, i, 0] = acc_b * lit + keep * back[y0 + j, x0 + i, 0]
            out_bgr[j, i, 1] = acc_g * lit + keep * back[y0 + j, x0 + i, 1]
            out_bgr[j, i, 2] = acc_r * lit + keep * back[y0 + j, x0 + i, 2]
            out_alpha[j, i] = acc_a * inv_n


@functools.cache
def _compiled():
    import numba

    return numba.njit(cache=True, fastmath=False)(_raster_py)


def _raster_nb(xw, yw, size, light, back, x0, y0, sin_t, cos_t, parts, out_bgr, out_alpha):
    """numba twin of :func:`_raster_py` (same signature, compiled on first call)."""
    _compiled()(xw, yw, size, light, back, x0, y0, sin_t, cos_t, parts, out_bgr, out_alpha)


def raster_pendulum(xw: np.ndarray, yw: np.ndarray, size: np.ndarray, light: np.ndarray, back: np.ndarray,
                    box: tuple[int, int, int, int], thetas: np.ndarray, parts: np.ndarray, *,
                    use_numba: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """The motion-blurred, lit pendulum over the backdrop, and its coverage, in a pixel box.

    Parameters
    ----------
    xw, yw, size : ndarray, shape (H, W)
        Per-pixel world coordinates [m] and footprint [m/px] (see
        :meth:`~pendtrack.render.scene.Scene.pixel_world_maps`).
    light : ndarray, shape (H, W, 1), float32
        Illumination [8-bit levels per unit reflectance].
    back : ndarray, shape (H, W, 3), float32
        Lit backdrop behind the pendulum [8-bit levels], BGR.
    box : tuple of int
        ``(x0, y0, x1, y1)``, half-open pixel box to render.
    thetas : ndarray, shape (n,)
        Sub-sample angles over the exposure [rad].
    parts : ndarray, shape (n_parts, 8)
        Part table (:meth:`~pendtrack.render.scene.Scene.parts`).
    use_numba : bool
        Use the compiled kernel (default) or the pure-Python twin.

    Returns
    -------
    bgr : ndarray, shape (y1 - y0, x1 - x0, 3), float32
        The picture in the box [8-bit levels, not clipped], BGR.
    alpha : ndarray, shape (y1 - y0, x1 - x0), float32
        Coverage in [0, 1].
    """
    x0, y0, x1, y1 = box
    thetas = np.ascontiguousarray(thetas, dtype=np.float64)
    if thetas.ndim != 1 or thetas.size == 0:
        raise ValueError("thetas must be a non-empty 1-D array")
    out_bgr = np.empty((max(y1 - y0, 0), max(x1 - x0, 0), 3), dtype=np.float32)
    out_alpha = np.zeros(out_bgr.shape[:2], dtype=np.float32)
    if out_alpha.size == 0:
        return out_bgr, out_alpha
    kernel = _raster_nb if use_numba else _raster_py
    kernel(xw, yw, size, light, back, int(x0), int(y0), np.sin(thetas), np.cos(thetas),
           np.ascontiguousarray(parts, dtype=np.float64), out_bgr, out_alpha)
    return out_bgr, out_alpha
