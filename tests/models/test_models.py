"""Registry, terms, parameter validation, packing and the simulate() entry point."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from pendtrack.errors import ModelError, PendtrackError
from pendtrack.models import TERMS, compose, get_model, list_models, simulate
from pendtrack.models import terms as T
from pendtrack.models.kernels import accel_free
from pendtrack.models.rhs import accel_free_vec

STANDARD = {"Omega0": 5.05, "C1": 0.01, "C0": 0.01, "C2": 0.002}
CLASSIC = {"Omega0": 5.05, "C0": 0.01, "C3": 0.05, "p": 1.7, "Ca": 0.05}
OPA = {"Omega0": 5.05, "C4": 1.0, "t0": -1.0, "C5": 0.002}
FRACTIONAL = {"Omega0": 5.05, "G1": 1e-4, "G2": 1e-3, "beta": 0.5, "p_f": 2.2}


def test_builtin_models_and_param_names() -> None:
    assert set(list_models()) == {"inertial", "standard", "classic", "opa", "fractional"}
    assert get_model("standard").param_names == ("Omega0", "C1", "C0", "C2")
    assert get_model("classic").param_names == ("Omega0", "C0", "C3", "p", "Ca")
    assert get_model("opa").param_names == ("Omega0", "C4", "t0", "C5")
    assert get_model("fractional").param_names == ("Omega0", "G1", "G2", "beta", "p_f")
    assert get_model("inertial").param_names == ("Omega0", "Ca")
    assert get_model("fractional").has_memory and not get_model("classic").has_memory
    assert get_model("fractional").bounds["beta"] == (0.0, 1.0)


def test_term_catalogue_names_are_fixed() -> None:
    assert tuple(TERMS) == ("viscous", "coulomb", "quadratic_drag", "power_drag", "added_mass",
                            "time_varying_damping", "opa_coulomb", "quarter_friction", "memory")


def test_compose_adds_terms_and_rejects_bad_ones() -> None:
    m = compose("standard", ["added_mass"])
    assert m.name == "standard+added_mass"
    assert m.param_names == ("Omega0", "C1", "C0", "C2", "Ca")
    assert compose(get_model("classic"), ["memory"], name="x").has_memory
    with pytest.raises(ModelError, match="unknown term 'wind'"):
        compose("standard", ["wind"])
    with pytest.raises(ModelError, match="already in model"):
        compose("standard", ["viscous"])


def test_get_model_takes_composed_names_in_any_term_order() -> None:
    a = get_model("standard+offset+memory")
    b = get_model("standard+memory+offset")
    assert a == b and a.name == "standard+memory+offset"  # catalogue order: physical terms, then measurement
    assert a.terms == compose("standard", ["memory", "offset"]).terms
    assert a.measurement_terms == ("offset",) and a.physics().terms == get_model("standard+memory").terms
    assert get_model("classic+offset").param_names[-1] == "theta_off"
    assert get_model(" classic + offset ").name == "classic+offset"


@pytest.mark.parametrize(("name", "pattern"), [
    ("standard+wind", r"model 'standard\+wind': unknown term 'wind' \(known models: .*standard.*; known terms: .*memory"),
    ("wind+memory", r"'wind' is unknown model \(known models"),
    ("memory+standard", "'memory' is a term, not a model"),
    ("nope", r"unknown model 'nope' \(known models: .*; known terms: .*offset"),
    ("standard+memory+memory", "lists a term twice"),
])
def test_bad_composed_name_names_the_unknown_part(name: str, pattern: str) -> None:
    with pytest.raises(ModelError, match=pattern) as info:
        get_model(name)
    assert "\n" not in str(info.value)


def test_unknown_model_is_a_model_error() -> None:
    with pytest.raises(ModelError, match="unknown model 'nope'.*standard"):
        get_model("nope")
    assert issubclass(ModelError, PendtrackError)


@pytest.mark.parametrize(
    ("model", "params", "pattern"),
    [
        ("standard", {**STANDARD, "Ca": 1.0}, "no parameter 'Ca'"),
        ("standard", {"Omega0": 5.0, "C1": 0.1, "C0": 0.1}, "needs parameter 'C2'"),
        ("standard", {**STANDARD, "C1": -0.1}, "'C1'.*outside its physical range"),
        ("standard", {**STANDARD, "Omega0": 0.0}, "'Omega0'.*outside"),
        ("standard", {**STANDARD, "C0": float("nan")}, "'C0'.*outside"),
        ("standard", {**STANDARD, "C0": "a"}, "must be a number"),
        ("fractional", {**FRACTIONAL, "beta": 1.2}, "'beta'.*\\(0, 1\\]"),
        ("fractional", {**FRACTIONAL, "beta": 0.0}, "'beta'"),
        ("fractional", {**FRACTIONAL, "p_f": 0.0}, "'p_f'"),
        ("classic", {**CLASSIC, "p": -1.0}, "'p'"),
    ],
)
def test_parameter_validation(model: str, params: dict, pattern: str) -> None:
    with pytest.raises(ModelError, match=pattern):
        get_model(model).pack(params)


def test_pack_layout() -> None:
    c = get_model("fractional").pack(FRACTIONAL)
    assert c.dtype == np.float64 and c.shape == (T.N_COEFFS,)
    w0 = 5.05
    assert c[T.K_SIN] == pytest.approx(w0 ** 2)
    assert c[T.K_QUARTER] == pytest.approx(4 * w0 ** 2 * 1e-4)
    assert c[T.K_MEM] == pytest.approx(4 * w0 ** 2 * 1e-3)
    assert c[T.K_TSCALE] == pytest.approx(2 * w0) and c[T.K_HAS_MEMORY] == 1.0
    c = get_model("opa").pack(OPA)
    assert c[T.K_COUL] == pytest.approx(2 * w0 * 0.002) and c[T.K_TV_T0] == -1.0


@pytest.mark.parametrize(("model", "params"), [("standard", STANDARD), ("classic", CLASSIC), ("opa", OPA),
                                               ("inertial", {"Omega0": 5.0, "Ca": 0.2})])
def test_vectorised_rhs_matches_kernel_rhs(model: str, params: dict) -> None:
    rng = np.random.default_rng(1)
    theta = rng.uniform(-3, 3, 50)
    omega = np.concatenate([rng.uniform(-10, 10, 49), [0.0]])
    t = rng.uniform(0, 60, 50)
    m = get_model(model)
    c = m.pack(params)
    vec = m.accel(params, theta, omega, t)
    scalar = [accel_free(a, np.sin(a), b, tt, 1.0 if b >= 0 else -1.0, c) for a, b, tt in zip(theta, omega, t)]
    # same formula, evaluated by numpy vs scalar Python: only rounding differs
    np.testing.assert_allclose(vec, scalar, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(accel_free_vec(c, theta, omega, t), vec, rtol=0, atol=0)


def test_rhs_along_a_simulation_is_its_alpha() -> None:
    # equation-error use: the model's alpha evaluated on its own trajectory is the trajectory's alpha
    t = np.arange(0, 5, 1 / 120)
    for name, p in (("classic", CLASSIC), ("fractional", FRACTIONAL)):
        sim = simulate(name, p, t, theta0=1.0, omega0=0.0)
        a = get_model(name).accel(p, sim.theta, sim.omega, t)
        # memory term on the corrected omegas equals the kernel's final re-evaluation exactly, up to rounding
        np.testing.assert_allclose(a[1:], sim.alpha[1:], rtol=1e-9, atol=1e-9)


def test_simulate_result_is_frozen_and_complete() -> None:
    t = np.linspace(0, 2, 241)
    sim = simulate(get_model("standard"), STANDARD, t, theta0=3.0, omega0=0.0, method="reference")
    assert sim.theta.shape == sim.omega.shape == sim.alpha.shape == t.shape
    assert sim.theta[0] == 3.0 and sim.method == "reference" and sim.model == "standard"
    with pytest.raises(ValueError):
        sim.theta[0] = 1.0
    d = sim.to_dict()
    assert d["params"] == STANDARD and len(d["theta"]) == t.size
    t[0] = -5.0  # the result owns its arrays
    assert sim.t[0] == 0.0


@pytest.mark.parametrize(
    ("t", "pattern"),
    [
        (np.array([0.0, 0.1, np.nan, 0.3]), "non-finite value at index 2"),
        (np.array([0.0, 0.1, 0.1, 0.3]), "strictly increasing"),
        (np.array([0.0, 0.2, 0.1]), "strictly increasing"),
        (np.array([0.0]), "at least 2"),
    ],
)
def test_bad_time_axis(t: np.ndarray, pattern: str) -> None:
    with pytest.raises(ModelError, match=pattern):
        simulate("standard", STANDARD, t, theta0=1.0, omega0=0.0)


def test_bad_simulation_options() -> None:
    t = np.arange(0, 1, 1 / 120)
    with pytest.raises(ModelError, match="memory_s must be a positive"):
        simulate("fractional", FRACTIONAL, t, theta0=1.0, omega0=0.0, memory_s=-1.0)
    with pytest.raises(ModelError, match="shorter than half the time step"):
        simulate("fractional", FRACTIONAL, t, theta0=1.0, omega0=0.0, memory_s=1e-4)
    with pytest.raises(ModelError, match="no reference integrator"):
        simulate("fractional", FRACTIONAL, t, theta0=1.0, omega0=0.0, method="reference")
    with pytest.raises(ModelError, match="t0 = 0.0 s.*earlier than the first time"):
        simulate("opa", {**OPA, "t0": 0.0}, t, theta0=1.0, omega0=0.0)
    with pytest.raises(ModelError, match="unknown method"):
        simulate("standard", STANDARD, t, theta0=1.0, omega0=0.0, method="euler")
    with pytest.raises(ModelError, match="initial state must be finite"):
        simulate("standard", STANDARD, t, theta0=float("nan"), omega0=0.0)


def test_memory_is_a_duration_not_a_step_count() -> None:
    t120 = np.arange(0, 2, 1 / 120)
    t240 = np.arange(0, 2, 1 / 240)
    assert simulate("fractional", FRACTIONAL, t120, theta0=1.0, omega0=0.0).memory_steps == 100
    assert simulate("fractional", FRACTIONAL, t240, theta0=1.0, omega0=0.0).memory_steps == 200
    assert simulate("fractional", FRACTIONAL, t120, theta0=1.0, omega0=0.0, full_history=True).memory_steps == -1


def test_non_uniform_time_is_interpolated() -> None:
    rng = np.random.default_rng(3)
    t_uni = np.arange(0, 10, 1 / 120)
    t_jit = t_uni + rng.uniform(-0.3, 0.3, t_uni.size) / 120
    t_jit[0] = 0.0
    ref = simulate("standard", STANDARD, t_jit, theta0=2.0, omega0=0.0, method="reference")
    fast = simulate("standard", STANDARD, t_jit, theta0=2.0, omega0=0.0, method="fast")
    # cubic Hermite between RK4 samples 1/120 s apart: error ~ h^4 |theta''''| / 384 ~ 1e-6 rad
    np.testing.assert_allclose(fast.theta, ref.theta, atol=2e-6)
    np.testing.assert_allclose(fast.omega, ref.omega, atol=2e-5)


@pytest.mark.integration
def test_import_compiles_nothing() -> None:
    code = ("import sys, pendtrack.models, pendtrack.kinematics; "
            "assert 'numba' not in sys.modules, 'numba imported at import time'; "
            "assert 'scipy.integrate' not in sys.modules")
    subprocess.run([sys.executable, "-c", code], check=True)


ALL_MEMORYLESS = ["viscous", "coulomb", "quadratic_drag", "power_drag", "added_mass", "time_varying_damping",
                  "opa_coulomb", "quarter_friction"]
ALL_PARAMS = {"Omega0": 5.05, "C1": 0.01, "C0": 0.01, "C2": 0.002, "C3": 0.02, "p": 1.7, "Ca": 0.05, "C4": 0.3,
              "t0": -2.0, "C5": 0.001, "G1": 1e-4, "G2": 1e-3, "beta": 0.6, "p_f": 2.0}


def test_every_term_composed_in_one_model() -> None:
    base = get_model("inertial")  # added_mass
    everything = compose(base, [t for t in ALL_MEMORYLESS if t != "added_mass"] + ["memory"])
    assert set(everything.terms) == set(TERMS)
    assert everything.param_names == tuple(ALL_PARAMS)
    t = np.arange(0, 5, 1 / 120)
    sim = simulate(everything, ALL_PARAMS, t, theta0=2.0, omega0=0.5)
    a = everything.accel(ALL_PARAMS, sim.theta, sim.omega, t)
    # the PC kernel's final alpha is the model's right-hand side on the corrected state
    np.testing.assert_allclose(a[1:], sim.alpha[1:], rtol=1e-9, atol=1e-9)
    memless = compose(base, [t for t in ALL_MEMORYLESS if t != "added_mass"])
    p = {k: v for k, v in ALL_PARAMS.items() if k in memless.param_names}
    ref = simulate(memless, p, t, theta0=2.0, omega0=0.5, method="reference")
    fast = simulate(memless, p, t, theta0=2.0, omega0=0.5, method="fast")
    # RK4 + events vs DOP853: |omega|^(1/4) (quarter_friction) is not smooth at the turning points,
    # which costs RK4 its order there; measured 2e-7 rad over 5 s with the default 3 sub-steps
    np.testing.assert_allclose(fast.theta, ref.theta, atol=1e-6)
    a = memless.accel(p, ref.theta, ref.omega, t)
    np.testing.assert_allclose(a[1:], ref.alpha[1:], rtol=1e-9, atol=1e-9)


def test_simulate_packed_guards_its_arrays() -> None:
    from pendtrack.models import simulate_packed

    c = get_model("fractional").pack(FRACTIONAL)
    short = np.empty(5)
    ok = np.empty(11)
    with pytest.raises(ModelError, match="n_steps \\+ 1 = 11"):
        simulate_packed(c, 10, 0.01, 1.0, 0.0, 100, ok, short, ok)
    with pytest.raises(ModelError, match="memory_steps"):
        simulate_packed(c, 10, 0.01, 1.0, 0.0, 0, ok, ok, ok)
    with pytest.raises(ModelError, match="forcing"):
        simulate_packed(c, 10, 0.01, 1.0, 0.0, 100, ok, ok, ok, forcing=np.zeros(3))


# --- declarations and measurement terms ----------------------------------------------------

def test_measurement_terms_are_declared_and_observed() -> None:
    m = compose("standard", ["offset"])
    assert "theta_off" in m.param_names and m.bounds["theta_off"] == (-np.inf, np.inf)
    assert m.physical_terms == ("viscous", "coulomb", "quadratic_drag") and m.measurement_terms == ("offset",)
    assert get_model("standard").measurement_terms == ()
    t = np.arange(0, 3, 1 / 120)
    plain = simulate("standard", STANDARD, t, theta0=2.0, omega0=0.0)
    shifted = simulate(m, {**STANDARD, "theta_off": 0.03}, t, theta0=2.0, omega0=0.0)
    # the offset is not in the equation of motion: the same kernel on the same coefficients
    np.testing.assert_array_equal(shifted.theta, plain.theta)
    np.testing.assert_array_equal(m.pack({**STANDARD, "theta_off": 0.03}), get_model("standard").pack(STANDARD))
    # theta + theta_off: one addition per sample, exact to rounding of that addition
    np.testing.assert_array_equal(m.observe(plain.theta, {**STANDARD, "theta_off": 0.03}), plain.theta + 0.03)
    np.testing.assert_array_equal(get_model("standard").observe(plain.theta, STANDARD), plain.theta)
    with pytest.raises(ModelError, match="'theta_off'"):
        m.observe(plain.theta, {**STANDARD, "theta_off": float("inf")})


def test_angle_scale_and_the_order_of_measurement_terms() -> None:
    m = compose("standard", ["angle_scale", "offset"])
    assert m.measurement_terms == ("offset", "angle_scale")  # catalogue order, whatever the order asked
    assert m.param_names[-2:] == ("theta_off", "k_scale") and m.param_spec("k_scale").unit == "1/rad^2"
    theta = np.linspace(-2.0, 2.0, 9)
    p = {**STANDARD, "theta_off": 0.1, "k_scale": -0.02}
    shifted = theta + 0.1
    # same operations as the declared formulas, in the same order: equal to the last bit
    np.testing.assert_array_equal(m.observe(theta, p), shifted * (1.0 + (-0.02) * shifted * shifted))
    scale_only = compose("standard", ["angle_scale"])
    np.testing.assert_array_equal(scale_only.observe(theta, {**STANDARD, "k_scale": 0.0}), theta)


def test_layout_is_derived_from_the_declarations() -> None:
    lay = T.LAYOUT
    assert lay.size == T.N_COEFFS == len(T.empty_coeffs())
    # every physical term with slots owns a contiguous range, in catalogue order, after gravity's
    spans = [lay.span(t) for t in (T.BASE, *T.TERMS.values()) if t.slots]
    assert spans[0][0] == 0 and all(a[1] == b[0] for a, b in zip(spans, spans[1:])) and spans[-1][1] == lay.size
    assert set(T.PARAMS) == {s.name for t in (T.BASE, *T.CATALOGUE.values()) for s in t.specs}
    assert not any(t.slots for t in T.MEASUREMENT_TERMS.values())
    # opa_coulomb is a Coulomb friction: it adds into coulomb's slot
    both = compose("standard", ["opa_coulomb"]).pack({**STANDARD, "C5": 0.002})
    assert both[T.K_COUL] == pytest.approx(0.01 + 2 * 5.05 * 0.002)


def test_a_new_declared_term_enters_pack_and_the_folds() -> None:
    # a declaration alone gives its parameters, slots, packing and contribution (here a
    # hypothetical linear drag in theta, declared outside the catalogue to leave it untouched)
    from pendtrack.models.declare import Layout, ParamSpec, Slot, Term
    from pendtrack.models.kernels import folds

    extra = Term("spring", "smooth", (ParamSpec("Ks", "1/s^2", 0.0, np.inf, False, True, "test spring"),),
                 "-Ks theta", "test", slots=(Slot("SPRING"),), pack=lambda p: {"SPRING": p["Ks"]},
                 fn=lambda theta, sin_theta, omega, t, c: -c[0] * theta,
                 dfn=lambda theta, sin_theta, cos_theta, omega, t, c: (-c[0] + 0.0 * theta, 0.0 * omega, (-theta,)))
    lay = Layout(T.BASE, (*T.CATALOGUE.values(), extra))
    assert lay.size == T.N_COEFFS + 1
    c = lay.pack(("viscous", "spring"), {"Omega0": 2.0, "C1": 0.1, "Ks": 3.0})
    assert c[lay.index["SPRING"]] == 3.0 and c[lay.index["VISC"]] == 0.1
    smooth = folds._smooth_add(folds._smooth_seed(T.BASE.fn, *lay.span(T.BASE)), extra.fn, *lay.span(extra))
    theta, omega = np.array([0.3, -0.2]), np.array([1.0, 2.0])
    a = smooth(theta, np.sin(theta), omega, 0.0, tuple(c.tolist()))
    np.testing.assert_allclose(a, -4.0 * np.sin(theta) - 3.0 * theta, rtol=1e-15)
    # its derivative formula enters the sensitivity kernel's fold the same way
    grad = folds._grad_smooth_add(folds._grad_smooth_add(None, T.BASE.dfn, *lay.span(T.BASE), always=True),
                                    extra.dfn, *lay.span(extra))
    k, kn = tuple(c.tolist()), (0.0,) * lay.size
    a_th, a_om, dcs = grad(theta[0], np.sin(theta[0]), np.cos(theta[0]), omega[0], 0.0, k, kn)
    assert a_th == pytest.approx(-4.0 * np.cos(theta[0]) - 3.0, rel=1e-15) and a_om == 0.0
    assert dcs == (-np.sin(theta[0]), -theta[0], -theta[0])  # by SIN, LIN, then SPRING
    with pytest.raises(ValueError, match="needs its derivative dfn"):
        Term("bad", "smooth", extra.specs, "", "", slots=(Slot("BAD"),), pack=extra.pack, fn=extra.fn)


def test_kernel_cache_is_keyed_on_the_declarations() -> None:
    # numba keys its cache on the kernel's own file; the declarations' source enters the key
    # through the stamped closure, so a changed term cannot load a stale kernel
    import pkgutil

    from pendtrack.models import kernels
    from pendtrack.models.kernels import jit

    stamp = kernels.declarations_stamp()
    assert stamp == kernels.declarations_stamp() and len(stamp) == 64
    run = jit._stamped(kernels.pc_kernel_py, stamp)
    assert stamp in [cell.cell_contents for cell in run.__closure__]
    # the kernels live in several files but numba compiles them behind jit.py's closure: every other
    # module of the package must be in the stamp, or a changed kernel would load a stale compilation
    package = {f"{kernels.__name__}.{m.name}" for m in pkgutil.iter_modules(kernels.__path__)}
    assert set(jit.KERNEL_MODULES) == package - {jit.__name__}


def test_accel_checks_the_declared_domain_and_ignores_measurement_terms() -> None:
    t = np.linspace(0.0, 1.0, 11)
    theta, omega = np.full(11, 0.2), np.linspace(-1.0, 1.0, 11)
    with pytest.raises(ModelError, match="model 'opa': parameter t0 = 0.0 s must be earlier than the first time"):
        get_model("opa").accel({**OPA, "t0": 0.0}, theta, omega, t)
    # the offset is in the observation, not in the equation of motion: same alpha to the last bit
    with_offset = compose("standard", ["offset"]).accel({**STANDARD, "theta_off": 0.5}, theta, omega, t)
    np.testing.assert_array_equal(with_offset, get_model("standard").accel(STANDARD, theta, omega, t))


def test_a_physical_term_vanishes_with_its_amplitude() -> None:
    # the first parameter of each physical term scales it: at 0 the term adds nothing to alpha
    # (what fitting's linear estimates and discovery's starts rely on)
    rng = np.random.default_rng(2)
    theta, omega, t = rng.uniform(-3, 3, 40), rng.uniform(-8, 8, 40), np.linspace(0.0, 1.0, 40)
    base = get_model("standard")
    for name, term in TERMS.items():
        if name in base.terms:
            continue
        m = compose(base, [name])
        p = {**STANDARD, **{k: ALL_PARAMS[k] for k in term.params}, term.amplitude: 0.0}
        # the same sums with zero added (the memory term: zero times its GL derivative)
        np.testing.assert_allclose(m.accel(p, theta, omega, t), base.accel(STANDARD, theta, omega, t),
                                   rtol=1e-15, atol=1e-15)
    assert [TERMS[n].amplitude for n in ("viscous", "power_drag", "memory")] == ["C1", "C3", "G2"]
