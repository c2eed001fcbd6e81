"""The sandwich's meat by FFT equals its lag-by-lag definition (:func:`pendtrack.fitting.uncertainty.hac_meat`)."""

from __future__ import annotations

import numpy as np
import pytest

from pendtrack.fitting.uncertainty import PROJECTION_ITERATIONS, hac_meat, kernel_weight, nearest_psd


def reference_meat(jac: np.ndarray, r: np.ndarray, n: int, lag: int) -> np.ndarray:
    """The flat-top meat with its projection-bias correction, written lag by lag as its docstrings define it."""
    c = jac.shape[0] // n
    jc = jac.reshape(c, n, -1)
    rc = r.reshape(c, n)
    lags = range(0, min(lag, n - 1) + 1)
    weights = [kernel_weight(ell, lag, "toeplitz") if ell else 1.0 for ell in lags]
    cross, gamma = {}, np.zeros((len(lags), c, c))
    for ell in lags:
        if weights[ell] == 0.0:
            continue
        for a in range(c):
            for b in range(c):
                gamma[ell, a, b] = float(rc[a, : n - ell] @ rc[b, ell:]) / (n - ell)
                cross[ell, a, b] = jc[a, : n - ell].T @ jc[b, ell:]
    binv = np.linalg.inv(np.einsum("cnp,cnq->pq", jc, jc))
    bias = np.zeros_like(gamma)
    for _ in range(PROJECTION_ITERATIONS):
        g = (gamma + bias) * np.asarray(weights)[:, None, None]
        q = np.zeros_like(jc)  # Sigma J
        for ell in range(g.shape[0]):
            for a in range(c):
                for b in range(c):
                    q[a, : n - ell] += g[ell, a, b] * jc[b, ell:]
                    if ell:
                        q[b, ell:] += g[ell, a, b] * jc[a, : n - ell]
        mid = binv @ np.einsum("cnp,cnq->pq", jc, q) @ binv
        new = np.zeros_like(gamma)
        for (ell, a, b), jj in cross.items():
            ps = float(np.sum(binv * (q[b, ell:].T @ jc[a, : n - ell])))
            sp = float(np.sum(binv * (jc[b, ell:].T @ q[a, : n - ell])))
            new[ell, a, b] = (ps + sp - float(np.sum(mid * jj.T))) / (n - ell)
        bias = new
    gamma = gamma + bias
    meat = np.zeros((jc.shape[2], jc.shape[2]))
    for (ell, a, b), term in cross.items():
        term = gamma[ell, a, b] * term
        meat += weights[ell] * (term if ell == 0 else term + term.T)
    return nearest_psd(meat)


@pytest.mark.parametrize(("c", "n", "p", "lag"), [(1, 400, 3, 24), (2, 300, 5, 50), (3, 250, 4, 60), (2, 40, 3, 60)])
def test_fft_meat_equals_the_lag_by_lag_sums(c, n, p, lag):
    rng = np.random.default_rng(7 + c)
    t = np.arange(n) / 20.0
    # columns at a pendulum's frequency and correlated residuals: what a fit's Jacobian and residuals look like
    jac = np.concatenate([np.stack([np.sin(1.3 * t * (k + 1) + a) * np.exp(-0.01 * t * k) for k in range(p)], axis=1)
                          + 0.1 * rng.standard_normal((n, p)) for a in range(c)])
    r = np.convolve(rng.standard_normal(c * n + 24), np.ones(25) / 25, mode="valid")
    got, used = hac_meat(jac, r, n, lag=lag)
    want = reference_meat(jac, r, n, lag)
    assert used == lag
    # both are sums of the same O(n L) products in another order: they agree to rounding, ~1e-13 of the largest
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-10 * np.abs(want).max())
