"""The paper's predictor-corrector with the Grunwald-Letnikov memory: :func:`pc_kernel_py`.

Section "Solving fractional differential equations": Taylor predictor for theta, sin(theta),
omega and the memory function; Grunwald-Letnikov history sum; linear-acceleration corrector;
alpha re-evaluated once. One departure: the sgn friction terms (Coulomb, quadratic, power-law,
the quarter-power G1 term) enter the corrector as their exact mean over the step with omega
linear between the step's ends (:func:`~pendtrack.models.kernels.folds.friction_mean`), not as
values at the grid points: evaluated there they make the solution a kinked function of the
parameters wherever a turning point falls near a grid point (and drop the order to 1.6-2.5,
erratically); the mean keeps the solution C1 in the parameters and the scheme second order.
Two transcendental functions on the step-to-step dependency chain are replaced by updates of
the previous step's values, refreshed from libm every
:data:`~pendtrack.models.kernels.rotation.REFRESH_STEPS` steps: sin/cos of the corrected angle
by a rotation with short polynomials (:func:`~pendtrack.models.kernels.rotation.sin_cos_after`,
10 % less time), and the memory function's ``|x|^(p_f - 1)`` by ``y_i (x_(i+1)/x_i)^(p_f - 1)``
with a binomial series (:func:`memory_pair_next`; the ``pow`` call cost ~17 % of the step, and
neither computing it off the dependency chain at an extrapolated omega nor an inline
``exp(a ln x)`` was faster: a call saves and restores the loop's registers). Both give the
libm values to a few ulp (~1e-11 rad over 10^4 steps). Used at the data step for models with
memory.
"""

from __future__ import annotations

import math

import numpy as np

from pendtrack.models.gl import gl_weights
from pendtrack.models.kernels.folds import accel_smooth, friction_mean, friction_pair, unpack
from pendtrack.models.kernels.rotation import REFRESH_STEPS, SINCOS_STEP_MAX, sin_cos_after
from pendtrack.models.terms import K_BETA, K_MEM, K_MEM_U, K_PF, K_TSCALE

def memory_fn(omega, u, pf):  # noqa: ANN001, ANN201
    """g(omega) = x |x|^(pf - 1) with x = omega/u (the argument of the GL derivative)."""
    x = omega / u
    if x >= 0.0:
        return x ** pf
    return -((-x) ** pf)


def memory_pair(omega, inv_u, pf):  # noqa: ANN001, ANN201
    """``(g, dg/domega)`` of g(omega) = x |x|^(pf - 1), x = omega inv_u; dg = inf if pf < 1 at 0.

    One ``pow`` (``|x|^(pf-1)``) serves both, so the predictor needs no division.
    """
    x = omega * inv_u
    xa = abs(x)
    if xa > 0.0:
        y = xa ** (pf - 1.0)
        return x * y, pf * y * inv_u
    if pf > 1.0:
        return 0.0, 0.0
    if pf == 1.0:
        return 0.0, inv_u
    return 0.0, math.inf


POW_SERIES_DEGREE = 24  # degree of the binomial series that replaces pow between samples (series_ratio_pow is written out for it)
POW_SERIES_DELTA = 0.25  # largest |x_(i+1)/x_i - 1| it is used for


def binomial_series(a, out):  # noqa: ANN001, ANN201
    """Fill ``out[k] = C(a, k)``, k = 0..POW_SERIES_DEGREE; return the ``|d|`` up to which
    ``sum_k out[k] d^k`` gives ``(1 + d)^a`` to < 1e-17 relative (the first omitted term),
    at most POW_SERIES_DELTA."""
    b = 1.0
    out[0] = 1.0
    for k in range(1, POW_SERIES_DEGREE + 1):
        b = b * (a - (k - 1)) / k
        out[k] = b
    nxt = abs(b * (a - POW_SERIES_DEGREE) / (POW_SERIES_DEGREE + 1))
    dmax = POW_SERIES_DELTA
    if nxt * dmax ** (POW_SERIES_DEGREE + 1) > 1e-17:
        dmax = (1e-17 / nxt) ** (1.0 / (POW_SERIES_DEGREE + 1))
    return dmax


def series_ratio_pow(d, b):  # noqa: ANN001, ANN201
    """``(1 + d)^a = sum_k b[k] d^k`` (``b`` from :func:`binomial_series`) by Estrin's scheme:
    ~30 operations but only ~6 deep, so it costs the step's dependency chain ~a fifth of a ``pow``."""
    d2 = d * d
    d4 = d2 * d2
    d8 = d4 * d4
    d16 = d8 * d8
    q0 = (b[0] + b[1] * d) + (b[2] + b[3] * d) * d2
    q1 = (b[4] + b[5] * d) + (b[6] + b[7] * d) * d2
    q2 = (b[8] + b[9] * d) + (b[10] + b[11] * d) * d2
    q3 = (b[12] + b[13] * d) + (b[14] + b[15] * d) * d2
    q4 = (b[16] + b[17] * d) + (b[18] + b[19] * d) * d2
    q5 = (b[20] + b[21] * d) + (b[22] + b[23] * d) * d2
    return ((q0 + q1 * d4) + (q2 + q3 * d4) * d8) + ((q4 + q5 * d4) + b[24] * d8) * d16


def memory_pair_next(omega, inv_u, pf, r_prev, y_prev, b, dmax, fresh):  # noqa: ANN001, ANN201
    """:func:`memory_pair` plus ``(y, 1/x)``, with ``y = |x|^(pf-1)`` from the previous sample's.

    ``y = y_prev (x/x_prev)^(pf-1)`` by the binomial series (:func:`series_ratio_pow`) where
    ``|x r_prev - 1| <= dmax`` (``r_prev = 1/x_prev``) and ``fresh`` is False; else a libm
    ``pow``. The series' rounding (a few ulp a step) accumulates, so the kernel asks for a
    fresh ``pow`` every :data:`REFRESH_STEPS` steps.
    """
    x = omega * inv_u
    d = x * r_prev - 1.0
    if not fresh and abs(d) <= dmax:
        y = y_prev * series_ratio_pow(d, b)
        return x * y, pf * y * inv_u, y, 1.0 / x
    g, dg = memory_pair(omega, inv_u, pf)
    xa = abs(x)
    if xa > 0.0:
        return g, dg, g / x, 1.0 / x
    return g, dg, 0.0, math.inf


def gl_dot(a, ia, b, ib, n):  # noqa: ANN001, ANN201
    """``sum_{m<n} a[ia + m] b[ib + m]``: the Grunwald-Letnikov history sum.

    The numba version is compiled with ``fastmath`` (reassociation lets LLVM vectorise the
    reduction, ~5x faster); it then differs from this Python twin by rounding only
    (~1e-16 relative per sum).
    """
    x = a[ia:ia + n]  # views: indices provably in range, so the loop vectorises
    y = b[ib:ib + n]
    acc = 0.0
    for m in range(n):
        acc += x[m] * y[m]
    return acc


def pc_kernel_py(coeffs, n_steps, h, t_start, theta0, omega0, memory_steps, forcing,
                 out_theta, out_omega, out_alpha):  # noqa: ANN001, ANN201
    """The paper's predictor-corrector at step h; fills ``out_*[0 .. n_steps]``.

    Parameters
    ----------
    coeffs : float64 array, packed model (any terms)
    n_steps : int; h : float [s]; t_start : float [s]; theta0, omega0 : float [rad], [rad/s]
    memory_steps : int
        N >= 1: the GL sum runs over the last N steps (paper: N = 100), the unknown past
        (before sample 0) taken at the initial value g(omega0) -- "null acceleration on the
        whole unknown past". -1: full history with that constant past extending to minus
        infinity, i.e. ``D = h^-beta sum_{k<=i} W_k (g_{i-k} - g_0)`` (Caputo-like GL).
    forcing : float64 array, length 0 or n_steps + 1 [rad/s^2], added to alpha at samples
    out_theta, out_omega, out_alpha : float64 arrays of length >= n_steps + 1 (written)

    Notes
    -----
    Step i -> i+1: predictor ``theta = theta_i + (omega_i + alpha_i h/2) h``,
    ``sin = sin_i + (omega_i cos_i + (alpha_i cos_i - omega_i^2 sin_i) h/2) h``,
    ``omega = omega_i + alpha_i h``, ``g = g_i + (dg/domega)_i alpha_i h``; alpha from the
    model with ``D = (g + Sigma_{i+1}) / h*^beta``, ``Sigma_{i+1} = sum_{k=1}^{N} W_k g_{i+1-k}``;
    corrector ``theta = theta_i + (omega_i + (2 alpha_i + alpha) h/6) h``,
    ``omega = omega_i + (alpha_i + alpha) h/2``; alpha re-evaluated once (eq. predcorralpha).
    The sgn friction ``f(omega)`` is kept out of the alphas of the corrector: it adds ``q h``
    to omega and ``q h^2/2`` to theta, ``q = (F(omega_p) - F(omega_i)) / (omega_p - omega_i)``
    its mean over the step (F its antiderivative, omega_p the predicted omega); the predictor
    uses the previous step's ``q``. ``out_alpha`` holds the model's acceleration at the
    samples, friction included (``sgn(0) = +1``, eq. sgn).
    The history is stored padded with N copies of g_0 (the unknown past), and the weights
    reversed, so Sigma is one forward dot product.
    """
    c = coeffs
    kc = unpack(c)
    has_mem = c[K_MEM] != 0.0
    beta = c[K_BETA]
    u = c[K_MEM_U]
    pf = c[K_PF]
    inv_u = 1.0 / u
    kmem = c[K_MEM]
    full = memory_steps < 0
    nf = forcing.shape[0]
    theta = theta0
    omega = omega0
    st = math.sin(theta)
    ct = math.cos(theta)
    g0 = memory_fn(omega, u, pf) if has_mem else 0.0
    hb = (c[K_TSCALE] * h) ** (-beta)
    # weights: truncated -> wr[m] = W_{N-m}, m < N (history gp padded with N copies of g0);
    # full -> wr[m] = W_{n_steps-m}, history gd = g - g0 (no padding)
    n_w = n_steps if full else memory_steps
    if not has_mem:
        n_w = 0
    wr = gl_weights(beta, n_w)[::-1].copy()
    pad = 0 if (full or not has_mem) else memory_steps
    gp = np.empty(pad + n_steps + 1)
    for j in range(pad):
        gp[j] = g0
    gref = g0 if full else 0.0
    gp[pad] = g0 - gref
    # alpha_0 (sgn(0) = +1, eq. sgn); D_0 = h*^-beta g0 sum_{k=0}^{N} W_k for a truncated memory
    # alpha_r: every term but the sgn friction; D_0 = h*^-beta g0 sum_{k=0}^{N} W_k (truncated memory)
    alpha_r = accel_smooth(theta, st, omega, t_start, kc)
    if nf > 0:
        alpha_r += forcing[0]
    if has_mem and not full:
        alpha_r -= kmem * hb * (g0 + gl_dot(wr, 0, gp, 1, memory_steps))
    m_i, big_m_i = friction_pair(abs(omega), kc)
    out_theta[0] = theta
    out_omega[0] = omega
    out_alpha[0] = alpha_r - (m_i if omega >= 0.0 else -m_i)  # sgn(0) = +1 (eq. sgn)
    # the predictor's friction: the mean over the previous step (here: over a friction-free first guess)
    om_g = omega + alpha_r * h
    m_g, big_m_g = friction_pair(abs(om_g), kc)
    q_prev = friction_mean(omega, om_g, m_i, big_m_i, m_g, big_m_g)
    gi, dgi = memory_pair(omega, inv_u, pf)
    khb = kmem * hb
    h2 = 0.5 * h
    h6 = h / 6.0
    hh2 = h * h2
    # The loop is latency-bound: each step waits for the last. Expressions are ordered (no
    # reassociation is allowed) so that the values computed last -- the memory function's pow
    # at the corrected omega, the friction's roots at the predicted one -- enter with one
    # operation each; everything else is prepared beside them.
    om_base = omega + q_prev * h
    # |x|^(pf-1) and 1/x at the current sample, x = omega/u (the memory function's pow)
    bser = np.empty(POW_SERIES_DEGREE + 1)
    dmax = binomial_series(pf - 1.0, bser)
    y_i = 0.0
    r_i = math.inf
    if has_mem and omega != 0.0:
        y_i = abs(omega * inv_u) ** (pf - 1.0)
        r_i = 1.0 / (omega * inv_u)
    for i in range(n_steps):
        t1 = t_start + (i + 1) * h
        f1 = forcing[i + 1] if nf > 0 else 0.0
        sigma = 0.0
        if has_mem:
            # the k = 1 term (the newest g) is added last, so that the long sum over the older
            # history does not wait for it (it is off the step-to-step dependency chain)
            if full:  # sum_{k=1}^{i+1} W_k (g_{i+1-k} - g0) = sum_{j<=i} wr[n_steps-i-1+j] gd_j
                sigma = gl_dot(wr, n_steps - i - 1, gp, 0, i) + wr[n_steps - 1] * gp[i]
            else:  # sum_{k=1}^{N} W_k g_{i+1-k} = sum_{m<N} wr[m] gp[i+1+m]
                sigma = gl_dot(wr, 0, gp, i + 1, memory_steps - 1) + wr[memory_steps - 1] * gp[i + memory_steps]
        # predictor (Taylor), with the friction at its mean over the previous step
        alpha = alpha_r + q_prev
        th_p = theta + (omega + alpha * h2) * h
        st_p = st + (omega * ct + (alpha * ct - omega * omega * st) * h2) * h
        om_p = om_base + alpha_r * h  # = omega + alpha h
        a_p = accel_smooth(th_p, st_p, om_p, t1, kc) + f1
        if has_mem:
            if math.isinf(dgi):  # pf < 1 at omega = 0: dg/domega infinite, evaluate g at the predicted omega
                a_p -= khb * (memory_fn(om_p, u, pf) - gref + sigma)
            else:  # g_p = g_i + (dg/domega)_i alpha h
                a_p -= khb * (gi - gref + sigma) + (khb * dgi * h) * alpha
        # corrector (linear acceleration); the friction enters as its exact mean over the step
        # with omega linear from omega_i to the predicted omega, which keeps the solution smooth
        # in the parameters when omega changes sign between grid points
        m_p, big_m_p = friction_pair(abs(om_p), kc)
        q = friction_mean(omega, om_p, m_i, big_m_i, m_p, big_m_p)
        th_c = theta + (omega + (2.0 * alpha_r + a_p) * h6) * h + q * hh2
        om_c = omega + (alpha_r + a_p) * h2 + q * h
        # then alpha re-evaluated once
        d_th = th_c - theta
        refresh = (i + 1) % REFRESH_STEPS == 0
        if not refresh and abs(d_th) <= SINCOS_STEP_MAX:
            st, ct = sin_cos_after(st, ct, d_th)
        else:
            st = math.sin(th_c)
            ct = math.cos(th_c)
        a_c = accel_smooth(th_c, st, om_c, t1, kc) + f1
        if has_mem:
            a_c -= khb * (sigma - gref)
            gi, dgi, y_i, r_i = memory_pair_next(om_c, inv_u, pf, r_i, y_i, bser, dmax, refresh)
            gp[pad + i + 1] = gi - gref
            a_c -= khb * gi
        m_i, big_m_i = friction_pair(abs(om_c), kc)
        theta = th_c
        omega = om_c
        alpha_r = a_c
        q_prev = q
        om_base = om_c + q * h
        out_theta[i + 1] = theta
        out_omega[i + 1] = omega
        out_alpha[i + 1] = a_c - (m_i if om_c >= 0.0 else -m_i)
