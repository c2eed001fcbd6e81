"""The declarations of every term the paper's models are built from -- one each.

Every model is ``alpha + Omega0**2 sin(theta) = sum of its terms`` (eq. basemodel1), with
``alpha = d2 theta/dt2`` in rad/s^2, ``sgn(0) = +1`` (eq. sgn). A declaration
(:class:`~pendtrack.models.declare.Term`) gives a term's parameters with their ranges, its
slots in the packed coefficient vector, how its parameters pack into them, and its formula
as code; the registry, ``Model.pack``, the numba kernels, their Python twins and the
vectorised right-hand side all derive from it (see :mod:`pendtrack.models.declare` for the
conventions). **Adding a term is one declaration here plus its tests.**

Measurement terms (kind ``"measurement"``) do not enter the equation of motion: they map
the model's angle to the observed one, ``theta_obs = f(theta, params)``
(``Model.observe``), applied in catalogue order.

The solvers do not see terms: they read one flat float64 coefficient vector (layout
:data:`LAYOUT`; the ``K_*`` indices below are kept for the low-level API
:func:`pendtrack.models.simulate_packed`); a term that is absent keeps its slots at their
neutral values and contributes nothing.
"""

from __future__ import annotations

import math

import numpy as np

from pendtrack.models.declare import Layout, Limit, ParamSpec, Slot, Term

__all__ = ["BASE", "CATALOGUE", "TERMS", "MEASUREMENT_TERMS", "PARAMS", "LAYOUT", "N_COEFFS", "Limit", "ParamSpec",
           "Term", "Slot", "empty_coeffs"]

INF = math.inf


def _p(name: str, unit: str, low: float, high: float, low_open: bool, high_open: bool, description: str) -> ParamSpec:
    return ParamSpec(name, unit, low, high, low_open, high_open, description)


# a drag's speed exponent: fluid drag goes from viscous (speed^1) to turbulent (speed^2), and the power laws of
# the paper's references stay within that; 3 leaves room for a record's unmodelled structure (lab1_data.txt's
# classic fit: p = 2.2 +- 0.14). An encoder log of a Furuta pendulum, whose arm takes energy from the swing
# at large amplitudes, fits p = 8.0 +- 0.7 and 15.3 +- 2.5: a drag that acts only at the fastest passes
DRAG_EXPONENT_MAX = 3.0
_DRAG_EXPONENT_WHY = "viscous drag goes as speed^1, turbulent drag as speed^2, no drag law faster"


def _exponent(name: str, description: str) -> ParamSpec:
    """A drag's speed exponent in (0, inf), physical up to :data:`DRAG_EXPONENT_MAX`."""
    return ParamSpec(name, "1", 0.0, INF, True, True, description, plausible_high=DRAG_EXPONENT_MAX,
                     plausible_why=_DRAG_EXPONENT_WHY)


def _positive(name: str, unit: str, description: str) -> ParamSpec:
    """A coefficient in [0, inf)."""
    return _p(name, unit, 0.0, INF, False, True, description)


# --- the formulas (c: the term's own slot values, in the order of its slots) ----------------
# Each works on floats (numba compiles it into the kernels) and on numpy arrays (the
# vectorised right-hand side), hence numpy ufuncs and no branches.

def _gravity(theta, sin_theta, omega, t, c):  # noqa: ANN001, ANN201
    return -c[0] * sin_theta - c[1] * theta


def _viscous(theta, sin_theta, omega, t, c):  # noqa: ANN001, ANN201
    return -c[0] * omega


def _added_mass(theta, sin_theta, omega, t, c):  # noqa: ANN001, ANN201
    return c[0] * omega * omega * sin_theta


def _time_varying_damping(theta, sin_theta, omega, t, c):  # noqa: ANN001, ANN201
    return -c[0] * omega / (t - c[1])


def _coulomb(w, c):  # noqa: ANN001, ANN201
    return c[0], c[0] * w


def _quadratic_drag(w, c):  # noqa: ANN001, ANN201
    w2 = w * w
    return c[0] * w2, c[0] * w2 * w / 3.0


def _power_drag(w, c):  # noqa: ANN001, ANN201
    amp, exponent, scale = c
    y = amp * (w * scale) ** exponent
    return y, y * w / (exponent + 1.0)


def _quarter_friction(w, c):  # noqa: ANN001, ANN201
    amp, scale = c
    r4 = np.sqrt(np.sqrt(w * scale))
    return amp * r4, (0.8 * amp * w) * r4  # (0.8 amp w) is ready before the root (off the critical path)


# --- their partial derivatives (Term.dfn; pendtrack.models.declare): smooth terms
# (d/dtheta, d/domega, (d/dc...)), friction terms (dm/dw, (dm/dc...)); finite at w = 0 except dm/dw

def _gravity_d(theta, sin_theta, cos_theta, omega, t, c):  # noqa: ANN001, ANN201
    return -c[0] * cos_theta - c[1], 0.0 * omega, (-sin_theta, -theta)


def _viscous_d(theta, sin_theta, cos_theta, omega, t, c):  # noqa: ANN001, ANN201
    return 0.0 * theta, -c[0] + 0.0 * omega, (-omega,)


def _added_mass_d(theta, sin_theta, cos_theta, omega, t, c):  # noqa: ANN001, ANN201
    return c[0] * omega * omega * cos_theta, 2.0 * c[0] * omega * sin_theta, (omega * omega * sin_theta,)


def _time_varying_damping_d(theta, sin_theta, cos_theta, omega, t, c):  # noqa: ANN001, ANN201
    r = 1.0 / (t - c[1])
    return 0.0 * theta, -c[0] * r + 0.0 * omega, (-omega * r, -c[0] * omega * r * r)


def _coulomb_d(w, c):  # noqa: ANN001, ANN201
    return 0.0 * w, (1.0 + 0.0 * w,)


def _quadratic_drag_d(w, c):  # noqa: ANN001, ANN201
    return 2.0 * c[0] * w, (w * w,)


def _power_drag_d(w, c):  # noqa: ANN001, ANN201
    amp, exponent, scale = c
    x = w * scale
    y = x ** exponent
    xs = np.maximum(x, 1e-300)  # 0 * ln(tiny) = 0 and 0 / tiny = 0 at w = 0, no exception, no second pow
    # dm/dw = amp p y / w (at w = 0 it is 0 here; the kernel does not use it there), dm/dp = y ln x
    return amp * exponent * scale * y / xs, (y, amp * y * np.log(xs), amp * exponent * y / scale)


def _quarter_friction_d(w, c):  # noqa: ANN001, ANN201
    amp, scale = c
    r4 = np.sqrt(np.sqrt(w * scale))
    return 0.25 * amp * scale / (r4 * r4 * r4), (r4, 0.25 * amp * r4 / scale)


def _offset(theta, c):  # noqa: ANN001, ANN201
    return theta + c[0]


def _angle_gain(theta, c):  # noqa: ANN001, ANN201
    return theta * (1.0 + c[0])


def _angle_scale(theta, c):  # noqa: ANN001, ANN201
    return theta * (1.0 + c[0] * theta * theta)


def _t0_before(p, t_first):  # noqa: ANN001, ANN201
    if p["t0"] < t_first:
        return None
    return (f"parameter t0 = {p['t0']!r} s must be earlier than the first time t[0] = {t_first!r} s "
            "(C4 omega/(t - t0) is singular at t0)")


# --- the declarations --------------------------------------------------------------------

#: Gravity, ``-Omega0^2 sin(theta)``: in every model. The linear restoring slot ``LIN``
#: (``-K_LIN theta``) is 0 in every pendulum model; tests set it to get an exactly linear
#: oscillator.
BASE = Term(
    "gravity", "base", (_p("Omega0", "rad/s", 0.0, INF, True, True, "natural angular frequency, eq. NatOmega0"),),
    "-Omega0^2 sin(theta)", "basemodel1",
    slots=(Slot("SIN", 0.0, "Omega0^2 [1/s^2]"), Slot("LIN", 0.0, "linear restoring coefficient [1/s^2]")),
    pack=lambda p: {"SIN": p["Omega0"] * p["Omega0"]}, fn=_gravity, dfn=_gravity_d)

#: The term catalogue, in canonical order (parameter order of models, slot order).
CATALOGUE: dict[str, Term] = {
    t.name: t
    for t in (
        Term("viscous", "smooth", (_positive("C1", "1/s", "viscous (Stokes) coefficient, eq. standarddiss"),),
             "-C1 omega", "standarddiss",
             slots=(Slot("VISC"),), pack=lambda p: {"VISC": p["C1"]}, fn=_viscous, dfn=_viscous_d, always=True),
        Term("coulomb", "friction",
             (_positive("C0", "rad/s^2", "Coulomb dry friction, eqs. standarddiss/classicmodel"),),
             "-C0 sgn(omega)", "standarddiss",
             slots=(Slot("COUL", 0.0, "C0 + 2 Omega0 C5"),), pack=lambda p: {"COUL": p["C0"]}, fn=_coulomb,
             dfn=_coulomb_d, always=True),
        Term("quadratic_drag", "friction", (_positive("C2", "1/rad", "quadratic (Newton) drag, eq. standarddiss"),),
             "-C2 omega |omega|", "standarddiss",
             slots=(Slot("QUAD"),), pack=lambda p: {"QUAD": p["C2"]}, fn=_quadratic_drag, dfn=_quadratic_drag_d, always=True),
        Term("power_drag", "friction",
             (_positive("C3", "rad/s^2", "power-law drag amplitude, eq. powerlawdiss"),
              _exponent("p", "power-law exponent, eq. powerlawdiss")),
             "-C3 |omega/Omega0|^p sgn(omega)", "powerlawdiss",
             slots=(Slot("POW"), Slot("POW_EXP", 1.0), Slot("POW_SCALE", 1.0, "1/Omega0")),
             pack=lambda p: {"POW": p["C3"], "POW_EXP": p["p"], "POW_SCALE": 1.0 / p["Omega0"]}, fn=_power_drag, dfn=_power_drag_d,
             limits=(Limit("C3", 0.0, unmeasured=("p",)),)),
        Term("added_mass", "smooth", (_positive("Ca", "1", "added-mass coefficient, eq. ainerdef"),),
             "+Ca omega^2 sin(theta)", "ainerdef",
             slots=(Slot("ADDED"),), pack=lambda p: {"ADDED": p["Ca"]}, fn=_added_mass, dfn=_added_mass_d, always=True),
        Term("time_varying_damping", "smooth",
             (_positive("C4", "1", "time-varying laminar damping, eq. newDNHM"),
              _p("t0", "s", -INF, INF, True, True, "time origin of the C4/(t - t0) damping (must be < t[0]), eq. newDNHM")),
             "-C4 omega/(t - t0)", "newDNHM",
             slots=(Slot("TV"), Slot("TV_T0", -INF)), pack=lambda p: {"TV": p["C4"], "TV_T0": p["t0"]},
             fn=_time_varying_damping, dfn=_time_varying_damping_d, domain=_t0_before,
             # t0 -> -inf: C4/(t - t0) is constant over the record, a plain viscous damping of rate C4/(t - t0)
             limits=(Limit("C4", 0.0, unmeasured=("t0",)),
                     Limit("t0", -INF, "a constant viscous damping", "viscous", unmeasured=("C4",)))),
        Term("opa_coulomb", "friction",
             (_positive("C5", "1/s", "OPA Coulomb coefficient (acts as 2 Omega0 C5), eq. newDNHM"),),
             "-2 Omega0 C5 sgn(omega)", "newDNHM",
             pack=lambda p: {"COUL": 2.0 * p["Omega0"] * p["C5"]}),  # a Coulomb friction: coulomb's slot and fn
        Term("quarter_friction", "friction", (_positive("G1", "1", "quarter-power friction, eq. ourfinalmodel"),),
             "-4 Omega0^2 G1 |A_omega|^(1/4) sgn(A_omega), A_omega = omega/(2 Omega0)", "ourfinalmodel",
             slots=(Slot("QUARTER", 0.0, "4 Omega0^2 G1"), Slot("QUARTER_SCALE", 1.0, "1/(2 Omega0)")),
             pack=lambda p: {"QUARTER": 4.0 * p["Omega0"] * p["Omega0"] * p["G1"],
                             "QUARTER_SCALE": 1.0 / (2.0 * p["Omega0"])}, fn=_quarter_friction, dfn=_quarter_friction_d),
        # alpha -= K_MEM D^K_BETA_tau(g(omega)), g = x |x|^(K_PF - 1), x = omega/K_MEM_U, tau = K_TSCALE t;
        # K_HAS_MEMORY = 1 selects the paper's predictor-corrector (also with G2 = 0)
        Term("memory", "memory",
             (_positive("G2", "1", "fractional (memory) drag amplitude, eq. ourfinalmodel"),
              _p("beta", "1", 0.0, 1.0, True, False, "order of the Grunwald-Letnikov derivative, eq. ourfinalmodel: "
                 "from a drag on the velocity (0) to one on the acceleration, an added mass (1)"),
              _exponent("p_f", "exponent inside the fractional derivative, eq. ourfinalmodel")),
             "-4 Omega0^2 G2 D^beta_{t*}(A_omega |A_omega|^(p_f-1)), t* = 2 Omega0 t (left Grunwald-Letnikov)",
             "ourfinalmodel",
             slots=(Slot("MEM", 0.0, "4 Omega0^2 G2"), Slot("BETA", 1.0), Slot("PF", 1.0),
                    Slot("MEM_U", 1.0, "2 Omega0 (omega -> A_omega)"), Slot("TSCALE", 1.0, "2 Omega0 (t -> t*)"),
                    Slot("HAS_MEMORY", 0.0, "1: the model has the memory term (the paper's PC scheme)")),
             pack=lambda p: {"MEM": 4.0 * p["Omega0"] * p["Omega0"] * p["G2"], "BETA": p["beta"], "PF": p["p_f"],
                             "MEM_U": 2.0 * p["Omega0"], "TSCALE": 2.0 * p["Omega0"], "HAS_MEMORY": 1.0},
             # beta -> 0: D^0 is the identity, the term is G2 A|A|^(p_f - 1), a power-law drag without memory
             limits=(Limit("G2", 0.0, unmeasured=("beta", "p_f")),
                     Limit("beta", 0.0, "a plain power-law drag", "power_drag"))),
        # measurement terms, applied in this order: the camera's zero, then its angle scale
        Term("offset", "measurement",
             (_p("theta_off", "rad", -INF, INF, True, True, "offset of the measured angle's zero"),),
             "theta_obs = theta + theta_off", "measurement", fn=_offset, shift=True),
        # a gain is told from the initial amplitude only by the swing's nonlinearity (the period's dependence
        # on the amplitude): determined on large swings, not on small ones
        Term("angle_gain", "measurement",
             (_p("theta_gain", "1", -1.0, INF, True, True,
                 "relative error of the measured angle's scale (an axle off along the radius, a codec's smoothing)"),),
             "theta_obs = theta (1 + theta_gain)", "measurement", fn=_angle_gain),
        Term("angle_scale", "measurement",
             (_p("k_scale", "1/rad^2", -INF, INF, True, True, "cubic error of the measured angle's scale"),),
             "theta_obs = theta (1 + k_scale theta^2)", "measurement", fn=_angle_scale),
    )
}

#: The physical terms (the equation of motion). Names are fixed: fitting, discovery and batch use them.
TERMS: dict[str, Term] = {n: t for n, t in CATALOGUE.items() if t.is_physical}
#: The measurement terms (the observation).
MEASUREMENT_TERMS: dict[str, Term] = {n: t for n, t in CATALOGUE.items() if t.kind == "measurement"}

#: Every parameter any term uses, in the canonical order of ``Model.param_names``.
PARAMS: dict[str, ParamSpec] = {s.name: s for t in (BASE, *CATALOGUE.values()) for s in t.specs}

#: The packed coefficient vector.
LAYOUT = Layout(BASE, CATALOGUE.values())
N_COEFFS = LAYOUT.size
# slot indices of the low-level API (tests and the memory term's special treatment use them)
K_SIN, K_LIN, K_VISC, K_COUL, K_QUAD = (LAYOUT.index[n] for n in ("SIN", "LIN", "VISC", "COUL", "QUAD"))
K_POW, K_POW_EXP, K_POW_SCALE = (LAYOUT.index[n] for n in ("POW", "POW_EXP", "POW_SCALE"))
K_ADDED, K_TV, K_TV_T0, K_QUARTER, K_QUARTER_SCALE = (
    LAYOUT.index[n] for n in ("ADDED", "TV", "TV_T0", "QUARTER", "QUARTER_SCALE"))
K_MEM, K_BETA, K_PF, K_MEM_U, K_TSCALE, K_HAS_MEMORY = (
    LAYOUT.index[n] for n in ("MEM", "BETA", "PF", "MEM_U", "TSCALE", "HAS_MEMORY"))


def empty_coeffs() -> list[float]:
    """A coefficient list with every term absent (neutral values for exponents/scales)."""
    return list(LAYOUT.neutral)
