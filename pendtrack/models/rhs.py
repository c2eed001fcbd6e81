"""Vectorised right-hand sides: a model's alpha on given series (equation-error fits).

:func:`model_accel` evaluates ``alpha = -Omega0^2 sin(theta) + sum of terms`` on arrays of
theta, omega and t -- typically measured (Savitzky-Golay) series -- so a fit can compare
it with the measured alpha without integrating. ``sgn(0) = +1`` (eq. sgn) as in the
paper. The memory term needs the history: it is the left Grunwald-Letnikov derivative of
``g = A|A|^(p_f-1)`` on the uniform grid of ``t`` (step ``h* = 2 Omega0 h``) with the same
conventions as the solvers (memory ``N = round(memory_s/h)`` steps, the unknown past
before ``t[0]`` at ``g[0]``; or the full history).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np

from pendtrack.errors import ModelError
from pendtrack.models import terms as T

if TYPE_CHECKING:
    from pendtrack.models.registry import Model


def accel_free_vec(coeffs: np.ndarray, theta: np.ndarray, omega: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Memory-free acceleration [rad/s^2] of a packed model on arrays (sgn(0) = +1)."""
    c = coeffs
    theta = np.asarray(theta, dtype=np.float64)
    omega = np.asarray(omega, dtype=np.float64)
    s = np.where(omega >= 0.0, 1.0, -1.0)
    w = np.abs(omega)
    sin_t = np.sin(theta)
    a = -c[T.K_SIN] * sin_t - c[T.K_LIN] * theta - c[T.K_VISC] * omega - s * (c[T.K_COUL] + c[T.K_QUAD] * w * w)
    if c[T.K_POW] != 0.0:
        a = a - s * c[T.K_POW] * (w * c[T.K_POW_SCALE]) ** c[T.K_POW_EXP]
    if c[T.K_ADDED] != 0.0:
        a = a + c[T.K_ADDED] * omega * omega * sin_t
    if c[T.K_TV] != 0.0:
        a = a - c[T.K_TV] * omega / (np.asarray(t, dtype=np.float64) - c[T.K_TV_T0])
    if c[T.K_QUARTER] != 0.0:
        a = a - s * c[T.K_QUARTER] * (w * c[T.K_QUARTER_SCALE]) ** 0.25
    return a


def model_accel(model: "Model", params: Mapping[str, float], theta: np.ndarray, omega: np.ndarray, t: np.ndarray, *,
                memory_s: float | None = None, full_history: bool = False) -> np.ndarray:
    """The model's alpha(theta, omega, t, [history]) on arrays [rad/s^2].

    Parameters
    ----------
    model : Model
    params : mapping of parameter values (validated)
    theta, omega : numpy.ndarray
        Angle [rad] and angular velocity [rad/s], same length as ``t``.
    t : numpy.ndarray
        Times [s]; must be uniform for a model with memory.
    memory_s : float, optional
        GL memory duration [s] (default ModelsConfig.memory_s).
    full_history : bool
        GL sum over the whole series.
    """
    from pendtrack.models.gl import gl_derivative
    from pendtrack.models.simulate import check_time, is_uniform, memory_steps_for

    coeffs = model.pack(params)
    theta = np.asarray(theta, dtype=np.float64)
    omega = np.asarray(omega, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    if not (theta.shape == omega.shape == t.shape):
        raise ModelError(f"theta, omega and t must have the same shape, got {theta.shape}, {omega.shape}, {t.shape}")
    if "time_varying_damping" in model.terms and np.any(t <= coeffs[T.K_TV_T0]):
        raise ModelError(f"parameter t0 = {coeffs[T.K_TV_T0]!r} s must be earlier than every time t")
    a = accel_free_vec(coeffs, theta, omega, t)
    if model.has_memory:
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
