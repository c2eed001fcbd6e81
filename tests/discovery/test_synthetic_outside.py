"""The physics outside the catalogue that the hidden-effect controls simulate, checked against theory."""

from __future__ import annotations

import numpy as np

from pendtrack.discovery.synthetic import simulate_outside

UNDAMPED = {"Omega0": 2.0 * np.pi, "C1": 0.0, "C0": 0.0, "C2": 0.0}  # a 1-s pendulum, no damping


def _swing(outside: str, extra: dict[str, float], *, theta0: float, duration: float) -> tuple[np.ndarray, np.ndarray]:
    # no noise: a zero standard deviation leaves the simulation itself
    return simulate_outside({**UNDAMPED, **extra}, outside, duration=duration, theta0=theta0, noise=0.0,
                            rng=np.random.default_rng(0), rate_hz=120.0)


def test_a_weak_drive_gives_the_linear_oscillators_forced_response():
    # theta'' = -W^2 sin(theta) + W^2 A sin(r W t + phi) from rest at 0; with |theta| ~ 1e-2, sin(theta) = theta
    # to theta^3/6 ~ 2e-7 rad, and the linear solution is the forced term plus the free one that starts at rest
    amp, r, phi, w = 4e-3, 1.5, 0.7, UNDAMPED["Omega0"]
    t, theta = _swing("weak_drive", {"drive_rad": amp, "drive_ratio": r, "drive_phase": phi}, theta0=0.0,
                      duration=20.0)
    k = amp / (1.0 - r * r)
    expected = k * (np.sin(r * w * t + phi) - np.sin(phi) * np.cos(w * t) - r * np.cos(phi) * np.sin(w * t))
    # the cubic term lowers the free swing's frequency by theta_max^2 / 16 ~ 4e-6 (theta_max ~ 8 mrad): over 20
    # periods a phase of 5e-4 rad on its 4.8-mrad amplitude, 2.4e-6 rad; a drive of the wrong frequency, phase or
    # sign would be off by its whole size (~1e-2 rad)
    assert np.max(np.abs(theta - expected)) < 5e-6


def test_a_slowly_changing_length_keeps_the_adiabatic_invariant():
    # a simple pendulum whose length changes slowly (here by -30 % over 60 periods) keeps E / omega, so its
    # small swings grow as l^(-3/4): with the wrong sign or size of the -2 (l'/l) dtheta/dt term they would
    # shrink, or grow as l^(-1/4) (without it)
    change = -0.3  # over the synthetic module's 60-s span
    t, theta = _swing("changing_length", {"length_change": change}, theta0=0.02, duration=60.0)
    first, last = np.max(np.abs(theta[t < 2.0])), np.max(np.abs(theta[t > 58.0]))
    length_ratio = 1.0 + change * 59.0 / 60.0  # l(t) / l at the last two seconds' middle
    # adiabatic to O(l'/(l Omega)) ~ 1e-3 per period, and the amplitude's sampling at 120 Hz to 1 - cos(pi/120)
    assert abs(last / first - length_ratio ** -0.75) < 0.01 * length_ratio ** -0.75
