"""The paper's models, built from declared terms (one declaration each, :mod:`.terms`), and their solvers.

Public API::

    from pendtrack.models import get_model, list_models, compose, simulate, simulate_packed
    sim = simulate(get_model("standard"), {"Omega0": 5.05, "C0": 0.01, "C1": 0.01, "C2": 0.002},
                   t, theta0=3.0, omega0=0.0, method="reference")
    sim.t, sim.theta, sim.omega, sim.alpha

Importing this package compiles nothing and does not import numba or scipy.
"""

from pendtrack.models.registry import Model, compose, get_model, list_models
from pendtrack.models.simulate import SimResult, simulate, simulate_packed
from pendtrack.models.terms import CATALOGUE, MEASUREMENT_TERMS, PARAMS, TERMS, ParamSpec, Term

__all__ = [
    "Model", "compose", "get_model", "list_models", "SimResult", "simulate", "simulate_packed",
    "CATALOGUE", "MEASUREMENT_TERMS", "PARAMS", "TERMS", "ParamSpec", "Term",
]
