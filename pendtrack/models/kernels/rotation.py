"""sin and cos carried from step to step by a rotation instead of libm calls.

The rotation (:func:`sin_cos_after`) turns ``(sin x0, cos x0)`` by an angle step with short
polynomials; the kernels take libm's values every :data:`REFRESH_STEPS` steps (the
predictor-corrector) or at every output sample and event (RK4), so the values stay within a few
ulp of libm's.
"""

from __future__ import annotations

import math

SINCOS_STEP_MAX = 0.5  # [rad] the rotation's polynomials are exact to < 2e-17 up to this angle step
REFRESH_STEPS = 32  # steps between exact libm sin/cos and pow (each step in between adds ~1 ulp)


# Taylor coefficients of sin(d)/d and cos(d) in z = d^2 (z^0 .. z^6): 1/(2k+1)! and 1/(2k)!, signed
_SIN_Z = (1.0, -1.0 / 6.0, 1.0 / 120.0, -1.0 / 5040.0, 1.0 / 362880.0, -1.0 / 39916800.0, 1.0 / 6227020800.0)
_COS_Z = (1.0, -1.0 / 2.0, 1.0 / 24.0, -1.0 / 720.0, 1.0 / 40320.0, -1.0 / 3628800.0, 1.0 / 479001600.0)


def sin_cos_after(s0, c0, d):  # noqa: ANN001, ANN201
    """``(sin, cos)`` of ``x0 + d`` from ``s0 = sin x0``, ``c0 = cos x0`` (|d| <= SINCOS_STEP_MAX).

    Rotation by d with sin d and cos d as Taylor polynomials to d^13 and d^12 (the first
    omitted terms are below 2e-17 at d = 0.5), evaluated in z = d^2 by Estrin's scheme with
    multiplications by constants (no division): four multiply-adds deep on the step's
    dependency chain instead of a libm ``sin`` and ``cos`` (or twelve for Horner's scheme).
    """
    s1, s2, s3, s4, s5, s6 = _SIN_Z[1], _SIN_Z[2], _SIN_Z[3], _SIN_Z[4], _SIN_Z[5], _SIN_Z[6]
    k1, k2, k3, k4, k5, k6 = _COS_Z[1], _COS_Z[2], _COS_Z[3], _COS_Z[4], _COS_Z[5], _COS_Z[6]
    z = d * d
    z2 = z * z
    z4 = z2 * z2
    sd = d * (((1.0 + s1 * z) + (s2 + s3 * z) * z2) + ((s4 + s5 * z) + s6 * z2) * z4)
    cd = ((1.0 + k1 * z) + (k2 + k3 * z) * z2) + ((k4 + k5 * z) + k6 * z2) * z4
    return s0 * cd + c0 * sd, c0 * cd - s0 * sd


def sin_cos_at(x, x0, s0, c0):  # noqa: ANN001, ANN201
    """``(sin x, cos x)`` from ``s0 = sin x0``, ``c0 = cos x0``: the rotation :func:`sin_cos_after` by
    ``x - x0`` when that is at most :data:`SINCOS_STEP_MAX`, else libm."""
    d = x - x0
    if abs(d) <= SINCOS_STEP_MAX:
        return sin_cos_after(s0, c0, d)
    return math.sin(x), math.cos(x)
