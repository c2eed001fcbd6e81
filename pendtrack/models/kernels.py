"""The solver kernels: plain arrays and scalars in, preallocated arrays out.

(A third, :func:`rk_sens_kernel_py` / :func:`rk_sens_kernel_nb`, is :func:`rk_kernel_py` with
the forward sensitivities, its partials folded from the terms' declared ``dfn``.)

Two kernels, each a pure-Python function (``*_py``) that numba compiles unchanged on first
use (``*_nb`` via :func:`pc_kernel_nb` / :func:`rk_kernel_nb`, ``@njit(cache=True)``);
nothing is compiled or even imported from numba at import time. Both read the packed
coefficient vector of :mod:`pendtrack.models.terms`, so one kernel serves every
composition of terms. No term is written here: the per-step functions
:func:`accel_smooth` and :func:`friction_pair` are folds of the formulas declared in
:mod:`pendtrack.models.terms` (built once at import as plain closures; numba compiles them
into the kernels, LLVM inlines them), and the same folds evaluate the vectorised
right-hand side (:mod:`pendtrack.models.rhs`). numba keys its cache on this file only, so
the kernels are compiled behind a closure holding :func:`declarations_stamp`: a changed or
added declaration recompiles them instead of loading a stale kernel.

``pc_kernel_py`` -- the paper's predictor-corrector (section "Solving fractional
differential equations"): Taylor predictor for theta, sin(theta), omega and the memory
function; Grunwald-Letnikov history sum; linear-acceleration corrector; alpha re-evaluated
once. One departure: the sgn friction terms (Coulomb, quadratic, power-law, the quarter-power
G1 term) enter the corrector as their exact mean over the step with omega linear between
the step's ends, not as values at the grid points. Evaluated at the grid points they make
the solution a kinked function of the parameters wherever a turning point falls near a
grid point (and drop the order to 1.6-2.5, erratically); the mean keeps the solution C1 in
the parameters and the scheme second order. Two transcendental functions on the
step-to-step dependency chain are replaced by updates of the previous step's values,
refreshed from libm every :data:`REFRESH_STEPS` steps: sin/cos of the corrected angle by a
rotation with short polynomials (:func:`sin_cos_after`, 10 % less time), and the memory
function's ``|x|^(p_f - 1)`` by ``y_i (x_(i+1)/x_i)^(p_f - 1)`` with a binomial series
(:func:`memory_pair_next`; the ``pow`` call cost ~17 % of the step, and neither computing it
off the dependency chain at an extrapolated omega nor an inline ``exp(a ln x)`` was faster:
a call saves and restores the loop's registers). Both give the libm values to a few ulp
(~1e-11 rad over 10^4 steps). Used at the data step for models with memory.

``rk_kernel_py`` -- classical RK4 with ``substeps`` sub-steps per output step for models
without memory. The ``sgn(omega)`` discontinuity is handled as an event: within a
sub-step where omega changes sign the crossing is located (regula falsi on the RK4 step
length), the step is finished from there with the new direction of motion. At omega = 0
the direction is the one the forces push towards; if static friction exceeds them
(``accel(+1) <= 0 <= accel(-1)``) the pendulum sticks (omega = alpha = 0) until they do.
The stages' sin(theta) are rotations of the sub-step's start value (:func:`sin_cos_at`), which
is itself rotated from the sub-step before and taken from libm at every output sample and
after every event: one libm sin/cos pair per sample instead of a sin per stage (the sensitivity
kernel, which needs cos too, the same), a few ulp from libm's values.

Compilation (:func:`_compile`, ~8 s of CPU): ``error_model="numpy"`` and ``fastmath`` limited to
``contract``/``arcp`` (fused multiply-add, reciprocal division) for the kernels, full
``fastmath`` only for the GL dot product (vectorised reduction). The numba kernels
therefore agree with their Python twins to rounding (~1e-13 rad over 600 steps), not
bit for bit. The compilation is cached (``cache=True``).
"""

from __future__ import annotations

import math

import numpy as np

from pendtrack.models import terms as T
from pendtrack.models.declare import Term
from pendtrack.models.gl import gl_weights
from pendtrack.models.terms import K_BETA, K_HAS_MEMORY, K_MEM, K_MEM_U, K_PF, K_TSCALE, empty_coeffs

# --- the per-step functions, folded from the term declarations (pendtrack.models.terms) ----
# Each fold level is a small closure over one declared formula and its slot range; numba
# inlines every level (register_jitable(inline="always")), so the compiled step is the same
# straight-line code as if it were written out. Every fold works on floats and on arrays.


def unpack(c):  # noqa: ANN001, ANN201
    """The packed coefficients as a tuple (kept in registers by numba; ``c[lo:hi]`` of it is static)."""
    return tuple(c.tolist())


def _smooth_seed(fn, lo, hi):  # noqa: ANN001, ANN202
    def accel(theta, sin_theta, omega, t, k):  # noqa: ANN001, ANN202
        return fn(theta, sin_theta, omega, t, k[lo:hi])
    return accel


def _smooth_add(rest, fn, lo, hi, always=False):  # noqa: ANN001, ANN202
    if always:
        def accel_always(theta, sin_theta, omega, t, k):  # noqa: ANN001, ANN202
            return rest(theta, sin_theta, omega, t, k) + fn(theta, sin_theta, omega, t, k[lo:hi])
        return accel_always

    def accel(theta, sin_theta, omega, t, k):  # noqa: ANN001, ANN202
        a = rest(theta, sin_theta, omega, t, k)
        if k[lo] != 0.0:  # absent term
            a = a + fn(theta, sin_theta, omega, t, k[lo:hi])
        return a
    return accel


def _friction_seed(w, k):  # noqa: ANN001, ANN202
    return 0.0, 0.0


def _friction_add(rest, fn, lo, hi, always=False):  # noqa: ANN001, ANN202
    if always:
        def pair_always(w, k):  # noqa: ANN001, ANN202
            m, big_m = rest(w, k)
            m1, big_m1 = fn(w, k[lo:hi])
            return m + m1, big_m + big_m1
        return pair_always

    def pair(w, k):  # noqa: ANN001, ANN202
        m, big_m = rest(w, k)
        if k[lo] != 0.0:  # absent term
            m1, big_m1 = fn(w, k[lo:hi])
            m = m + m1
            big_m = big_m + big_m1
        return m, big_m
    return pair


def _fold(terms: tuple[Term, ...]) -> tuple[object, object, tuple[object, ...]]:
    """``(accel_smooth, friction_pair, every function made)`` from the declarations."""
    lay = T.LAYOUT
    made: list[object] = []
    smooth = _smooth_seed(lay.base.fn, *lay.span(lay.base))
    made.append(smooth)
    friction = _friction_seed
    for term in terms:
        if term.fn is None:  # acts through another term's slots, or the memory term
            continue
        if term.kind == "smooth":
            smooth = _smooth_add(smooth, term.fn, *lay.span(term), always=term.always)
            made.append(smooth)
        elif term.kind == "friction":
            friction = _friction_add(friction, term.fn, *lay.span(term), always=term.always)
            made.append(friction)
    return smooth, friction, tuple(made)


_ACCEL_SMOOTH, _FRICTION_PAIR, _FOLDED = _fold(tuple(T.TERMS.values()))


# --- their partial derivatives, folded from the declared Term.dfn the same way ------------
# grad_smooth(theta, st, ct, omega, t, k, kn) -> (d alpha_smooth/d theta, d alpha_smooth/d omega,
# dcs) with dcs the tuple of d alpha/d c over the smooth slots (in GRAD_SLOTS order);
# grad_friction(w, k, kn) -> (sum of dm/dw, dcf) with dcf the tuple of dm/dc over the friction
# slots. Tuples, not an output array: the folds then pass only scalars, as the value folds do.
# A term whose first slot is 0 (absent, unless ``always``) adds nothing to the theta/omega
# partials and is not evaluated (its slot derivatives are 0) -- unless ``kn[lo]`` is non-zero
# (``kn``: 1 at the differentiated slots): at C3 = 0 the derivative by C3 is not 0, and a fit may
# sit on that bound. Its other slots' derivatives are then 0 as given, every term's
# contribution being proportional to its first slot (pendtrack.models.declare).

def _grad_smooth_add(rest, dfn, lo, hi, always=False):  # noqa: ANN001, ANN202
    zeros = (0.0,) * (hi - lo)
    if rest is None:
        def grad_first(theta, sin_theta, cos_theta, omega, t, k, kn):  # noqa: ANN001, ANN202
            return dfn(theta, sin_theta, cos_theta, omega, t, k[lo:hi])
        return grad_first
    if always:
        def grad_always(theta, sin_theta, cos_theta, omega, t, k, kn):  # noqa: ANN001, ANN202
            a_th, a_om, dcs = rest(theta, sin_theta, cos_theta, omega, t, k, kn)
            d_th, d_om, dc = dfn(theta, sin_theta, cos_theta, omega, t, k[lo:hi])
            return a_th + d_th, a_om + d_om, dcs + dc
        return grad_always

    def grad(theta, sin_theta, cos_theta, omega, t, k, kn):  # noqa: ANN001, ANN202
        a_th, a_om, dcs = rest(theta, sin_theta, cos_theta, omega, t, k, kn)
        dc = zeros
        if k[lo] != 0.0 or kn[lo] != 0.0:
            d_th, d_om, dc = dfn(theta, sin_theta, cos_theta, omega, t, k[lo:hi])
            if k[lo] != 0.0:
                a_th = a_th + d_th
                a_om = a_om + d_om
        return a_th, a_om, dcs + dc
    return grad


def _grad_friction_add(rest, dfn, lo, hi, always=False):  # noqa: ANN001, ANN202
    zeros = (0.0,) * (hi - lo)
    if rest is None and always:
        def grad_first(w, k, kn):  # noqa: ANN001, ANN202
            return dfn(w, k[lo:hi])
        return grad_first
    if always:
        def grad_always(w, k, kn):  # noqa: ANN001, ANN202
            dm, dcf = rest(w, k, kn)
            d_w, dc = dfn(w, k[lo:hi])
            return dm + d_w, dcf + dc
        return grad_always

    def grad(w, k, kn):  # noqa: ANN001, ANN202
        dm, dcf = rest(w, k, kn)
        dc = zeros
        if k[lo] != 0.0 or kn[lo] != 0.0:
            d_w, dc = dfn(w, k[lo:hi])
            if k[lo] != 0.0:
                dm = dm + d_w
        return dm, dcf + dc
    return grad


def _fold_grad(terms: tuple[Term, ...]) -> tuple[object, object, tuple[object, ...], tuple[int, ...], tuple[int, ...]]:
    """``(grad_smooth, grad_friction, every function made, smooth slots, friction slots)``
    from the declarations' ``dfn``; the slot tuples give the order of ``dcs`` and ``dcf``."""
    lay = T.LAYOUT
    made: list[object] = []
    smooth = _grad_smooth_add(None, lay.base.dfn, *lay.span(lay.base), always=True)
    made.append(smooth)
    slots_s = list(range(*lay.span(lay.base)))
    friction = None
    slots_f: list[int] = []
    ordered = sorted((t for t in terms if t.dfn is not None and t.kind == "friction"), key=lambda t: not t.always)
    for term in (*(t for t in terms if t.dfn is not None and t.kind == "smooth"), *ordered):
        if term.kind == "smooth":
            smooth = _grad_smooth_add(smooth, term.dfn, *lay.span(term), always=term.always)
            made.append(smooth)
            slots_s.extend(range(*lay.span(term)))
        else:  # the first friction term must be an ``always`` one (it starts the tuple): sorted so
            friction = _grad_friction_add(friction, term.dfn, *lay.span(term), always=term.always)
            made.append(friction)
            slots_f.extend(range(*lay.span(term)))
    return smooth, friction, tuple(made), tuple(slots_s), tuple(slots_f)


_GRAD_SMOOTH, _GRAD_FRICTION, _GRAD_FOLDED, GRAD_SLOTS_SMOOTH, GRAD_SLOTS_FRICTION = _fold_grad(tuple(T.TERMS.values()))


def _scatter_seed(dcs, dcf, s, out):  # noqa: ANN001, ANN202
    pass


def _scatter_smooth(rest, pos, slot):  # noqa: ANN001, ANN202
    def scatter(dcs, dcf, s, out):  # noqa: ANN001, ANN202
        rest(dcs, dcf, s, out)
        out[slot] = dcs[pos]
    return scatter


def _scatter_friction(rest, pos, slot):  # noqa: ANN001, ANN202
    def scatter(dcs, dcf, s, out):  # noqa: ANN001, ANN202
        rest(dcs, dcf, s, out)
        out[slot] = -s * dcf[pos]
    return scatter


def _fold_scatter() -> tuple[object, tuple[object, ...]]:
    """``(scatter, every function made)``: ``scatter(dcs, dcf, s, out)`` writes each slot's
    d alpha/d c into ``out[slot]`` (a friction slot's as ``-s dm/dc``), every tuple position a
    constant (a tuple indexed at run time cost ~30 ns a stage, measured)."""
    made: list[object] = [_scatter_seed]
    scatter = _scatter_seed
    for pos, slot in enumerate(GRAD_SLOTS_SMOOTH):
        scatter = _scatter_smooth(scatter, pos, slot)
        made.append(scatter)
    for pos, slot in enumerate(GRAD_SLOTS_FRICTION):
        scatter = _scatter_friction(scatter, pos, slot)
        made.append(scatter)
    return scatter, tuple(made)


_SCATTER, _SCATTER_FOLDED = _fold_scatter()


def grad_smooth(theta, sin_theta, cos_theta, omega, t, k, kn):  # noqa: ANN001, ANN201 (numba-compiled)
    """Partials of :func:`accel_smooth`: ``(d/dtheta, d/domega, dcs)`` [1/s^2, 1/s], ``dcs`` the
    derivatives by the smooth slots (:data:`GRAD_SLOTS_SMOOTH` order). Folded from the ``dfn``."""
    return _GRAD_SMOOTH(theta, sin_theta, cos_theta, omega, t, k, kn)


def grad_friction(w, k, kn):  # noqa: ANN001, ANN201 (numba-compiled)
    """``(dm/dw, dcf)`` of the sgn friction at ``w = |omega|`` (its alpha is ``-s m(w)``, so
    ``d alpha/d omega = -dm/dw``, ``d alpha/d c = -s dm/dc``); ``dcf`` by the friction slots
    (:data:`GRAD_SLOTS_FRICTION` order)."""
    return _GRAD_FRICTION(w, k, kn)


def accel_smooth(theta, sin_theta, omega, t, k):  # noqa: ANN001, ANN201 (numba-compiled)
    """The terms of the acceleration that are smooth in omega [rad/s^2], gravity included.

    ``k`` from :func:`unpack`. The sum of every declared ``"base"``/``"smooth"`` term's ``fn``.
    """
    return _ACCEL_SMOOTH(theta, sin_theta, omega, t, k)


def friction_pair(w, k):  # noqa: ANN001, ANN201 (numba-compiled)
    """``(m(w), M(w))`` of the sgn friction at speed ``w = |omega|`` >= 0; ``k`` from :func:`unpack`.

    The friction terms (every declared ``"friction"`` term: Coulomb, quadratic, power-law,
    quarter-power) add ``-sgn(omega) m(|omega|)`` to alpha; ``M(w) = int_0^w m`` is its
    antiderivative, so ``-M(|omega|)`` is an even antiderivative of the friction in omega.
    """
    return _FRICTION_PAIR(w, k)


def friction_mean(om_a, om_b, m_a, big_m_a, m_b, big_m_b):  # noqa: ANN001, ANN201
    """Mean of the sgn friction over a step where omega runs linearly from om_a to om_b [rad/s^2].

    ``-(M(|b|) - M(|a|)) / (b - a)``: exact for linear omega, continuous (and away from
    ``a = b = 0`` differentiable) in both ends even when omega changes sign within the step,
    unlike the friction evaluated at the grid points. When the ends nearly coincide the
    difference quotient loses digits; there the trapezoid of the end values replaces it
    (they differ by ~f'' (b - a)^2 / 12, far below rounding at the 1e-7 relative switch).
    """
    d = om_b - om_a
    if abs(d) > 1e-7 * (abs(om_a) + abs(om_b)):
        return -(big_m_b - big_m_a) / d
    fa = -m_a if om_a > 0.0 else (m_a if om_a < 0.0 else 0.0)
    fb = -m_b if om_b > 0.0 else (m_b if om_b < 0.0 else 0.0)
    return 0.5 * (fa + fb)


def accel_terms(theta, sin_theta, omega, t, s, k):  # noqa: ANN001, ANN201 (numba-compiled)
    """Memory-free angular acceleration [rad/s^2]; ``k`` from :func:`unpack`.

    ``s`` (+-1) is the direction used for the sgn terms; ``sin_theta`` is passed
    separately so the predictor can use its Taylor value.
    """
    m, _ = friction_pair(abs(omega), k)
    return accel_smooth(theta, sin_theta, omega, t, k) - s * m


def accel_free(theta, sin_theta, omega, t, s, c):  # noqa: ANN001, ANN201 (numba-compiled)
    """:func:`accel_terms` with the coefficients taken from the packed vector ``c``."""
    return accel_terms(theta, sin_theta, omega, t, s, unpack(c))


def forcing_at(forcing, t, t_start, h):  # noqa: ANN001, ANN201
    """External forcing [rad/s^2] at time t: linear interpolation of samples on the grid."""
    n = forcing.shape[0]
    if n == 0:
        return 0.0
    x = (t - t_start) / h
    i = int(math.floor(x))
    if i < 0:
        return forcing[0]
    if i >= n - 1:
        return forcing[n - 1]
    f = x - i
    return forcing[i] * (1.0 - f) + forcing[i + 1] * f


def direction(theta, omega, t, c, f):  # noqa: ANN001, ANN201
    """Direction of motion: sgn(omega), or at omega == 0 where the forces push (0: stuck)."""
    if omega > 0.0:
        return 1.0
    if omega < 0.0:
        return -1.0
    st = math.sin(theta)
    if accel_free(theta, st, 0.0, t, 1.0, c) + f > 0.0:
        return 1.0
    if accel_free(theta, st, 0.0, t, -1.0, c) + f < 0.0:
        return -1.0
    return 0.0


def sin_cos_at(x, x0, s0, c0):  # noqa: ANN001, ANN201
    """``(sin x, cos x)`` from ``s0 = sin x0``, ``c0 = cos x0``: the rotation :func:`sin_cos_after` by
    ``x - x0`` when that is at most :data:`SINCOS_STEP_MAX`, else libm."""
    d = x - x0
    if abs(d) <= SINCOS_STEP_MAX:
        return sin_cos_after(s0, c0, d)
    return math.sin(x), math.cos(x)


def rk4_step(theta, st, ct, omega, t, dt, s, k, forcing, t_start, h):  # noqa: ANN001, ANN201
    """One RK4 step of length dt with the sgn terms frozen at direction s; returns
    ``(theta, omega, sin theta, cos theta)`` after it.

    ``st, ct``: sin and cos of ``theta``; the stages' sines (and the result's) are rotations of
    them (:func:`sin_cos_at`, within a few ulp of libm's). ``k`` from :func:`unpack`.
    """
    k1t = omega
    k1w = accel_terms(theta, st, omega, t, s, k) + forcing_at(forcing, t, t_start, h)
    th2 = theta + 0.5 * dt * k1t
    w2 = omega + 0.5 * dt * k1w
    tm = t + 0.5 * dt
    fm = forcing_at(forcing, tm, t_start, h)
    k2t = w2
    s2, _ = sin_cos_at(th2, theta, st, ct)
    k2w = accel_terms(th2, s2, w2, tm, s, k) + fm
    th3 = theta + 0.5 * dt * k2t
    w3 = omega + 0.5 * dt * k2w
    k3t = w3
    s3, _ = sin_cos_at(th3, theta, st, ct)
    k3w = accel_terms(th3, s3, w3, tm, s, k) + fm
    th4 = theta + dt * k3t
    w4 = omega + dt * k3w
    k4t = w4
    s4, _ = sin_cos_at(th4, theta, st, ct)
    k4w = accel_terms(th4, s4, w4, t + dt, s, k) + forcing_at(forcing, t + dt, t_start, h)
    th_new = theta + dt * (k1t + 2.0 * k2t + 2.0 * k3t + k4t) / 6.0
    s_new, c_new = sin_cos_at(th_new, theta, st, ct)
    return th_new, omega + dt * (k1w + 2.0 * k2w + 2.0 * k3w + k4w) / 6.0, s_new, c_new


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
    omega = omega0
    st = math.sin(theta)  # sin, cos of theta: rotated through the sub-steps, from libm at every sample
    ct = math.cos(theta)
    s = direction(theta, omega, t_start, c, forcing_at(forcing, t_start, t_start, h))
    if s == 0.0:
        omega = 0.0
    out_theta[0] = theta
    out_omega[0] = omega
    want_alpha = out_alpha.shape[0] > 0
    if want_alpha:
        out_alpha[0] = 0.0 if s == 0.0 else (
            accel_terms(theta, st, omega, t_start, s, kc) + forcing_at(forcing, t_start, t_start, h))
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
                # omega changes sign inside: locate tau with omega(tau) = 0 (Illinois regula falsi)
                ta = 0.0
                fa = s * omega
                tb = remaining
                fb = s * w1
                tc = remaining
                thc = th1
                side = 0
                for _it in range(60):
                    tc = (ta * fb - tb * fa) / (fb - fa)
                    thc, wc, _, _ = rk4_step(theta, st, ct, omega, t, tc, s, kc, forcing, t_start, h)
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
                theta = thc
                st = math.sin(theta)
                ct = math.cos(theta)
                omega = 0.0
                t = t + tc
                remaining = remaining - tc
                s = direction(theta, 0.0, t, c, forcing_at(forcing, t, t_start, h))
                if remaining <= 0.0:
                    break
        ti = t_start + (i + 1) * h
        out_theta[i + 1] = theta
        out_omega[i + 1] = omega
        st = math.sin(theta)  # the rotations' rounding does not accumulate past a sample
        ct = math.cos(theta)
        if not want_alpha:
            continue
        if s == 0.0:
            out_alpha[i + 1] = 0.0
        else:
            out_alpha[i + 1] = accel_terms(theta, st, omega, ti, s, kc) + forcing_at(forcing, ti, t_start, h)


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
    th2 = theta + 0.5 * dt * k1t
    w2 = omega + 0.5 * dt * k1w
    tm = t + 0.5 * dt
    fm = forcing_at(forcing, tm, t_start, h)
    k2t = w2
    s2, c2 = sin_cos_at(th2, theta, st, ct)
    k2w = accel_terms(th2, s2, w2, tm, s, k) + fm
    a_th, a_om = accel_grad(th2, s2, c2, w2, tm, s, k, kn, slot_index, dcoeffs, g, dca)
    for j in range(n_p):
        d_th2 = sth[j] + 0.5 * dt * som[j]
        d_w2 = som[j] + 0.5 * dt * w[0, j]
        w[1, j] = d_w2  # dk2t
        w[2, j] = a_th * d_th2 + a_om * d_w2 + g[j]  # dk2w
    th3 = theta + 0.5 * dt * k2t
    w3 = omega + 0.5 * dt * k2w
    k3t = w3
    s3, c3 = sin_cos_at(th3, theta, st, ct)
    k3w = accel_terms(th3, s3, w3, tm, s, k) + fm
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
    th4 = theta + dt * k3t
    w4 = omega + dt * k3w
    k4t = w4
    s4, c4 = sin_cos_at(th4, theta, st, ct)
    k4w = accel_terms(th4, s4, w4, t + dt, s, k) + forcing_at(forcing, t + dt, t_start, h)
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
    omega = omega0
    st = math.sin(theta)  # as rk_kernel_py: rotated through the sub-steps, from libm at every sample
    ct = math.cos(theta)
    s = direction(theta, omega, t_start, c, forcing_at(forcing, t_start, t_start, h))
    if s == 0.0:
        omega = 0.0
        for j in range(n_p):
            som[j] = 0.0
    out_theta[0] = theta
    out_omega[0] = omega
    want_alpha = out_alpha.shape[0] > 0
    if want_alpha:
        out_alpha[0] = 0.0 if s == 0.0 else (
            accel_terms(theta, st, omega, t_start, s, kc) + forcing_at(forcing, t_start, t_start, h))
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
                # omega changes sign inside: locate tau with omega(tau) = 0 (Illinois regula falsi)
                ta = 0.0
                fa = s * omega
                tb = remaining
                fb = s * w1
                tc = remaining
                thc = th1
                wc = w1
                side = 0
                for _it in range(60):
                    tc = (ta * fb - tb * fa) / (fb - fa)
                    thc, wc, _, _ = rk4_step(theta, st, ct, omega, t, tc, s, kc, forcing, t_start, h)
                    fc_ = s * wc
                    if fc_ > 0.0:
                        ta = tc
                        fa = fc_
                        if side == 1:
                            fb *= 0.5
                        side = 1
                    elif fc_ < 0.0:
                        tb = tc
                        fb = fc_
                        if side == -1:
                            fa *= 0.5
                        side = -1
                    else:
                        break
                    if tb - ta <= 1e-15 * hs or abs(fc_) <= 1e-15:
                        break
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
                theta = thc
                st = math.sin(theta)
                ct = math.cos(theta)
                omega = 0.0
                t = t + tc
                remaining = remaining - tc
                s = direction(theta, 0.0, t, c, forcing_at(forcing, t, t_start, h))
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
        if not want_alpha:
            continue
        if s == 0.0:
            out_alpha[i + 1] = 0.0
        else:
            out_alpha[i + 1] = accel_terms(theta, st, omega, ti, s, kc) + forcing_at(forcing, ti, t_start, h)


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


_NB: dict[str, object] = {}


def declarations_stamp() -> str:
    """sha256 of the source of every module whose code the kernels compile besides this one.

    numba's cache is keyed on the kernel's own file only: a changed or added term in
    :mod:`pendtrack.models.terms` would otherwise load a stale kernel. The stamp enters the
    cache key through :func:`_stamped`.
    """
    import hashlib
    import sys
    from pathlib import Path

    modules = {T.__name__, Term.__module__, gl_weights.__module__}
    modules.update(t.fn.__module__ for t in (T.BASE, *T.TERMS.values()) if t.fn is not None)
    digest = hashlib.sha256()
    for name in sorted(modules):
        digest.update(name.encode())
        digest.update(Path(sys.modules[name].__file__).read_bytes())
    return digest.hexdigest()


def _stamped(kernel, stamp):  # noqa: ANN001, ANN202
    """``kernel`` behind a closure whose cells (``kernel``, ``stamp``) numba hashes into its cache key."""
    def run(coeffs, n_steps, h, t_start, theta0, omega0, option, forcing,
            out_theta, out_omega, out_alpha):  # noqa: ANN001, ANN202
        if stamp:  # always true: the reference puts the stamp into the closure
            kernel(coeffs, n_steps, h, t_start, theta0, omega0, option, forcing, out_theta, out_omega, out_alpha)
    return run


def _stamped_sens(kernel, stamp):  # noqa: ANN001, ANN202
    """:func:`_stamped` for the sensitivity kernel's signature."""
    def run(coeffs, slot_index, dcoeffs, n_steps, h, t_start, theta0, omega0, substeps, forcing,
            dtheta0, domega0, out_theta, out_omega, out_alpha, out_dtheta, out_domega):  # noqa: ANN001, ANN202
        if stamp:  # always true: the reference puts the stamp into the closure
            kernel(coeffs, slot_index, dcoeffs, n_steps, h, t_start, theta0, omega0, substeps, forcing,
                   dtheta0, domega0, out_theta, out_omega, out_alpha, out_dtheta, out_domega)
    return run


# error_model="numpy": no zero-division checks in the loops (packed models never divide by 0);
# fastmath contract/arcp only (fused multiply-add, division by reciprocal): the per-step
# dependency chain gets ~30 % shorter; no reassociation, no NaN/inf assumptions. The
# twins then differ by rounding only (measured <= 4e-13 rad over 600 steps; test 1e-12)
_OPTIONS = {"error_model": "numpy", "fastmath": {"contract", "arcp"}}


def _register() -> None:
    """Register the helpers with numba (once per process).

    The small per-step helpers -- the declared terms' formulas and their folds included --
    are inlined at numba-IR level (a call each would cost more than the arithmetic).
    """
    if "registered" in _NB:
        return
    from numba.extending import overload, register_jitable
    from numba.np.unsafe.ndarray import to_fixed_tuple

    n_coeffs = T.N_COEFFS

    @overload(unpack, inline="always")
    def _unpack(c):  # noqa: ANN001, ANN202
        return lambda c: to_fixed_tuple(c, n_coeffs)

    # the folds of the declared formulas: ordinary calls that LLVM inlines (numba's IR-level
    # inlining of the nested folds would cost minutes of compilation)
    formulas = tuple(t.fn for t in (T.BASE, *T.TERMS.values()) if t.fn is not None)
    derivatives = tuple(t.dfn for t in (T.BASE, *T.TERMS.values()) if t.dfn is not None)
    for fn in (*formulas, *_FOLDED, _friction_seed, *derivatives, *_GRAD_FOLDED, *_SCATTER_FOLDED):
        register_jitable(fn)
    for fn in (accel_smooth, friction_pair, friction_mean, accel_terms, accel_free, forcing_at, memory_fn,
               memory_pair, memory_pair_next, series_ratio_pow, sin_cos_after, sin_cos_at, grad_smooth, grad_friction):
        register_jitable(inline="always")(fn)
    for fn in (direction, rk4_step, rk4_length_derivative):  # larger: ordinary calls (inlining costs compile time)
        register_jitable(fn)
    # the sensitivity step and its partials pass arrays: inlined, so that no call passes (and
    # reference-counts) them per stage (3x faster, measured)
    register_jitable(inline="always")(accel_grad)
    register_jitable(inline="always")(rk4_sens_step)
    register_jitable(fastmath=True)(gl_dot)
    register_jitable(binomial_series)
    register_jitable(gl_weights)
    for kernel in (rk_kernel_py, pc_kernel_py, rk_sens_kernel_py):
        register_jitable(**_OPTIONS)(kernel)
    _NB["registered"] = True


def _compile() -> None:
    """Register the helpers with numba, build both kernels and compile them (or load the cache).

    numba's pedantic SSA check warns about inlined variables, which is harmless, so those
    warnings are silenced during this one compilation.
    """
    import warnings

    from numba import njit
    from numba.core.errors import NumbaIRAssumptionWarning

    _register()
    stamp = declarations_stamp()
    compiled = {}
    for name, kernel in (("rk", rk_kernel_py), ("pc", pc_kernel_py)):
        compiled[name] = njit(cache=True, **_OPTIONS)(_stamped(kernel, stamp))
    c = np.asarray(empty_coeffs())
    c[K_HAS_MEMORY] = 1.0
    out = np.zeros(3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NumbaIRAssumptionWarning)
        for kern in compiled.values():
            kern(c, 1, 0.1, 0.0, 0.1, 0.0, 1, np.zeros(0), out, out, out)
    _NB.update(compiled)


def rk_sens_kernel_nb():  # noqa: ANN201
    """The numba-compiled :func:`rk_sens_kernel_py` (compiled, or loaded from cache, on first call)."""
    if "rk_sens" not in _NB:
        import warnings

        from numba import njit
        from numba.core.errors import NumbaIRAssumptionWarning

        _register()
        kern = njit(cache=True, **_OPTIONS)(_stamped_sens(rk_sens_kernel_py, declarations_stamp()))
        c = np.asarray(empty_coeffs())
        c[T.K_SIN] = 1.0
        out = np.zeros(3)
        d = np.zeros((3, 1))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", NumbaIRAssumptionWarning)
            kern(c, np.zeros(1, dtype=np.int64), np.zeros((1, 1)), 1, 0.1, 0.0, 0.1, 0.0, 1, np.zeros(0),
                 np.zeros(1), np.zeros(1), out, out, out, d, d)
        _NB["rk_sens"] = kern
    return _NB["rk_sens"]


def rk_kernel_nb():  # noqa: ANN201
    """The numba-compiled :func:`rk_kernel_py` (compiled, or loaded from cache, on first call)."""
    if "rk" not in _NB:
        _compile()
    return _NB["rk"]


def pc_kernel_nb():  # noqa: ANN201
    """The numba-compiled :func:`pc_kernel_py` (compiled, or loaded from cache, on first call)."""
    if "pc" not in _NB:
        _compile()
    return _NB["pc"]


def compile_kernels() -> None:
    """Compile every numba kernel now (or load it from numba's on-disk cache).

    ``make setup`` calls it, so a fresh clone's first run does not compile; results never depend
    on it (a fit counts its work, not its seconds), only the first run's wall time does.
    """
    rk_kernel_nb()
    pc_kernel_nb()
    rk_sens_kernel_nb()
