"""Fitting physical models to a pendulum record, with the paper's and honest uncertainties.

Public API::

    fit_model(model, t, theta, omega, *, options=FitConfig(), model_options=ModelsConfig(),
              alpha=None, ok=None, window=None, observation=None, ...)
        -> FitResult                                 # arrays in; pendtrack.fitting.fitter
    fit_models(models, t, theta, omega, *, alpha, ok, provenance_extra, provenance_config, options,
               model_options, source, progress) -> ModelFits   # what `fit` and pt.fit write
    predict(result, model, t) -> (theta, omega)        # the fitted model on any times
    score(result, model, t, theta, omega, *, window=...) -> WindowScore   # held-out cost
    cross_model_relations(classic, fractional) -> CrossModel             # G1 ~ C0/(4 Omega0^2), ...
    fit_two_cuboid(l1, omega0, sigma=None) -> TwoCuboidFit               # eq. consistencycheck
    Observation(savgol_window, savgol_order, smooth_theta)              # the data's filter

The steps of :func:`fit_model`, each a module: :mod:`~pendtrack.fitting.estimate` ->
:mod:`~pendtrack.fitting.search` -> :mod:`~pendtrack.fitting.refine` ->
:mod:`~pendtrack.fitting.uncertainty` (:func:`~pendtrack.fitting.uncertainty.assess`) ->
:mod:`~pendtrack.fitting.result` (:func:`~pendtrack.fitting.result.build_result`).
Building blocks: :mod:`~pendtrack.fitting.leastsq.samples` (usable samples, grid, :func:`build_problem`),
:mod:`~pendtrack.fitting.leastsq.cost` (Xi^2, observation), :mod:`~pendtrack.fitting.leastsq.problem` (residuals
on a window), :mod:`~pendtrack.fitting.leastsq.equation_error` (equation-error estimates),
:mod:`~pendtrack.fitting.leastsq.local_fits` (local fits over growing windows, parallel),
:mod:`~pendtrack.fitting.leastsq.profile` (profile polish and profile sigmas), :mod:`~pendtrack.fitting.leastsq.lm`,
:mod:`~pendtrack.fitting.cross_model`, :mod:`~pendtrack.fitting.two_cuboid`.

Importing this package is cheap: numba and the solvers are loaded on first use.
"""

from __future__ import annotations

from pendtrack.fitting.leastsq.cost import COSTS, Observation
from pendtrack.fitting.cross_model import CrossModel, Relation, cross_model_relations
from pendtrack.fitting.fitter import check_options, fit_model
from pendtrack.fitting.models_fit import ModelFits, fit_models
from pendtrack.fitting.predict import WindowScore, predict, score
from pendtrack.fitting.leastsq.samples import Record, build_problem, check_record
from pendtrack.fitting.result import FitResult, ParamEstimate
from pendtrack.fitting.two_cuboid import TwoCuboidFit, fit_two_cuboid

__all__ = [
    "COSTS", "CrossModel", "FitResult", "ModelFits", "Observation", "ParamEstimate", "Relation", "TwoCuboidFit",
    "Record", "WindowScore", "build_problem", "check_options", "check_record", "cross_model_relations", "fit_model",
    "fit_models", "fit_two_cuboid", "predict", "score",
]
