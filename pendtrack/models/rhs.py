"""Vectorised right-hand sides: a model's alpha on given series (equation-error fits).

:func:`accel_packed` evaluates ``alpha = -Omega0^2 sin(theta) + sum of terms`` on arrays of
theta, omega and t -- typically measured (Savitzky-Golay) series -- so a fit can compare
it with the measured alpha without integrating (``Model.accel``). ``sgn(0) = +1`` (eq. sgn)
as in the paper. The memory-free terms are the kernels' own folds of the declared formulas
(:func:`pendtrack.models.kernels.accel_free`, which work on arrays as on floats). The
memory term needs the history: it is the left Grunwald-Letnikov derivative of
``g = A|A|^(p_f-1)`` on the uniform grid of ``t`` (step ``h* = 2 Omega0 h``) with the same
conventions as the solvers (memory ``N = round(memory_s/h)`` steps, the unknown past
before ``t[0]`` at ``g[0]``; or the full history).
"""

from __future__ import annotations

import numpy as np

from pendtrack.errors import ModelError
from pendtrack.models import terms as T
from pendtrack.models.gl import gl_derivative
from pendtrack.models.kernels import accel_free
from pendtrack.models.timegrid import check_time, is_uniform, memory_steps_for


def accel_free_vec(coeffs: np.ndarray, theta: np.ndarray, omega: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Memory-free acceleration [rad/s^2] of a packed model on arrays (sgn(0) = +1)."""
    theta = np.asarray(theta, dtype=np.float64)
    omega = np.asarray(omega, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    s = np.where(omega >= 0.0, 1.0, -1.0)
    return accel_free(theta, np.sin(theta), omega, t, s, coeffs)


def accel_packed(coeffs: np.ndarray, theta: np.ndarray, omega: np.ndarray, t: np.ndarray, *,
                 memory_s: float | None = None, full_history: bool = False) -> np.ndarray:
    """A packed model's alpha(theta, omega, t, [history]) on arrays [rad/s^2].

    Parameters
    ----------
    coeffs : numpy.ndarray
        Packed model (``Model.pack``); the memory term is evaluated if ``coeffs[K_HAS_MEMORY]``.
    theta, omega : numpy.ndarray
        Angle [rad] and angular velocity [rad/s], same length as ``t``.
    t : numpy.ndarray
        Times [s]; must be uniform for a model with memory.
    memory_s : float, optional
        GL memory duration [s] (default ModelsConfig.memory_s).
    full_history : bool
        GL sum over the whole series.
    """
    theta = np.asarray(theta, dtype=np.float64)
    omega = np.asarray(omega, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    if not (theta.shape == omega.shape == t.shape):
        raise ModelError(f"theta, omega and t must have the same shape, got {theta.shape}, {omega.shape}, {t.shape}")
    a = accel_free_vec(coeffs, theta, omega, t)
    if coeffs[T.K_HAS_MEMORY] != 0.0:
        tt = check_time(t)
        if not is_uniform(tt):
            raise ModelError("the memory term needs a uniform time axis")
        h = (tt[-1] - tt[0]) / (tt.size - 1)
        n_mem = memory_steps_for(memory_s, h, full_history=full_history)
        x = omega / coeffs[T.K_MEM_U]
        g = np.sign(x) * np.abs(x) ** coeffs[T.K_PF]
        d = gl_derivative(g, coeffs[T.K_TSCALE] * h, coeffs[T.K_BETA], memory_steps=n_mem)
        a = a - coeffs[T.K_MEM] * d
    return a
