"""Parameter uncertainties: the paper's 5/4 spread and a statistically grounded standard error.

Three numbers per parameter:

``u_paper``
    Eq. paramuncertain: among the starts with Xi^2 <= (5/4) Xi^2_min, half the range of the
    parameter. With a local optimiser that converges (unlike the paper's annealing, which
    stopped anywhere inside the valley) the accepted starts meet at the same minimum unless the
    landscape has several nearly equal minima, so ``u_paper`` measures *multimodality*, and is
    often far below the statistical error. Over every start's end point: a start merged with
    another on the growing windows (:mod:`pendtrack.fitting.leastsq.ladder`) counts with that one's.
``u_region``
    The half-width of the region Xi^2 <= (5/4) Xi^2_min itself, from the quadratic expansion at
    the optimum: what the paper's procedure tends to when the sampler explores the whole valley.
    It equals ``sqrt(N)/2`` times the naive standard error, i.e. it is very conservative.
``stderr``
    Autocorrelation-consistent sandwich covariance ``B^-1 S B^-1`` at the best fit,
    ``B = J^T J`` and ``S = J^T Sigma J`` with ``Sigma`` the residuals' covariance, Toeplitz from
    their sample auto- and cross-covariances up to a data-chosen lag with a flat-top kernel
    (:func:`hac_meat`; the Newey-West estimate from the scores is biased low, see there). The
    residuals of a pendulum fit are strongly autocorrelated (the Savitzky-Golay filter alone
    correlates ~25 samples; a slightly wrong model leaves residuals at the pendulum's period),
    so the textbook ``s^2 (J^T J)^-1`` would be too small by a large factor.

The intervals to quote: at 68 % ``value +- stderr``; at 95 % ``value +- 1.96 stderr``, widened
for a model with memory by profile scans (every parameter's own, and beta's valley that the others
follow; :mod:`pendtrack.fitting.leastsq.profile_interval`): the memory parameters' estimates have
tails along the beta-G2-p_f valley that the curvature at the best fit does not show.

Optionally the profile-likelihood sigmas on each side (:func:`pendtrack.fitting.leastsq.profile.profile_sigmas`)
and a moving-block bootstrap (:func:`bootstrap_problems`: refits of data rebuilt as best-fit
model plus moving blocks of the residuals).

:func:`assess` is step 4 of a fit, *uncertainty*: all of these at the refined best fit, plus a
smoothness check of the solver (the sandwich recomputed with 10x larger finite-difference steps).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from concurrent.futures import Executor
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
import scipy.fft

from pendtrack.config import FitConfig
from pendtrack.fitting.leastsq.cost import channels
from pendtrack.fitting.leastsq.local_fits import StartOutcome, run_tasks
from pendtrack.fitting.leastsq.profile import profile_sigmas
from pendtrack.fitting.leastsq.profile_interval import (SCAN_ALONG, ProfileScan, one_se_rise, scan_intervals,
                                                        scan_valley)
from pendtrack.fitting.leastsq.problem import FD_REL, STATE_NAMES, FitProblem

if TYPE_CHECKING:
    from pendtrack.fitting.search import Search

HAC_KERNELS = ("toeplitz", "bartlett")
SMOOTH_RATIO = 1.3  # the sandwich may change by this factor when the finite-difference steps grow 10x
Z95 = 1.959964  # the 95 % interval's half-width in standard errors (two-sided Gaussian)
NULL_COLUMN = 1e-12  # a Jacobian column this much weaker than the strongest changes no residual (an absent term)


def paper_uncertainty(xs: np.ndarray, costs: np.ndarray, accept_ratio: float) -> tuple[np.ndarray, np.ndarray]:
    """The paper's eq. paramuncertain over the accepted starts.

    Parameters
    ----------
    xs : ndarray, shape (n_starts, p)
        Final vectors of every start.
    costs : ndarray, shape (n_starts,)
        Their Xi^2 (non-finite = failed start).
    accept_ratio : float
        5/4 in the paper.

    Returns
    -------
    u : ndarray, shape (p,)
        ``(max - min)/2`` over the accepted starts, per parameter.
    accepted : ndarray of bool, shape (n_starts,)
    """
    costs = np.asarray(costs, dtype=float)
    ok = np.isfinite(costs)
    if not ok.any():
        return np.full(xs.shape[1], np.nan), ok
    accepted = ok & (costs <= accept_ratio * costs[ok].min())
    sel = xs[accepted]
    return 0.5 * (sel.max(axis=0) - sel.min(axis=0)), accepted


def andrews_lag(scores: np.ndarray) -> int:
    """Bartlett bandwidth by Andrews' (1991) AR(1) plug-in rule on the score series.

    Parameters
    ----------
    scores : ndarray, shape (n, p)

    Returns
    -------
    int
        Lag truncation L >= 1 [samples], at most n/4.
    """
    n = scores.shape[0]
    num = 0.0
    den = 0.0
    for a in range(scores.shape[1]):
        g = scores[:, a] - scores[:, a].mean()
        var = float(g @ g)
        if var <= 0:
            continue
        rho = float(g[1:] @ g[:-1]) / var
        rho = min(max(rho, -0.99), 0.99)
        s2 = var / n * (1 - rho**2)
        num += 4 * rho**2 * s2**2 / ((1 - rho) ** 6 * (1 + rho) ** 2)
        den += s2**2 / (1 - rho) ** 4
    if den == 0:
        return 1
    alpha1 = num / den
    lag = int(math.ceil(1.1447 * (alpha1 * n) ** (1 / 3)))
    return int(min(max(lag, 1), n // 4))


def scale_shift(problem: FitProblem, x: np.ndarray, rel: float) -> np.ndarray:
    """How far the fit moves when the measured angle's scale is off by ``rel`` [each parameter's unit].

    theta from a track is ``atan2`` about the fitted axle: an axle off vertically by ``d`` scales
    every angle by about ``1 + d / radius`` (the angle stage's ``theta_scale_rel``, the radius'
    relative uncertainty). The same factor in every sample is a systematic error the residuals
    cannot show, so the sandwich does not count it. Its effect on the minimum is, to first order
    (the Gauss-Newton step of the data's change), ``dx = -(J^T J)^-1 J^T dr`` with ``dr`` the
    residuals' change when theta and omega are scaled by ``1 + rel`` at the fitted ``x``.

    Parameters
    ----------
    problem : FitProblem
        The whole-window problem.
    x : ndarray
        The fitted vector.
    rel : float
        Relative scale uncertainty of theta [1]; 0 gives zeros.

    Returns
    -------
    ndarray
        ``|dx|``, per fitted parameter (0 for one on a bound; NaN where the Jacobian is not finite).
    """
    if not (math.isfinite(rel) and rel > 0):
        return np.zeros(x.size)
    scaled = replace(problem, theta=problem.theta * (1.0 + rel), omega=problem.omega * (1.0 + rel))
    dr = scaled.residuals(x) - problem.residuals(x)
    jac = problem.jacobian(x, central=True, method="fd")
    if not (np.all(np.isfinite(jac)) and np.all(np.isfinite(dr))):
        return np.full(x.size, np.nan)
    # a parameter on a bound stays there (the refit of a rescaled record could not leave it either)
    free = (x > problem.lower) & (x < problem.upper)
    dx = np.zeros(x.size)
    if free.any():
        dx[free] = np.linalg.lstsq(jac[:, free], -dr, rcond=None)[0]
    return np.abs(dx)


def hac_covariance(jac: np.ndarray, r: np.ndarray, n: int, *, lag: int | None = None,
                   kernel: str = "toeplitz", min_flat: int = 0) -> tuple[np.ndarray, int]:
    """Newey-West sandwich covariance of the least-squares estimate.

    Parameters
    ----------
    jac : ndarray, shape (m, p)
        Jacobian of the residual vector at the optimum, ``m = c * n`` for ``c`` channels.
    r : ndarray, shape (m,)
        Residual vector at the optimum.
    n : int
        Number of samples (channels are stacked sample blocks of length n).
    lag : int, optional
        Truncation lag [samples]; default :func:`flat_top_lag` of the residuals (``"toeplitz"``)
        or :func:`andrews_lag` of the scores (``"bartlett"``).
    kernel : {"toeplitz", "bartlett"}
        How the long-run covariance is estimated (:func:`hac_meat`).
    min_flat : int
        ``"toeplitz"`` without ``lag``: the kernel stays flat up to at least this lag [samples]
        (:func:`flat_top_lag`), e.g. ``savgol_window - 1``: a Savitzky-Golay filter correlates
        its output over that many samples even for white noise.

    Returns
    -------
    cov : ndarray, shape (p, p)
        Covariance of the fitted vector [parameter units squared]; NaN if ``J^T J`` is singular.
        A parameter whose Jacobian column is exactly zero changes no residual (a power drag's
        exponent when its amplitude is 0): its row and column are NaN, and the others' covariance
        is that of the fit without it (with it, ``J^T J`` is singular and every entry was NaN).
    lag : int
        The lag used.
    """
    live = _live_columns(jac)
    meat, lag = hac_meat(jac[:, live], r, n, lag=lag, kernel=kernel, min_flat=min_flat)
    if live.all():
        return sandwich(jac.T @ jac, meat), lag
    cov = np.full((jac.shape[1], jac.shape[1]), np.nan)
    cov[np.ix_(live, live)] = sandwich(jac[:, live].T @ jac[:, live], meat)
    return cov, lag


def _live_columns(jac: np.ndarray) -> np.ndarray:
    """Columns of ``jac`` that change the residuals: norm above :data:`NULL_COLUMN` of the largest.

    An absent term's parameter gives an exactly zero column by finite differences and a round-off
    one (1e-300) by forward sensitivities; no parameter of a determined fit is 1e12 times weaker.
    """
    with np.errstate(over="ignore", invalid="ignore"):
        norms = np.linalg.norm(np.nan_to_num(jac, nan=0.0, posinf=0.0, neginf=0.0), axis=0)
    top = float(norms.max()) if norms.size else 0.0
    return norms > NULL_COLUMN * top if top > 0 else np.ones(jac.shape[1], dtype=bool)


def filter_support(problem: FitProblem) -> int:
    """Lags over which the data's Savitzky-Golay filter correlates its output (window - 1; 0: no filter) [samples]."""
    return max(int(problem.observation.savgol_window) - 1, 0)


def sandwich(bread: np.ndarray, meat: np.ndarray) -> np.ndarray:
    """``B^-1 S B^-1``, symmetrised; NaN if the bread ``B = J^T J`` is singular."""
    try:
        binv = np.linalg.inv(bread)
    except np.linalg.LinAlgError:
        return np.full_like(bread, np.nan)
    with np.errstate(over="ignore", invalid="ignore"):  # singular to rounding: inf or NaN entries, not a warning
        cov = binv @ meat @ binv
    return 0.5 * (cov + cov.T)


def hac_meat(jac: np.ndarray, r: np.ndarray, n: int, *, lag: int | None = None,
             kernel: str = "toeplitz", min_flat: int = 0) -> tuple[np.ndarray, int]:
    """The long-run covariance ``S`` of the scores ``J^T r`` (the sandwich's meat).

    ``"toeplitz"`` (default): ``S = sum_k w_k sum_ab gamma_ab(k) sum_i J_a(i)^T J_b(i+k)`` (+ the
    mirrored lags), the residual channels' sample auto- and cross-covariances ``gamma_ab(k)``
    weighted by the flat-top kernel (:func:`kernel_weight`) up to :func:`flat_top_lag` of the
    residuals. ``"bartlett"``: Newey-West, the Bartlett-weighted autocovariances of the
    per-sample scores ``g_i = sum_a J_a(i) r_a(i)`` up to :func:`andrews_lag` of the scores.

    Why Toeplitz: at the optimum the scores sum to zero (``J^T r = 0``), so a kernel estimate
    from the scores misses about ``lag p / n`` of their long-run variance, and nothing can be
    added back from the scores alone: on 20-s OPA records (n = 2400, lags ~80, p = 6) the
    Newey-West standard errors of C4 and t0 were 12-16 % below the exact ones. The residuals'
    autocovariances lose a like share at the pendulum's frequency, but that loss is known given
    ``Sigma`` (:func:`projection_bias`) and is added back. The Toeplitz form assumes a noise
    correlation that does not change along the record (stationary noise).

    Arguments as :func:`hac_covariance`. Independent records add their meats (a joint fit's
    sandwich is ``B^-1 (S_1 + S_2 + ...) B^-1``).

    Returns
    -------
    meat : ndarray, shape (p, p)
    lag : int
        The truncation lag used [samples].
    """
    if kernel not in HAC_KERNELS:
        raise ValueError(f"unknown HAC kernel {kernel!r} (use {' or '.join(HAC_KERNELS)})")
    jc = channels(jac, n)  # (c, n, p)
    rc = channels(r, n)  # (c, n)
    if kernel == "bartlett":
        scores = np.einsum("cnp,cn->np", jc, rc)
        if lag is None:
            lag = andrews_lag(scores)
        meat = scores.T @ scores
        for ell in range(1, lag + 1):
            gamma = scores[ell:].T @ scores[:-ell]
            meat += kernel_weight(ell, lag, kernel) * (gamma + gamma.T)
        return meat, lag
    if lag is None:
        lag = flat_top_lag(rc.T, min_flat=min_flat)
    top = min(lag, n - 1)
    weights = np.array([kernel_weight(ell, lag, kernel) if ell else 1.0 for ell in range(top + 1)])
    c = rc.shape[0]
    gamma = np.zeros((top + 1, c, c))  # mean r_a(i) r_b(i + ell), on the lags the kernel weighs
    for ell in np.flatnonzero(weights):
        gamma[ell] = rc[:, : n - ell] @ rc[:, ell:].T / (n - ell)
    toeplitz = ToeplitzProducts(jc, top)
    gamma = gamma + projection_bias(toeplitz, gamma, weights)
    meat = np.einsum("cnp,cnq->pq", jc, toeplitz.sigma_times(gamma * weights[:, None, None]))
    return nearest_psd(meat), lag


PROJECTION_ITERATIONS = 3  # fixed-point steps of the bias correction (each changes the meat by ~(p lag / n)^k)


class ToeplitzProducts:
    """Products of a stationary covariance ``Sigma`` with the Jacobian's channels, by FFT.

    ``Sigma`` is block Toeplitz: ``E e_a(i) e_b(i + ell) = g[ell, a, b]`` for ``0 <= ell <= L`` (and its
    mirror for negative lags), zero beyond. Both products the meat needs are correlations over the
    sample index, so the FFT (padded to ``n + L``: no wrap-around) does in O(c^2 p n log n) what lag by
    lag takes O(L c^2 p^2 n).

    Parameters
    ----------
    jc : ndarray, shape (c, n, p)
        The Jacobian's channels.
    top : int
        The largest lag ``L`` [samples].
    """

    def __init__(self, jc: np.ndarray, top: int) -> None:
        self.jc = jc
        self.n = jc.shape[1]
        self.top = top
        self.size = scipy.fft.next_fast_len(self.n + top + 1, real=True)
        self.spectrum = scipy.fft.rfft(jc, self.size, axis=1)  # (c, size // 2 + 1, p)

    def sigma_times(self, g: np.ndarray) -> np.ndarray:
        """``Sigma J`` channel by channel, ``g`` the kernel-weighted covariances, shape (L + 1, c, c).

        ``(Sigma J)_a(i) = sum_b [sum_{ell >= 0} g[ell, a, b] J_b(i + ell) + sum_{ell >= 1} g[ell, b, a] J_b(i - ell)]``.
        """
        c = g.shape[1]
        kernel = np.zeros((c, c, self.size))  # circular: lag ell at index -ell, lag -ell at index ell
        kernel[:, :, 0] = g[0]
        kernel[:, :, self.size - np.arange(1, self.top + 1)] = np.moveaxis(g[1:], 0, -1)
        kernel[:, :, 1: self.top + 1] = np.moveaxis(g[1:], 0, -1).transpose(1, 0, 2)
        spec = scipy.fft.rfft(kernel, axis=2)  # (c, c, f)
        q = scipy.fft.irfft(np.einsum("abf,bfp->afp", spec, self.spectrum), self.size, axis=1)
        return q[:, : self.n]

    def lagged_dots(self, x: np.ndarray, y_spectrum: np.ndarray) -> np.ndarray:
        """``D[ell, a, b] = sum_i x_a(i) . y_b(i + ell)`` for ``ell = 0..L``, ``y`` given by its spectrum.

        Parameters
        ----------
        x : ndarray, shape (c, n, p)
        y_spectrum : ndarray, shape (c, f, p)
            ``scipy.fft.rfft(y, self.size, axis=1)``.
        """
        xs = scipy.fft.rfft(x, self.size, axis=1)
        d = scipy.fft.irfft(np.einsum("afp,bfp->abf", np.conj(xs), y_spectrum), self.size, axis=2)
        return np.moveaxis(d[:, :, : self.top + 1], 2, 0)


def projection_bias(toeplitz: ToeplitzProducts, gamma: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """How much the residuals' autocovariances fall short of the noise's, because the fit absorbed part of it.

    The residuals are ``r = (I - P) e``, ``P = J B^-1 J^T`` the projection on the Jacobian's
    columns, so ``E[r r^T] = Sigma - P Sigma - Sigma P + P Sigma P``: the lag-``ell`` autocovariance
    of the residuals is low by the mean of the ``ell``-th diagonal of the last three terms. The
    Jacobian's columns vary at the pendulum's frequency, where the sandwich needs the noise, so
    the loss there is about ``p lag / n`` of it (15-25 % on 10-s records with the 25-point filter),
    much more than the ``p / n`` of the whole variance. ``Sigma`` is the Toeplitz matrix of the
    corrected, kernel-weighted autocovariances (a fixed point, :data:`PROJECTION_ITERATIONS` steps
    from the residuals' own).

    Parameters
    ----------
    toeplitz : ToeplitzProducts
        Over the Jacobian's channels.
    gamma : ndarray, shape (L + 1, c, c)
        Mean ``r_a(i) r_b(i + ell)`` of the residual channels.
    weights : ndarray, shape (L + 1,)
        The kernel's weight of each lag.

    Returns
    -------
    ndarray, shape (L + 1, c, c)
        What to add to ``gamma`` (zero on the lags of weight 0).
    """
    jc = toeplitz.jc
    try:
        binv = np.linalg.inv(np.einsum("cnp,cnq->pq", jc, jc))
    except np.linalg.LinAlgError:
        return np.zeros_like(gamma)
    with np.errstate(over="ignore", invalid="ignore"):
        bias = _projection_fixed_point(toeplitz, gamma, weights, binv)
    # J^T J singular to rounding (a memory fit on a 140-s Tracker record ran p_f to 189 and G2 to 2.5e159:
    # cond 3e20) gives an inverse whose products overflow; then, as for an exactly singular one, no correction
    return bias if np.all(np.isfinite(bias)) else np.zeros_like(gamma)


def _projection_fixed_point(toeplitz: ToeplitzProducts, gamma: np.ndarray, weights: np.ndarray,
                            binv: np.ndarray) -> np.ndarray:
    """:func:`projection_bias`'s fixed point, given ``binv = (J^T J)^-1``.

    The ``ell``-th diagonal of ``P Sigma + Sigma P - P Sigma P`` between channels ``a`` and ``b`` sums to
    ``sum_i [(J_a B^-1)(i) . (Sigma J)_b(i + ell) + ((Sigma J)_a B^-1 - J_a M)(i) . J_b(i + ell)]`` with
    ``M = B^-1 J^T Sigma J B^-1``: lagged dot products of sample rows (:meth:`ToeplitzProducts.lagged_dots`).
    """
    jc, n = toeplitz.jc, toeplitz.n
    live = weights != 0.0
    scale = np.where(live, 1.0 / (n - np.arange(weights.size)), 0.0)[:, None, None]
    jb = jc @ binv  # (c, n, p); B^-1 is symmetric
    bias = np.zeros_like(gamma)
    for _ in range(PROJECTION_ITERATIONS):
        q = toeplitz.sigma_times((gamma + bias) * weights[:, None, None])  # Sigma J, channel by channel
        mid = binv @ np.einsum("cnp,cnq->pq", jc, q) @ binv  # B^-1 J^T Sigma J B^-1
        ps = toeplitz.lagged_dots(jb, scipy.fft.rfft(q, toeplitz.size, axis=1))  # P Sigma
        sp = toeplitz.lagged_dots(q @ binv - jc @ mid.T, toeplitz.spectrum)  # Sigma P - P Sigma P
        bias = (ps + sp) * scale
    return bias


def kernel_weight(ell: int, lag: int, kernel: str) -> float:
    """Weight of the lag-``ell`` autocovariance in the meat truncated at ``lag`` [1].

    ``"bartlett"``: ``1 - ell/(lag + 1)``; ``"toeplitz"``: Politis-Romano's flat-top trapezoid, 1 up
    to ``lag/2``, then falling linearly to 0 at ``lag`` (no downweighting of the lags where the
    residuals are correlated, hence no bias there).
    """
    if kernel == "bartlett":
        return 1.0 - ell / (lag + 1.0)
    return min(1.0, max(0.0, 2.0 * (1.0 - ell / lag)))


def flat_top_lag(scores: np.ndarray, *, c: float = 2.0, min_flat: int = 0) -> int:
    """Truncation lag of the flat-top kernel by Politis' (2003) empirical rule.

    Per column of ``scores`` (a series each, e.g. the residual channels): ``m`` is the smallest lag after which the sample autocorrelation stays
    within ``c sqrt(log10(n)/n)`` (an approximate 95 % band of a zero autocorrelation) for
    ``K = max(5, sqrt(log10 n))`` consecutive lags; the lag is ``2 max(m, min_flat)``, at most n/4.
    The rule alone stops too early after a Savitzky-Golay filter: the tail of the filter's
    autocorrelation (lags 15-24 of a 25-point window) lies inside the band yet adds ~20 % to the
    long-run variance, hence ``min_flat``: the filter's known support.

    Parameters
    ----------
    scores : ndarray, shape (n, p)
    c : float
        Width of the band in units of ``sqrt(log10(n)/n)``.
    min_flat : int
        The flat part's least length [samples].

    Returns
    -------
    int
        Lag ``M`` >= 2 [samples]: the kernel is flat up to ``M/2``.
    """
    n = scores.shape[0]
    max_lag = max(n // 4, 2)
    band = c * math.sqrt(math.log10(max(n, 10)) / n)
    k_run = max(5, int(math.ceil(math.sqrt(math.log10(max(n, 10))))))
    m_all = max(1, int(min_flat))
    for a in range(scores.shape[1]):
        g = scores[:, a] - scores[:, a].mean()
        var = float(g @ g)
        if var <= 0:
            continue
        nl = min(max_lag // 2 + k_run, n - 1)
        spec = np.fft.rfft(g, 2 * n)
        acf = np.fft.irfft(spec * np.conj(spec))[: nl + 1] / var  # sample autocorrelation, lags 0..nl
        small = np.abs(acf[1:]) < band  # lag 1.. nl
        m = nl
        run = 0
        for ell in range(1, nl + 1):
            run = run + 1 if small[ell - 1] else 0
            if run >= k_run:
                m = ell - k_run  # the last lag before the run of small autocorrelations
                break
        m_all = max(m_all, m)
    return int(min(max(2 * m_all, 2), max_lag))


def nearest_psd(a: np.ndarray) -> np.ndarray:
    """``a`` (symmetric) with its negative eigenvalues set to 0: a flat-top kernel's meat made a covariance."""
    a = 0.5 * (a + a.T)
    if not np.all(np.isfinite(a)):  # no covariance to make: NaN, as a singular J^T J gives
        return np.full_like(a, np.nan)
    vals, vecs = np.linalg.eigh(a)
    if vals.min() >= 0:
        return a
    return (vecs * np.maximum(vals, 0.0)) @ vecs.T


def naive_covariance(jac: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Textbook ``s^2 (J^T J)^-1`` (independent, equal-variance residuals): for comparison only."""
    m, p = jac.shape
    s2 = float(r @ r) / max(m - p, 1)
    try:
        return s2 * np.linalg.inv(jac.T @ jac)
    except np.linalg.LinAlgError:
        return np.full((p, p), np.nan)


def region_halfwidth(jac: np.ndarray, cost_min: float, accept_ratio: float) -> np.ndarray:
    """Half-width of ``{cost <= accept_ratio * cost_min}`` along each parameter (quadratic model).

    With ``cost = r^T r`` the region is ``dx^T J^T J dx <= (ratio - 1) cost_min``; its extent
    along parameter j is ``sqrt((ratio - 1) cost_min [(J^T J)^-1]_jj)``.
    """
    try:
        inv = np.linalg.inv(jac.T @ jac)
    except np.linalg.LinAlgError:
        return np.full(jac.shape[1], np.nan)
    return np.sqrt(np.maximum((accept_ratio - 1.0) * cost_min * np.diag(inv), 0.0))


def block_indices(n: int, block: int, rng: np.random.Generator) -> np.ndarray:
    """Moving-block bootstrap: n indices made of random blocks of ``block`` consecutive samples."""
    block = max(1, min(block, n))
    n_blocks = int(math.ceil(n / block))
    starts = rng.integers(0, n - block + 1, size=n_blocks)
    return (starts[:, None] + np.arange(block)[None, :]).ravel()[:n]


def bootstrap_problems(problem: FitProblem, x_best: np.ndarray, n_boot: int, block: int,
                       seed: int) -> list[FitProblem]:
    """Problems whose data are the best-fit model plus block-resampled residuals.

    Parameters
    ----------
    problem : FitProblem
    x_best : ndarray
        Best-fit vector.
    n_boot : int
        Number of replicates.
    block : int
        Block length [samples]; a few correlation lengths (e.g. the HAC lag).
    seed : int

    Returns
    -------
    list of FitProblem
    """
    from dataclasses import replace

    theta_m, omega_m = problem.model_at_data(x_best)
    e_theta = problem.theta - theta_m
    e_omega = problem.omega - omega_m
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n_boot):
        idx = block_indices(problem.n, block, rng)
        out.append(replace(problem, theta=theta_m + e_theta[idx], omega=omega_m + e_omega[idx]))
    return out


def stderr_from_cov(cov: np.ndarray) -> np.ndarray:
    """Square roots of the diagonal (NaN where not positive)."""
    d = np.diag(cov)
    with np.errstate(invalid="ignore"):
        return np.where(d > 0, np.sqrt(np.abs(d)), np.nan)



@dataclass(frozen=True, eq=False)
class Uncertainty:
    """Every uncertainty of a best fit (arrays in ``problem.names`` order, parameter units).

    Attributes
    ----------
    covariance : ndarray
        Sandwich covariance of the fitted vector.
    hac_lag : int
        Its truncation lag [samples].
    stderr, stderr_naive, u_paper, u_region : ndarray
        Sandwich, textbook, paper's 5/4 spread, 5/4-region half-width.
    n_accepted : int
        Starts within ``accept_ratio`` of the minimum (before the refine step).
    stderr_low, stderr_high, stderr_bootstrap : ndarray
        Profile-likelihood sigmas per side and the bootstrap one (NaN where not computed).
    step_spread : float
        Largest ``|ln|`` ratio of the sandwich standard errors with 10x larger finite-difference
        steps to the ordinary ones (inf if not finite) [1].
    stderr_judged : ndarray
        The standard errors the plausibility flags judge by: for a model with forward
        sensitivities, the larger of ``stderr`` and the sandwich on the sensitivity Jacobian (the
        finite differences' limit of zero step); else ``stderr``.
    interval68, interval95 : tuple of ndarray
        ``(low, high)``: the 68 % and 95 % intervals to quote: ``value +- z stderr``, the 95 % one
        widened for a model with memory (:func:`pendtrack.fitting.leastsq.profile_interval.scan_intervals`).
    """

    covariance: np.ndarray
    hac_lag: int
    stderr: np.ndarray
    stderr_naive: np.ndarray
    u_paper: np.ndarray
    u_region: np.ndarray
    n_accepted: int
    stderr_low: np.ndarray
    stderr_high: np.ndarray
    stderr_bootstrap: np.ndarray
    step_spread: float
    stderr_judged: np.ndarray
    interval68: tuple[np.ndarray, np.ndarray]
    interval95: tuple[np.ndarray, np.ndarray]

    @property
    def reliable(self) -> bool:
        """The standard errors do not depend on the finite-difference step (a smooth solver)."""
        return bool(self.step_spread <= math.log(SMOOTH_RATIO))


def assess(problem: FitProblem, best: StartOutcome, found: Search, *, options: FitConfig, seed: int, workers: int,
           on_progress: Callable[[int], None] | None = None,
           pool: Executor | None = None) -> Uncertainty:
    """The uncertainties of the refined best fit (step 4 of a fit).

    Parameters
    ----------
    problem : FitProblem
        The whole-window problem.
    best : StartOutcome
        The refined best fit.
    found : Search
        The starts (their end points and costs give ``u_paper``).
    options : FitConfig
        Uses ``accept_ratio``, ``profile`` (the profile sigmas, and the valley scan of the intervals) and
        ``bootstrap``.
    seed : int
        The bootstrap's seed is ``seed + 1``.
    workers : int
        Processes for the bootstrap refits.
    on_progress : callable, optional
        Called with 1 after each bootstrap refit.
    pool : Executor, optional
        Worker processes kept by the caller (the search's): the profile sigmas' sides run there.
    """
    x = best.x
    u_paper, accepted = paper_uncertainty(found.xs, found.costs, options.accept_ratio)
    r = problem.residuals(x)
    jac = problem.jacobian(x, central=True, method="fd")  # the sandwich and its 10x-step check: finite differences
    cov, lag = hac_covariance(jac, r, problem.n, min_flat=filter_support(problem))
    # smoothness check: the sandwich of the parameters inside their bounds, with 10x larger steps,
    # must agree (it does for smooth solvers; a solver that is rough in the parameters makes
    # local standard errors mean little)
    inner = (x > problem.lower) & (x < problem.upper) & _live_columns(jac)  # a null column has no error
    step_spread = 0.0
    if inner.any():
        se_in, _ = hac_covariance(jac[:, inner], r, problem.n, lag=lag)
        wide = problem.jacobian(x, central=True, rel=10 * FD_REL, method="fd")
        se_wide, _ = hac_covariance(wide[:, inner], r, problem.n, lag=lag)
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = np.abs(np.log(stderr_from_cov(se_wide) / stderr_from_cov(se_in)))
        step_spread = float(np.max(ratio)) if np.all(np.isfinite(ratio)) else math.inf
    stderr = stderr_from_cov(cov)
    judged = stderr
    if problem.has_sensitivities:
        # Where the sandwich changes with the step, its value at one step is not a measurement's error
        # and "determined by the data" must not hang on it: on a drifting-Omega0 record the time-varying
        # damping's C4 = 5.4 had 8.8 (host code) and 13.3 (generic code) at the ordinary step, on either
        # side of the 2|C4| rule, and 110 from the sensitivities (the zero-step limit) under both. A
        # parameter counts as determined only if the zero-step limit also says so. Not only where the
        # 10x-step check calls the errors unreliable: that check itself fell on either side of its
        # threshold (time-varying damping + added mass on the same record). For a smooth fit the two
        # agree and nothing changes.
        try:
            sens, _ = hac_covariance(problem.jacobian(x, method="sensitivity"), r, problem.n, lag=lag)
        except (FloatingPointError, ValueError, np.linalg.LinAlgError):  # no sensitivities there: the step's own
            sens = np.full_like(cov, np.nan)
        judged = np.fmax(stderr, stderr_from_cov(sens))  # fmax: a NaN on one side leaves the other
    se_naive = stderr_from_cov(naive_covariance(jac, r))
    nan = np.full(x.size, np.nan)
    se_low, se_high = nan, nan
    if options.profile:
        profiled = [nm for nm in problem.names if nm not in STATE_NAMES]
        se_low, se_high = profile_sigmas(problem, x, float(best.cost), cov, se_naive, profiled, executor=pool)
    se_boot = nan
    if options.bootstrap > 0:
        block = max(lag, problem.observation.savgol_window, 1)
        se_boot = _bootstrap(problem, x, options.bootstrap, block, seed, workers, on_progress)
    dof = r.size - x.size
    scans: dict[int, ProfileScan] = {}
    if options.profile and SCAN_ALONG in problem.names and x.size > 1:  # memory's valley: the 95 % intervals' tails
        scans = _valley_scans(problem, x, float(best.cost), cov, se_naive, dof, pool)
    valley = next((k for k in scans if problem.names[k] == SCAN_ALONG), None)
    interval68 = scan_intervals({}, x=x, cost=float(best.cost), cov=cov, naive=se_naive, dof=dof, z=1.0)
    interval95 = scan_intervals(scans, x=x, cost=float(best.cost), cov=cov, naive=se_naive, dof=dof, z=Z95,
                                valley=valley)
    return Uncertainty(covariance=cov, hac_lag=int(lag), stderr=stderr, stderr_naive=se_naive,
                       u_paper=u_paper, u_region=region_halfwidth(jac, best.cost, options.accept_ratio),
                       n_accepted=int(accepted.sum()), stderr_low=se_low, stderr_high=se_high,
                       stderr_bootstrap=se_boot, step_spread=step_spread, stderr_judged=judged,
                       interval68=interval68, interval95=interval95)


def _valley_scans(problem: FitProblem, x: np.ndarray, cost: float, cov: np.ndarray, naive: np.ndarray, dof: int,
                  pool: Executor | None) -> dict[int, ProfileScan]:
    """The profile scan (:func:`pendtrack.fitting.leastsq.profile_interval.scan_valley`) of every fitted
    parameter but the initial state, in ``pool`` where given (the same scans as in this process)."""
    stderr = stderr_from_cov(cov)
    tasks = []
    for k, name in enumerate(problem.names):
        if name in STATE_NAMES:
            continue
        rise = one_se_rise(cost, dof, float(stderr[k]), float(naive[k]))
        tasks.append((k, (problem, x, cost, cov, name, rise)))
    if pool is not None and len(tasks) > 1:
        futures = [(k, pool.submit(scan_valley, *args)) for k, args in tasks]
        found = [(k, f.result()) for k, f in futures]
    else:
        found = [(k, scan_valley(*args)) for k, args in tasks]
    return {k: scan for k, scan in found if scan is not None}


def _bootstrap(problem: FitProblem, x: np.ndarray, n_boot: int, block: int, seed: int, workers: int,
               on_progress: Callable[[int], None] | None) -> np.ndarray:
    """Standard deviation of block-bootstrap refits started at the best fit."""
    problems = bootstrap_problems(problem, x, n_boot, block, seed + 1)
    tasks = [(p, x, (problem.t_end,)) for p in problems]
    outs = run_tasks(tasks, workers=workers, on_progress=on_progress)
    xb = np.array([o.x for o in outs if np.isfinite(o.cost)])
    if xb.shape[0] < 2:
        return np.full(x.size, np.nan)
    return xb.std(axis=0, ddof=1)
