"""Whole-image lens correction: OpenCV remap tables built from :meth:`Fisheye.distort_points`.

Conventions
-----------
A remap table gives, for every pixel ``(x, y)`` of the corrected (rectilinear) image, the
raw-frame coordinates ``(map_x[y, x], map_y[y, x])`` [px] it is sampled from; pixel centres
at integer coordinates, x right, y down. Corrected pixels whose source lies outside the raw
frame are filled with ``border_value``. For 4:2:0 video the chroma planes (half size, chroma
samples centred between their 2x2 luma pixels, FFmpeg's default for converted RGB) use
:func:`chroma_maps`.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from pendtrack.lens.fisheye import Fisheye


@dataclass(frozen=True)
class RemapTables:
    """Remap tables of one :class:`Fisheye` correction.

    Attributes
    ----------
    map_x, map_y : ndarray, float32, shape (height, width)
        Raw-frame source coordinates [px] of every corrected pixel.
    """

    map_x: np.ndarray
    map_y: np.ndarray

    @property
    def shape(self) -> tuple[int, int]:
        return self.map_x.shape  # type: ignore[return-value]


def remap_tables(fisheye: Fisheye, *, region: tuple[int, int, int, int] | None = None) -> RemapTables:
    """Source coordinates in the raw frame for every pixel of the corrected image.

    Parameters
    ----------
    fisheye : Fisheye
        The correction (image size, projection, field of view, fixed pixels).
    region : (x0, y0, w, h), optional
        Only this rectangle of the corrected image [px]; default the whole image.

    Returns
    -------
    RemapTables
        float32 tables; computed in float64 and rounded once.
    """
    x0, y0, w, h = region if region is not None else (0, 0, fisheye.width, fisheye.height)
    xs = np.arange(x0, x0 + w, dtype=float)
    ys = np.arange(y0, y0 + h, dtype=float)
    gx, gy = np.meshgrid(xs, ys)
    sx, sy = fisheye.distort_points(gx, gy)
    return RemapTables(sx.astype(np.float32), sy.astype(np.float32))


def chroma_maps(tables: RemapTables) -> RemapTables:
    """Tables into a 4:2:0 chroma plane: luma coordinate ``u`` -> chroma ``(u + 0.5) / 2 - 0.5``."""
    return RemapTables(((tables.map_x + 0.5) * 0.5 - 0.5).astype(np.float32),
                       ((tables.map_y + 0.5) * 0.5 - 0.5).astype(np.float32))


def undistort_image(image: np.ndarray, tables: RemapTables, *, interpolation: int = cv2.INTER_LINEAR,
                    border_value: float = 0.0) -> np.ndarray:
    """The corrected image: ``out[y, x] = image(map_x[y, x], map_y[y, x])``.

    Parameters
    ----------
    image : ndarray, shape (H, W) or (H, W, C)
        Raw frame (any dtype cv2.remap accepts).
    tables : RemapTables
        From :func:`remap_tables` (or :func:`chroma_maps` for a chroma plane).
    interpolation : int
        OpenCV interpolation flag (bilinear by default).
    border_value : float
        Value of corrected pixels whose source is outside the raw frame.
    """
    return cv2.remap(image, tables.map_x, tables.map_y, interpolation, borderMode=cv2.BORDER_CONSTANT,
                     borderValue=border_value)
