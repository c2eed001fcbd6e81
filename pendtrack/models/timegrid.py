"""Time axes: checks shared by the simulation and the vectorised right-hand side."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from pendtrack.config import ModelsConfig
from pendtrack.errors import ModelError

UNIFORM_RTOL = 1e-6  # relative spread of the spacing below which t counts as uniform


def check_time(t: Any, *, what: str = "t", error: type[Exception] = ModelError, min_size: int = 2) -> np.ndarray:
    """Return ``t`` as a float64 1-D array after checking it is finite and strictly increasing.

    Parameters
    ----------
    t : array_like
        Times [s].
    what : str
        Name of the array in the messages.
    error : exception class
        Raised on a bad axis (the caller's layer's error; default :class:`ModelError`).
    min_size : int
        Fewest samples accepted.

    Raises
    ------
    error
        Fewer than ``min_size`` samples, NaN/inf, or not strictly increasing (names the first bad index).
    """
    arr = np.asarray(t, dtype=np.float64)
    if arr.ndim != 1 or arr.size < min_size:
        raise error(f"{what} must be a 1-D array of at least {min_size} times, got shape {arr.shape}")
    bad = np.flatnonzero(~np.isfinite(arr))
    if bad.size:
        raise error(f"{what} has a non-finite value at index {bad[0]} ({arr[bad[0]]})")
    steps = np.diff(arr)
    bad = np.flatnonzero(steps <= 0)
    if bad.size:
        i = bad[0]
        raise error(f"{what} must be strictly increasing: {what}[{i + 1}] = {arr[i + 1]!r} <= {what}[{i}] = {arr[i]!r}")
    return arr


def is_uniform(t: np.ndarray) -> bool:
    """True if the spacing of ``t`` is constant to :data:`UNIFORM_RTOL`."""
    d = np.diff(t)
    h = (t[-1] - t[0]) / (t.size - 1)
    return bool(np.max(np.abs(d - h)) <= UNIFORM_RTOL * h)


def memory_steps_for(memory_s: float | None, h: float, *, full_history: bool = False) -> int:
    """GL memory length in steps: ``round(memory_s / h)`` (>= 1), or -1 for the full history.

    ``memory_s=None`` takes :attr:`ModelsConfig.memory_s` (paper: 100 frames at 120 fps).
    """
    if full_history:
        return -1
    m = ModelsConfig().memory_s if memory_s is None else memory_s
    try:
        m = float(m)
    except (TypeError, ValueError):
        raise ModelError(f"memory_s must be a duration in seconds, got {memory_s!r}") from None
    if not math.isfinite(m) or m <= 0:
        raise ModelError(f"memory_s must be a positive duration in seconds, got {m!r}")
    n = int(round(m / h))
    if n < 1:
        raise ModelError(f"memory_s = {m:g} s is shorter than half the time step ({h:g} s): no memory left")
    return n
