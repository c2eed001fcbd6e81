"""Grunwald-Letnikov derivative, the GL solver and the Mittag-Leffler benchmark."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import binom, erfcx, gamma
from factory import mittag_leffler, solve_gl_fde

from pendtrack.errors import ModelError
from pendtrack.models.gl import gl_derivative, gl_weights


def _orders(errors: list[float]) -> np.ndarray:
    e = np.asarray(errors)
    return np.log2(e[:-1] / e[1:])


def test_weights_are_signed_binomials() -> None:
    for beta in (0.3, 1.0, 1.5):
        k = np.arange(30)
        np.testing.assert_allclose(gl_weights(beta, 29), (-1.0) ** k * binom(beta, k), rtol=1e-12, atol=1e-15)
    # beta = 1: backward difference
    np.testing.assert_array_equal(gl_weights(1.0, 3), [1.0, -1.0, 0.0, 0.0])


@pytest.mark.parametrize(("k", "beta"), [(2, 0.5), (1, 0.7), (3, 1.5), (2, 1.3)])
def test_gl_derivative_of_power_is_first_order(k: int, beta: float) -> None:
    errors = []
    for n in (100, 200, 400, 800):
        h = 1.0 / n
        t = np.arange(n + 1) * h
        d = gl_derivative(t ** k, h, beta)
        exact = gamma(k + 1) / gamma(k + 1 - beta) * t ** (k - beta)
        errors.append(abs(d[-1] - exact[-1]))
    orders = _orders(errors)
    assert np.all(np.abs(orders - 1.0) < 0.1), orders  # GL is O(h): measured 0.998-1.001


def test_truncated_memory_uses_constant_past() -> None:
    f = np.full(50, 2.0)
    # full history of a constant: exactly zero (Caputo sense)
    np.testing.assert_allclose(gl_derivative(f, 0.1, 0.5), 0.0, atol=1e-15)
    # truncated sum of a constant: f * sum_{k<=N} W_k / h^beta (the paper's truncation bias)
    d = gl_derivative(f, 0.1, 0.5, memory_steps=10)
    np.testing.assert_allclose(d, 2.0 * gl_weights(0.5, 10).sum() * 0.1 ** -0.5, rtol=1e-12)
    with pytest.raises(ModelError):
        gl_derivative(f, 0.1, 0.5, memory_steps=0)


def test_mittag_leffler_against_known_cases() -> None:
    x = np.array([0.0, 0.3, 1.0, 2.5, 7.0, 30.0, 200.0])
    # E_{1/2}(-x) = exp(x^2) erfc(x)
    np.testing.assert_allclose(mittag_leffler(0.5, -x), erfcx(x), rtol=1e-11, atol=1e-14)
    np.testing.assert_allclose(mittag_leffler(1.0, -x), np.exp(-x), rtol=1e-14)
    # large-argument asymptote E_beta(-x) ~ 1/(x Gamma(1-beta)) - 1/(x^2 Gamma(1-2 beta))
    b = 0.8
    big = 1000.0
    asym = 1 / (big * math.gamma(1 - b)) - 1 / (big ** 2 * math.gamma(1 - 2 * b))
    assert mittag_leffler(b, -big) == pytest.approx(asym, rel=1e-5)


def test_mittag_leffler_series_and_integral_agree() -> None:
    from reference_solutions import _integral, _series

    for beta in (0.3, 0.6, 0.8, 0.95):
        for x in (0.2, 1.0, 1.5):
            assert _series(beta, -x) == pytest.approx(_integral(beta, x), abs=1e-12)


def test_relaxation_against_mittag_leffler() -> None:
    # D^0.8 y = -10 y, y(0) = 1 on [0, 5]: y = E_0.8(-10 t^0.8) (Garrappa's benchmark)
    beta, lam = 0.8, 10.0
    errors = []
    for n in (500, 1000, 2000):
        h = 5.0 / n
        y = solve_gl_fde(lambda t, y: -lam * y, beta, 1.0, h, n)
        t = np.arange(n + 1) * h
        errors.append(np.max(np.abs(y - mittag_leffler(beta, -lam * t ** beta))))
    orders = _orders(errors)
    # first order, approached from below (the t^beta singularity at 0): measured 0.91, 0.95
    assert np.all(orders > 0.85) and np.all(orders < 1.1), orders
    assert errors[-1] < 0.01
