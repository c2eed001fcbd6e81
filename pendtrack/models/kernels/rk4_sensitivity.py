"""RK4 with the forward sensitivities: :func:`rk_sens_kernel_py`, :func:`rk4_sens_step`.

The trajectory is :func:`~pendtrack.models.kernels.rk4.rk_kernel_py`'s (same arithmetic, same
events, the same event locator); beside it every RK4 step is differentiated, with the
acceleration's partials folded from the terms' declared ``dfn``
(:func:`~pendtrack.models.kernels.folds.grad_smooth`).
"""

from __future__ import annotations

import math

import numpy as np

from pendtrack.models.kernels.folds import (
    _SCATTER, accel_terms, direction, forcing_at, grad_friction, grad_smooth, unpack,
)
from pendtrack.models.kernels.rk4 import locate_stop, restart_at_stop, rk4_stage, sample_alpha, start_outputs
from pendtrack.models.kernels.rotation import sin_cos_at

def accel_grad(theta, st, ct, omega, t, s, k, kn, slot_index, dcoeffs, g, dca):  # noqa: ANN001, ANN201
    """Partials of the memory-free acceleration at one point with the sgn terms at direction s.

    ``st, ct = sin(theta), cos(theta)``; ``kn``: 1 at the differentiated slots (:func:`grad_smooth`). Returns
    ``(d alpha/d theta, d alpha/d omega)``; writes ``g[j] = sum_u (d alpha/d c_u) (d c_u/d p_j)``
    over the slots ``slot_index`` (``dcoeffs[u, j]``, from
    :meth:`~pendtrack.models.declare.Layout.pack_jacobian`); ``dca``: scratch of length N_COEFFS,
    0 at the slots without a formula. At ``omega == 0`` exactly the
    friction's omega-derivative (infinite for a sub-linear friction) is taken as 0: the
    sensitivity kernel evaluates there only at the start of a segment pinned to omega = 0 by
    an event, where the omega-sensitivity is 0 by construction (:func:`rk_sens_kernel_py`).
    """
    a_th, a_om, dcs = grad_smooth(theta, st, ct, omega, t, k, kn)
    dmw, dcf = grad_friction(abs(omega), k, kn)
    if omega != 0.0:
        a_om = a_om - dmw
    _SCATTER(dcs, dcf, s, dca)
    for j in range(g.shape[0]):
        g[j] = 0.0
    for u in range(slot_index.shape[0]):
        v = dca[slot_index[u]]
        for j in range(g.shape[0]):
            g[j] += v * dcoeffs[u, j]
    return a_th, a_om


def rk4_sens_step(theta, st, ct, omega, t, dt, s, k, forcing, t_start, h, sth, som, out_sth, out_som,
                  kn, slot_index, dcoeffs, g, w, dca):  # noqa: ANN001, ANN201
    """:func:`rk4_step` (same arithmetic, same rotated sines) and the derivative of its result by the parameters.

    ``sth, som`` [rad/p, rad/s/p]: d theta/d p_j, d omega/d p_j at the start; the step's
    derivatives (the RK4 stages differentiated, i.e. RK4 on the variational equations, exact
    for the discrete map at fixed dt) go to ``out_sth, out_som`` (may alias ``sth, som``).
    ``w``: scratch, shape ``(4, P)``; ``dca``: :func:`accel_grad`'s. Returns ``(theta, omega, sin theta, cos theta)`` after the step.
    """
    n_p = sth.shape[0]
    k1t = omega
    k1w = accel_terms(theta, st, omega, t, s, k) + forcing_at(forcing, t, t_start, h)
    a_th, a_om = accel_grad(theta, st, ct, omega, t, s, k, kn, slot_index, dcoeffs, g, dca)
    for j in range(n_p):  # w[0]: dk1t = som, w[1]: dk1w; w[2], w[3]: the next stage's state derivatives
        w[0, j] = a_th * sth[j] + a_om * som[j] + g[j]  # dk1w
    tm = t + 0.5 * dt
    fm = forcing_at(forcing, tm, t_start, h)
    th2, w2, s2, c2, k2w = rk4_stage(theta, st, ct, omega, 0.5 * dt, k1t, k1w, tm, s, k, fm)
    k2t = w2
    a_th, a_om = accel_grad(th2, s2, c2, w2, tm, s, k, kn, slot_index, dcoeffs, g, dca)
    for j in range(n_p):
        d_th2 = sth[j] + 0.5 * dt * som[j]
        d_w2 = som[j] + 0.5 * dt * w[0, j]
        w[1, j] = d_w2  # dk2t
        w[2, j] = a_th * d_th2 + a_om * d_w2 + g[j]  # dk2w
    th3, w3, s3, c3, k3w = rk4_stage(theta, st, ct, omega, 0.5 * dt, k2t, k2w, tm, s, k, fm)
    k3t = w3
    a_th, a_om = accel_grad(th3, s3, c3, w3, tm, s, k, kn, slot_index, dcoeffs, g, dca)
    for j in range(n_p):
        d_th3 = sth[j] + 0.5 * dt * w[1, j]
        d_w3 = som[j] + 0.5 * dt * w[2, j]
        dk3w = a_th * d_th3 + a_om * d_w3 + g[j]
        # accumulate the weighted sums in place: w[0] <- dk1w + 2 dk2w + 2 dk3w, w[1] <- dk1t + 2 dk2t + 2 dk3t
        w[0, j] = w[0, j] + 2.0 * w[2, j] + 2.0 * dk3w
        w[1, j] = som[j] + 2.0 * w[1, j] + 2.0 * d_w3
        w[2, j] = d_w3  # dk3t
        w[3, j] = dk3w
    th4, w4, s4, c4, k4w = rk4_stage(theta, st, ct, omega, dt, k3t, k3w, t + dt, s, k,
                                     forcing_at(forcing, t + dt, t_start, h))
    k4t = w4
    a_th, a_om = accel_grad(th4, s4, c4, w4, t + dt, s, k, kn, slot_index, dcoeffs, g, dca)
    for j in range(n_p):
        d_th4 = sth[j] + dt * w[2, j]
        d_w4 = som[j] + dt * w[3, j]
        dk4w = a_th * d_th4 + a_om * d_w4 + g[j]
        new_th = sth[j] + dt * (w[1, j] + d_w4) / 6.0
        new_om = som[j] + dt * (w[0, j] + dk4w) / 6.0
        out_sth[j] = new_th
        out_som[j] = new_om
    th_new = theta + dt * (k1t + 2.0 * k2t + 2.0 * k3t + k4t) / 6.0
    s_new, c_new = sin_cos_at(th_new, theta, st, ct)
    return th_new, omega + dt * (k1w + 2.0 * k2w + 2.0 * k3w + k4w) / 6.0, s_new, c_new


def rk4_length_derivative(theta, omega, t, dt, s, k, forcing, t_start, h, kn, slot_index, dcoeffs, g, dca):  # noqa: ANN001, ANN201
    """``(d theta, d omega)`` of :func:`rk4_step`'s result by its step length ``dt``, the start state fixed.

    The stages differentiated by dt (the right-hand side's explicit time-dependence, the
    ``C4/(t - t0)`` term's and the forcing's, is neglected). It replaces the exact flow's
    ``f(end)`` at the events: with a sub-linear friction (``|omega|^p``, p < 1; the quarter-power
    term) the RK4 step that leaves omega = 0 differs from the flow by far more than its usual
    O(dt^5) (the friction's omega-derivative is singular there), and its own derivative is
    what the discrete solution has (``f(end)`` instead was 15 % off in the Jacobian, measured).
    """
    k1t = omega
    s1 = math.sin(theta)
    k1w = accel_terms(theta, s1, omega, t, s, k) + forcing_at(forcing, t, t_start, h)
    th2 = theta + 0.5 * dt * k1t
    w2 = omega + 0.5 * dt * k1w
    tm = t + 0.5 * dt
    fm = forcing_at(forcing, tm, t_start, h)
    k2t = w2
    s2 = math.sin(th2)
    k2w = accel_terms(th2, s2, w2, tm, s, k) + fm
    d_th2 = 0.5 * k1t
    d_w2 = 0.5 * k1w
    a_th, a_om = accel_grad(th2, s2, math.cos(th2), w2, tm, s, k, kn, slot_index, dcoeffs, g, dca)
    d_k2t = d_w2
    d_k2w = a_th * d_th2 + a_om * d_w2
    th3 = theta + 0.5 * dt * k2t
    w3 = omega + 0.5 * dt * k2w
    k3t = w3
    s3 = math.sin(th3)
    k3w = accel_terms(th3, s3, w3, tm, s, k) + fm
    d_th3 = 0.5 * k2t + 0.5 * dt * d_k2t
    d_w3 = 0.5 * k2w + 0.5 * dt * d_k2w
    a_th, a_om = accel_grad(th3, s3, math.cos(th3), w3, tm, s, k, kn, slot_index, dcoeffs, g, dca)
    d_k3t = d_w3
    d_k3w = a_th * d_th3 + a_om * d_w3
    th4 = theta + dt * k3t
    w4 = omega + dt * k3w
    k4t = w4
    s4 = math.sin(th4)
    k4w = accel_terms(th4, s4, w4, t + dt, s, k) + forcing_at(forcing, t + dt, t_start, h)
    d_th4 = k3t + dt * d_k3t
    d_w4 = k3w + dt * d_k3w
    a_th, a_om = accel_grad(th4, s4, math.cos(th4), w4, t + dt, s, k, kn, slot_index, dcoeffs, g, dca)
    d_k4t = d_w4
    d_k4w = a_th * d_th4 + a_om * d_w4
    return ((k1t + 2.0 * k2t + 2.0 * k3t + k4t) / 6.0 + dt * (2.0 * d_k2t + 2.0 * d_k3t + d_k4t) / 6.0,
            (k1w + 2.0 * k2w + 2.0 * k3w + k4w) / 6.0 + dt * (2.0 * d_k2w + 2.0 * d_k3w + d_k4w) / 6.0)


def rk_sens_kernel_py(coeffs, slot_index, dcoeffs, n_steps, h, t_start, theta0, omega0, substeps, forcing,
                      dtheta0, domega0, out_theta, out_omega, out_alpha, out_dtheta, out_domega):  # noqa: ANN001, ANN201
    """:func:`rk_kernel_py` plus the forward sensitivities d theta/d p_j, d omega/d p_j.

    The trajectory is computed by the same arithmetic as :func:`rk_kernel_py` (same sub-steps,
    same events); beside it every RK4 step is differentiated (the stages' derivatives: the
    exact derivative of the discrete step), with the acceleration's partials folded from the
    declared ``dfn`` of the terms (:func:`accel_grad`).

    Parameters
    ----------
    coeffs : float64 array, packed model (no memory term)
    slot_index : int64 array (U,), the slots whose derivatives by the parameters are not all 0
    dcoeffs : float64 array (U, P), ``d coeffs[slot_index[u]] / d p_j`` (:meth:`Layout.pack_jacobian`)
    n_steps, h, t_start, theta0, omega0, substeps, forcing : as :func:`rk_kernel_py`
    dtheta0, domega0 : float64 arrays (P,), derivatives of the initial state by the parameters
        (a unit vector for the columns of theta0 and omega0, else 0)
    out_theta, out_omega, out_alpha : float64 arrays (>= n_steps + 1,; ``out_alpha`` may be empty), as :func:`rk_kernel_py`
    out_dtheta, out_domega : float64 arrays (>= n_steps + 1, P) [rad / p_j], [rad/s / p_j]

    Notes
    -----
    **Events** (omega changes sign within a sub-step at tau). The state there is pinned,
    ``omega(tau) = 0``, and tau depends on the parameters: ``d tau/dp = -S_omega^- / E_omega``
    (``S_omega^-`` the omega-sensitivity of the RK4 step of length tau, ``E_omega`` the
    derivative of that step's omega by its length, :func:`rk4_length_derivative`; ``S_theta``
    gets ``E_theta d tau/dp``). The segment after it starts from ``(theta(tau), 0)`` with the
    sensitivities ``(S_theta, 0)`` and remembers ``d tau/dp``; a later event in the segment adds
    it to its own time; at the sub-step's end the segment is shorter by ``d tau/dp``:
    ``S -= E(end) d tau/dp`` with the step-length derivative of the segment's step. For the exact
    flow ``E = f = (omega, alpha)``, and this is the classical jump ``S_omega^+ = S_omega^-
    alpha^+/alpha^-`` of sensitivities at a switching surface (with Coulomb friction
    ``alpha^+ != alpha^-``, so it matters); the discrete step's own E keeps the result the exact
    derivative of the discrete solution, and the friction's omega-derivative (infinite at
    omega = 0 for a sub-linear friction) is never multiplied by a non-zero sensitivity: at a
    pinned start :func:`accel_grad` sets it to 0, and the sensitivity it multiplies is 0. The
    right-hand side's explicit time-dependence (the ``C4/(t - t0)`` term, a forcing) is left
    out of E (measured: classic plus that term, t - t0 >= 5 s, within 1e-6 of central
    differences). A pendulum that sticks (static friction holds it) keeps ``S_omega = 0`` and a
    constant ``S_theta``; unsticking (only with a time-dependent forcing) is not differentiated.
    At ``omega0 = 0`` exactly the solution is not differentiable in
    ``omega0`` (the initial direction switches); the kernel then gives one side's derivative.
    """
    c = coeffs
    kc = unpack(c)
    n_p = dtheta0.shape[0]
    need = np.zeros(c.shape[0])  # 1 at the differentiated slots (grad_smooth: amplitudes at 0 still differentiated)
    for u in range(slot_index.shape[0]):
        need[slot_index[u]] = 1.0
    kn = unpack(need)
    g = np.zeros(n_p)
    w = np.zeros((4, n_p))
    dca = np.zeros(c.shape[0])  # d alpha/d c by slot (accel_grad's scratch)
    sth = dtheta0.copy()
    som = domega0.copy()
    delta = np.zeros(n_p)  # d(start time of the current segment)/dp, when it starts pinned at an event
    hs = h / substeps
    theta = theta0
    omega, st, ct, s, want_alpha = start_outputs(theta, omega0, t_start, c, kc, forcing, h, out_theta, out_omega,
                                                 out_alpha)
    if s == 0.0:  # stuck at the start: omega = 0 whatever the parameters
        for j in range(n_p):
            som[j] = 0.0
    for j in range(n_p):
        out_dtheta[0, j] = sth[j]
        out_domega[0, j] = som[j]
    for i in range(n_steps):
        for jj in range(substeps):
            t = t_start + i * h + jj * hs
            t_end = t + hs
            remaining = hs
            shifted = False
            for _event in range(16):  # at most 16 direction changes within one sub-step
                if s == 0.0:
                    s = direction(theta, 0.0, t, c, forcing_at(forcing, t, t_start, h))
                    if s == 0.0:
                        shifted = False
                        for j in range(n_p):
                            som[j] = 0.0
                        break  # still stuck: theta, omega = 0 unchanged over this sub-step
                th1, w1, st1, ct1 = rk4_sens_step(theta, st, ct, omega, t, remaining, s, kc, forcing, t_start, h,
                                                  sth, som, out_dtheta[i + 1], out_domega[i + 1], kn, slot_index,
                                                  dcoeffs, g, w, dca)
                if s * w1 >= 0.0:
                    if shifted:  # this segment started at an event: its start time (and length) move with p
                        e_th, e_om = rk4_length_derivative(theta, omega, t, remaining, s, kc, forcing, t_start, h,
                                                           kn, slot_index, dcoeffs, g, dca)
                    theta = th1
                    omega = w1
                    st = st1
                    ct = ct1
                    for j in range(n_p):
                        sth[j] = out_dtheta[i + 1, j]
                        som[j] = out_domega[i + 1, j]
                        if shifted:  # the segment is shorter by d(start)/dp
                            sth[j] -= e_th * delta[j]
                            som[j] -= e_om * delta[j]
                    shifted = False
                    break
                # omega changes sign inside: stop where it is 0
                tc, thc = locate_stop(theta, st, ct, omega, t, remaining, s, kc, forcing, t_start, h, th1, w1, hs)
                # the sensitivities at the event: the step to tau at fixed length, then tau's own
                # dependence, d tau/dp = -S_omega / (d omega_end/d dt); the event's time moves by
                # that plus the segment's start shift (the step's start time does not enter an
                # autonomous step)
                rk4_sens_step(theta, st, ct, omega, t, tc, s, kc, forcing, t_start, h, sth, som, sth, som,
                              kn, slot_index, dcoeffs, g, w, dca)
                e_th, e_om = rk4_length_derivative(theta, omega, t, tc, s, kc, forcing, t_start, h,
                                                   kn, slot_index, dcoeffs, g, dca)
                for j in range(n_p):
                    dtau = -som[j] / e_om if e_om != 0.0 else 0.0
                    sth[j] += e_th * dtau
                    delta[j] = (delta[j] + dtau) if shifted else dtau
                    som[j] = 0.0
                shifted = True
                omega = 0.0
                theta, st, ct, t, remaining, s = restart_at_stop(thc, t, tc, remaining, c, forcing, t_start, h)
                if remaining <= 0.0:
                    break
            if shifted:  # an event at the sub-step's very end (or 16 of them): the pinned state's shift
                if s != 0.0:
                    e_th, e_om = rk4_length_derivative(theta, omega, t, max(t_end - t, 0.0), s, kc, forcing,
                                                       t_start, h, kn, slot_index, dcoeffs, g, dca)
                    for j in range(n_p):
                        sth[j] -= e_th * delta[j]
                        som[j] -= e_om * delta[j]
                else:
                    for j in range(n_p):
                        som[j] = 0.0
        ti = t_start + (i + 1) * h
        out_theta[i + 1] = theta
        out_omega[i + 1] = omega
        st = math.sin(theta)
        ct = math.cos(theta)
        for j in range(n_p):
            out_dtheta[i + 1, j] = sth[j]
            out_domega[i + 1, j] = som[j]
        if want_alpha:
            out_alpha[i + 1] = sample_alpha(theta, st, omega, ti, s, kc, forcing, t_start, h)
