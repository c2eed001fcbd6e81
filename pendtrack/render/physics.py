"""Which model drives the virtual pendulum, with which parameters, and how it is sampled.

The dynamics are :mod:`pendtrack.models`' (no model is written here). This module only
chooses parameter values the user did not give (realistic magnitudes for the paper's
apparatus) and wraps :func:`pendtrack.models.simulate` into the ``simulate(t)`` callable
that :func:`pendtrack.render.motion.sample_motion` evaluates.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING

import numpy as np

from pendtrack.apparatus import two_cuboid_omega0
from pendtrack.errors import ConfigError, ModelError
from pendtrack.render.motion import Simulator

if TYPE_CHECKING:
    from pendtrack.models import Model

#: Parameters a rendered pendulum gets unless the user sets them (Omega0 comes from the
#: apparatus, see :func:`resolve_params`). Magnitudes follow the paper: Coulomb friction
#: ~0.01 rad/s^2, OPA values of its run 09la1, fractional values from its relations
#: G1 ~ C0/(4 Omega0^2), G2 ~ C3/(2^(2-p) Omega0^2), p_f - beta ~ p.
DEFAULT_PARAMS: dict[str, dict[str, float]] = {
    "standard": {"C1": 0.01, "C0": 0.01, "C2": 0.002},
    "classic": {"C0": 0.01, "C3": 0.02, "p": 1.5, "Ca": 0.01},
    "opa": {"C4": 3.25, "t0": -8.85, "C5": 1.57e-3},
    "fractional": {"G1": 1e-4, "G2": 5e-4, "beta": 0.5, "p_f": 2.0},
    "inertial": {"Ca": 0.01},
}

FINE_STEPS_PER_FRAME = 16  # models with memory: integration steps per frame interval


def parse_params(items: Iterable[str]) -> dict[str, float]:
    """``["C0=0.01", "Omega0=5"]`` -> ``{"C0": 0.01, "Omega0": 5.0}``.

    Raises
    ------
    ConfigError
        An item without ``=``, an empty name, a value that is not a number, or a name
        given twice.
    """
    out: dict[str, float] = {}
    for item in items:
        name, sep, value = str(item).partition("=")
        name = name.strip()
        if not sep or not name:
            raise ConfigError(f"model parameter {item!r} must look like NAME=VALUE")
        try:
            number = float(value)
        except ValueError:
            raise ConfigError(f"model parameter '{name}' must be a number, got {value.strip()!r}") from None
        if name in out:
            raise ConfigError(f"model parameter '{name}' is given twice")
        out[name] = number
    return out


def resolve_params(model_name: str, given: Mapping[str, float], *, tile_length_m: float, x: float, l0_m: float,
                   gravity: float) -> tuple[Model, dict[str, float]]:
    """The model and its full, validated parameter set.

    ``model_name`` is a registered model or a composed one, ``"<baseline>+<term>+..."``
    (:func:`pendtrack.models.get_model`, e.g. ``"standard+memory"``); measurement terms
    (``offset``, ``angle_scale``) are refused: they describe the camera, not the pendulum.

    ``Omega0`` defaults to the apparatus' ``two_cuboid_omega0(l1, x, l0, g)`` (``l1 = 0``
    without a tile); other parameters to :data:`DEFAULT_PARAMS`; ``given`` wins.

    Returns
    -------
    model : pendtrack.models.Model
    params : dict of str to float

    Raises
    ------
    ModelError
        Unknown model, a measurement term, unknown parameter, a missing one (model without
        defaults) or a value out of its physical range.
    """
    from pendtrack.models import get_model

    model = get_model(str(model_name))  # a built-in or composed name, normalised to catalogue order
    base_name = model.name.split("+")[0]
    if model.measurement_terms:
        # a measurement term describes the camera's reading of the angle, not the pendulum: the
        # renderer draws the pendulum, and its tracked angle carries whatever the camera does
        raise ModelError(f"model '{model.name}': measurement terms ({', '.join(model.measurement_terms)}) cannot be "
                         f"rendered: they describe how a camera reads the angle, not the pendulum; render "
                         f"'{model.physics_name}' and fit with the measurement term")
    params = {"Omega0": float(two_cuboid_omega0(tile_length_m, x=x, l0=l0_m, g=gravity))}
    # a composed model ("standard+memory"): its baseline's defaults, then each added term's
    # parameters from the first built-in model that has them (G2, beta, p_f from fractional, ...)
    for defaults in (DEFAULT_PARAMS.get(base_name, {}), *DEFAULT_PARAMS.values()):
        for k, v in defaults.items():
            params.setdefault(k, v)
    params = {k: v for k, v in params.items() if k in model.param_names}
    unknown = [k for k in given if k not in model.param_names]
    if unknown:
        raise ModelError(f"model '{model.name}' has no parameter '{unknown[0]}' "
                         f"(its parameters: {', '.join(model.param_names)})")
    params.update(given)
    return model, model.validate(params)


def string_omega0(*, length_m: float, radius_m: float, gravity: float) -> float:
    """Small-angle angular frequency [rad/s] of a solid ball on a massless string.

    The ball's centre at ``length_m`` [m] from the axle, radius ``radius_m`` [m]:
    ``Omega0^2 = g L / (L^2 + 2 R^2 / 5)`` (a physical pendulum; ``sqrt(g/L)`` as R -> 0).
    """
    return float(np.sqrt(gravity * length_m / (length_m**2 + 0.4 * radius_m**2)))


def model_simulator(model: Model, params: Mapping[str, float], *, theta0: float, omega0: float,
                    fps: float) -> Simulator:
    """``simulate(t) -> (theta, omega)`` for ascending ``t`` [s] starting at 0.

    Memory-free models use the models' ``"reference"`` integrator (DOP853, rtol 1e-10,
    friction sign changes as events) sampled exactly at ``t``. Models with memory have
    no reference integrator: they run the ``"fast"`` predictor-corrector on a uniform
    grid of ``FINE_STEPS_PER_FRAME`` steps per frame interval (frame times lie on it)
    and are interpolated to ``t`` by cubic Hermite splines (theta with omega, omega with
    alpha as derivatives).
    """
    from pendtrack.models import simulate

    def run(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        t = np.asarray(t, dtype=float)
        if model.has_memory:
            h = 1.0 / (fps * FINE_STEPS_PER_FRAME)
            n = int(np.ceil(t[-1] / h - 1e-9)) + 1
            grid = h * np.arange(max(n, 2))
            sim = simulate(model, params, grid, theta0=theta0, omega0=omega0, method="fast")
            from scipy.interpolate import CubicHermiteSpline

            theta = CubicHermiteSpline(grid, sim.theta, sim.omega)(t)
            omega = CubicHermiteSpline(grid, sim.omega, sim.alpha)(t)
            return theta, omega
        tt = t if t.size >= 2 else np.array([t[0], t[0] + 1.0 / fps])
        sim = simulate(model, params, tt, theta0=theta0, omega0=omega0, method="reference")
        return np.array(sim.theta[:t.size]), np.array(sim.omega[:t.size])

    return run
