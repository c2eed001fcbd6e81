"""The paper's apparatus as physics: Omega0 of the bar plus a tile (eq. consistencycheck)."""

from __future__ import annotations

import numpy as np


def two_cuboid_omega0(l1: np.ndarray | float, *, x: float, l0: float, g: float = 9.81) -> np.ndarray:
    """Natural angular frequency of a bar (length l0) carrying a tile of length l1 at its end.

    Eq. consistencycheck of the paper: both bodies are uniform cuboids, the tile's outer edge
    at the bar's end, ``X = lambda0 / lambda1`` the ratio of their masses per unit length.

    Parameters
    ----------
    l1 : array_like
        Tile length [m]; 0 means no tile.
    x : float
        X = lambda0 / lambda1 [1], > 0.
    l0 : float
        Axle to the pendulum's extreme [m], > 0.
    g : float
        Gravitational acceleration [m/s^2].

    Returns
    -------
    ndarray
        Omega0 [rad/s].
    """
    if x <= 0 or l0 <= 0 or g <= 0:
        raise ValueError("x, l0 and g must be positive")
    r = np.asarray(l1, dtype=float) / l0
    num = 0.5 * x + r - 0.5 * r**2
    den = x / 3.0 + r - r**2 + r**3 / 3.0
    return np.sqrt(g / l0) * np.sqrt(num / den)
