"""The parameters and named physical terms the paper's models are built from.

Every model is ``alpha + Omega0**2 sin(theta) = sum of its terms`` (eq. basemodel1), with
``alpha = d2 theta/dt2`` in rad/s^2. Each term below contributes to the right-hand side
(in rad/s^2) as written in its ``formula``; ``sgn(0) = +1`` (eq. sgn).

The solvers do not see terms: a model's parameters are packed into one flat float64
coefficient vector (layout ``K_*`` below) that a single generic kernel reads; a term that
is absent simply has zero coefficients. The layout is part of the low-level API
(:func:`pendtrack.models.simulate_packed`); a test pins it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

INF = math.inf


@dataclass(frozen=True)
class ParamSpec:
    """One physical parameter: name as in the paper, unit, physical range and meaning.

    ``low``/``high`` are the bounds; ``low_open``/``high_open`` say whether the bound
    itself is excluded.
    """

    name: str
    unit: str
    low: float
    high: float
    low_open: bool
    high_open: bool
    description: str

    def contains(self, value: float) -> bool:
        """True if ``value`` is finite (unless a bound is infinite) and inside the range."""
        if math.isnan(value):
            return False
        above = value > self.low if self.low_open else value >= self.low
        below = value < self.high if self.high_open else value <= self.high
        return above and below

    def range_text(self) -> str:
        left = "(" if self.low_open else "["
        right = ")" if self.high_open else "]"
        return f"{left}{self.low:g}, {self.high:g}{right}"


def _p(name: str, unit: str, low: float, high: float, low_open: bool, high_open: bool, description: str) -> ParamSpec:
    return ParamSpec(name, unit, low, high, low_open, high_open, description)


#: Every parameter any term uses, in the canonical order of ``Model.param_names``.
PARAMS: dict[str, ParamSpec] = {
    s.name: s
    for s in (
        _p("Omega0", "rad/s", 0.0, INF, True, True, "natural angular frequency, eq. NatOmega0"),
        _p("C1", "1/s", 0.0, INF, False, True, "viscous (Stokes) coefficient, eq. standarddiss"),
        _p("C0", "rad/s^2", 0.0, INF, False, True, "Coulomb dry friction, eqs. standarddiss/classicmodel"),
        _p("C2", "1/rad", 0.0, INF, False, True, "quadratic (Newton) drag, eq. standarddiss"),
        _p("C3", "rad/s^2", 0.0, INF, False, True, "power-law drag amplitude, eq. powerlawdiss"),
        _p("p", "1", 0.0, INF, True, True, "power-law exponent, eq. powerlawdiss"),
        _p("Ca", "1", 0.0, INF, False, True, "added-mass coefficient, eq. ainerdef"),
        _p("C4", "1", 0.0, INF, False, True, "time-varying laminar damping, eq. newDNHM"),
        _p("t0", "s", -INF, INF, True, True, "time origin of the C4/(t - t0) damping (must be < t[0]), eq. newDNHM"),
        _p("C5", "1/s", 0.0, INF, False, True, "OPA Coulomb coefficient (acts as 2 Omega0 C5), eq. newDNHM"),
        _p("G1", "1", 0.0, INF, False, True, "quarter-power friction, eq. ourfinalmodel"),
        _p("G2", "1", 0.0, INF, False, True, "fractional (memory) drag amplitude, eq. ourfinalmodel"),
        _p("beta", "1", 0.0, 2.0, True, True, "order of the Grunwald-Letnikov derivative, eq. ourfinalmodel"),
        _p("p_f", "1", 0.0, INF, True, True, "exponent inside the fractional derivative, eq. ourfinalmodel"),
    )
}


@dataclass(frozen=True)
class Term:
    """A named physical term of the right-hand side.

    Attributes
    ----------
    name : str
        Catalogue name (fixed; other packages refer to terms by it).
    params : tuple of str
        Parameters the term uses (besides ``Omega0``, which every model has).
    formula : str
        Its contribution to ``alpha + Omega0^2 sin(theta)`` [rad/s^2].
    equation : str
        The paper's equation label.
    has_memory : bool
        True for the Grunwald-Letnikov term (needs the history of omega).
    """

    name: str
    params: tuple[str, ...]
    formula: str
    equation: str
    has_memory: bool = False

    def to_dict(self) -> dict[str, object]:
        return {"name": self.name, "params": list(self.params), "formula": self.formula,
                "equation": self.equation, "has_memory": self.has_memory}


#: The term catalogue. Names are fixed: fitting, discovery and batch use them.
TERMS: dict[str, Term] = {
    t.name: t
    for t in (
        Term("viscous", ("C1",), "-C1 omega", "standarddiss"),
        Term("coulomb", ("C0",), "-C0 sgn(omega)", "standarddiss"),
        Term("quadratic_drag", ("C2",), "-C2 omega |omega|", "standarddiss"),
        Term("power_drag", ("C3", "p"), "-C3 |omega/Omega0|^p sgn(omega)", "powerlawdiss"),
        Term("added_mass", ("Ca",), "+Ca omega^2 sin(theta)", "ainerdef"),
        Term("time_varying_damping", ("C4", "t0"), "-C4 omega/(t - t0)", "newDNHM"),
        Term("opa_coulomb", ("C5",), "-2 Omega0 C5 sgn(omega)", "newDNHM"),
        Term("quarter_friction", ("G1",), "-4 Omega0^2 G1 |A_omega|^(1/4) sgn(A_omega), A_omega = omega/(2 Omega0)",
             "ourfinalmodel"),
        Term("memory", ("G2", "beta", "p_f"),
             "-4 Omega0^2 G2 D^beta_{t*}(A_omega |A_omega|^(p_f-1)), t* = 2 Omega0 t (left Grunwald-Letnikov)",
             "ourfinalmodel", has_memory=True),
    )
}

# --- packed coefficient layout (read by the kernels) ---------------------------------
# alpha = -K_SIN sin(theta) - K_LIN theta - K_VISC omega - s (K_COUL + K_QUAD omega^2)
#         - s K_POW |omega K_POW_SCALE|^K_POW_EXP + K_ADDED omega^2 sin(theta)
#         - K_TV omega/(t - K_TV_T0) - s K_QUARTER |omega K_QUARTER_SCALE|^(1/4)
#         - K_MEM D^K_BETA_{tau}(g(omega)),  g(omega) = x |x|^(K_PF - 1), x = omega/K_MEM_U,
#           tau = K_TSCALE t  (so the GL step is K_TSCALE h)
#         + forcing(t)
# where s = sgn(omega) (or the direction of motion at omega = 0, see kernels).
K_SIN = 0  # Omega0^2 [1/s^2]
K_LIN = 1  # linear restoring coefficient [1/s^2] (0 for every pendulum model; tests use it)
K_VISC = 2  # C1
K_COUL = 3  # C0 + 2 Omega0 C5
K_QUAD = 4  # C2
K_POW = 5  # C3
K_POW_EXP = 6  # p
K_POW_SCALE = 7  # 1/Omega0
K_ADDED = 8  # Ca
K_TV = 9  # C4
K_TV_T0 = 10  # t0
K_QUARTER = 11  # 4 Omega0^2 G1
K_QUARTER_SCALE = 12  # 1/(2 Omega0)
K_MEM = 13  # 4 Omega0^2 G2
K_BETA = 14  # beta
K_PF = 15  # p_f
K_MEM_U = 16  # 2 Omega0 (omega -> A_omega)
K_TSCALE = 17  # 2 Omega0 (t -> t*)
K_HAS_MEMORY = 18  # 1.0 if the model has the memory term (selects the paper's PC scheme)
N_COEFFS = 19


def empty_coeffs() -> list[float]:
    """A coefficient list with every term absent (neutral values for exponents/scales)."""
    c = [0.0] * N_COEFFS
    c[K_POW_EXP] = 1.0
    c[K_POW_SCALE] = 1.0
    c[K_TV_T0] = -INF
    c[K_QUARTER_SCALE] = 1.0
    c[K_BETA] = 1.0
    c[K_PF] = 1.0
    c[K_MEM_U] = 1.0
    c[K_TSCALE] = 1.0
    return c
