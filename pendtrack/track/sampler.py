"""Feature windows cut from 4:2:0 planes, in raw or lens-corrected coordinates.

A sampler turns a rectangle ``[x0, x0 + w) x [y0, y0 + h)`` of the tracking coordinate
system (raw frame pixels, or corrected pixels) into a float32 feature window (see
:mod:`pendtrack.track.colour`), touching only the pixels it needs: chroma is upsampled
(bilinear, chroma samples centred on their 2x2 luma block) only inside the window, and the
corrected sampler remaps only the window through slices of precomputed tables.
"""

from __future__ import annotations

import cv2
import numpy as np

from pendtrack.lens.fisheye import Fisheye, local_scale, undistort_blob_centres
from pendtrack.lens.remap import RemapTables, chroma_maps, remap_tables
from pendtrack.track.colour import MarkerColour, chroma_feature, half_resolution_feature


class RawSampler:
    """Feature windows in raw frame coordinates.

    Parameters
    ----------
    colour : MarkerColour
        Feature weights.
    width, height : int
        Frame size [px]; windows must lie inside it.
    """

    corrected = False
    half_windows = True  # window_half gives windows in this sampler's coordinates (halved)

    def __init__(self, colour: MarkerColour, *, width: int, height: int) -> None:
        self.colour = colour
        self.width = width
        self.height = height

    def window(self, y: np.ndarray, u: np.ndarray, v: np.ndarray, x0: int, y0: int, w: int, h: int) -> np.ndarray:
        """Feature of the window (h, w), float32; the window must lie inside the frame."""
        colour = self.colour
        if colour.uses_chroma:
            ch, cw = u.shape
            cx0 = max(x0 // 2 - 1, 0)
            cy0 = max(y0 // 2 - 1, 0)
            cx1 = min((x0 + w + 1) // 2 + 1, cw)
            cy1 = min((y0 + h + 1) // 2 + 1, ch)
            c = chroma_feature(u[cy0:cy1, cx0:cx1], v[cy0:cy1, cx0:cx1], colour)
            big = cv2.resize(c, (2 * (cx1 - cx0), 2 * (cy1 - cy0)), interpolation=cv2.INTER_LINEAR)
            ox, oy = x0 - 2 * cx0, y0 - 2 * cy0
            f = big[oy:oy + h, ox:ox + w]
            if colour.uses_luma:
                f = f + np.float32(colour.wy) * (y[y0:y0 + h, x0:x0 + w].astype(np.float32) - np.float32(128))
            return np.ascontiguousarray(f)
        f = y[y0:y0 + h, x0:x0 + w].astype(np.float32)
        f -= np.float32(128.0)
        f *= np.float32(colour.wy)
        return f

    def whole_half(self, y: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Feature of the whole frame at half resolution: sample ``(i, j)`` at ``(2i + 0.5, 2j + 0.5)``."""
        return half_resolution_feature(y, u, v, self.colour)

    @property
    def half_width(self) -> int:
        """Columns of the half-resolution grid whose 2x2 luma blocks lie inside the frame."""
        return self.width // 2

    @property
    def half_height(self) -> int:
        """Rows of the half-resolution grid whose 2x2 luma blocks lie inside the frame."""
        return self.height // 2

    def window_half(self, y: np.ndarray, u: np.ndarray, v: np.ndarray, x0: int, y0: int, w: int,
                    h: int) -> np.ndarray:
        """Feature of a window of the half-resolution grid (h, w), float32, as :meth:`whole_half` computes it
        (sample ``(i, j)`` at raw ``(2i + 0.5, 2j + 0.5)``: the chroma sample as it is, luma averaged over its
        2x2 block) but touching only the window; it must lie inside ``half_width`` x ``half_height``."""
        colour = self.colour
        f = None
        if colour.uses_chroma:
            f = chroma_feature(u[y0:y0 + h, x0:x0 + w], v[y0:y0 + h, x0:x0 + w], colour)
        if colour.uses_luma:
            small = cv2.resize(y[2 * y0:2 * (y0 + h), 2 * x0:2 * (x0 + w)], (w, h), interpolation=cv2.INTER_AREA)
            lum = np.float32(colour.wy) * (small.astype(np.float32) - np.float32(128.0))
            f = lum if f is None else f + lum
        return f

    def to_raw(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Tracking coordinates -> raw frame coordinates (identity here)."""
        return np.asarray(x, float), np.asarray(y, float)

    def from_raw(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Raw frame coordinates -> tracking coordinates (identity here)."""
        return np.asarray(x, float), np.asarray(y, float)

    def local_scale(self, x: float, y: float) -> float:
        """Tracking px per raw px near a raw point (1 here)."""
        return 1.0

    def cuttable(self, x0: int, y0: int, x1: int, y1: int) -> tuple[int, int, int, int]:
        """The part of the window ``[x0, x1) x [y0, y1)`` [px] this sampler can cut: the frame's."""
        return max(x0, 0), max(y0, 0), min(x1, self.width), min(y1, self.height)

    def can_cut(self, x0: int, y0: int, x1: int, y1: int) -> bool:
        """Can the whole window ``[x0, x1) x [y0, y1)`` [px] be cut, every pixel of it seen in the frame?"""
        return self.cuttable(x0, y0, x1, y1) == (x0, y0, x1, y1)

    def blob_from_raw(self, x: float, y: float, radius: float) -> tuple[float, float, float]:
        """A round marker's raw blob (centroid, radius [raw px]) -> its centre and radius in tracking coordinates."""
        return float(x), float(y), float(radius)


class CorrectedSampler(RawSampler):
    """Feature windows in lens-corrected coordinates, remapped window by window from raw planes.

    Parameters
    ----------
    colour : MarkerColour
    fisheye : Fisheye
        The correction; its size is the frame size.
    precompute : bool
        Tabulate the whole image's remap once (fast windows, ~0.3 s to build); False
        computes each window's table when asked (for a few windows only).
    """

    corrected = True
    half_windows = False  # window_half would cut raw, not corrected, windows

    def __init__(self, colour: MarkerColour, *, fisheye: Fisheye, precompute: bool = True) -> None:
        super().__init__(colour, width=fisheye.width, height=fisheye.height)
        self.fisheye = fisheye
        self.luma_tables: RemapTables | None = None
        self.chroma_tables: RemapTables | None = None
        self._half_luma: RemapTables | None = None
        self._half_chroma: RemapTables | None = None
        if precompute:
            self.luma_tables = remap_tables(fisheye)
            self.chroma_tables = chroma_maps(self.luma_tables)
            self._half_tables()

    def _half_tables(self) -> tuple[RemapTables, RemapTables]:
        if self._half_luma is None or self._half_chroma is None:
            hw, hh = (self.fisheye.width + 1) // 2, (self.fisheye.height + 1) // 2
            # half-resolution grid of the corrected image, sample (i, j) at (2i + 0.5, 2j + 0.5)
            gx, gy = np.meshgrid(2 * np.arange(hw) + 0.5, 2 * np.arange(hh) + 0.5)
            sx, sy = self.fisheye.distort_points(gx, gy)
            self._half_luma = RemapTables(sx.astype(np.float32), sy.astype(np.float32))
            self._half_chroma = chroma_maps(self._half_luma)
        return self._half_luma, self._half_chroma

    def _tables(self, x0: int, y0: int, w: int, h: int) -> tuple[RemapTables, RemapTables]:
        """Luma and chroma remap tables of a window."""
        if self.luma_tables is not None and self.chroma_tables is not None:
            lt, ct = self.luma_tables, self.chroma_tables
            return (RemapTables(lt.map_x[y0:y0 + h, x0:x0 + w], lt.map_y[y0:y0 + h, x0:x0 + w]),
                    RemapTables(ct.map_x[y0:y0 + h, x0:x0 + w], ct.map_y[y0:y0 + h, x0:x0 + w]))
        lt = remap_tables(self.fisheye, region=(x0, y0, w, h))
        return lt, chroma_maps(lt)

    def window(self, y: np.ndarray, u: np.ndarray, v: np.ndarray, x0: int, y0: int, w: int, h: int) -> np.ndarray:
        colour = self.colour
        f = None
        lt, ct = self._tables(x0, y0, w, h)
        if colour.uses_chroma:
            mx, my = ct.map_x, ct.map_y
            uu = cv2.remap(u, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
            vv = cv2.remap(v, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
            f = chroma_feature(uu, vv, colour)
        if colour.uses_luma:
            mx, my = lt.map_x, lt.map_y
            yy = cv2.remap(y, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE).astype(np.float32)
            lum = np.float32(colour.wy) * (yy - np.float32(128.0))
            f = lum if f is None else f + lum
        return f

    def whole_half(self, y: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        colour = self.colour
        lt, ht = self._half_tables()
        f = np.zeros(ht.shape, np.float32)
        if colour.uses_chroma:
            uu = cv2.remap(u, ht.map_x, ht.map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
            vv = cv2.remap(v, ht.map_x, ht.map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
            f += chroma_feature(uu, vv, colour)
        if colour.uses_luma:
            yy = cv2.remap(y, lt.map_x, lt.map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
            f += np.float32(colour.wy) * (yy.astype(np.float32) - np.float32(128.0))
        return f

    def to_raw(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.fisheye.distort_points(x, y)

    def cuttable(self, x0: int, y0: int, x1: int, y1: int) -> tuple[int, int, int, int]:
        """With tables, the corrected frame's part of the window; without, the whole window.

        Remapped on demand, a window may reach past the corrected frame's rectangle: the lens
        correction maps the raw frame's edges beyond it (a 16:9 frame under the paper's fisheye: raw x = 30 px of
        1280 to corrected x = -191 px), and its pixels are the raw frame's all the same.
        """
        if self.luma_tables is not None:
            return super().cuttable(x0, y0, x1, y1)
        return x0, y0, x1, y1

    def can_cut(self, x0: int, y0: int, x1: int, y1: int) -> bool:
        """Is every pixel of the window seen in the frame? Without tables: does its raw footprint lie inside the
        raw frame (its border, sampled every pixel, mapped through the lens)?"""
        if self.luma_tables is not None:
            return super().can_cut(x0, y0, x1, y1)
        xs, ys = np.arange(x0, x1, dtype=float), np.arange(y0, y1, dtype=float)
        bx = np.concatenate([xs, xs, np.full(ys.size, float(x0)), np.full(ys.size, float(x1 - 1))])
        by = np.concatenate([np.full(xs.size, float(y0)), np.full(xs.size, float(y1 - 1)), ys, ys])
        rx, ry = self.fisheye.distort_points(bx, by)
        return bool(np.all((rx >= 0) & (rx <= self.width - 1) & (ry >= 0) & (ry <= self.height - 1)))

    def from_raw(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.fisheye.undistort_points(x, y)

    def blob_from_raw(self, x: float, y: float, radius: float) -> tuple[float, float, float]:
        """Centre of the disc whose raw blob has centroid ``(x, y)``, and its corrected radius.

        The lens shifts a blob's raw centroid from the image of its centre by a second-order
        amount (:func:`pendtrack.lens.fisheye.raw_centroid_offset`), removed here.
        """
        rc = radius * self.local_scale(x, y)
        cx, cy = undistort_blob_centres(self.fisheye, np.array(x), np.array(y), rc)
        return float(cx), float(cy), rc

    def local_scale(self, x: float, y: float) -> float:
        """Corrected px per raw px near raw point ``(x, y)`` (geometric mean of the two axes)."""
        return local_scale(self.fisheye, x, y)


class WarpedRawSampler(RawSampler):
    """Raw frame coordinates, with a template that follows the lens' local distortion.

    The template is cut once in corrected (rectilinear) space, where the round marker looks
    the same everywhere on its circle, and warped for every position into the raw frame
    with the lens' local affine map (its Jacobian, tabulated on a grid of ``grid_px``).
    Tracking stays in raw frames (no remap of the search window) while the template fits
    the blob wherever the fisheye squeezes it. The tracked point is the blob's centroid to
    second order (measured: the lens' centroid shift, ~0.1 px, is what separates it from
    the image of the centre), which :func:`pendtrack.lens.fisheye.undistort_blob_centres`
    maps to the corrected centre.

    Parameters
    ----------
    colour : MarkerColour
    fisheye : Fisheye
    grid_px : int
        Spacing of the Jacobian table [raw px].
    """

    warps_template = True
    half_windows = False  # the template is warped per position at full resolution

    def __init__(self, colour: MarkerColour, *, fisheye: Fisheye, grid_px: int = 16) -> None:
        super().__init__(colour, width=fisheye.width, height=fisheye.height)
        self.fisheye = fisheye
        self.corrected_sampler = CorrectedSampler(colour, fisheye=fisheye, precompute=False)
        self.grid_px = grid_px
        gx, gy = np.meshgrid(np.arange(0, fisheye.width + grid_px, grid_px, dtype=float),
                             np.arange(0, fisheye.height + grid_px, grid_px, dtype=float))
        cx, cy = fisheye.undistort_points(gx, gy)
        h = 0.25
        ax, ay = fisheye.distort_points(cx + h, cy)
        bx, by = fisheye.distort_points(cx, cy + h)
        # d(raw)/d(corrected): columns = images of the corrected unit vectors
        self._jac = np.stack([(ax - gx) / h, (bx - gx) / h, (ay - gy) / h, (by - gy) / h], axis=-1)

    @property  # type: ignore[override]
    def colour(self) -> MarkerColour:
        return self._colour

    @colour.setter
    def colour(self, value: MarkerColour) -> None:
        self._colour = value
        if hasattr(self, "corrected_sampler"):
            self.corrected_sampler.colour = value

    def jacobian(self, x: float, y: float) -> tuple[float, float, float, float]:
        """``(dxr/dxc, dxr/dyc, dyr/dxc, dyr/dyc)`` of the lens near raw point ``(x, y)`` (nearest grid node)."""
        j = self._jac
        i = min(max(int(round(y / self.grid_px)), 0), j.shape[0] - 1)
        k = min(max(int(round(x / self.grid_px)), 0), j.shape[1] - 1)
        a, b, c, d = j[i, k]
        return float(a), float(b), float(c), float(d)

    def blob_from_raw(self, x: float, y: float, radius: float) -> tuple[float, float, float]:
        """Raw coordinates stay as they are (the blob's centroid is what the raw path tracks)."""
        return float(x), float(y), float(radius)
