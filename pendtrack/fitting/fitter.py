"""Fit a model to a record: :func:`fit_model` (arrays in, :class:`FitResult` out).

An output-error fit (see :mod:`pendtrack.fitting.leastsq.cost` for the cost) in five steps, each a
function of its own module:

1. **estimate** (:func:`pendtrack.fitting.estimate.estimate`): the usable samples on the
   simulation grid, the model-free facts and the data-derived estimates, the start ranges;
2. **search** (:func:`pendtrack.fitting.search.search`): ``n_starts`` seeded starts around the
   estimates, each a growing-window least-squares fit, in parallel;
3. **refine** (:func:`pendtrack.fitting.refine.refine`): the best start finished (continued if
   its budget ran out, profile polish along beta for models with memory, optionally a
   trust-region polish);
4. **uncertainty** (:func:`pendtrack.fitting.uncertainty.assess`): the paper's 5/4 spread, the
   sandwich standard errors, the smoothness check, optionally profile sigmas and a bootstrap;
5. **result** (:func:`pendtrack.fitting.result.build_result`): rms, AIC/BIC, the verdict.

Every option of the method is a field of :class:`pendtrack.config.FitConfig` (``[fit]`` of the
config) or :class:`pendtrack.config.ModelsConfig` (``[models]``): a library call and the CLI
with the defaults run the same fit.

The paper used simulated annealing (``amebsa``); multi-start bounded Levenberg-Marquardt least
squares on the residual vector (:mod:`pendtrack.fitting.leastsq.lm`) is the modern equivalent: each start
descends to the bottom of its basin with far fewer model evaluations, and the many starts search
for the global minimum.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from pendtrack.config import FIT_COORDINATES, FitConfig, ModelsConfig
from pendtrack.errors import FitError
from pendtrack.fitting.leastsq.cost import COSTS, Observation
from pendtrack.fitting.estimate import Setup, estimate
from pendtrack.fitting.leastsq.problem import JACOBIANS, Simulator
from pendtrack.fitting.leastsq.samples import Record
from pendtrack.fitting.refine import refine
from pendtrack.fitting.result import FitResult, build_result
from pendtrack.fitting.search import search
from pendtrack.fitting.uncertainty import assess, scale_shift
from pendtrack.parallel import ProcessPool


def check_options(options: FitConfig, *, source: str = "the data") -> None:
    """FitError if ``options`` cannot run a fit (unknown cost, Jacobian or coordinates, no start, 5/4 rule or hopeless ratio below 1)."""
    if options.cost not in COSTS:
        raise FitError(f"unknown cost '{options.cost}' (use {' or '.join(COSTS)})", path=source)
    if options.jacobian not in JACOBIANS:
        raise FitError(f"unknown jacobian '{options.jacobian}' (use {' or '.join(JACOBIANS)})", path=source)
    if options.coordinates not in FIT_COORDINATES:
        raise FitError(f"unknown coordinates '{options.coordinates}' (use {' or '.join(FIT_COORDINATES)})",
                       path=source)
    if options.n_starts < 1:
        raise FitError(f"n_starts must be >= 1, got {options.n_starts}", path=source)
    if options.accept_ratio < 1:
        raise FitError(f"accept_ratio must be >= 1, got {options.accept_ratio}", path=source)
    for key in ("hopeless_ratio", "hopeless_ratio_memory"):
        if 0 < getattr(options, key) < 1:
            raise FitError(f"{key} must be 0 (off) or >= 1, got {getattr(options, key)}", path=source)


def fit_model(model: Any, t: np.ndarray, theta: np.ndarray, omega: np.ndarray, *,
              options: FitConfig | None = None, model_options: ModelsConfig | None = None,
              alpha: np.ndarray | None = None, ok: np.ndarray | None = None,
              window: tuple[float, float] | None = None, observation: Observation | None = None,
              fixed: Mapping[str, float] | None = None, initial: Mapping[str, float] | None = None,
              extra_starts: Sequence[Mapping[str, float]] = (), seed: int | None = None,
              workers: int | None = None, simulator: Simulator | None = None, method: str = "auto",
              on_progress: Callable[[int], None] | None = None, source: str = "the data",
              pool: ProcessPool | None = None, theta_scale_rel: float = 0.0,
              cost_out: np.ndarray | None = None) -> FitResult:
    """Fit ``model`` to a record by output error, with the paper's uncertainties and better ones.

    Parameters
    ----------
    model : Model
        From :func:`pendtrack.models.get_model` or :func:`pendtrack.models.compose`.
    t, theta, omega : ndarray
        Sample times [s] (uniformly spaced, samples may be missing), measured angle [rad] and
        angular velocity [rad/s]: as in :class:`pendtrack.fitting.leastsq.samples.Record`.
    options : FitConfig, optional
        The method (``[fit]`` of the config): cost, starts, 5/4 rule, start spreads, start
        budget, growing windows, trust-region polish, profile sigmas, bootstrap; default
        ``FitConfig()``, the defaults of ``pendtrack fit``. Its ``models`` field is not used.
    model_options : ModelsConfig, optional
        The memory of models with the memory term (``[models]``); default ``ModelsConfig()``.
    alpha : ndarray, optional
        Measured angular acceleration [rad/s^2], used only for the estimates; default
        ``gradient(omega, t)``.
    ok : ndarray of bool, optional
        Usable samples (default: every finite one).
    window : (float, float), optional
        Only samples with ``window[0] <= t <= window[1]`` enter the fit [s] (held-out tests);
        the initial state is fitted at the first of them.
    observation : Observation, optional
        How the data were filtered (so the model is filtered alike); default none.
    fixed : mapping, optional
        Parameters held at given values (not fitted), e.g. ``{"Ca": 0.0}``.
    initial : mapping, optional
        Start centre overriding the data-derived estimates for the named parameters (a warm
        start from an earlier fit -- never a truth in a test).
    extra_starts : sequence of mapping, optional
        Further starts after the ``options.n_starts`` drawn ones (names left out take the
        centre's value).
    seed : int, optional
        Seed of the start draws (and of the bootstrap); default ``options.seed``.
    workers : int, optional
        Processes for the starts; 0 = all cores, 1 = this process; default ``options.workers``.
    simulator : callable, optional
        ``simulate(model, params, t, *, theta0, omega0, memory_s, method)``; default the models
        package's numba hot path.
    method : str
        Simulator method (only used with a custom ``simulator``).
    on_progress : callable, optional
        Called with 1 after each start (and each bootstrap refit).
    source : str
        Name of the data in error messages.
    pool : ProcessPool, optional
        Worker processes for the starts, kept by the caller across fits
        (:func:`pendtrack.fitting.leastsq.ladder.search_pool`: a fit stage's models start them once), also
        running the profile sigmas' sides; default: ``workers`` processes started for the search.
    theta_scale_rel : float
        Relative uncertainty of theta's scale [1] (the angle stage's ``theta_scale_rel``: the
        axle's radius uncertainty); each parameter's first-order shift under it is
        ``ParamEstimate.stderr_scale`` (:func:`pendtrack.fitting.uncertainty.scale_shift`).
    cost_out : ndarray of bool, optional
        Samples left out of the cost (:attr:`pendtrack.fitting.leastsq.samples.Record.cost_out`: a
        compressed video's slow frames, :func:`~pendtrack.fitting.leastsq.samples.slow_frames`).

    Returns
    -------
    FitResult

    Raises
    ------
    FitError
        Too few samples, none usable, no oscillation, time stamps not uniform, bad options.
    """
    t_wall = time.monotonic()
    options = FitConfig() if options is None else options
    model_options = ModelsConfig() if model_options is None else model_options
    seed = options.seed if seed is None else seed
    workers = options.workers if workers is None else workers
    check_options(options, source=source)
    record = Record(t, theta, omega, alpha=alpha, ok=ok, window=window, observation=observation or Observation(),
                    source=source, cost_out=cost_out)
    setup = estimate(model, record, options=options, model_options=model_options, fixed=fixed, initial=initial,
                     simulator=simulator, method=method)
    return fit_setup(setup, options=options, model_options=model_options, seed=seed, workers=workers,
                     extra_starts=extra_starts, on_progress=on_progress, pool=pool, t_wall=t_wall,
                     theta_scale_rel=theta_scale_rel)


def fit_setup(setup: Setup, *, options: FitConfig, model_options: ModelsConfig, seed: int, workers: int,
              extra_starts: Sequence[Mapping[str, float]] = (), on_progress: Callable[[int], None] | None = None,
              pool: ProcessPool | None = None, t_wall: float | None = None, theta_scale_rel: float = 0.0
              ) -> FitResult:
    """Steps 2-5 of a fit (search, refine, uncertainty, result) from an estimate step's :class:`Setup`.

    The arguments are :func:`fit_model`'s (resolved: ``seed``, ``workers`` given); ``t_wall`` is the
    :func:`time.monotonic` the runtime counts from (default: now). A caller that needs the problem of
    the fit too (a joint fit over several records) runs :func:`~pendtrack.fitting.estimate.estimate`
    itself and then this.
    """
    t_wall = time.monotonic() if t_wall is None else t_wall
    found = search(setup, options=options, seed=seed, workers=workers, extra_starts=extra_starts,
                   on_progress=on_progress, pool=pool)
    best = refine(setup.problem, found.best, options=options)
    unc = assess(setup.problem, best, found, options=options, seed=seed, workers=workers, on_progress=on_progress,
                 pool=pool)
    return build_result(setup, found, best, unc, options=options, model_options=model_options, seed=seed,
                        runtime_s=time.monotonic() - t_wall,
                        scale=scale_shift(setup.problem, best.x, theta_scale_rel) if theta_scale_rel else None)


__all__ = ["check_options", "fit_model", "fit_setup"]
