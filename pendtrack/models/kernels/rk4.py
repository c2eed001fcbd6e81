"""Classical RK4 with sgn(omega) events, for the models without memory.

:func:`rk_kernel_py` runs ``substeps`` RK4 steps per output step. The ``sgn(omega)``
discontinuity is handled as an event: within a sub-step where omega changes sign the crossing
is located (:func:`locate_stop`, regula falsi on the RK4 step length; the sensitivity kernel
uses the same), the step is finished from there with the new direction of motion. At omega = 0
the direction is the one the forces push towards; if static friction exceeds them
(``accel(+1) <= 0 <= accel(-1)``) the pendulum sticks (omega = alpha = 0) until they do.
The stages' sin(theta) are rotations of the sub-step's start value
(:func:`~pendtrack.models.kernels.rotation.sin_cos_at`), which is itself rotated from the
sub-step before and taken from libm at every output sample and after every event: one libm
sin/cos pair per sample instead of a sin per stage, a few ulp from libm's values.
"""

from __future__ import annotations

import math

from pendtrack.models.kernels.folds import accel_terms, direction, forcing_at, unpack
from pendtrack.models.kernels.rotation import sin_cos_at

def rk4_stage(theta, st, ct, omega, a, kt, kw, tm, s, k, fm):  # noqa: ANN001, ANN201
    """An RK4 stage from the step's start state: ``(theta_i, omega_i, sin theta_i, cos theta_i, alpha_i)``.

    ``theta_i = theta + a kt``, ``omega_i = omega + a kw`` (``a``: dt/2 or dt, ``kt, kw``: the
    previous stage's slopes); the sine is rotated from the start's ``st, ct``; ``alpha_i`` the
    acceleration at ``tm`` with the forcing value ``fm``. Both RK4 kernels build their stages
    with it, so their trajectories agree to the last bit.
    """
    th = theta + a * kt
    w = omega + a * kw
    sn, cs = sin_cos_at(th, theta, st, ct)
    return th, w, sn, cs, accel_terms(th, sn, w, tm, s, k) + fm


def rk4_step(theta, st, ct, omega, t, dt, s, k, forcing, t_start, h):  # noqa: ANN001, ANN201
    """One RK4 step of length dt with the sgn terms frozen at direction s; returns
    ``(theta, omega, sin theta, cos theta)`` after it.

    ``st, ct``: sin and cos of ``theta``; the stages' sines (and the result's) are rotations of
    them (:func:`sin_cos_at`, within a few ulp of libm's). ``k`` from :func:`unpack`.
    """
    k1t = omega
    k1w = accel_terms(theta, st, omega, t, s, k) + forcing_at(forcing, t, t_start, h)
    tm = t + 0.5 * dt
    fm = forcing_at(forcing, tm, t_start, h)
    _, k2t, _, _, k2w = rk4_stage(theta, st, ct, omega, 0.5 * dt, k1t, k1w, tm, s, k, fm)
    _, k3t, _, _, k3w = rk4_stage(theta, st, ct, omega, 0.5 * dt, k2t, k2w, tm, s, k, fm)
    _, k4t, _, _, k4w = rk4_stage(theta, st, ct, omega, dt, k3t, k3w, t + dt, s, k,
                                  forcing_at(forcing, t + dt, t_start, h))
    th_new = theta + dt * (k1t + 2.0 * k2t + 2.0 * k3t + k4t) / 6.0
    s_new, c_new = sin_cos_at(th_new, theta, st, ct)
    return th_new, omega + dt * (k1w + 2.0 * k2w + 2.0 * k3w + k4w) / 6.0, s_new, c_new


def locate_stop(theta, st, ct, omega, t, remaining, s, k, forcing, t_start, h, th1, w1, hs):  # noqa: ANN001, ANN201
    """The event within a step: ``(tau, theta(tau))`` with omega(tau) = 0 [s, rad].

    ``th1, w1``: :func:`rk4_step`'s result over the whole ``remaining`` length, where
    ``s * w1 < 0`` (omega changed sign). tau is the root of the RK4 step's omega in its length
    (Illinois regula falsi, to 1e-15 of the sub-step ``hs`` or of omega). Both RK4 kernels stop
    here, so the trajectory of the sensitivity kernel is the plain kernel's.
    """
    ta = 0.0
    fa = s * omega
    tb = remaining
    fb = s * w1
    tc = remaining
    thc = th1
    side = 0
    for _it in range(60):
        tc = (ta * fb - tb * fa) / (fb - fa)
        thc, wc, _, _ = rk4_step(theta, st, ct, omega, t, tc, s, k, forcing, t_start, h)
        fc = s * wc
        if fc > 0.0:
            ta = tc
            fa = fc
            if side == 1:
                fb *= 0.5
            side = 1
        elif fc < 0.0:
            tb = tc
            fb = fc
            if side == -1:
                fa *= 0.5
            side = -1
        else:
            break
        if tb - ta <= 1e-15 * hs or abs(fc) <= 1e-15:
            break
    return tc, thc


def sample_alpha(theta, st, omega, t, s, k, forcing, t_start, h):  # noqa: ANN001, ANN201
    """alpha [rad/s^2] at an output sample: 0 while stuck (``s == 0``), else the acceleration plus the forcing."""
    if s == 0.0:
        return 0.0
    return accel_terms(theta, st, omega, t, s, k) + forcing_at(forcing, t, t_start, h)


def start_outputs(theta, omega, t_start, c, kc, forcing, h, out_theta, out_omega, out_alpha):  # noqa: ANN001, ANN201
    """The first output sample of an RK4 kernel: ``(omega, sin theta, cos theta, s, want_alpha)``.

    ``s`` is the initial direction of motion (0: stuck, then ``omega`` = 0); sin and cos from libm;
    ``want_alpha``: ``out_alpha`` is to be written (length > 0).
    """
    st = math.sin(theta)  # sin, cos of theta: rotated through the sub-steps, from libm at every sample
    ct = math.cos(theta)
    s = direction(theta, omega, t_start, c, forcing_at(forcing, t_start, t_start, h))
    if s == 0.0:
        omega = 0.0
    out_theta[0] = theta
    out_omega[0] = omega
    want_alpha = out_alpha.shape[0] > 0
    if want_alpha:
        out_alpha[0] = sample_alpha(theta, st, omega, t_start, s, kc, forcing, t_start, h)
    return omega, st, ct, s, want_alpha


def restart_at_stop(theta, t, tc, remaining, c, forcing, t_start, h):  # noqa: ANN001, ANN201
    """After an event at ``t + tc`` (omega = 0 there): ``(theta, sin theta, cos theta, t, remaining, s)``,
    sin and cos from libm, ``s`` the new direction of motion (0: stuck)."""
    t = t + tc
    s = direction(theta, 0.0, t, c, forcing_at(forcing, t, t_start, h))
    return theta, math.sin(theta), math.cos(theta), t, remaining - tc, s


def rk_kernel_py(coeffs, n_steps, h, t_start, theta0, omega0, substeps, forcing,
                 out_theta, out_omega, out_alpha):  # noqa: ANN001, ANN201
    """RK4 with sgn-crossing events; fills ``out_*[0 .. n_steps]`` at t_start + i h.

    Parameters
    ----------
    coeffs : float64 array, packed model (no memory term)
    n_steps : int, number of output steps (outputs have n_steps + 1 samples)
    h : float, output step [s]; t_start : float, time of sample 0 [s]
    theta0, omega0 : float, initial state [rad], [rad/s]
    substeps : int >= 1, RK4 steps per output step
    forcing : float64 array, length 0 (none) or n_steps + 1 [rad/s^2], added to alpha
    out_theta, out_omega, out_alpha : float64 arrays of length >= n_steps + 1 (written); ``out_alpha``
        of length 0: the acceleration is not wanted (a fit's residuals; one evaluation a sample less)
    """
    c = coeffs
    kc = unpack(c)
    hs = h / substeps
    theta = theta0
    omega, st, ct, s, want_alpha = start_outputs(theta, omega0, t_start, c, kc, forcing, h, out_theta, out_omega,
                                                 out_alpha)
    for i in range(n_steps):
        for j in range(substeps):
            t = t_start + i * h + j * hs
            remaining = hs
            for _event in range(16):  # at most 16 direction changes within one sub-step
                if s == 0.0:
                    s = direction(theta, 0.0, t, c, forcing_at(forcing, t, t_start, h))
                    if s == 0.0:
                        break  # still stuck: theta, omega = 0 unchanged over this sub-step
                th1, w1, st1, ct1 = rk4_step(theta, st, ct, omega, t, remaining, s, kc, forcing, t_start, h)
                if s * w1 >= 0.0:
                    theta = th1
                    omega = w1
                    st = st1
                    ct = ct1
                    break
                # omega changes sign inside: stop where it is 0
                tc, thc = locate_stop(theta, st, ct, omega, t, remaining, s, kc, forcing, t_start, h, th1, w1, hs)
                omega = 0.0
                theta, st, ct, t, remaining, s = restart_at_stop(thc, t, tc, remaining, c, forcing, t_start, h)
                if remaining <= 0.0:
                    break
        ti = t_start + (i + 1) * h
        out_theta[i + 1] = theta
        out_omega[i + 1] = omega
        st = math.sin(theta)  # the rotations' rounding does not accumulate past a sample
        ct = math.cos(theta)
        if want_alpha:
            out_alpha[i + 1] = sample_alpha(theta, st, omega, ti, s, kc, forcing, t_start, h)
