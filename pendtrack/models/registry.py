"""Models as compositions of named terms, and the registry other packages use.

Everything a model knows about its terms -- parameters, ranges, packing, the observation --
comes from their declarations in :mod:`pendtrack.models.terms`. A model may also hold
measurement terms (``compose("standard", ["offset"])``): they add parameters and enter
:meth:`Model.observe`, not the equation of motion.

>>> from pendtrack.models import get_model
>>> m = get_model("standard")
>>> m.param_names
('Omega0', 'C1', 'C0', 'C2')

Built-in models (parameter names as in the paper):

``inertial``   eq. nullmodel: added mass only (closed form eq. pureinertialsolut).
``standard``   eq. standarddiss: viscous + Coulomb + quadratic drag.
``classic``    eq. classicmodel: Coulomb + power-law drag + added mass.
``opa``        eq. newDNHM: time-varying damping C4 omega/(t - t0) + Coulomb 2 Omega0 C5.
``fractional`` eq. ourfinalmodel: quarter-power friction G1 + GL memory (G2, beta, p_f).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from pendtrack.errors import ModelError
from pendtrack.models.declare import ParamSpec
from pendtrack.models.rhs import accel_packed
from pendtrack.models.terms import BASE, CATALOGUE, LAYOUT, PARAMS


#: Half-step of the central difference that gives the observation's slope d theta_obs/d theta [rad]:
#: exact for an affine observation (offset) up to rounding (~1e-16 |theta|/1e-4 = 1e-12 relative),
#: and off by k_scale * 1e-8 for the cubic angle scale (its third derivative is 6 k_scale): both far
#: below a tracked angle's noise (~1e-3 relative).
OBSERVE_FD_STEP = 1e-4


@dataclass(frozen=True)
class Model:
    """A model: ``alpha + Omega0^2 sin(theta) = sum of terms``.

    Attributes
    ----------
    name : str
        Registry name (or ``baseline+term+...`` for a composed model).
    terms : tuple of str
        Term names from :data:`pendtrack.models.terms.CATALOGUE` (physical and measurement
        terms), in catalogue order.
    description : str
        One line with the paper's equation.
    """

    name: str
    terms: tuple[str, ...]
    description: str = ""

    @cached_property  # asked for on every model evaluation of a fit
    def param_names(self) -> tuple[str, ...]:
        """Ordered parameter names: ``Omega0`` then each term's, in catalogue order."""
        used = set(BASE.params)
        for t in self.terms:
            used.update(CATALOGUE[t].params)
        return tuple(n for n in PARAMS if n in used)

    @property
    def physical_terms(self) -> tuple[str, ...]:
        """The terms of the equation of motion."""
        return tuple(t for t in self.terms if CATALOGUE[t].is_physical)

    @cached_property  # asked for on every model evaluation of a fit
    def measurement_terms(self) -> tuple[str, ...]:
        """The terms of the observation (``theta_obs = f(theta, params)``), applied in this order."""
        return tuple(t for t in self.terms if CATALOGUE[t].kind == "measurement")

    @cached_property
    def _observes_by_shifts(self) -> bool:
        """Every measurement term is a shift of the angle (its slope exactly 1)."""
        return all(CATALOGUE[t].shift for t in self.measurement_terms)

    def physics(self) -> "Model":
        """The model without its measurement terms (the equation of motion alone)."""
        if not self.measurement_terms:
            return self
        return Model(name=self.physics_name, terms=self.physical_terms, description=self.description)

    @property
    def physics_name(self) -> str:
        """The name without the measurement terms' parts (``standard+offset`` -> ``standard``)."""
        parts = [p for p in self.name.split("+") if p not in self.measurement_terms]
        return "+".join(parts) if parts else self.name

    @property
    def bounds(self) -> dict[str, tuple[float, float]]:
        """Physical ``(low, high)`` per parameter (see :meth:`param_spec` for open/closed)."""
        return {n: (PARAMS[n].low, PARAMS[n].high) for n in self.param_names}

    def param_spec(self, name: str) -> ParamSpec:
        """Unit, range and meaning of one parameter."""
        if name not in self.param_names:
            raise ModelError(f"model '{self.name}' has no parameter '{name}' (has {', '.join(self.param_names)})")
        return PARAMS[name]

    @cached_property  # asked for on every model evaluation of a fit
    def has_memory(self) -> bool:
        """True if a term needs the history (the fractional GL term)."""
        return any(CATALOGUE[t].has_memory for t in self.terms)

    def validate(self, params: Mapping[str, float]) -> dict[str, float]:
        """Check a parameter dict and return it as plain floats in ``param_names`` order.

        Raises
        ------
        ModelError
            Unknown or missing parameter, a value that is not a finite number (``t0`` may
            not be infinite either) or outside its physical range.
        """
        unknown = [k for k in params if k not in self.param_names]
        if unknown:
            raise ModelError(f"model '{self.name}' has no parameter '{unknown[0]}' "
                             f"(its parameters: {', '.join(self.param_names)})")
        missing = [k for k in self.param_names if k not in params]
        if missing:
            raise ModelError(f"model '{self.name}' needs parameter '{missing[0]}' "
                             f"(its parameters: {', '.join(self.param_names)})")
        out: dict[str, float] = {}
        for name in self.param_names:
            raw = params[name]
            try:
                value = float(raw)
            except (TypeError, ValueError):
                raise ModelError(f"parameter '{name}' of model '{self.name}' must be a number, got {raw!r}") from None
            spec = PARAMS[name]
            if not math.isfinite(value) or not spec.contains(value):
                raise ModelError(f"parameter '{name}' of model '{self.name}' = {value!r} is outside its physical "
                                 f"range {spec.range_text()} ({spec.description})")
            out[name] = value
        return out

    def pack(self, params: Mapping[str, float], *, validated: bool = False) -> np.ndarray:
        """Validate ``params`` and pack them into the kernels' coefficient vector.

        ``validated``: ``params`` is already :meth:`validate`'s output (a fit's hot path validates
        once per evaluation and passes the result on).

        Returns
        -------
        numpy.ndarray
            float64, shape ``(terms.N_COEFFS,)``; layout ``terms.K_*``.
        """
        return LAYOUT.pack(self.terms, params if validated else self.validate(params))

    def check_domain(self, params: Mapping[str, float], t_first: float) -> None:
        """Raise if validated ``params`` are outside a term's domain for times from ``t_first`` [s] on.

        Raises
        ------
        ModelError
            E.g. ``t0 >= t_first`` for the ``C4/(t - t0)`` damping.
        """
        for t in self.terms:
            check = CATALOGUE[t].domain
            problem = None if check is None else check(params, t_first)
            if problem:
                raise ModelError(f"model '{self.name}': {problem}")

    def observe(self, theta: np.ndarray, params: Mapping[str, float]) -> np.ndarray:
        """The observed angle ``theta_obs = f(theta, params)`` [rad] of the model's angle ``theta``.

        The measurement terms applied in catalogue order (``offset`` then ``angle_scale``:
        ``theta_obs = (theta + theta_off)(1 + k_scale (theta + theta_off)^2)``); the identity
        when the model has none.

        Parameters
        ----------
        theta : numpy.ndarray
            The model's angle [rad] (e.g. ``simulate(...).theta``).
        params : mapping
            The model's parameters (validated; measurement parameters included).

        Returns
        -------
        numpy.ndarray
            float64, the shape of ``theta`` [rad].
        """
        return self._observe(np.asarray(theta, dtype=np.float64), self.validate(params))

    def observe_state(self, theta: np.ndarray, omega: np.ndarray, params: Mapping[str, float], *,
                      validated: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """The observed angle and angular velocity of the model's ``(theta, omega)``.

        ``theta_obs = f(theta)`` as in :meth:`observe`, and ``omega_obs = d theta_obs/dt =
        f'(theta) omega``, with ``f'`` a central difference of the composed observation over
        +-:data:`OBSERVE_FD_STEP`: derived from the declarations (no term declares a
        derivative); exactly 1 when every measurement term is a shift (``Term.shift``). The identity (the same arrays) when the model has no measurement term.

        Parameters
        ----------
        theta, omega : numpy.ndarray
            The model's angle [rad] and angular velocity [rad/s].
        params : mapping
            The model's parameters (measurement parameters included).
        validated : bool
            ``params`` is already :meth:`validate`'s output.

        Returns
        -------
        theta_obs, omega_obs : numpy.ndarray
            [rad], [rad/s].
        """
        if not self.measurement_terms:
            return theta, omega
        p = params if validated else self.validate(params)
        theta = np.asarray(theta, dtype=np.float64)
        if self._observes_by_shifts:
            return self._observe(theta, p), np.asarray(omega, dtype=np.float64)
        d = OBSERVE_FD_STEP
        slope = (self._observe(theta + d, p) - self._observe(theta - d, p)) / (2.0 * d)
        return self._observe(theta, p), slope * np.asarray(omega, dtype=np.float64)

    def _observe(self, theta: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
        out = theta
        for name in self.measurement_terms:
            term = CATALOGUE[name]
            out = term.fn(out, tuple(p[n] for n in term.params))
        return out

    def accel(self, params: Mapping[str, float], theta: np.ndarray, omega: np.ndarray, t: np.ndarray, *,
              memory_s: float | None = None, full_history: bool = False) -> np.ndarray:
        """The model's angular acceleration alpha(theta, omega, t, [history]) [rad/s^2].

        For equation-error use: evaluates the right-hand side on given (e.g. measured)
        series; measurement terms do not enter. See :func:`pendtrack.models.rhs.accel_packed`
        for the memory conventions.
        """
        p = self.validate(params)
        t_arr = np.asarray(t, dtype=np.float64)
        if t_arr.size:
            self.check_domain(p, float(np.fmin.reduce(t_arr, axis=None)))  # NaN times are no earlier
        return accel_packed(LAYOUT.pack(self.terms, p), theta, omega, t_arr, memory_s=memory_s, full_history=full_history)

    def to_dict(self) -> dict[str, object]:
        return {"name": self.name, "terms": list(self.terms), "param_names": list(self.param_names),
                "has_memory": self.has_memory, "description": self.description,
                "bounds": {k: [v[0], v[1]] for k, v in self.bounds.items()}}


def _make(name: str, term_names: Iterable[str], description: str) -> Model:
    names = tuple(term_names)
    for t in names:
        if t not in CATALOGUE:
            raise ModelError(f"unknown term '{t}' (known terms: {', '.join(CATALOGUE)})")
    if len(set(names)) != len(names):
        raise ModelError(f"model '{name}' lists a term twice: {', '.join(names)}")
    order = list(CATALOGUE)
    return Model(name=name, terms=tuple(sorted(names, key=order.index)), description=description)


_BUILTIN: dict[str, tuple[tuple[str, ...], str]] = {
    "inertial": (("added_mass",), "alpha + (Omega0^2 - Ca omega^2) sin(theta) = 0 (eq. nullmodel)"),
    "standard": (("viscous", "coulomb", "quadratic_drag"),
                 "alpha + Omega0^2 sin(theta) = -C1 omega - sgn(omega)(C0 + C2 omega^2) (eq. standarddiss)"),
    "classic": (("coulomb", "power_drag", "added_mass"),
                "alpha + Omega0^2 sin(theta) = Ca omega^2 sin(theta) - sgn(omega)(C0 + C3|omega/Omega0|^p) "
                "(eq. classicmodel)"),
    "opa": (("time_varying_damping", "opa_coulomb"),
            "d omega/dt + 2 Omega0 C5 sgn(omega) + C4 omega/(t - t0) + Omega0^2 sin(theta) = 0 (eq. newDNHM)"),
    "fractional": (("quarter_friction", "memory"),
                   "dA/dt* + sin(theta)/4 = -G1 |A|^(1/4) sgn(A) - G2 D^beta_{t*}(A|A|^(p_f-1)), "
                   "A = omega/(2 Omega0), t* = 2 Omega0 t (eq. ourfinalmodel)"),
}


def list_models() -> tuple[str, ...]:
    """Names of the built-in models."""
    return tuple(_BUILTIN)


def get_model(name: str) -> Model:
    """The model called ``name``: a built-in one, or a composed ``baseline+term+term``.

    A composed name is a built-in baseline and catalogue terms (physical or measurement), in
    any order (``standard+offset+memory``); the model is :func:`compose` of them, named in
    catalogue order (``standard+memory+offset``), so one model has one name.

    Raises
    ------
    ModelError
        An unknown baseline or term (the message names it and lists the known models and
        terms), a term twice or already in the baseline.
    """
    if isinstance(name, Model):
        return name
    if name in _BUILTIN:
        term_names, description = _BUILTIN[name]
        return _make(name, term_names, description)
    parts = [p.strip() for p in str(name).split("+")]
    known = f"known models: {', '.join(_BUILTIN)}; known terms: {', '.join(CATALOGUE)}"
    if len(parts) == 1:
        raise ModelError(f"unknown model '{name}' ({known}; or compose them: baseline+term+...)")
    baseline, extra = parts[0], parts[1:]
    if baseline not in _BUILTIN:
        what = "a term, not a model: put a model first" if baseline in CATALOGUE else "unknown model"
        raise ModelError(f"model '{name}': '{baseline}' is {what} ({known})")
    for part in extra:
        if part not in CATALOGUE:
            raise ModelError(f"model '{name}': unknown term '{part}' ({known})")
    order = list(CATALOGUE)
    extra = sorted(extra, key=order.index)
    return compose(baseline, extra, name="+".join((baseline, *extra)))


def compose(baseline: str | Model, extra_terms: Iterable[str], *, name: str | None = None) -> Model:
    """A model made of a baseline's terms plus named extra terms.

    Parameters
    ----------
    baseline : str or Model
        Built-in model name or a model.
    extra_terms : iterable of str
        Term names from the catalogue (physical or measurement terms); a term already in
        the baseline is an error.
    name : str, optional
        Name of the new model; default ``"<baseline>+<term>+..."``.
    """
    base = get_model(baseline) if isinstance(baseline, str) else baseline
    extra = tuple(extra_terms)
    for t in extra:
        if t not in CATALOGUE:
            raise ModelError(f"unknown term '{t}' (known terms: {', '.join(CATALOGUE)})")
        if t in base.terms:
            raise ModelError(f"term '{t}' is already in model '{base.name}'")
    new_name = name or "+".join((base.name, *extra))
    return _make(new_name, base.terms + extra, f"{base.name} plus {', '.join(extra) or 'nothing'}")
