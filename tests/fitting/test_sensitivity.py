"""Forward-sensitivity Jacobians of the memory-free models (``[fit] jacobian = "sensitivity"``).

The chain: the declared derivative formulas (``Term.dfn``) and the packing's complex-step
derivatives -> the RK4 sensitivity kernel (numba and its Python twin) with its events -> the
measurement terms, the Savitzky-Golay observation and the cost's chain rule
(``FitProblem.jacobian_sensitivity``), each checked here against an independent reference.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from factory import FS, synthetic_problem

from pendtrack.config import FitConfig
from pendtrack.fitting.leastsq.local_fits import local_fit
from pendtrack.fitting.uncertainty import hac_covariance
from pendtrack.models import get_model
from pendtrack.models import terms as T
from pendtrack.models.simulate import simulate_packed, simulate_sensitivities

TRUTHS = {
    "standard": {"Omega0": 5.0, "C1": 0.02, "C0": 0.02, "C2": 0.002},
    "classic": {"Omega0": 5.0, "C0": 0.02, "C3": 0.05, "p": 2.0, "Ca": 0.01},
    "opa": {"Omega0": 5.05, "C4": 3.25, "t0": -8.85, "C5": 1.57e-3},
    "inertial": {"Omega0": 5.0, "Ca": 0.01},
    # composed: a second power-law exponent, time-varying damping and both measurement terms
    "standard+power_drag+time_varying_damping+offset+angle_scale": {
        "Omega0": 5.0, "C1": 0.02, "C0": 0.02, "C2": 0.002, "C3": 0.03, "p": 1.7, "C4": 1.0, "t0": -5.0,
        "theta_off": 0.01, "k_scale": 0.01},
    # a gain of the angle: linear in theta, not a shift
    "classic+angle_gain": {"Omega0": 5.0, "C0": 0.02, "C3": 0.05, "p": 2.0, "Ca": 0.01, "theta_gain": 2e-3},
    # the offset alone: a shift, whose chain rule is exact (Term.shift)
    "classic+offset": {"Omega0": 5.0, "C0": 0.02, "C3": 0.05, "p": 2.0, "Ca": 0.01, "theta_off": 0.01},
}


def _problem(name: str, seconds: float = 10.0, *, cost: str = "xi2", seed: int = 0):
    """A FitProblem on a synthetic, noisy, Savitzky-Golay-filtered record of ``name``, and a point
    off the truth (1 % on every parameter, released with some speed): a generic point."""
    return synthetic_problem(name, TRUTHS[name], seconds, cost=cost, seed=seed)


def _column_errors(a: np.ndarray, ref: np.ndarray) -> np.ndarray:
    return np.linalg.norm(a - ref, axis=0) / np.linalg.norm(ref, axis=0)


# --- the declarations' derivatives ------------------------------------------------------------

def _declared_with_dfn():
    return [t for t in (T.BASE, *T.TERMS.values()) if t.dfn is not None]


@pytest.mark.parametrize("term", _declared_with_dfn(), ids=lambda t: t.name)
def test_declared_derivatives_match_central_differences_of_the_formulas(term):
    rng = np.random.default_rng(7)
    lo, hi = T.LAYOUT.span(term)
    n = hi - lo
    # slot values of the term's scale: amplitudes ~0.1-1, exponents 0.6-2.5, scales ~0.2, t0 < t
    c = rng.uniform(0.2, 1.0, n)
    if term.name == "power_drag":
        c[1] = 0.6
    if term.name == "time_varying_damping":
        c[1] = -3.0
    h = 1e-6  # central differences: truncation ~h^2 f''' ~1e-12, rounding ~1e-16/h = 1e-10 relative
    tol = 1e-7  # well above both, far below any wrong formula (an O(1) relative error)
    for _ in range(5):
        theta, omega, t = rng.uniform(-3, 3), rng.uniform(0.3, 8), rng.uniform(0, 5)
        if term.kind == "friction":
            w = omega
            d_w, dc = term.dfn(w, tuple(c))
            assert d_w == pytest.approx((term.fn(w + h, tuple(c))[0] - term.fn(w - h, tuple(c))[0]) / (2 * h), rel=tol)
            for i in range(n):
                cp, cm = c.copy(), c.copy()
                cp[i] += h
                cm[i] -= h
                fd = (term.fn(w, tuple(cp))[0] - term.fn(w, tuple(cm))[0]) / (2 * h)
                assert dc[i] == pytest.approx(fd, rel=tol, abs=1e-12)
            # at w = 0 (an event) the slot derivatives stay finite (dm/dw may not: it is not used there)
            with np.errstate(all="ignore"):
                assert np.all(np.isfinite(term.dfn(0.0, tuple(c))[1]))
            continue

        def f(th, om, cc):
            return term.fn(th, math.sin(th), om, t, tuple(cc))

        d_th, d_om, dc = term.dfn(theta, math.sin(theta), math.cos(theta), omega, t, tuple(c))
        assert d_th == pytest.approx((f(theta + h, omega, c) - f(theta - h, omega, c)) / (2 * h), rel=tol, abs=1e-12)
        assert d_om == pytest.approx((f(theta, omega + h, c) - f(theta, omega - h, c)) / (2 * h), rel=tol, abs=1e-12)
        for i in range(n):
            cp, cm = c.copy(), c.copy()
            cp[i] += h
            cm[i] -= h
            assert dc[i] == pytest.approx((f(theta, omega, cp) - f(theta, omega, cm)) / (2 * h), rel=tol, abs=1e-12)


def test_pack_jacobian_matches_central_differences_of_pack():
    m = get_model("classic+quarter_friction+opa_coulomb+time_varying_damping")
    p = m.validate({"Omega0": 5.0, "C0": 0.02, "C3": 0.05, "p": 1.5, "Ca": 0.01, "G1": 1e-3, "C5": 2e-3,
                    "C4": 1.0, "t0": -5.0})
    d = T.LAYOUT.pack_jacobian(m.terms, p, m.param_names)
    h = 1e-6  # central differences of Omega0^2, 1/Omega0, 4 Omega0^2 G1: relative truncation ~h^2
    for j, name in enumerate(m.param_names):
        pp, pm = dict(p), dict(p)
        pp[name] += h
        pm[name] -= h
        fd = (T.LAYOUT.pack(m.terms, pp) - T.LAYOUT.pack(m.terms, pm)) / (2 * h)
        np.testing.assert_allclose(d[:, j], fd, rtol=1e-7, atol=1e-9)  # rounding of fd ~1e-16 * 25 / h
    assert d[T.LAYOUT.index["COUL"], m.param_names.index("Omega0")] == pytest.approx(2 * 2e-3, rel=1e-15)


# --- the kernel ---------------------------------------------------------------------------

def _kernel_inputs(name: str, params: dict[str, float]):
    m = get_model(name)
    c = m.pack(params)
    names = m.param_names
    p_n = len(names) + 2
    d = np.zeros((c.size, p_n))
    d[:, :len(names)] = T.LAYOUT.pack_jacobian(m.terms, m.validate(params), names)
    d0, e0 = np.zeros(p_n), np.zeros(p_n)
    d0[-2] = e0[-1] = 1.0
    return m, c, d, d0, e0


@pytest.mark.parametrize("name, params", [
    ("classic", TRUTHS["classic"]),
    ("standard+power_drag+quarter_friction", {**TRUTHS["standard"], "C3": 0.03, "p": 0.7, "G1": 1e-3}),
])
def test_sensitivity_kernel_numba_agrees_with_its_python_twin(name, params):
    _, c, d, d0, e0 = _kernel_inputs(name, params)
    n = 240  # 2 s: four turning points (events) at Omega0 = 5 rad/s
    nb = simulate_sensitivities(c, d, n, 1 / FS, 2.5, 0.3, d0, e0, t_start=0.3)
    py = simulate_sensitivities(c, d, n, 1 / FS, 2.5, 0.3, d0, e0, t_start=0.3, python=True)
    # fastmath contract/arcp in the numba kernel: rounding-level differences only (as the plain kernels)
    for a, b in zip(nb, py):
        assert np.max(np.abs(a - b)) <= 1e-12 * max(1.0, np.max(np.abs(b)))
    # and the trajectory is the plain kernel's, to the last bit
    out = np.empty((3, n + 1))
    simulate_packed(c, n, 1 / FS, 2.5, 0.3, -1, out[0], out[1], out[2], t_start=0.3)
    np.testing.assert_array_equal(nb[0], out[0])
    np.testing.assert_array_equal(nb[1], out[1])


def test_events_coulomb_jump_against_the_closed_form():
    # theta'' = -L theta - C0 sgn(theta'): each half swing is harmonic about +-C0/L, the amplitude
    # drops by 2 C0/L per half swing; the turning points at k pi/sqrt(L) move with L, so d/dL needs
    # the event's jump S_omega+ = S_omega- alpha+/alpha- (alpha+ != alpha-: Coulomb friction)
    lin, c0, a0 = 25.0, 0.5, 1.0
    coeffs = np.asarray(T.empty_coeffs())
    coeffs[T.K_LIN] = lin
    coeffs[T.K_COUL] = c0
    d = np.zeros((coeffs.size, 3))
    d[T.K_LIN, 0] = 1.0
    d[T.K_COUL, 1] = 1.0
    d0 = np.array([0.0, 0.0, 1.0])
    n = 360  # 3 s: ~5 half swings before it sticks at |theta| <= C0/L = 0.02
    th, om, dth, dom = simulate_sensitivities(coeffs, d, n, 1 / FS, a0, 0.0, d0, np.zeros(3), substeps=4)
    t = np.arange(n + 1) / FS
    w0 = math.sqrt(lin)
    dd = c0 / lin
    k = np.floor(w0 * t / math.pi)
    sign = (-1.0) ** k
    phase = w0 * t - k * math.pi
    amp = a0 - (2 * k + 1) * dd
    moving = amp > dd  # before the pendulum sticks
    theta_exact = sign * (dd + amp * np.cos(phase))
    d_dd = sign * (1 - (2 * k + 1) * np.cos(phase))  # d theta / d (C0/L)
    d_w0 = -sign * amp * np.sin(phase) * t  # d theta / d sqrt(L)
    exact = {0: d_dd * (-c0 / lin ** 2) + d_w0 / (2 * w0), 1: d_dd / lin, 2: sign * np.cos(phase)}
    assert np.max(np.abs(th - theta_exact)[moving]) < 1e-7  # RK4, 4 sub-steps: ~1e-9 rad (measured)
    for j, ref in exact.items():
        err = np.linalg.norm((dth[:, j] - ref)[moving]) / np.linalg.norm(ref[moving])
        assert err < 1e-6, (j, err)  # RK4's error on the sensitivities, far below a missing jump's O(1)


def test_events_a_stuck_pendulum_keeps_its_sensitivities():
    # strong Coulomb friction: it sticks at a turning point; then omega = 0, d omega/dp = 0 and
    # d theta/dp stays constant (no later event: nothing unsticks it without forcing)
    coeffs = np.asarray(T.empty_coeffs())
    coeffs[T.K_SIN] = 25.0
    coeffs[T.K_COUL] = 6.0
    d = np.zeros((coeffs.size, 2))
    d[T.K_SIN, 0] = 1.0
    d[T.K_COUL, 1] = 1.0
    th, om, dth, dom = simulate_sensitivities(coeffs, d, 240, 1 / FS, 1.2, 0.0, np.zeros(2), np.zeros(2))
    stuck = np.flatnonzero(om == 0.0)
    stuck = stuck[stuck > 0]
    assert stuck.size > 50 and np.all(np.diff(stuck) == 1)  # it sticks and stays
    assert np.all(dom[stuck] == 0.0)
    assert np.all(dth[stuck] == dth[stuck[0]]) and np.all(np.isfinite(dth))
    # the stuck angle's sensitivity is the true one (central differences of the simulation)
    for j, slot in enumerate((T.K_SIN, T.K_COUL)):
        h = 1e-6 * coeffs[slot]
        outs = []
        for sgn in (1, -1):
            cc = coeffs.copy()
            cc[slot] += sgn * h
            o = np.empty((3, 241))
            simulate_packed(cc, 240, 1 / FS, 1.2, 0.0, -1, o[0], o[1], o[2])
            outs.append(o[0, -1])
        assert dth[-1, j] == pytest.approx((outs[0] - outs[1]) / (2 * h), rel=1e-5)


def test_events_sublinear_friction_is_finite_and_close_to_differences():
    # |omega|^p friction with p < 1 (and the quarter-power term): its omega-derivative is infinite
    # at omega = 0. The kernel never multiplies it by a non-zero sensitivity (the segment after an
    # event starts pinned, with d omega/dp = 0) and differentiates the step leaving the event by its
    # length; the discrete RK4 solution is barely smooth there: 4e-5-8e-5 from central differences
    # (measured, 10 s), against 1e-7 for smooth friction. Tolerance 1e-3: a missing or wrong event
    # treatment was 0.15 (measured).
    params = {"Omega0": 5.0, "C0": 0.02, "C3": 0.05, "p": 1.5, "Ca": 0.01, "G1": 1e-3}
    m, c, d, d0, e0 = _kernel_inputs("classic+quarter_friction", params)
    n = 1200
    th, om, dth, dom = simulate_sensitivities(c, d, n, 1 / FS, 2.5, 0.3, d0, e0)
    assert np.all(np.isfinite(dth)) and np.all(np.isfinite(dom))
    names = list(m.param_names) + ["theta0", "omega0"]
    for j, name in enumerate(names):
        h = 1e-7 * max(abs(params.get(name, 1.0)), 1.0)
        res = []
        for sgn in (1, -1):
            pp, a, b = dict(params), 2.5, 0.3
            if name == "theta0":
                a += sgn * h
            elif name == "omega0":
                b += sgn * h
            else:
                pp[name] += sgn * h
            o = np.empty((3, n + 1))
            simulate_packed(m.pack(pp), n, 1 / FS, a, b, -1, o[0], o[1], o[2])
            res.append(o[1])
        fd = (res[0] - res[1]) / (2 * h)
        assert np.linalg.norm(dom[:, j] - fd) / np.linalg.norm(fd) < 1e-3, name


# --- the fit's Jacobian ---------------------------------------------------------------------

@pytest.mark.parametrize("phase", [0.0, FitConfig().substep_phase], ids=["own_substeps", "fit_substeps"])
@pytest.mark.parametrize("name", list(TRUTHS))
def test_sensitivity_jacobian_agrees_with_central_differences(name, phase):
    from dataclasses import replace

    prob, x = _problem(name)
    prob = replace(prob, substep_phase=phase)  # the simulation's 3 sub-steps, and the fits' 2
    sens = prob.jacobian(x, method="sensitivity")
    central = prob.jacobian(x, method="fd", central=True)
    # column-norm relative; measured <= 3e-7 (10 s records): central differences' own error
    # (truncation ~ (1e-5)^2, rounding ~1e-16/1e-5 of the residuals) and RK4's on the sensitivities
    assert np.all(_column_errors(sens, central) < 1e-5), _column_errors(sens, central)
    # forward differences, the solver's other Jacobian, are ~1e-4 off: the test tells the two apart
    assert _column_errors(prob.jacobian(x, method="fd"), central).max() > 1e-5


def test_sensitivity_jacobian_of_the_theta_cost():
    prob, x = _problem("classic", cost="theta")
    err = _column_errors(prob.jacobian(x, method="sensitivity"), prob.jacobian(x, method="fd", central=True))
    assert np.all(err < 1e-5), err  # as for xi2


def test_the_jacobian_method_follows_the_problem_and_falls_back_for_memory():
    prob, x = _problem("classic")
    assert prob.uses_sensitivities() and not prob.uses_sensitivities("fd")
    np.testing.assert_array_equal(prob.jacobian(x), prob.jacobian(x, method="sensitivity"))
    with pytest.raises(ValueError, match="unknown Jacobian method"):
        prob.jacobian(x, method="adjoint")
    frac = get_model("fractional")
    from dataclasses import replace

    mem = replace(prob, model=frac, lower=np.zeros(7), upper=np.full(7, np.inf))
    assert mem.has_sensitivities is False and not mem.uses_sensitivities()


def test_local_fit_reaches_the_same_minimum_with_either_jacobian():
    # the same start, the same window and budgets: the same minimum (cost to 1e-6 relative or
    # lower, parameters within 0.1 standard errors: the criterion for the whole fit)
    prob, x = _problem("classic", seconds=20.0, seed=3)
    fd = local_fit(prob.__class__(**{**prob.__dict__, "jacobian_method": "fd"}), x, (prob.t_end,))
    sens = local_fit(prob, x, (prob.t_end,))
    assert fd.success and sens.success
    # "or lower": on classic's slow valley the forward-difference fit stopped 1.2e-6 (relative) higher
    assert sens.cost <= fd.cost * (1 + 1e-6)
    cov, _ = hac_covariance(prob.jacobian(sens.x, method="fd", central=True), prob.residuals(sens.x), prob.n)
    se = np.sqrt(np.diag(cov))  # the fit's reported (sandwich) standard errors
    assert np.all(np.abs(sens.x - fd.x) < 0.1 * se), (sens.x - fd.x) / se  # measured <= 0.045


def test_fit_config_jacobian_key():
    assert FitConfig().jacobian in ("fd", "sensitivity")
    from pendtrack.errors import FitError
    from pendtrack.fitting.fitter import check_options

    with pytest.raises(FitError, match="unknown jacobian"):
        check_options(FitConfig(jacobian="adjoint"))


@pytest.mark.parametrize("name", ["classic", "opa", "standard"])
def test_the_steering_jacobian_is_close_and_leads_to_the_same_minimum(name):
    from dataclasses import replace

    prob, x = _problem(name, seconds=20.0, seed=5)
    exact = prob.jacobian(x, method="sensitivity")
    coarse = replace(prob, steer_phase=FitConfig().steer_phase)  # 1 sub-step at 120 fps (Omega0 h = 0.042)
    # 0 steers with the simulation's own sub-steps: the exact sensitivity Jacobian
    np.testing.assert_array_equal(prob.jacobian_sensitivity(x, steer=True), exact)
    steer = coarse.jacobian_sensitivity(x, steer=True)
    central = prob.jacobian(x, method="fd", central=True)
    # RK4's error at 1 sub-step (Omega0 h = 0.04 rad): measured <= 3e-6 on 20-s records, 9e-5 on the
    # added-mass-only model at 60 s; the exact one stays the reported `sensitivity` Jacobian
    assert np.all(_column_errors(steer, central) < 1e-4), _column_errors(steer, central)
    assert _column_errors(steer, exact).max() > 0  # it is a different integration
    a = local_fit(prob, x, (prob.t_end,))
    b = local_fit(coarse, x, (prob.t_end,))
    assert a.success and b.success
    # the residuals alone decide where a fit ends: same cost to 1e-9 (relative), far below FINAL_TOL's
    # 1e-8, and values within 1e-3 standard errors
    assert b.cost == pytest.approx(a.cost, rel=1e-9)
    cov, _ = hac_covariance(prob.jacobian(a.x, method="fd", central=True), prob.residuals(a.x), prob.n)
    se = np.sqrt(np.diag(cov))
    assert np.all(np.abs(b.x - a.x) < 1e-3 * se), (b.x - a.x) / se


@pytest.mark.parametrize("name", ["classic", "opa"])
def test_the_ladders_shorter_windows_integrate_coarser_and_the_start_ends_where_it_did(name):
    from dataclasses import replace

    from pendtrack.fitting.leastsq.local_fits import window_ladder, windows

    prob, x = _problem(name, seconds=20.0, seed=5)
    prob = replace(prob, substep_phase=FitConfig().substep_phase)  # the fits' 2 sub-steps at 120 fps
    coarse = replace(prob, rung_phase=FitConfig().rung_phase)  # 1 on the shorter windows
    ends = window_ladder(prob.t_start, prob.t_end, prob.t_start + 3.0)
    assert len(ends) >= 3
    for (sub, last), (fine, _) in zip(windows(coarse, ends), windows(prob, ends)):
        assert sub.substep_phase == (prob.substep_phase if last else coarse.rung_phase)
        assert sub.n == fine.n
        if not last:  # RK4 at Omega0 h = 0.04 rad, 1 sub-step: another integration, its residuals within
            # ~1e-6 of their size here (measured 3e-9 to 1.5e-8 against 5e-3 to 1.6e-2); bar 100x that
            d = np.abs(sub.residuals(x) - fine.residuals(x)).max()
            assert 0 < d < 1e-4 * np.abs(fine.residuals(x)).max(), d
    a = local_fit(prob, x, ends)
    b = local_fit(coarse, x, ends)
    assert a.success and b.success
    # the whole window's residuals alone decide where a start ends: the same cost (1e-9 relative, below
    # FINAL_TOL's 1e-8) and values within 1e-3 standard errors
    assert b.cost == pytest.approx(a.cost, rel=1e-9)
    cov, _ = hac_covariance(prob.jacobian(a.x, method="fd", central=True), prob.residuals(a.x), prob.n)
    se = np.sqrt(np.diag(cov))
    assert np.all(np.abs(b.x - a.x) < 1e-3 * se), (b.x - a.x) / se


def test_the_flags_judge_by_the_zero_step_sandwich_which_a_smooth_fit_shares():
    # the plausibility flags judge each parameter by the larger of the finite-difference sandwich and the
    # sensitivity one (Uncertainty.stderr_judged): for a well-determined fit of a smooth model the two
    # agree, so judging by both does not make a measured parameter look undetermined
    from pendtrack.fitting.search import Search
    from pendtrack.fitting.uncertainty import assess

    prob, x = _problem("classic", seconds=20.0, seed=3)
    best = local_fit(prob, x, (prob.t_end,))
    assert best.success
    found = Search(outcomes=[best], xs=best.x[None, :], costs=np.array([best.cost]), best=best)
    unc = assess(prob, best, found, options=FitConfig(profile=False, bootstrap=0), seed=0, workers=1)
    assert np.all(unc.stderr_judged >= unc.stderr)
    sens, _ = hac_covariance(prob.jacobian(best.x, method="sensitivity"), prob.residuals(best.x), prob.n,
                             lag=unc.hac_lag)
    np.testing.assert_array_equal(unc.stderr_judged, np.fmax(unc.stderr, np.sqrt(np.diag(sens))))
    # SMOOTH_RATIO (1.3) is what the 10x-step check allows a smooth fit's sandwich to move; measured <= 1.000001 here
    assert np.all(unc.stderr_judged <= 1.3 * unc.stderr), unc.stderr_judged / unc.stderr
