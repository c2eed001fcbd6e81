"""Marker colours and the scalar "marker-likeness" feature computed from Y/Cb/Cr planes.

The feature of a pixel is a linear form of its 8-bit Y, Cb, Cr values::

    f = wy * (Y - 128) + wu * (Cb - 128) + wv * (Cr - 128)

with unit weight vector ``(wy, wu, wv)`` pointing from a neutral background towards the
marker colour: the chroma direction of a coloured marker (pink, red, green, ..., ``#RRGGBB`` with
chroma), ``-Y`` for a dark marker, ``+Y`` for a pale one. Pink was chosen by the paper
"because it produced the best contrast"; its feature is essentially Cr. Template matching
runs on this single-channel image, so a frame is never converted to BGR.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

#: Named marker colours (RGB, 8-bit): only their chroma direction counts, so "red" finds a red ball in any light
NAMED = {"pink": (255, 105, 180), "red": (220, 30, 30), "orange": (255, 140, 0), "yellow": (240, 220, 40),
         "green": (40, 170, 60), "blue": (30, 60, 220)}
#: What ``--marker-color`` takes by name
COLOUR_NAMES = (*NAMED, "dark")
_HEX = re.compile(r"^#([0-9a-fA-F]{6})$")
_MIN_CHROMA = 24.0  # below this |(Cb, Cr) - 128| a #RRGGBB colour counts as grey: match on luma


@dataclass(frozen=True)
class MarkerColour:
    """Weights of the marker feature (unit vector over Y, Cb, Cr).

    Attributes
    ----------
    name : str
        What the user asked for ("pink", "dark", "#ff00aa", "roi").
    wy, wu, wv : float
        Weights of Y - 128, Cb - 128 and Cr - 128.
    floor_level : float or None
        Feature level [8-bit levels] below which every pixel counts as background: the
        feature is raised to it (:func:`floored`). Set by the detection when the marker
        touches something of its own colour, only less so (a dark ball on a dark-grey bar:
        the bar turns with the pendulum and must not be part of the template); None: none.
    """

    name: str
    wy: float
    wu: float
    wv: float
    floor_level: float | None = None

    def to_dict(self) -> dict[str, object]:
        return {"name": self.name, "wy": self.wy, "wu": self.wu, "wv": self.wv, "floor_level": self.floor_level}

    @property
    def uses_luma(self) -> bool:
        return self.wy != 0.0

    @property
    def uses_chroma(self) -> bool:
        return self.wu != 0.0 or self.wv != 0.0


def rgb_to_ycbcr(r: float, g: float, b: float) -> tuple[float, float, float]:
    """BT.601 full-range Y, Cb, Cr (8-bit levels) of an RGB colour (8-bit levels)."""
    y = 0.299 * r + 0.587 * g + 0.114 * b
    cb = 128 - 0.168736 * r - 0.331264 * g + 0.5 * b
    cr = 128 + 0.5 * r - 0.418688 * g - 0.081312 * b
    return y, cb, cr


def from_direction(name: str, dy: float, du: float, dv: float) -> MarkerColour:
    """A :class:`MarkerColour` from an (unnormalised) Y, Cb, Cr direction."""
    n = float(np.sqrt(dy * dy + du * du + dv * dv))
    if not n > 0:
        raise ValueError("colour direction is zero")
    return MarkerColour(name, dy / n, du / n, dv / n)


def parse_marker_colour(spec: str) -> MarkerColour:
    """A name of :data:`COLOUR_NAMES` or ``#RRGGBB`` -> :class:`MarkerColour`.

    A ``#RRGGBB`` colour with a clear hue matches on chroma only (robust to uneven lighting);
    a grey one on luma, darker or paler than mid-grey.

    Raises
    ------
    ValueError
        For anything else (the caller turns it into a user error).
    """
    key = spec.strip().lower()
    if key == "dark":
        return MarkerColour("dark", -1.0, 0.0, 0.0)
    if key in NAMED:
        rgb = NAMED[key]
    else:
        m = _HEX.match(key)
        if not m:
            raise ValueError(f"unknown marker colour {spec!r}; expected {', '.join(COLOUR_NAMES)} or #RRGGBB")
        h = m.group(1)
        rgb = (int(h[0:2], 16), int(h[2:4], 16), int(h[4:6], 16))
    y, cb, cr = rgb_to_ycbcr(*rgb)
    du, dv = cb - 128.0, cr - 128.0
    if np.hypot(du, dv) < _MIN_CHROMA:
        return MarkerColour(key, -1.0 if y < 128 else 1.0, 0.0, 0.0)
    return from_direction(key, 0.0, du, dv)


def floored(feature: np.ndarray, colour: MarkerColour) -> np.ndarray:
    """``feature`` raised to ``colour.floor_level`` (float32, same shape; as is when the colour has none)."""
    if colour.floor_level is None:
        return feature
    return np.maximum(feature, np.float32(colour.floor_level))


def chroma_feature(u: np.ndarray, v: np.ndarray, colour: MarkerColour) -> np.ndarray:
    """``wu (Cb - 128) + wv (Cr - 128)`` as float32, same shape as the planes.

    Element by element in float64, rounded once to float32: each pixel's value depends on its own Cb, Cr only.
    OpenCV 5.1's ``addWeighted`` rounds a pixel differently in its vector loop and in the row's tail, so a
    window's feature depended on where the window ended (a template and a search window disagreed by 1e-5).
    """
    f = colour.wu * (u.astype(np.float64) - 128.0)
    f += colour.wv * (v.astype(np.float64) - 128.0)
    return f.astype(np.float32)


def half_resolution_feature(y: np.ndarray, u: np.ndarray, v: np.ndarray, colour: MarkerColour) -> np.ndarray:
    """The feature of a whole 4:2:0 frame on the chroma grid (half resolution), float32.

    Chroma sample ``(i, j)`` sits at luma coordinates ``(2i + 0.5, 2j + 0.5)``; luma is
    averaged over the 2x2 block it covers.
    """
    import cv2

    ch, cw = u.shape
    f = chroma_feature(u, v, colour) if colour.uses_chroma else np.zeros((ch, cw), np.float32)
    if colour.uses_luma:
        h, w = y.shape
        yy = y
        if h != 2 * ch or w != 2 * cw:  # odd size: pad the last row/column
            yy = np.pad(y, ((0, 2 * ch - h), (0, 2 * cw - w)), mode="edge")
        small = cv2.resize(yy, (cw, ch), interpolation=cv2.INTER_AREA).astype(np.float32)
        f += np.float32(colour.wy) * (small - np.float32(128.0))
    return f
