"""The decorrelated coordinates of the Levenberg-Marquardt steps (pendtrack.fitting.leastsq.coordinates)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from factory import filtered, swing, synthetic_problem

from pendtrack.config import FitConfig
from pendtrack.errors import FitError
from pendtrack.fitting import fit_model
from pendtrack.fitting.leastsq.coordinates import fit_coordinates
from pendtrack.fitting.fitter import check_options
from pendtrack.fitting.leastsq.local_fits import local_fit
from pendtrack.fitting.uncertainty import hac_covariance
from pendtrack.models import get_model

TRUTHS = {
    "classic": {"Omega0": 5.0, "C0": 0.02, "C3": 0.05, "p": 1.7, "Ca": 0.01},
    "opa": {"Omega0": 5.05, "C4": 3.25, "t0": -60.0, "C5": 1.57e-3},
    "fractional": {"Omega0": 5.0, "G1": 2e-4, "G2": 3e-3, "beta": 0.3, "p_f": 1.5},
    "standard+power_drag+time_varying_damping+offset": {
        "Omega0": 5.0, "C1": 0.02, "C0": 0.02, "C2": 0.002, "C3": 0.03, "p": 1.7, "C4": 1.0, "t0": -5.0,
        "theta_off": 0.01},
}


def _problem(name: str, seconds: float = 10.0, seed: int = 0):
    """A FitProblem (decorrelated coordinates from its data) on a synthetic noisy record, and a
    point 1 % off the truth on every parameter."""
    truth = TRUTHS[name]
    prob, x = synthetic_problem(name, truth, seconds, seed=seed)
    coords = fit_coordinates(prob.model.param_names, prob.t, prob.omega, omega0_hat=truth["Omega0"], center=truth)
    return replace(prob, coordinates=coords), x


@pytest.mark.parametrize("name", list(TRUTHS))
def test_the_maps_are_inverse_and_map_the_box_onto_a_box(name):
    prob, x = _problem(name, seconds=5.0)
    bound = prob.coordinates.bind(prob.names)
    assert bound is not None
    y = bound.to_internal(x)
    assert not np.allclose(y, x)  # something is mapped
    np.testing.assert_allclose(bound.to_natural(y), x, rtol=1e-13, atol=1e-15)
    lo, hi = bound.bounds(prob.lower, prob.upper)
    rng = np.random.default_rng(1)
    # points inside the box of x (infinite bounds replaced by a wide finite range) are inside the box of y
    a = np.where(np.isfinite(prob.lower), prob.lower, -10.0)
    b = np.where(np.isfinite(prob.upper), prob.upper, 10.0)
    for _ in range(50):
        xs = a + (b - a) * rng.uniform(size=x.size)
        ys = bound.to_internal(xs)
        assert np.all(ys >= lo) and np.all(ys <= hi)
        np.testing.assert_allclose(bound.to_natural(ys), xs, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("name", list(TRUTHS))
def test_the_jacobian_by_the_step_coordinates_matches_their_differences(name):
    prob, x = _problem(name, seconds=5.0)
    bound = prob.coordinates.bind(prob.names)
    y = bound.to_internal(x)
    jac = bound.jacobian(prob.jacobian(x, central=True, method="fd"), y)
    ref = np.empty_like(jac)
    for j in range(y.size):  # central differences of the residuals as a function of y
        h = 1e-6 * max(abs(y[j]), 1e-3)
        yp, ym = y.copy(), y.copy()
        yp[j] += h
        ym[j] -= h
        ref[:, j] = (prob.residuals(bound.to_natural(yp)) - prob.residuals(bound.to_natural(ym))) / (2 * h)
    err = np.linalg.norm(jac - ref, axis=0) / np.linalg.norm(ref, axis=0)
    # both sides are central differences (steps 1e-6 relative): agreement to their truncation and
    # rounding, measured <= 1e-6; a wrong chain-rule factor would be an O(1) error in its column
    assert np.all(err < 1e-4), err


def test_a_held_parameter_drops_its_map():
    prob, _ = _problem("standard+power_drag+time_varying_damping+offset", seconds=5.0)
    assert prob.coordinates.bind(prob.with_fixed({"p": 1.7}).names).scaled == ()
    assert prob.coordinates.bind(prob.with_fixed({"p": 1.7}).names).tv is not None
    assert prob.coordinates.bind(prob.with_fixed({"t0": -5.0}).names).tv is None
    assert prob.coordinates.bind(prob.with_fixed({"p": 1.7, "C4": 1.0}).names) is None
    # a model without these terms has none
    assert fit_coordinates(get_model("standard").param_names, np.arange(3.0), np.ones(3), omega0_hat=5.0) is None


@pytest.mark.parametrize("name", ["classic", "opa"])
def test_a_local_fit_ends_at_the_same_minimum_in_either_coordinates(name):
    # issue #16's criterion for the whole fit: the cost the same to 1e-6 relative or lower, the values
    # within 0.1 standard errors. (A model with memory is finished by the profile polish, not by one
    # local fit: the whole fit's test is below.)
    prob, x = _problem(name, seconds=20.0, seed=3)
    natural = local_fit(replace(prob, coordinates=None), x, (prob.t_end,))
    steps = local_fit(prob, x, (prob.t_end,))
    assert steps.success
    assert steps.cost <= natural.cost * (1 + 1e-6)
    cov, _ = hac_covariance(prob.jacobian(steps.x, method="fd", central=True), prob.residuals(steps.x), prob.n)
    se = np.sqrt(np.diag(cov))
    assert np.all(np.abs(steps.x - natural.x) < 0.1 * se), (steps.x - natural.x) / se


def test_the_coordinates_key_is_checked():
    assert FitConfig().coordinates == "decorrelated"
    with pytest.raises(FitError, match="unknown coordinates"):
        check_options(FitConfig(coordinates="polar"))


def test_the_memory_models_whole_fit_ends_at_the_same_minimum_in_either_coordinates():
    # one local fit of the fractional model stops in its curved G2-beta valley wherever its tolerance
    # says (either coordinates, ~1e-6 relative apart); the fit's profile polish finishes the best start
    m = get_model("fractional")
    truth = TRUTHS["fractional"]
    kin, obs = filtered(*swing(m, truth, seconds=20.0, theta0=2.8, noise=3e-3, seed=4))
    fits = {}
    for coords in ("natural", "decorrelated"):
        options = FitConfig(n_starts=6, profile=False, coordinates=coords)
        fits[coords] = fit_model(m, kin.t, kin.theta, kin.omega, ok=kin.ok, observation=obs, options=options,
                                 seed=0, workers=1)
    a, b = fits["natural"], fits["decorrelated"]
    assert b.converged
    assert b.xi2_min <= a.xi2_min * (1 + 1e-6)
    for name in m.param_names:
        se = b.params[name].stderr
        assert abs(b.params[name].value - a.params[name].value) < 0.1 * se, name


def test_an_exponent_far_outside_the_data_maps_without_overflow():
    # a Levenberg-Marquardt step may try p = 1e4: the maps stay finite (the fit's penalty residuals
    # then turn it back) instead of raising OverflowError in a worker
    prob, x = _problem("classic", seconds=5.0)
    bound = prob.coordinates.bind(prob.names)
    i = list(prob.names).index("p")
    for p in (1e4, 1e-6):
        xs = x.copy()
        xs[i] = p
        y = bound.to_internal(xs)
        assert np.all(np.isfinite(y))
        assert np.all(np.isfinite(bound.to_natural(y)))
        jac = bound.jacobian(np.ones((3, x.size)), y)
        assert np.all(np.isfinite(jac))
    ys = bound.to_internal(x)
    ys[i] = 1e5  # a step in y far outside
    assert np.all(np.isfinite(bound.to_natural(ys)))
    assert np.all(np.isfinite(prob.residuals(bound.to_natural(ys))))


def _runs_with_drag(logs):
    """Stand-ins of runs' problems: only their coordinates (C3 at the reference of p) are read."""
    from types import SimpleNamespace

    from pendtrack.fitting.leastsq.coordinates import Coordinates
    return tuple(SimpleNamespace(coordinates=Coordinates(scaled=(("C3", (("p", lg),)),))) for lg in logs)


def test_a_joint_drag_steps_at_the_mean_of_its_runs_references():
    from pendtrack.fitting.joint.stacked import joint_coordinates
    runs = _runs_with_drag([-0.2, -0.4, -0.9])
    # C3 and p per group: runs 0 and 1 in group a, run 2 in group b
    labels = [{"C3": "C3[a]", "p": "p[a]"}, {"C3": "C3[a]", "p": "p[a]"}, {"C3": "C3[b]", "p": "p[b]"}]
    coords = joint_coordinates(runs, labels)
    assert coords.scaled == (("C3[a]", (("p[a]", pytest.approx(-0.3)),)), ("C3[b]", (("p[b]", -0.9),)))
    # a shared p under per-group C3: each amplitude takes its own runs' reference on the one p column
    shared_p = [{"C3": "C3[a]", "p": "p"}, {"C3": "C3[a]", "p": "p"}, {"C3": "C3[b]", "p": "p"}]
    assert joint_coordinates(runs, shared_p).scaled[1] == ("C3[b]", (("p", -0.9),))
    bound = joint_coordinates(runs, shared_p).bind(("C3[a]", "p", "C3[b]"))
    x = np.array([0.02, 1.5, 0.03])
    np.testing.assert_allclose(bound.to_natural(bound.to_internal(x)), x, rtol=1e-14)
    # two amplitudes on one exponent: the chain rule through both (central differences in y)
    def res(v):
        return np.array([v[0] * v[1], v[2] * v[1] ** 2, v[0] + 3.0 * v[2]])
    jac_x = np.array([[x[1], x[0], 0.0], [0.0, 2.0 * x[2] * x[1], x[1] ** 2], [1.0, 0.0, 3.0]])
    y = bound.to_internal(x)
    h = 1e-6 * np.maximum(np.abs(y), 1e-3)
    fd = np.column_stack([(res(bound.to_natural(y + h[k] * np.eye(3)[k])) - res(bound.to_natural(y - h[k] * np.eye(3)[k])))
                          / (2.0 * h[k]) for k in range(3)])
    np.testing.assert_allclose(bound.jacobian(jac_x, y), fd, rtol=1e-6, atol=1e-9)


def test_a_joint_amplitude_over_exponents_fitted_per_run_keeps_its_own_coordinate():
    from pendtrack.fitting.joint.stacked import joint_coordinates
    runs = _runs_with_drag([-0.2, -0.4])
    per_run_p = [{"C3": "C3", "p": "p[r1]"}, {"C3": "C3", "p": "p[r2]"}]
    assert joint_coordinates(runs, per_run_p) is None
    held_c3 = [{"p": "p"}, {"p": "p"}]  # C3 held: not in the fitted labels
    assert joint_coordinates(runs, held_c3) is None


def test_a_step_far_out_maps_to_a_finite_point_without_an_overflow_warning():
    # a 140-s Tracker record at 30 fps printed numpy's "overflow encountered in scalar multiply" to the user:
    # an amplitude of 1e10 with an exponent step to 80 (exp clipped at 700) multiplied past float64's range:
    # inf, as before, and no warning
    import warnings

    from pendtrack.fitting.leastsq.coordinates import BoundCoordinates

    coords = BoundCoordinates(scaled=((0, ((1, 10.0),)),))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        x = coords.to_natural(np.array([1e10, -80.0]))
        y = coords.to_internal(np.array([-1e10, 80.0]))
    assert x[0] == np.inf and x[1] == -80.0
    assert y[0] == -np.inf
    # inside the range the maps are each other's inverse
    back = coords.to_natural(coords.to_internal(np.array([0.3, 1.7])))
    assert np.allclose(back, [0.3, 1.7], rtol=1e-12)
    # the Jacobian's chain rule at such a point (tylertian123/phy180_lab's trial1_rawdata.txt printed "overflow
    # encountered in multiply" from it): inf entries, no warning
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        jac = coords.jacobian(np.full((4, 2), 1e300), np.array([1e10, -80.0]))
    assert np.isinf(jac).any()
