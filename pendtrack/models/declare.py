"""How a term is declared: its parameters, its coefficient slots and its formula, in one object.

A :class:`Term` is the single source of everything about one effect. The rest of
:mod:`pendtrack.models` derives from the declarations in :mod:`pendtrack.models.terms`:

* :data:`~pendtrack.models.terms.PARAMS` and the validation of a model's parameters from
  :attr:`Term.specs`;
* the packed coefficient vector the solvers read (:class:`Layout`, ``Model.pack``) from
  :attr:`Term.slots` and :attr:`Term.pack`;
* the acceleration -- in the numba kernels, their pure-Python twins and the vectorised
  right-hand side alike -- by folding the :attr:`Term.fn` of every declared term
  (:mod:`pendtrack.models.kernels`);
* the observation ``theta_obs = f(theta_model, params)`` from the measurement terms
  (``Model.observe``);
* the partial derivatives of the acceleration (the forward sensitivity equations of the RK4
  kernel, :func:`pendtrack.models.kernels.rk_sens_kernel_py`) by folding every term's
  :attr:`Term.dfn` the same way, and the derivatives of the packed slots with respect to the
  parameters by complex-step differentiation of :attr:`Term.pack` (:meth:`Layout.pack_jacobian`).

Term kinds and the signature of :attr:`Term.fn` (``c`` is the tuple of the term's own slot
values, in the order of :attr:`Term.slots`; every ``fn`` of the equation of motion must work
unchanged on floats -- numba compiles it -- and on numpy arrays -- the vectorised right-hand
side calls it -- so it uses arithmetic and numpy ufuncs only, no ``if`` on the arguments):

``"base"``        gravity; ``fn(theta, sin_theta, omega, t, c)`` [rad/s^2], always evaluated.
``"smooth"``      a term smooth in omega; ``fn(theta, sin_theta, omega, t, c)`` [rad/s^2], its
                  contribution to alpha.
``"friction"``    a term ``-sgn(omega) m(|omega|)``; ``fn(w, c) -> (m(w), M(w))`` at ``w = |omega|``
                  with ``M(w) = int_0^w m`` (the predictor-corrector integrates the friction as
                  its exact mean over a step, ``-(M(|b|) - M(|a|)) / (b - a)``).
``"memory"``      the Grunwald-Letnikov term: declared for its parameters and slots; the
                  kernels and :mod:`pendtrack.models.rhs` treat its history specially.
``"measurement"`` not in the equation of motion: ``fn(theta, c) -> theta_obs`` with ``c`` the
                  term's parameter values (in :attr:`Term.specs` order); no slots.

The derivative formula :attr:`Term.dfn` (terms with an ``fn`` in the equation of motion; same
rules as ``fn``):

``"base"``, ``"smooth"``  ``dfn(theta, sin_theta, cos_theta, omega, t, c) -> (d/dtheta, d/domega,
                  (d/dc_0, d/dc_1, ...))`` of the term's contribution (theta-derivative total,
                  ``sin_theta = sin(theta)``), one entry per slot.
``"friction"``    ``dfn(w, c) -> (dm/dw, (dm/dc_0, ...))`` of ``m`` (not of ``M``: the RK4 kernel
                  does not use the antiderivative). ``dm/dw`` may be infinite at ``w = 0`` (a
                  sub-linear friction); the slot derivatives must stay finite there.

The measurement terms and the packing need no derivative: both are differentiated by complex
steps (their formulas are arithmetic), so they must be complex-analytic (no ``abs``, no
``math.*``). A test checks every declared ``dfn`` against central differences of its ``fn``.

One compiled kernel serves every composition: an absent term has its slots at their neutral
values. A smooth or friction term whose first slot is 0 contributes nothing, and the kernels
skip it -- unless it is declared ``always`` (cheap, and 0 at its neutral values).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass

import numpy as np

KINDS = ("base", "smooth", "friction", "memory", "measurement")
PHYSICAL_KINDS = ("smooth", "friction", "memory")


@dataclass(frozen=True)
class ParamSpec:
    """One physical parameter: name as in the paper, unit, physical range and meaning.

    ``low``/``high`` are the bounds; ``low_open``/``high_open`` say whether the bound
    itself is excluded. ``plausible_high`` is the largest value the physics the parameter stands
    for takes (an exponent of a drag law), ``plausible_why`` the reason: a fit that measures the
    parameter above it is flagged (:func:`pendtrack.fitting.result.plausibility_flags`), its term
    standing in for something the model lacks.
    """

    name: str
    unit: str
    low: float
    high: float
    low_open: bool
    high_open: bool
    description: str
    plausible_high: float = math.inf
    plausible_why: str = ""

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


@dataclass(frozen=True)
class Limit:
    """A limit of one parameter where its term is absent, or becomes a simpler term.

    A fit that ends at such a limit has found that the data show no such effect: a finding
    about the pendulum, not a failure of the fit (:func:`pendtrack.fitting.result.split_findings`).

    Attributes
    ----------
    param : str
        The parameter that reaches the limit.
    value : float
        The limit [the parameter's unit]: ``0.0`` for an amplitude or an order, ``-inf`` for a
        time origin infinitely far before the record.
    becomes : str
        What the term is at the limit, in words (e.g. ``"a plain power-law drag"``); ``""`` when
        it simply vanishes.
    nested : str
        The catalogue term the model then reduces to in place of this one (``""``: none).
    unmeasured : tuple of str
        The term's other parameters, which the data cannot measure at the limit (the exponents of
        a vanished amplitude, the amplitude of a damping whose time origin is infinitely far).
    """

    param: str
    value: float
    becomes: str = ""
    nested: str = ""
    unmeasured: tuple[str, ...] = ()


@dataclass(frozen=True)
class Slot:
    """One entry of the packed coefficient vector (``K_<name>`` in the layout).

    ``neutral`` is its value when no term of the model sets it (chosen so that an absent
    term is inert and its formula stays finite).
    """

    name: str
    neutral: float = 0.0
    meaning: str = ""


@dataclass(frozen=True)
class Term:
    """The declaration of one term: everything the package knows about it.

    Attributes
    ----------
    name : str
        Catalogue name (fixed; other packages refer to terms by it).
    kind : str
        One of :data:`KINDS` (see the module docstring).
    specs : tuple of ParamSpec
        Its parameters (besides ``Omega0``, which the base declares) with units and ranges.
    formula : str
        Its contribution to ``alpha + Omega0^2 sin(theta)`` [rad/s^2], or the observation.
    equation : str
        The paper's equation label.
    slots : tuple of Slot
        Its own coefficient slots (contiguous in the packed vector; what ``fn`` receives).
    pack : callable, optional
        ``pack(p) -> {slot name: value}`` from the validated parameters ``p`` (which include
        ``Omega0``). It may name another term's slot: values given to one slot by several
        terms of a model add up (e.g. ``opa_coulomb`` is a Coulomb friction of amplitude
        ``2 Omega0 C5`` and adds into ``coulomb``'s slot).
    fn : callable, optional
        The formula as code (signature by kind, module docstring). ``None`` for a term that
        acts only through another's slots, and for the memory term.
    domain : callable, optional
        ``domain(p, t_first) -> str | None``: a message if the parameters are outside the
        formula's domain for times from ``t_first`` on (e.g. ``t0`` of ``C4/(t - t0)``).
    dfn : callable, optional
        The formula's partial derivatives (signature by kind, module docstring); ``None``
        exactly when ``fn`` is ``None`` or the term is a measurement term.
    always : bool
        Evaluate ``fn`` even when the term is absent, instead of testing its first slot
        for 0: for a cheap formula that is exactly 0 at its neutral slot values (its
        multiply-adds cost the kernel's step less than the branch: with viscous, Coulomb,
        quadratic drag and added mass ``always``, the fractional simulation is 2-3 % faster
        than with them tested, measured).
    shift : bool
        A measurement term that adds a constant to the angle (``theta_obs = theta + c``): its
        slope in theta is exactly 1, so the observed angular velocity is the model's
        (:meth:`pendtrack.models.registry.Model.observe_state` skips the difference quotient).
    limits : tuple of Limit
        Where the term is absent or reduces to a simpler one, beyond its amplitude at 0
        (:class:`Limit`).
    """

    name: str
    kind: str
    specs: tuple[ParamSpec, ...]
    formula: str
    equation: str
    slots: tuple[Slot, ...] = ()
    pack: Callable[[Mapping[str, float]], Mapping[str, float]] | None = None
    fn: Callable | None = None
    domain: Callable[[Mapping[str, float], float], str | None] | None = None
    always: bool = False
    dfn: Callable | None = None
    shift: bool = False
    limits: tuple[Limit, ...] = ()

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"term '{self.name}': unknown kind '{self.kind}' (kinds: {', '.join(KINDS)})")
        if self.kind in ("base", "smooth", "friction") and self.fn is None and self.slots:
            raise ValueError(f"term '{self.name}' has slots but no fn")
        if self.kind == "measurement" and (self.slots or self.pack is not None or self.fn is None):
            raise ValueError(f"measurement term '{self.name}' needs an fn and has no slots")
        if self.shift and self.kind != "measurement":
            raise ValueError(f"term '{self.name}': only a measurement term can be a shift")
        if self.kind in ("base", "smooth", "friction") and (self.fn is None) != (self.dfn is None):
            raise ValueError(f"term '{self.name}': an fn needs its derivative dfn (and only an fn has one)")

    @property
    def params(self) -> tuple[str, ...]:
        """Names of its parameters."""
        return tuple(s.name for s in self.specs)

    @property
    def amplitude(self) -> str | None:
        """The parameter that scales a physical term linearly (its first): at 0 the term vanishes.

        ``None`` for gravity and the measurement terms.
        """
        return self.specs[0].name if self.is_physical else None

    @property
    def has_memory(self) -> bool:
        """True for the Grunwald-Letnikov term (needs the history of omega)."""
        return self.kind == "memory"

    @property
    def is_physical(self) -> bool:
        """True if it enters the equation of motion (not a measurement term)."""
        return self.kind in PHYSICAL_KINDS

    def to_dict(self) -> dict[str, object]:
        return {"name": self.name, "params": list(self.params), "formula": self.formula,
                "equation": self.equation, "has_memory": self.has_memory}


class Layout:
    """The packed coefficient vector: every declared slot, base first, then term by term.

    Parameters
    ----------
    base : Term
        The always-present declaration (gravity).
    terms : iterable of Term
        The catalogue, in order.
    """

    def __init__(self, base: Term, terms: Iterable[Term]) -> None:
        self.terms: dict[str, Term] = {t.name: t for t in (base, *terms)}
        self.base = base
        names = [s.name for t in self.terms.values() for s in t.slots]
        if len(set(names)) != len(names):
            raise ValueError(f"two terms declare the same slot: {names}")
        self.index: dict[str, int] = {n: i for i, n in enumerate(names)}
        self.neutral: tuple[float, ...] = tuple(s.neutral for t in self.terms.values() for s in t.slots)
        self.size = len(names)
        for t in self.terms.values():
            if t.slots and t.pack is None:
                raise ValueError(f"term '{t.name}' has slots but no pack")

    def span(self, term: Term) -> tuple[int, int]:
        """``(lo, hi)``: the term's own slots are ``c[lo:hi]``."""
        if not term.slots:
            return (0, 0)
        lo = self.index[term.slots[0].name]
        return lo, lo + len(term.slots)

    def pack(self, term_names: Iterable[str], params: Mapping[str, float]) -> np.ndarray:
        """The coefficient vector of a model made of the base and ``term_names``.

        Parameters
        ----------
        term_names : iterable of str
            Terms of the model (measurement terms have no slots and are ignored).
        params : mapping
            Validated parameter values (including ``Omega0``).

        Returns
        -------
        numpy.ndarray
            float64, shape ``(size,)``.
        """
        return np.asarray(self._values(term_names, params), dtype=np.float64)

    def _values(self, term_names: Iterable[str], params: Mapping[str, object]) -> list:
        c: list = list(self.neutral)
        given: set[str] = set()
        for t in (self.base, *(self.terms[n] for n in term_names)):
            if t.pack is None:
                continue
            for slot, value in t.pack(params).items():
                i = self.index[slot]
                c[i] = (c[i] + value) if slot in given else value
                given.add(slot)
        return c

    def pack_jacobian(self, term_names: Iterable[str], params: Mapping[str, float],
                      names: Iterable[str]) -> np.ndarray:
        """``d c_k / d p_j``: the packed vector's derivatives with respect to the parameters ``names``.

        Complex-step differentiation of the declared :attr:`Term.pack` functions
        (``Im c(p + i eps e_j) / eps``, eps = 1e-30): exact to rounding, with no subtraction,
        for any arithmetic packing (``Omega0^2``, ``1/Omega0``, ``2 Omega0 C5`` ...).

        Parameters
        ----------
        term_names : iterable of str
            Terms of the model.
        params : mapping
            Validated parameter values (including ``Omega0``).
        names : iterable of str
            The parameters to differentiate by (each a key of ``params``).

        Returns
        -------
        numpy.ndarray
            float64, shape ``(size, len(names))`` [slot unit / parameter unit].
        """
        terms = tuple(term_names)
        names = tuple(names)
        out = np.zeros((self.size, len(names)))
        eps = 1e-30
        for j, name in enumerate(names):
            p = {k: complex(v) for k, v in params.items()}
            p[name] = p[name] + 1j * eps
            out[:, j] = [complex(v).imag / eps for v in self._values(terms, p)]
        return out
