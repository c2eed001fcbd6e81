"""The pendulum angle from the corrected marker track.

Convention (docs/architecture.md): ``theta = atan2(dx, dy)`` with ``(dx, dy)`` the marker
minus the axle in corrected image coordinates (x right, y down): 0 when the marker hangs
straight below the axle, positive when it swings to the image's right. The series is
unwrapped, so full turns over the top accumulate (2 pi per turn).

Zero: as in the paper, the pendulum's final stopping position. If the record ends with the
pendulum still for ``rest_seconds`` (|omega| below ``rest_omega_max`` throughout), the
median angle of that stretch is subtracted (``zero_reference = "rest"``). Otherwise the
image vertical is kept as zero (``"vertical"``), with the branch of the unwrapped series
chosen so that its last ok sample lies in (-pi, pi].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import savgol_filter

from pendtrack.track.circle import CircleFit


@dataclass(frozen=True)
class AngleResult:
    """theta(t) and how its axle and zero were chosen.

    Attributes
    ----------
    t : ndarray
        Time [s].
    theta : ndarray
        Angle [rad] (NaN where not ok).
    ok : ndarray, bool
        Sample usable (its track frame was ok).
    axle : (float, float)
        Axle [corrected px].
    zero_reference : str
        ``"rest"`` or ``"vertical"``.
    zero_offset : float
        Angle of the zero direction from the image vertical [rad], in (-pi, pi] (0 for
        ``"vertical"``).
    circle : CircleFit or None
        The fit that gave the axle (None if the axle was given).
    """

    t: np.ndarray
    theta: np.ndarray
    ok: np.ndarray
    axle: tuple[float, float]
    zero_reference: str
    zero_offset: float
    circle: CircleFit | None

    def to_dict(self) -> dict[str, object]:
        out: dict[str, object] = {"axle_px": list(self.axle), "zero_reference": self.zero_reference,
                                  "zero_offset_rad": self.zero_offset, "n": int(self.t.size),
                                  "n_ok": int(self.ok.sum())}
        if self.circle is not None:
            out["circle"] = self.circle.to_dict()
        return out


def wrap(a: np.ndarray | float) -> np.ndarray:
    """Angle(s) wrapped into (-pi, pi]."""
    a = np.asarray(a, dtype=float)
    return np.pi - np.mod(np.pi - a, 2 * np.pi)


def raw_theta(x: np.ndarray, y: np.ndarray, axle: tuple[float, float]) -> np.ndarray:
    """``atan2(x - xa, y - ya)`` [rad] in (-pi, pi]: 0 straight down, + to the right (y down)."""
    return np.arctan2(np.asarray(x, float) - axle[0], np.asarray(y, float) - axle[1])


def rest_angle(t: np.ndarray, theta: np.ndarray, *, rest_seconds: float, omega_max: float) -> float | None:
    """Median angle of the final still stretch, or None if the record does not end at rest.

    Parameters
    ----------
    t, theta : ndarray
        Time [s] and unwrapped angle [rad] of the ok samples, increasing time.
    rest_seconds : float
        Length of the final stretch [s].
    omega_max : float
        Still means |omega| < omega_max throughout [rad/s]; omega from a quadratic
        Savitzky-Golay derivative over 0.25 s (at least 5 samples).
    """
    if t.size < 5 or rest_seconds <= 0:
        return None
    t_end = t[-1]
    sel = t >= t_end - rest_seconds
    dt = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    if not dt > 0:
        return None
    n = int(sel.sum())
    if n < 5 or (t_end - t[sel][0]) < 0.9 * rest_seconds or n < 0.8 * rest_seconds / dt:
        return None
    win = max(5, int(round(0.25 / dt)) | 1)
    th = theta[sel]
    if win > th.size:
        win = th.size if th.size % 2 else th.size - 1
    omega = savgol_filter(th, win, 2, deriv=1, delta=dt)
    if np.max(np.abs(omega)) >= omega_max:
        return None
    return float(np.median(th))


def theta_from_track(t: np.ndarray, x: np.ndarray, y: np.ndarray, ok: np.ndarray, *, axle: tuple[float, float],
                     rest_seconds: float, rest_omega_max: float,
                     circle: CircleFit | None = None) -> AngleResult:
    """theta(t) from corrected marker positions and an axle.

    Parameters
    ----------
    t : ndarray
        Time [s].
    x, y : ndarray
        Corrected marker centre [px].
    ok : ndarray, bool
        Usable track samples; the others get theta = NaN and ok = False.
    axle : (float, float)
        Axle [corrected px].
    rest_seconds, rest_omega_max : float
        See :func:`rest_angle`.
    circle : CircleFit, optional
        Recorded in the result.
    """
    t = np.asarray(t, float)
    ok = np.asarray(ok, bool) & np.isfinite(x) & np.isfinite(y)
    theta = np.full(t.shape, np.nan)
    if not ok.any():
        return AngleResult(t, theta, ok, axle, "vertical", 0.0, circle)
    th = np.unwrap(raw_theta(np.asarray(x)[ok], np.asarray(y)[ok], axle))
    rest = rest_angle(t[ok], th, rest_seconds=rest_seconds, omega_max=rest_omega_max)
    if rest is not None:
        th = th - rest
        reference, offset = "rest", float(wrap(rest))
    else:
        th = th - 2 * np.pi * np.round((th[-1] - wrap(th[-1])) / (2 * np.pi))
        reference, offset = "vertical", 0.0
    theta[ok] = th
    return AngleResult(t, theta, ok, (float(axle[0]), float(axle[1])), reference, offset, circle)
