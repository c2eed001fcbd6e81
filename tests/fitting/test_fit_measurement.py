"""Measurement terms in the fit: the zero of theta (``offset``) and a scale error (``angle_scale``).

Each record: the standard model simulated at 120 Hz for 30 s from rest at 2.5 rad, mapped
through a known measurement error, plus 1 mrad of white noise, then the paper's 25-frame cubic
Savitzky-Golay filter (:func:`pendtrack.kinematics.savgol_kinematics`). The fits start from the
data-derived estimates only (the centre of the oscillation for ``theta_off``, 0 for
``k_scale``), never from the truths.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from factory import filtered, swing

from pendtrack.config import FitConfig
from pendtrack.fitting import fit_model
from pendtrack.fitting.leastsq.equation_error import equation_error_estimates, oscillation_center
from pendtrack.fitting.leastsq.local_fits import FINAL_ITERATIONS
from pendtrack.fitting.result import plausibility_flags
from pendtrack.models import compose, get_model

SECONDS = 30.0
NOISE = 1e-3  # [rad]
THETA0 = 2.5  # [rad], released from rest
TRUTH = {"Omega0": 5.0, "C1": 0.02, "C0": 0.01, "C2": 0.005}
OFFSET = 0.01  # [rad], a camera zero 10 mrad off
K_SCALE = 0.1 / THETA0**2  # [1/rad^2]: the angle 10 % too large at 2.5 rad
GAIN = -2e-3  # the angle read 0.2 % small at every amplitude (an axle 0.2 % of the radius off along it)


def options() -> FitConfig:
    # two starts: the standard model has one minimum (every start meets it); no wall-clock budget
    return FitConfig(n_starts=2, start_budget=FINAL_ITERATIONS, profile=False)


def record(measured):  # noqa: ANN001, ANN201
    """(t, theta, omega, alpha, ok, observation) of the standard model seen through ``measured(theta)``."""
    kin, obs = filtered(*swing("standard", TRUTH, seconds=SECONDS, theta0=THETA0, noise=NOISE, seed=7,
                               measured=measured))
    return kin.t, kin.theta, kin.omega, kin.alpha, kin.ok, obs


def fit(model, rec):  # noqa: ANN001, ANN201
    t, theta, omega, alpha, ok, obs = rec
    return fit_model(model, t, theta, omega, alpha=alpha, ok=ok, observation=obs, options=options(), seed=0, workers=1)


@pytest.fixture(scope="module")
def fits() -> dict[str, object]:
    plain = record(lambda th: th)
    shifted = record(lambda th: th + OFFSET)
    offset_model = compose("standard", ["offset"])
    return {
        "plain_standard": fit(get_model("standard"), plain),
        "plain_offset": fit(offset_model, plain),
        "shifted_standard": fit(get_model("standard"), shifted),
        "shifted_offset": fit(offset_model, shifted),
    }


# ---- the observation's derivative -----------------------------------------------------------
def test_observe_state_slope_is_the_derivative_of_the_observation():
    model = compose("standard", ["offset", "angle_scale"])
    p = {**TRUTH, "theta_off": 0.02, "k_scale": 0.03}
    theta = np.linspace(-3.0, 3.0, 101)
    omega = np.linspace(2.0, -1.0, 101)
    th_obs, om_obs = model.observe_state(theta, omega, p)
    np.testing.assert_array_equal(th_obs, model.observe(theta, p))
    x = theta + 0.02
    exact = (1.0 + 3.0 * 0.03 * x * x) * omega  # d/dt [x (1 + k x^2)]
    # central difference over 1e-4 rad: off by k d^2 = 3e-10 relative, plus rounding ~1e-12
    np.testing.assert_allclose(om_obs, exact, rtol=1e-9, atol=1e-12)
    th, om = get_model("standard").observe_state(theta, omega, TRUTH)
    assert th is theta and om is omega  # no measurement term: the identity
    shifted = compose("standard", ["offset"])
    th, om = shifted.observe_state(theta, omega, {**TRUTH, "theta_off": 0.02})
    np.testing.assert_array_equal(th, theta + 0.02)
    np.testing.assert_array_equal(om, omega)  # a shift's slope is exactly 1 (no difference quotient's rounding)


# ---- data-derived start values ---------------------------------------------------------------
def test_oscillation_center_cancels_a_linear_decay():
    # turning angles of a swing about 0.03 rad decaying by 0.05 rad per half swing
    k = np.arange(12)
    turns = 0.03 + (-1.0) ** k * (2.0 - 0.05 * k)
    center, se = oscillation_center(turns)
    assert center == pytest.approx(0.03, abs=1e-12)
    assert se == pytest.approx(0.0, abs=1e-12)
    assert math.isnan(oscillation_center(turns[:2])[1])


def test_equation_error_estimates_accept_a_model_with_measurement_terms():
    t, theta, omega, _, ok, _ = record(lambda th: th + OFFSET)
    use = np.asarray(ok, bool)
    w0 = TRUTH["Omega0"]
    est = equation_error_estimates(compose("standard", ["offset", "angle_scale"]), t, theta, omega, omega0_hat=w0,
                                   memory_s=10.0, use=use)
    plain = equation_error_estimates(get_model("standard"), t, theta - est.values["theta_off"], omega, omega0_hat=w0,
                                     memory_s=10.0, use=use)
    # the centre of the turning points: the 10 mrad offset to within ~the noise on a turning angle (1 mrad)
    assert est.values["theta_off"] == pytest.approx(OFFSET, abs=1e-3)
    assert est.values["k_scale"] == 0.0
    for name in TRUTH:  # the physics: those of the plain model on theta - theta_off_hat
        assert est.values[name] == pytest.approx(plain.values[name], rel=1e-9, abs=1e-12)


# ---- recovery -------------------------------------------------------------------------------
def test_offset_recovered_within_its_standard_error(fits):
    res = fits["shifted_offset"]
    assert res.converged and res.trustworthy, (res.message, res.flags)
    off = res.params["theta_off"]
    assert abs(off.value - OFFSET) < 3.0 * off.stderr, (off.value, off.stderr)
    # 1 mrad white noise over 3600 samples: the offset is known to ~20 urad, not to a mrad
    assert off.stderr < 1e-4
    d = res.to_dict()
    assert d["measurement"] == ["offset"]
    assert set(d["params"]["theta_off"]) == {"value", "stderr", "u_paper"}


def test_offset_fit_measures_omega0_as_well_as_a_fit_of_the_unshifted_record(fits):
    ref = fits["plain_standard"].params["Omega0"]
    got = fits["shifted_offset"].params["Omega0"]
    assert abs(got.value - TRUTH["Omega0"]) < 3.0 * got.stderr
    # same noise realisation, the offset fitted: the same Omega0 (within a tenth of its error) and error bar
    assert abs(got.value - ref.value) < 0.1 * ref.stderr
    assert got.stderr == pytest.approx(ref.stderr, rel=0.1)


def test_ignoring_the_offset_costs_clearly_more(fits):
    with_off = fits["shifted_offset"]
    without = fits["shifted_standard"]
    # measured 25x: a 10 mrad zero error is 10x the noise on every sample
    assert without.xi2_min > 5.0 * with_off.xi2_min
    assert without.rms > 5.0 * with_off.rms


def test_no_offset_gives_theta_off_consistent_with_zero_and_no_flag(fits):
    res = fits["plain_offset"]
    off = res.params["theta_off"]
    assert abs(off.value) < 3.0 * off.stderr, (off.value, off.stderr)
    assert res.trustworthy, (res.message, res.flags)  # theta_off = 0 +- x is a result, not "not determined"
    plain = fits["plain_standard"]
    assert res.xi2_min <= plain.xi2_min * (1.0 + 1e-6)  # one more free parameter never fits worse


def test_angle_scale_recovered():
    rec = record(lambda th: th * (1.0 + K_SCALE * th * th))
    res = fit(compose("standard", ["angle_scale"]), rec)
    assert res.converged and res.trustworthy, (res.message, res.flags)
    k = res.params["k_scale"]
    assert abs(k.value - K_SCALE) < 3.0 * k.stderr, (k.value, k.stderr)
    w = res.params["Omega0"]
    assert abs(w.value - TRUTH["Omega0"]) < 3.0 * w.stderr
    # without the term the 10 % scale error is a different pendulum: Omega0 off by > 0.1 %
    # (measured 0.6 %), the rms 100x the noise
    wrong = fit(get_model("standard"), rec)
    assert abs(wrong.params["Omega0"].value / TRUTH["Omega0"] - 1.0) > 1e-3
    assert wrong.rms > 10.0 * res.rms


def test_angle_gain_recovered_where_the_swing_is_nonlinear():
    # theta (1 + g): told from theta0 only by the period's dependence on the amplitude, which at 2.5 rad is
    # strong (the period 25 % longer than at small swings)
    rec = record(lambda th: th * (1.0 + GAIN))
    res = fit(compose("standard", ["angle_gain"]), rec)
    assert res.converged and res.trustworthy, (res.message, res.flags)
    g, w = res.params["theta_gain"], res.params["Omega0"]
    assert abs(g.value - GAIN) < 3.0 * g.stderr and g.stderr < abs(GAIN) / 3.0, (g.value, g.stderr)
    assert abs(w.value - TRUTH["Omega0"]) < 3.0 * w.stderr
    # without the term an angle read small is a pendulum swinging faster at a smaller amplitude: Omega0 off
    # by more than 3 of its standard errors
    wrong = fit(get_model("standard"), rec)
    assert abs(wrong.params["Omega0"].value - TRUTH["Omega0"]) > 3.0 * wrong.params["Omega0"].stderr


def test_plausibility_flags_judge_a_measurement_parameter_by_its_error_only():
    names = ("Omega0", "C1", "theta_off")
    x = np.array([5.0, 0.02, 2e-3])
    se = np.array([1e-4, 1e-3, 5e-3])  # theta_off 0.4 sigma from 0, above the 1e-3 rad floor
    lo = np.array([1e-6, 0.0, -np.inf])
    hi = np.full(3, np.inf)
    floors = {"Omega0": 1e-3, "C1": 5e-3, "theta_off": 1e-3}
    assert "theta_off" in plausibility_flags(names, x, se, lo, hi, t_start=0.0, t_end=30.0, floors=floors)
    assert plausibility_flags(names, x, se, lo, hi, t_start=0.0, t_end=30.0, floors=floors,
                              nuisance=("theta_off",)) == {}
    se[2] = np.nan
    assert "theta_off" in plausibility_flags(names, x, se, lo, hi, t_start=0.0, t_end=30.0, floors=floors,
                                             nuisance=("theta_off",))


def test_a_held_offset_is_the_models_zero():
    """``fixed={"theta_off": x}``: the start of the model's angle is the data's less x, and the fit keeps x."""
    from pendtrack.config import ModelsConfig
    from pendtrack.fitting.estimate import estimate
    from pendtrack.fitting.leastsq.samples import Record

    t, theta, omega, alpha, ok, obs = record(lambda th: th + OFFSET)
    rec = Record(t, theta, omega, alpha=alpha, ok=ok, observation=obs)
    model = compose("standard", ["offset"])
    free = estimate(model, rec, options=options(), model_options=ModelsConfig())
    held = estimate(model, rec, options=options(), model_options=ModelsConfig(), fixed={"theta_off": 0.0})
    first = float(theta[np.flatnonzero(rec.usable())[0]])
    assert free.estimates["theta_off"] == pytest.approx(OFFSET, abs=1e-3)  # the oscillation's centre
    assert free.estimates["theta0"] == pytest.approx(first - free.estimates["theta_off"], abs=1e-12)
    assert held.estimates["theta0"] == pytest.approx(first, abs=1e-12)
    assert "theta_off" not in held.problem.names
    res = fit_model(model, t, theta, omega, alpha=alpha, ok=ok, observation=obs, options=options(), seed=0,
                    workers=1, fixed={"theta_off": 0.0})
    assert res.params["theta_off"].fixed and res.params["theta_off"].value == 0.0
    assert res.to_dict()["fixed"] == ["theta_off"]


def _fd_by_simulating_every_column(prob, x, *, central):  # noqa: ANN001, ANN202
    """The finite-difference Jacobian with every column simulated afresh (:meth:`FitProblem.jacobian`'s steps)."""
    steps = prob.fd_steps(x)
    r0 = prob.residuals(x)
    cols = []
    for j in range(x.size):
        up, down = prob.upper[j] - x[j], x[j] - prob.lower[j]
        if central:
            hp, hm = min(steps[j], up), min(steps[j], down)
            xp, xm = x.copy(), x.copy()
            xp[j] += hp
            xm[j] -= hm
            cols.append((prob.residuals(xp) - prob.residuals(xm)) / (hp + hm))
        else:
            h = steps[j] if steps[j] <= up else -min(steps[j], down)
            xp = x.copy()
            xp[j] += h
            cols.append((prob.residuals(xp) - r0) / h)
    return np.column_stack(cols)


@pytest.mark.parametrize("central", [False, True], ids=["forward", "central"])
def test_measurement_columns_observe_the_state_again_and_equal_fresh_simulations(central):
    # the simulated state does not depend on theta_off or k_scale: their finite-difference columns observe the
    # state at x again instead of simulating; the Jacobian must be the one that simulates every column, bit for bit
    from factory import synthetic_problem

    from pendtrack.fitting.leastsq.local_fits import _Tracker

    truth = {"Omega0": 5.0, "C1": 0.02, "C0": 0.02, "C2": 0.002, "theta_off": 0.01, "k_scale": 0.01}
    prob, x = synthetic_problem("standard+offset+angle_scale", truth, 6.0)
    prob = prob.__class__(**{**prob.__dict__, "jacobian_method": "fd"})
    assert [prob.names[j] for j in prob.measurement_columns] == ["theta_off", "k_scale"]
    reference = _fd_by_simulating_every_column(prob, x, central=central)
    np.testing.assert_array_equal(prob.jacobian(x, central=central), reference)
    # the local fits' counter: the same columns, and every column still counts as an evaluation (the budgets)
    tracker = _Tracker(prob, 10**6, central=central)
    r0 = tracker(x)
    calls = tracker.calls
    np.testing.assert_array_equal(tracker.jac(x, r0), reference)
    assert tracker.calls - calls == x.size * (2 if central else 1)
