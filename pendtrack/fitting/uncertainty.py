"""Parameter uncertainties: the paper's 5/4 spread and a statistically grounded standard error.

Three numbers per parameter:

``u_paper``
    Eq. paramuncertain: among the starts with Xi^2 <= (5/4) Xi^2_min, half the range of the
    parameter. With a local optimiser that converges (unlike the paper's annealing, which
    stopped anywhere inside the valley) the accepted starts meet at the same minimum unless the
    landscape has several nearly equal minima, so ``u_paper`` measures *multimodality*, and is
    often far below the statistical error.
``u_region``
    The half-width of the region Xi^2 <= (5/4) Xi^2_min itself, from the quadratic expansion at
    the optimum: what the paper's procedure tends to when the sampler explores the whole valley.
    It equals ``sqrt(N)/2`` times the naive standard error, i.e. it is very conservative.
``stderr``
    Heteroscedasticity- and autocorrelation-consistent (Newey-West) sandwich covariance
    ``B^-1 S B^-1`` at the best fit, ``B = J^T J`` and ``S`` the long-run covariance of the
    per-sample scores ``g_i = sum_channel J_ci r_ci`` with a Bartlett kernel. The residuals of
    a pendulum fit are strongly autocorrelated (the Savitzky-Golay filter alone correlates
    ~25 samples; a slightly wrong model leaves residuals at the pendulum's period), so the
    textbook ``s^2 (J^T J)^-1`` would be too small by a large factor.

Optionally :func:`block_residual_bootstrap` refits data rebuilt as best-fit model plus moving
blocks of the residuals.
"""

from __future__ import annotations

import math

import numpy as np

from pendtrack.fitting.cost import channels
from pendtrack.fitting.problem import FitProblem


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


def hac_covariance(jac: np.ndarray, r: np.ndarray, n: int, *, lag: int | None = None) -> tuple[np.ndarray, int]:
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
        Bartlett truncation lag [samples]; default :func:`andrews_lag`.

    Returns
    -------
    cov : ndarray, shape (p, p)
        Covariance of the fitted vector [parameter units squared]; NaN if ``J^T J`` is singular.
    lag : int
        The lag used.
    """
    jc = channels(jac, n)  # (c, n, p)
    rc = channels(r, n)  # (c, n)
    scores = np.einsum("cnp,cn->np", jc, rc)
    if lag is None:
        lag = andrews_lag(scores)
    meat = scores.T @ scores
    for ell in range(1, lag + 1):
        w = 1.0 - ell / (lag + 1.0)
        gamma = scores[ell:].T @ scores[:-ell]
        meat += w * (gamma + gamma.T)
    bread = jac.T @ jac
    try:
        binv = np.linalg.inv(bread)
    except np.linalg.LinAlgError:
        return np.full_like(bread, np.nan), lag
    cov = binv @ meat @ binv
    return 0.5 * (cov + cov.T), lag


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

