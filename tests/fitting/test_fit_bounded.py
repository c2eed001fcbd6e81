"""Fits whose work is counted, never timed; flags for implausible values and findings for absent effects;
gappy records; one exit-code rule for `fit` and `run`."""

from __future__ import annotations

import json
import time
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from factory import swing

from pendtrack.artifacts import Provenance, write_artifact
from pendtrack.cli import cli
from pendtrack.config import Config, FitConfig
from pendtrack.errors import FitError
from pendtrack.fitting import fit_model
from pendtrack.fitting.result import ParamEstimate, in_range, plausibility_flags, plausible_limits, split_findings
from pendtrack.models import get_model
from pendtrack.fitting.models_fit import fit_problems, with_axle_uncertainty
from pendtrack.stages.kinematics import kinematics_stage

STANDARD = {"Omega0": 5.0, "C1": 0.02, "C0": 0.02, "C2": 0.002}
FAST = replace(FitConfig(), n_starts=2, workers=1, profile=False)


def _record(seconds: float = 20.0, rate: float = 60.0, seed: int = 0):
    t, theta = swing("standard", STANDARD, seconds=seconds, fps=rate, theta0=2.5, noise=3e-3, seed=seed)
    return t, theta, np.gradient(theta, t)


def _gappy_ok(n: int, run: int, share: float = 0.79) -> np.ndarray:
    """ok in runs of ``run`` samples, then not ok, ``share`` of the samples ok (a blue ball lost at every swing)."""
    ok = np.ones(n, bool)
    period = int(round(run / share))
    for s in range(0, n, period):
        ok[s + run:s + period] = False
    return ok


@pytest.mark.parametrize("run", [40, 20, 10])
def test_gappy_record_fits_or_fails_in_one_line(run):
    # 79 % ok in runs shorter than a period: every one-period span of the equation-error
    # estimate had a gap, and _polish divided by zero residuals (ZeroDivisionError, traceback)
    t, theta, omega = _record(30.0)
    ok = _gappy_ok(t.size, run)
    assert 0.75 < ok.mean() < 0.85  # ~79 % (rounding of the run pattern)
    try:
        res = fit_model(get_model("standard"), t, theta, omega, ok=ok, options=FAST)
    except FitError as exc:
        assert "\n" not in str(exc)
    else:
        assert np.isfinite(res.xi2_min) and res.converged


def test_too_gappy_record_fails_with_a_one_line_fit_error():
    t, theta, omega = _record(30.0)
    ok = _gappy_ok(t.size, 2, share=0.5)  # never 4 samples in a row: no gap-free span at all
    with pytest.raises(FitError) as info:
        fit_model(get_model("standard"), t, theta, omega, ok=ok, options=FAST)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("periods", [2.6, 1.6])
def test_few_turning_points_fit_or_say_why(periods):
    # 2.6 periods: ~5 turning points, the fit runs (its damping is then flagged, not converged-and-quoted);
    # 1.6 periods: too few, one line saying how many there are and how many are needed
    t, theta = swing("standard", STANDARD, seconds=periods * 2 * np.pi / 5.0, theta0=1.0, noise=3e-3)
    try:
        res = fit_model(get_model("classic"), t, theta, np.gradient(theta, t), options=FAST)
    except FitError as exc:
        assert periods < 2 and "\n" not in str(exc) and "turning points" in str(exc) and "need" in str(exc)
    else:
        assert periods > 2 and np.isfinite(res.xi2_min)
        assert res.trustworthy == (res.converged and not res.flags)


def test_every_start_runs_and_the_result_holds_no_clock(monkeypatch):
    # a fit's work is counted in starts and evaluations, never in seconds: with a clock that jumps an hour at
    # every reading, the fit is the same to the last digit (a budget in seconds would have cut it short)
    t, theta, omega = _record(20.0)
    opts = replace(FAST, n_starts=3)
    calm = fit_model(get_model("standard"), t, theta, omega, options=opts).to_dict()
    ticks = iter(range(10**6))
    monkeypatch.setattr(time, "monotonic", lambda: 3600.0 * next(ticks))
    monkeypatch.setattr(time, "perf_counter", lambda: 3600.0 * next(ticks))
    rushed = fit_model(get_model("standard"), t, theta, omega, options=opts).to_dict()
    for d in (calm, rushed):
        d.pop("runtime_s")
    assert rushed == calm
    assert calm["n_starts"] == 3 and len(calm["start_costs"]) == 3


def test_no_budget_runs_every_start():
    t, theta, omega = _record(20.0)
    res = fit_model(get_model("standard"), t, theta, omega, options=replace(FAST, n_starts=3))
    d = res.to_dict()
    assert d["n_starts"] == 3 and "stopped" not in d
    # flags and trustworthy are always written (on 20 s at 60 Hz C0 and C1 may be told apart only together)
    assert isinstance(d["flags"], dict) and d["trustworthy"] is (res.converged and not d["flags"])


def test_plausibility_flags_rules():
    names = ("Omega0", "C4", "t0", "G2", "Ca", "beta", "theta0", "omega0")
    x = np.array([5.0, 0.3, -1154.0, 150.0, 0.0007, 1e-6, 2.5, 1e-4])
    se = np.array([1e-4, 0.01, 50.0, 2776.0, 0.001, 0.01, 1e-3, 1e-2])
    lo = np.array([1e-6, 0.0, -1e4, 0.0, 0.0, 1e-6, -np.inf, -np.inf])
    hi = np.array([np.inf, np.inf, -1e-3, np.inf, np.inf, 1.0, np.inf, np.inf])
    floors = {"Omega0": 1e-3, "C4": 5e-3, "G2": 1e-3, "Ca": 1e-3, "beta": 1e-3, "t0": 0.0}
    flags = plausibility_flags(names, x, se, lo, hi, t_start=0.0, t_end=60.0, floors=floors)
    assert set(flags) == {"t0", "G2", "beta"}
    assert flags["t0"].startswith("far before the record")
    assert flags["G2"].startswith("not determined")
    assert "lower bound" in flags["beta"]
    # a coefficient at its physical zero is a result (the term is absent), not a flag
    x2 = x.copy()
    x2[1] = 0.0
    assert "C4" not in plausibility_flags(names, x2, se, lo, hi, t_start=0.0, t_end=60.0, floors=floors)


def test_a_drag_exponent_above_any_drag_law_is_flagged():
    names = ("Omega0", "C0", "C3", "p", "theta0", "omega0")
    lo = np.array([1e-6, 0.0, 0.0, 1e-6, -np.inf, -np.inf])
    hi = np.array([np.inf, np.inf, np.inf, np.inf, np.inf, np.inf])
    se = np.array([1e-4, 1e-3, 1e-3, 0.66, 1e-3, 1e-2])
    limits = plausible_limits(get_model("classic"), names)
    assert set(limits) == {"p"} and limits["p"][0] == 3.0

    def flags(p: float, p_se: float) -> dict:
        x, s = np.array([11.0, 0.02, 0.08, p, 2.0, 0.0]), se.copy()
        s[3] = p_se
        return plausibility_flags(names, x, s, lo, hi, t_start=0.0, t_end=60.0, floors={}, plausible=limits)

    # the Furuta pendulum's encoder log (arm taking energy at the fastest passes): p = 7.97 +- 0.66
    assert flags(7.97, 0.66)["p"].startswith("above any physical value: 7.97 +- 0.66")
    # lab1's classic fit (2.2 +- 0.14) and lab2's (3.1 +- 2.0) are drag laws, or not told from one
    assert flags(2.2, 0.14) == {} and flags(3.14, 2.0) == {}
    assert "p_f" in plausible_limits(get_model("fractional"), ("G2", "beta", "p_f"))


def test_a_fit_that_measures_a_drag_exponent_of_eight_is_not_trustworthy():
    # losses at the fastest passes only (a drag |omega/Omega0|^8): the classic fit measures p to +-0.1 and
    # flags it; the same record with quadratic drag (p = 2) is trustworthy
    def fit(p: float):
        truth = {"Omega0": 5.0, "C0": 0.02, "C3": 0.05, "p": p, "Ca": 0.0}
        t, theta = swing("classic", truth, seconds=30.0, fps=60.0, theta0=2.8, noise=2e-3, seed=3)
        return fit_model(get_model("classic"), t, theta, np.gradient(theta, t), options=replace(FAST, n_starts=4))

    eight, two = fit(8.0), fit(2.0)
    assert eight.converged and abs(eight.params["p"].value - 8.0) < 3 * eight.params["p"].stderr + 0.05
    assert eight.flags["p"].startswith("above any physical value") and not eight.trustworthy
    assert "p" not in two.flags


def test_an_effect_at_the_limit_where_it_vanishes_is_a_finding_not_a_flag():
    names = ("Omega0", "C4", "t0", "G2", "beta", "p_f", "theta0", "omega0")
    lo = np.array([1e-6, 0.0, -1e4, 0.0, 1e-6, 1e-6, -np.inf, -np.inf])
    hi = np.array([np.inf, np.inf, -1e-3, np.inf, 1.0, np.inf, np.inf, np.inf])
    se = np.array([1e-4, 0.01, 50.0, 0.01, 0.05, 0.3, 1e-3, 1e-2])
    terms = ("time_varying_damping", "memory")

    def split(x: np.ndarray) -> tuple[dict, dict]:
        raw = plausibility_flags(names, x, se, lo, hi, t_start=0.0, t_end=60.0, floors={})
        return split_findings(terms, names, x, se, lo, raw, t_start=0.0, t_end=60.0)

    # t0 far before the record (OPA on a record without time-varying damping), beta on its bound 0 (the memory
    # term a plain power-law drag): both findings, naming the model they reduce to; nothing flagged
    flags, findings = split(np.array([5.0, 0.3, -1154.0, 0.02, 1e-6, 1.3, 2.5, 1e-4]))
    assert flags == {} and set(findings) == {"C4", "t0", "beta"}
    assert findings["t0"].startswith("the data show no time varying damping")
    assert findings["beta"].startswith("the data show no memory") and "power-law drag" in findings["beta"]
    assert findings["t0"].endswith("reduces to gravity+viscous+power_drag")
    # G2 at 0: memory absent, its beta and p_f not measured -- findings, not "not determined" flags
    flags, findings = split(np.array([5.0, 0.3, -10.0, 0.0, 0.4, 40.0, 2.5, 1e-4]))
    assert {"G2", "beta", "p_f"} <= set(findings) and not {"G2", "beta", "p_f"} & set(flags)
    # memory present (beta inside its range, G2 > 0) and t0 within the record's reach: no finding
    flags, findings = split(np.array([5.0, 0.3, -10.0, 0.02, 0.4, 1.3, 2.5, 1e-4]))
    assert findings == {}
    # a value merely small, or consistent with 0, is not at the limit: still a flag where undetermined
    flags, findings = split(np.array([5.0, 0.3, -10.0, 0.002, 0.4, 1.3, 2.5, 1e-4]))
    assert findings == {} and "G2" in flags
    # beta a hair inside its bound 0 and within one standard error of it (the demo's fractional fit once its slow
    # frames left the cost: 0.022 +- 0.056): the same finding as on the bound, not "not determined"
    flags, findings = split(np.array([5.0, 0.3, -10.0, 0.02, 0.022, 1.3, 2.5, 1e-4]))
    assert "beta" not in flags and findings["beta"].startswith("the data show no memory")
    assert "within one standard error of 0" in findings["beta"] and "power-law drag" in findings["beta"]
    # two standard errors from 0: measured, no finding
    flags, findings = split(np.array([5.0, 0.3, -10.0, 0.02, 0.11, 1.3, 2.5, 1e-4]))
    assert "beta" not in findings and "beta" not in flags


def test_the_memory_term_as_an_added_mass_flags_omega0():
    # the field render's fractional fit (axle out of frame): beta and p_f within 2 standard errors of 1, where
    # -G2 D^beta(A |A|^(p_f-1)) is G2 dA/dt*, an added mass: Omega0 (7 % off the swing's) trades off against G2
    names = ("Omega0", "G1", "G2", "beta", "p_f", "theta_off", "theta0", "omega0")
    x = np.array([5.571, 0.0, 0.1377, 0.99995, 0.99357, 1.7e-4, 0.8, 0.05])
    se = np.array([0.11, 2e-4, 0.046, 0.007, 0.0045, 3e-5, 1e-3, 1e-2])
    lo = np.array([1e-6, 0.0, 0.0, 1e-6, 1e-6, -np.inf, -np.inf, -np.inf])
    hi = np.array([np.inf, np.inf, np.inf, 1.0, np.inf, np.inf, np.inf, np.inf])
    floors = {"Omega0": 1e-3, "G1": 1e-3, "G2": 1e-3}

    def flags(xx: np.ndarray, ss: np.ndarray) -> dict[str, str]:
        return plausibility_flags(names, xx, ss, lo, hi, t_start=0.0, t_end=12.0, floors=floors,
                                  nuisance=("theta_off",))

    assert set(flags(x, se)) == {"Omega0"} and "added mass" in flags(x, se)["Omega0"]
    # p_f told from 1 (2.2 standard errors), or beta told from 1, or no memory: Omega0 stands
    for j, v in ((4, 1.01), (3, 0.9), (2, 0.0)):
        moved = x.copy()
        moved[j] = v
        assert "Omega0" not in flags(moved, se), (j, v)
    # the drag-like minimum of the same record: beta 0 +- 0.13, p_f 1.2 +- 1.6
    drag = x.copy()
    drag[[0, 2, 3, 4]] = (5.2207, 0.0025, 0.3, 1.235)
    wide = se.copy()
    wide[[0, 3, 4]] = (0.0022, 0.13, 1.6)
    assert "Omega0" not in flags(drag, wide)
    # beta and p_f within 2 standard errors of 1 only because they are not measured (a 30-fps memory record:
    # beta 0.45 +- 0.61, p_f 1.26 +- 0.54): no added mass
    loose = x.copy()
    loose[[3, 4]] = (0.45, 1.26)
    loose_se = se.copy()
    loose_se[[3, 4]] = (0.61, 0.54)
    assert "Omega0" not in flags(loose, loose_se)


@pytest.mark.integration
def test_a_swing_without_damping_fits_classic_with_every_term_absent(tmp_path):
    # a clock's pendulum, kept at constant amplitude by its escapement (KatieButler/Non-Linear's pendulum.MOV):
    # classic put C0, C3 and Ca at 0, where the power drag's exponent p changes no residual; J^T J was
    # singular, so the fit was "NOT CONVERGED" with Omega0 +- n/a, though the data fix Omega0 well
    t, theta = swing("standard", {"Omega0": 5.5, "C1": 0.0, "C0": 0.0, "C2": 0.0}, seconds=7.0, theta0=0.06, fps=30.0,
                     noise=0.001, seed=3)
    src = tmp_path / "clock.txt"
    src.write_text("t theta\n" + "".join(f"{a!r} {b!r}\n" for a, b in zip(t.tolist(), theta.tolist())))
    res = _invoke("fit", src, "--model", "classic", "--starts", "8", "--workers", "1", "-q", "--out", tmp_path / "f")
    assert res.exit_code == 0, res.output
    fit = json.loads((tmp_path / "f" / "fit_classic.json").read_text())
    assert fit["converged"] and fit["flags"] == {} and {"C0", "C3", "p", "Ca"} <= set(fit["findings"])
    omega0 = fit["params"]["Omega0"]
    assert omega0["stderr"] is not None and abs(omega0["value"] - 5.5) < 3.0 * omega0["stderr"]
    assert fit["params"]["p"]["stderr"] is None  # the exponent of an absent drag has no error


def test_fit_problems_from_facts():
    facts = {"models": {"a": {"message": "singular"}}, "not_converged": ["a"],
             "flagged": {"a": {"p": "x"}, "b": {"t0": "far before the record"}}}
    problems = fit_problems(facts)
    assert problems["a"].startswith("did not converge: singular")
    assert problems["b"] == "flagged: t0 far before the record"
    assert fit_problems({"models": {}, "not_converged": []}) == {}


@pytest.fixture(scope="module")
def kin_file(tmp_path_factory):
    d = tmp_path_factory.mktemp("bounded")
    t, theta, _ = _record(20.0, rate=120.0)
    angle = d / "angle.parquet"
    write_artifact(pd.DataFrame({"t": t, "theta": theta, "ok": np.ones(t.size, bool)}), angle, "angle",
                   provenance=Provenance(stage="test"))
    return kinematics_stage(angle, out_dir=d, config=Config(), progress=False).path


def _invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


@pytest.mark.integration
def test_fit_exit_codes(kin_file, tmp_path, monkeypatch):
    ok = _invoke("fit", kin_file, "--model", "standard", "--starts", "2", "--workers", "1", "-q", "--out", tmp_path / "a")
    assert ok.exit_code == 0, ok.output
    rec = json.loads((tmp_path / "a" / "fit.json").read_text())
    assert rec["trustworthy"] is True and rec["flags"] == {}
    cfg = tmp_path / "short.toml"
    cfg.write_text("[fit]\nstart_budget = 1\nladder = false\nprofile = false\n")
    # OPA on a record without time-varying damping: t0 goes far before the record, where C4/(t - t0) is a
    # constant viscous damping. The fit found the effect absent: a finding, exit 0, no warning
    opa = _invoke("fit", kin_file, "--model", "opa", "--starts", "1", "--workers", "1", "-q", "--config", cfg,
                  "--out", tmp_path / "o")
    rec = json.loads((tmp_path / "o" / "fit.json").read_text())
    assert opa.exit_code == 0 and "warning" not in opa.output, opa.output
    assert rec["trustworthy"] is True and "t0" not in rec["flags"]
    assert rec["findings"]["t0"].startswith("the data show no time varying damping")
    assert "reduces to gravity+viscous" in rec["findings"]["t0"] and "no time varying damping" in opa.output
    # a fit with a flagged parameter: files written, exit 1 with a warning. The flag is forced: whether a short
    # fit of a real model ends flagged or converged turns on rounding (host and generic code differ), the rule
    # under test does not
    import pendtrack.fitting.result as result_mod

    monkeypatch.setattr(result_mod, "plausibility_flags", lambda *a, **k: {"Omega0": "not determined by the data (test)"})
    bad = _invoke("fit", kin_file, "--model", "standard", "--starts", "1", "--workers", "1", "-q", "--config", cfg,
                  "--out", tmp_path / "b")
    rec = json.loads((tmp_path / "b" / "fit.json").read_text())
    assert rec["trustworthy"] is False and rec["flags"] == {"Omega0": "not determined by the data (test)"}
    assert bad.exit_code == 1, bad.output
    assert "warning: the standard fit" in bad.output
    # a user error: exit 2
    err = _invoke("fit", tmp_path / "missing.parquet", "--out", tmp_path / "c", "-q")
    assert err.exit_code == 2


@pytest.mark.integration
def test_run_exit_code_follows_the_fit(monkeypatch, tmp_path):
    # `run` applies the same rule to its fit stage's facts (the pipeline itself is stubbed here:
    # the video stages are tested elsewhere)
    from pendtrack.stages import StageOutput
    from pendtrack.stages import run as run_mod

    video = tmp_path / "v.mp4"
    video.write_bytes(b"")

    def fake(facts):
        def run_pipeline(video, *, out_dir, config, models=None, table=None, force=False, progress=True):
            return run_mod.RunOutput(out_dir=tmp_path, stages={"fit": StageOutput((tmp_path / "fit.json",), facts=facts)})
        return run_pipeline

    monkeypatch.setattr(run_mod, "run_pipeline", fake({"models": {}, "not_converged": [], "flagged": {}}))
    assert _invoke("run", video, "--out", tmp_path, "-q").exit_code == 0
    monkeypatch.setattr(run_mod, "run_pipeline", fake({"models": {"opa": {"converged": True}}, "not_converged": [],
                                                       "flagged": {"opa": {"t0": "far before the record"}}}))
    res = _invoke("run", video, "--out", tmp_path, "-q")
    assert res.exit_code == 1 and "warning: the opa fit flagged: t0 far before the record" in res.output
    monkeypatch.setattr(run_mod, "run_pipeline", fake({"models": {"classic": {"message": "stopped"}},
                                                       "not_converged": ["classic"]}))
    assert _invoke("run", video, "--out", tmp_path, "-q").exit_code == 1


def test_omega0_stays_below_the_records_nyquist_frequency(monkeypatch):
    # issue 27's field trial: sborquez/Pendulum-Tracking video2 (20 s at 29.97 fps, a 0.21 rad swing that barely
    # decays): a start of the classic+offset fit ran off to Omega0 = 2.3e4 rad/s, where the RK4 sub-steps
    # (Omega h_sub <= substep_phase) grew to 15172 a sample, and the fit ran for half an hour. A record sampled every
    # h shows no oscillation faster than pi/h, so Omega0 is bounded there: at most ceil(pi / substep_phase) sub-steps
    import sys

    from scipy.signal import savgol_filter

    from pendtrack.fitting.leastsq.cost import Observation
    from pendtrack.models import compose

    sim = sys.modules["pendtrack.models.simulate"]
    most = [0]
    real = sim.default_substeps

    def counted(coeffs, h, phase=sim.SUBSTEP_PHASE):
        k = real(coeffs, h, phase)
        most[0] = max(most[0], k)
        return k

    monkeypatch.setattr(sim, "default_substeps", counted)
    h = 1 / 29.97
    t = np.arange(581) * h
    theta = (0.21 * np.exp(-t / 400) * np.cos(3.944 * t + 0.3) - 0.03
             + np.random.default_rng(0).normal(0, 2e-3, t.size))
    omega = savgol_filter(theta, 7, 3, deriv=1, delta=h)
    alpha = savgol_filter(theta, 7, 3, deriv=2, delta=h)
    res = fit_model(compose(get_model("classic"), ["offset"]), t, theta, omega, alpha=alpha,
                    observation=Observation(savgol_window=7, savgol_order=3, smooth_theta=True),
                    options=replace(FAST, n_starts=5), seed=0)
    # without the bound a start of this fit reached 252 sub-steps (Omega0 = 189 rad/s, twice the Nyquist 94 rad/s)
    limit = int(np.ceil(np.pi / FitConfig().substep_phase))
    assert 0 < most[0] <= limit
    # the record is a linear swing at 3.944 rad/s; the pendulum's sin(theta) lengthens the period of a 0.21 rad
    # swing by theta0^2/16, so the fitted small-angle Omega0 is higher by that (0.28 %), to within the noise
    assert res.values["Omega0"] == pytest.approx(3.944 * (1 + 0.21 ** 2 / 16), rel=1e-3)


def test_a_quoted_interval_ends_at_its_parameters_physical_range():
    # beta = 0 (the data show no memory) +- 0.047 reached to -0.047, a value no memory can take (issue #29)
    assert in_range("beta", (-0.047, 0.047)) == (0.0, 0.047)
    assert in_range("G2", (-0.01, 0.02)) == (0.0, 0.02)
    assert in_range("beta", (0.93, 1.08)) == (0.93, 1.0)  # beta's range ends at 1 (an added mass)
    assert in_range("Omega0", (5.1, 5.2)) == (5.1, 5.2)  # inside: untouched
    assert in_range("theta_off", (-3.0, 3.0)) == (-3.0, 3.0)  # the offset has no bound
    assert in_range("theta0", (-9.0, 9.0)) == (-9.0, 9.0)  # the initial state has no declared range
    lo, hi = in_range("G2", (float("nan"), 0.02))
    assert np.isnan(lo) and hi == 0.02  # an interval the fit could not give stays unknown

    # the axle's share widens the intervals; a parameter at its bound 0 still does not reach below it
    base = fit_model(get_model("standard"), *_record(seconds=8.0), options=replace(FAST, n_starts=1))
    c2 = ParamEstimate(value=0.0, stderr=0.004, u_paper=0.0, u_region=0.0, stderr_naive=0.003,
                       stderr_scale=0.002, interval68=(0.0, 0.004), interval95=(0.0, 0.0078))
    widened = with_axle_uncertainty(replace(base, params={**base.params, "C2": c2}), 0.0)
    lo, hi = widened.params["C2"].interval95
    assert lo == 0.0 and hi == pytest.approx(np.hypot(0.0078, 1.959964 * 0.002))
