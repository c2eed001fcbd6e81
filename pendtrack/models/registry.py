"""Models as compositions of named terms, and the registry other packages use.

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
from pendtrack.models import terms as T
from pendtrack.models.terms import PARAMS, TERMS, ParamSpec


@dataclass(frozen=True)
class Model:
    """A model: ``alpha + Omega0^2 sin(theta) = sum of terms``.

    Attributes
    ----------
    name : str
        Registry name (or ``baseline+term+...`` for a composed model).
    terms : tuple of str
        Term names from :data:`pendtrack.models.terms.TERMS`, in catalogue order.
    description : str
        One line with the paper's equation.
    """

    name: str
    terms: tuple[str, ...]
    description: str = ""

    @cached_property  # asked for on every model evaluation of a fit
    def param_names(self) -> tuple[str, ...]:
        """Ordered parameter names: ``Omega0`` then each term's, in catalogue order."""
        used = {"Omega0"}
        for t in self.terms:
            used.update(TERMS[t].params)
        return tuple(n for n in PARAMS if n in used)

    @property
    def bounds(self) -> dict[str, tuple[float, float]]:
        """Physical ``(low, high)`` per parameter (see :meth:`param_spec` for open/closed)."""
        return {n: (PARAMS[n].low, PARAMS[n].high) for n in self.param_names}

    def param_spec(self, name: str) -> ParamSpec:
        """Unit, range and meaning of one parameter."""
        if name not in self.param_names:
            raise ModelError(f"model '{self.name}' has no parameter '{name}' (has {', '.join(self.param_names)})")
        return PARAMS[name]

    @property
    def has_memory(self) -> bool:
        """True if a term needs the history (the fractional GL term)."""
        return any(TERMS[t].has_memory for t in self.terms)

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

    def pack(self, params: Mapping[str, float]) -> np.ndarray:
        """Validate ``params`` and pack them into the kernels' coefficient vector.

        Returns
        -------
        numpy.ndarray
            float64, shape ``(terms.N_COEFFS,)``; layout ``terms.K_*``.
        """
        p = self.validate(params)
        c = T.empty_coeffs()
        w0 = p["Omega0"]
        c[T.K_SIN] = w0 * w0
        present = set(self.terms)
        if "viscous" in present:
            c[T.K_VISC] = p["C1"]
        if "coulomb" in present:
            c[T.K_COUL] += p["C0"]
        if "opa_coulomb" in present:
            c[T.K_COUL] += 2.0 * w0 * p["C5"]
        if "quadratic_drag" in present:
            c[T.K_QUAD] = p["C2"]
        if "power_drag" in present:
            c[T.K_POW] = p["C3"]
            c[T.K_POW_EXP] = p["p"]
            c[T.K_POW_SCALE] = 1.0 / w0
        if "added_mass" in present:
            c[T.K_ADDED] = p["Ca"]
        if "time_varying_damping" in present:
            c[T.K_TV] = p["C4"]
            c[T.K_TV_T0] = p["t0"]
        if "quarter_friction" in present:
            c[T.K_QUARTER] = 4.0 * w0 * w0 * p["G1"]
            c[T.K_QUARTER_SCALE] = 1.0 / (2.0 * w0)
        if "memory" in present:
            c[T.K_MEM] = 4.0 * w0 * w0 * p["G2"]
            c[T.K_BETA] = p["beta"]
            c[T.K_PF] = p["p_f"]
            c[T.K_MEM_U] = 2.0 * w0
            c[T.K_TSCALE] = 2.0 * w0
            c[T.K_HAS_MEMORY] = 1.0
        return np.asarray(c, dtype=np.float64)

    def accel(self, params: Mapping[str, float], theta: np.ndarray, omega: np.ndarray, t: np.ndarray, *,
              memory_s: float | None = None, full_history: bool = False) -> np.ndarray:
        """The model's angular acceleration alpha(theta, omega, t, [history]) [rad/s^2].

        For equation-error use: evaluates the right-hand side on given (e.g. measured)
        series. See :func:`pendtrack.models.rhs.model_accel` for the memory conventions.
        """
        from pendtrack.models.rhs import model_accel

        return model_accel(self, params, theta, omega, t, memory_s=memory_s, full_history=full_history)

    def to_dict(self) -> dict[str, object]:
        return {"name": self.name, "terms": list(self.terms), "param_names": list(self.param_names),
                "has_memory": self.has_memory, "description": self.description,
                "bounds": {k: [v[0], v[1]] for k, v in self.bounds.items()}}


def _make(name: str, term_names: Iterable[str], description: str) -> Model:
    names = tuple(term_names)
    for t in names:
        if t not in TERMS:
            raise ModelError(f"unknown term '{t}' (known terms: {', '.join(TERMS)})")
    if len(set(names)) != len(names):
        raise ModelError(f"model '{name}' lists a term twice: {', '.join(names)}")
    order = list(TERMS)
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
    """The built-in model called ``name``.

    Raises
    ------
    ModelError
        If there is no such model.
    """
    if isinstance(name, Model):
        return name
    if name not in _BUILTIN:
        raise ModelError(f"unknown model '{name}' (known models: {', '.join(_BUILTIN)})")
    term_names, description = _BUILTIN[name]
    return _make(name, term_names, description)


def compose(baseline: str | Model, extra_terms: Iterable[str], *, name: str | None = None) -> Model:
    """A model made of a baseline's terms plus named extra terms.

    Parameters
    ----------
    baseline : str or Model
        Built-in model name or a model.
    extra_terms : iterable of str
        Term names from the catalogue; a term already in the baseline is an error.
    name : str, optional
        Name of the new model; default ``"<baseline>+<term>+..."``.
    """
    base = get_model(baseline) if isinstance(baseline, str) else baseline
    extra = tuple(extra_terms)
    for t in extra:
        if t not in TERMS:
            raise ModelError(f"unknown term '{t}' (known terms: {', '.join(TERMS)})")
        if t in base.terms:
            raise ModelError(f"term '{t}' is already in model '{base.name}'")
    new_name = name or "+".join((base.name, *extra))
    return _make(new_name, base.terms + extra, f"{base.name} plus {', '.join(extra) or 'nothing'}")
