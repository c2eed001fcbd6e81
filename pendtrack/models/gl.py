"""Grunwald-Letnikov fractional derivatives (eq. grunletexperder).

``(D^beta f)_i = h^-beta sum_{k=0}^{N} W_k f_{i-k}``, ``W_0 = 1``,
``W_k = (1 - (beta + 1)/k) W_{k-1}`` (so ``W_k = (-1)^k binom(beta, k)``). The left
(causal) derivative; samples before the first are the *unknown past*, taken equal to
``f[0]`` ("null acceleration on the whole unknown past"). With the full history that
constant past extends to minus infinity, which makes the sum
``h^-beta sum_{k<=i} W_k (f_{i-k} - f_0)`` -- the GL form of the Caputo derivative from
the first sample (for ``f[0] = 0`` it is also the Riemann-Liouville one). First order in h.
"""

from __future__ import annotations

import math

import numpy as np

from pendtrack.errors import ModelError


def gl_weights(beta: float, n: int) -> np.ndarray:
    """GL weights ``W_0 .. W_n`` (float64, length n + 1) for order ``beta``."""
    w = np.empty(n + 1)
    w[0] = 1.0
    for k in range(1, n + 1):
        w[k] = (1.0 - (beta + 1.0) / k) * w[k - 1]
    return w


def gl_derivative(f: np.ndarray, h: float, beta: float, *, memory_steps: int = -1) -> np.ndarray:
    """Left GL derivative of order ``beta`` of samples ``f`` with step ``h``.

    Parameters
    ----------
    f : numpy.ndarray
        Samples f(t0 + i h) [any unit U].
    h : float
        Step [s] (or whatever time unit the derivative is taken in).
    beta : float
        Order, > 0.
    memory_steps : int
        N >= 1: truncated sum over the last N steps, samples before f[0] taken as f[0]
        (the paper's scheme, N = 100); -1: full history, constant past (Caputo-like).

    Returns
    -------
    numpy.ndarray
        ``D^beta f`` at every sample [U / s^beta].
    """
    f = np.asarray(f, dtype=np.float64)
    if not (beta > 0) or not math.isfinite(beta):
        raise ModelError(f"GL derivative order beta must be positive, got {beta!r}")
    if memory_steps == 0 or memory_steps < -1:
        raise ModelError(f"memory_steps must be >= 1 or -1 (full history), got {memory_steps}")
    n = f.size
    if n == 0:
        return f.copy()
    f0 = f[0]
    if memory_steps == -1:
        w = gl_weights(beta, n - 1)
        return np.convolve(f - f0, w)[:n] * h ** (-beta)
    w = gl_weights(beta, memory_steps)
    padded = np.concatenate([np.full(memory_steps, f0), f])
    return np.convolve(padded, w, mode="valid") * h ** (-beta)
