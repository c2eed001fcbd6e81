"""Fitting physical models to a pendulum record, with the paper's and honest uncertainties.

Public API::

    fit_model(model, t, theta, omega, *, alpha=None, ok=None, window=None, n_starts=150, ...)
        -> FitResult                                 # arrays in; pendtrack.fitting.fitter
    predict(result, model, t) -> (theta, omega)        # the fitted model on any times
    score(result, model, t, theta, omega, *, window=...) -> WindowScore   # held-out cost
    cross_model_relations(classic, fractional) -> CrossModel             # G1 ~ C0/(4 Omega0^2), ...
    fit_two_cuboid(l1, omega0, sigma=None) -> TwoCuboidFit               # eq. consistencycheck
    Observation(savgol_window, savgol_order, smooth_theta)              # the data's filter

Modules: :mod:`~pendtrack.fitting.cost` (Xi^2, observation), :mod:`~pendtrack.fitting.problem`
(residuals on a window), :mod:`~pendtrack.fitting.estimates` (data-derived starts),
:mod:`~pendtrack.fitting.multistart` (growing-window multi-start least squares, parallel),
:mod:`~pendtrack.fitting.uncertainty` (paper's 5/4 spread, HAC sandwich, bootstrap),
:mod:`~pendtrack.fitting.result`, :mod:`~pendtrack.fitting.cross_model`,
:mod:`~pendtrack.fitting.two_cuboid`.

Importing this package is cheap: numba and the solvers are loaded on first use.
"""

from __future__ import annotations

from pendtrack.fitting.cost import COSTS, Observation
from pendtrack.fitting.cross_model import CrossModel, Relation, cross_model_relations
from pendtrack.fitting.fitter import build_problem, fit_model
from pendtrack.fitting.predict import WindowScore, predict, score
from pendtrack.fitting.result import FitResult, ParamEstimate
from pendtrack.fitting.two_cuboid import TwoCuboidFit, fit_two_cuboid

__all__ = [
    "COSTS", "CrossModel", "FitResult", "Observation", "ParamEstimate", "Relation", "TwoCuboidFit",
    "WindowScore", "build_problem", "cross_model_relations", "fit_model", "fit_two_cuboid", "predict", "score",
]
