"""The per-step functions of the kernels, folded from the term declarations.

No term is written here: :func:`accel_smooth` and :func:`friction_pair` (and the partials
:func:`grad_smooth`, :func:`grad_friction` of the sensitivity kernel) are folds of the
formulas declared in :mod:`pendtrack.models.terms`, built once at import as plain closures;
numba compiles them into the kernels and LLVM inlines them, and the same folds evaluate the
vectorised right-hand side (:mod:`pendtrack.models.rhs`). Also the pieces every kernel
shares: :func:`friction_mean`, :func:`accel_terms`, :func:`accel_free`, :func:`forcing_at`
and :func:`direction` (the direction of motion at omega = 0).
"""

from __future__ import annotations

import math

from pendtrack.models import terms as T
from pendtrack.models.declare import Term

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
