"""Synthetic run and batch folders for the report tests (realistic damped-pendulum numbers).

The run is a 24-cm-tile-like pendulum released near the top (theta0 = 3.0 rad), integrated
with the paper's classic model (eq. classicmodel) by scipy, observed at 120 fps with 2 mrad of
tracking noise and differentiated by the paper's 25-frame cubic Savitzky-Golay filter. The
"fitted" models are the truth (classic) and two slightly detuned copies (opa, fractional), so
every figure has something to draw. Files are written through pendtrack.artifacts, as the
stages do. Other test modules import :func:`write_run` and :func:`write_batch`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from scipy.integrate import solve_ivp
from scipy.signal import savgol_filter

from pendtrack.artifacts import (
    DISCOVERY_JSON_KEYS,
    FIT_JSON_KEYS,
    Provenance,
    write_artifact,
    write_json_artifact,
)

FPS = 120.0
AXLE = (640.0, 250.0)  # [px]
RADIUS = 300.0  # [px]
CLASSIC = {"Omega0": 4.8, "C0": 0.02, "C3": 0.35, "p": 1.7, "Ca": 0.02}
OPA = {"Omega0": 4.79, "C4": 3.2, "t0": -8.8, "C5": 0.0016}
FRACTIONAL = {"Omega0": 4.801, "G1": 0.0009, "G2": 0.02, "beta": 0.4, "p_f": 2.1}


def _classic(params: dict, seconds: float, theta0: float, omega0: float) -> tuple[np.ndarray, ...]:
    w0, c0, c3, p, ca = (params[k] for k in ("Omega0", "C0", "C3", "p", "Ca"))

    def rhs(_t, y):
        th, om = y
        s = 1.0 if om >= 0 else -1.0
        return [om, -w0 ** 2 * np.sin(th) + ca * om ** 2 * np.sin(th) - s * (c0 + c3 * abs(om / w0) ** p)]

    t = np.arange(int(seconds * FPS)) / FPS
    sol = solve_ivp(rhs, (0, t[-1]), [theta0, omega0], t_eval=t, rtol=1e-9, atol=1e-11, max_step=1 / FPS)
    return t, sol.y[0], sol.y[1]


def _fit_json(model: str, params: dict, rms: float, n: int) -> dict:
    rel = {"classic": 0.002, "opa": 0.004, "fractional": 0.003}[model]
    entry = {k: {"value": v, "stderr": abs(v) * rel + 1e-6, "u_paper": abs(v) * 2 * rel + 1e-6}
             for k, v in params.items()}
    k = len(params) + 2
    xi2 = (rms / 2) ** 2
    return {"model": model, "params": entry, "xi2_min": xi2, "rms": rms, "aic": n * np.log(xi2) + 2 * k,
            "bic": n * np.log(xi2) + k * np.log(n), "n": n, "converged": True, "runtime_s": 12.5, "seed": 0,
            "window": [0.0, n / FPS], "omega0_hat": 4.8}


def write_run(run_dir: Path, *, seconds: float = 30.0, seed: int = 0, models=("classic", "opa", "fractional"),
              discovery: bool = True, stages=("track", "angle", "kinematics", "fit")) -> Path:
    """Write a synthetic run folder; ``stages`` chooses which artifacts exist."""
    rng = np.random.default_rng(seed)
    run_dir = Path(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    t, theta_true, omega_true = _classic(CLASSIC, seconds, 3.0, 0.0)
    n = t.size
    theta_meas = theta_true + rng.normal(0, 0.002, n)
    x = AXLE[0] + RADIUS * np.sin(theta_meas) + rng.normal(0, 0.4, n)
    y = AXLE[1] + RADIUS * np.cos(theta_meas) + rng.normal(0, 0.4, n)
    score = np.clip(0.93 - 0.05 * np.abs(omega_true) / 8 + rng.normal(0, 0.015, n), -1, 1)
    bad = rng.choice(n, 12, replace=False)
    score[bad] = rng.uniform(0.3, 0.55, bad.size)
    ok = score >= 0.6
    if "track" in stages:
        track = pd.DataFrame({"frame": np.arange(n, dtype=np.int64), "t": t, "x_px": x * 1.01, "y_px": y * 0.99,
                              "x": x, "y": y, "score": score, "ok": ok})
        write_artifact(track, run_dir / "track.parquet", "track",
                       provenance=Provenance(stage="track", config={"track": {"min_score": 0.6}, "lens": {}},
                                             extra={"fps": FPS, "ok_fraction": float(ok.mean())}))
    if "angle" in stages:
        write_artifact(pd.DataFrame({"t": t, "theta": theta_meas, "ok": ok}), run_dir / "angle.parquet", "angle",
                       provenance=Provenance(stage="angle", config={"angle": {"axle": []}}, extra={
                           "axle_source": "circle_fit", "axle_px": list(AXLE), "zero_reference": 0.0012,
                           "circle": {"xc": AXLE[0], "yc": AXLE[1], "radius": RADIUS, "rms_px": 0.55,
                                      "mad_px": 0.4, "n": int(ok.sum()), "arc_span_deg": 330.0},
                           "circle_rms_px": 0.55}))
    w = 25
    th = savgol_filter(theta_meas, w, 3)
    om = savgol_filter(theta_meas, w, 3, deriv=1, delta=1 / FPS)
    al = savgol_filter(theta_meas, w, 3, deriv=2, delta=1 / FPS)
    w0 = CLASSIC["Omega0"]
    a_th, a_om = np.sin(th / 2), om / (2 * w0)
    phase = np.arctan2(a_th, a_om)
    dalpha = al + w0 ** 2 * np.sin(th)
    if "kinematics" in stages:
        kin = pd.DataFrame({"t": t, "theta": th, "omega": om, "alpha": al, "ok": ok,
                            "segment": np.zeros(n, np.int64), "A_theta": a_th, "A_omega": a_om,
                            "energy": a_th ** 2 + a_om ** 2, "phase": phase,
                            "phase_speed": np.gradient(np.unwrap(phase), t), "delta_alpha": dalpha,
                            "negative_damping": dalpha * om > 0})
        write_artifact(kin, run_dir / "kinematics.parquet", "kinematics",
                       provenance=Provenance(stage="kinematics",
                                             config={"kinematics": {"savgol_window_s": w / FPS, "savgol_order": 3}},
                                             extra={"Omega0": w0, "Omega0_stderr": 0.004, "Omega0_raw": 4.79,
                                                    "Omega0_reason": "", "h": 1 / FPS, "window_points": w,
                                                    "window_s": w / FPS, "order": 3}))
    if "fit" in stages:
        curves, fits = [], {}
        for name, params in (("classic", CLASSIC), ("opa", None), ("fractional", None)):
            if name not in models:
                continue
            detune = {"classic": CLASSIC, "opa": dict(CLASSIC, Omega0=4.79, C3=0.33),
                      "fractional": dict(CLASSIC, Omega0=4.801, C0=0.021)}[name]
            _, thm, omm = _classic(detune, seconds, 3.0, 0.0)
            curves.append(pd.DataFrame({"t": t, "theta": theta_meas, "theta_model": thm, "omega_model": omm,
                                        "residual": theta_meas - thm, "model": name}))
            fit_params = {"classic": CLASSIC, "opa": OPA, "fractional": FRACTIONAL}[name]
            fits[name] = _fit_json(name, fit_params, float(np.sqrt(np.mean((theta_meas - thm) ** 2))), n)
            write_json_artifact(fits[name], run_dir / f"fit_{name}.json", required=FIT_JSON_KEYS,
                                provenance=Provenance(stage="fit"))
        write_artifact(pd.concat(curves, ignore_index=True), run_dir / "fit.parquet", "fit",
                       provenance=Provenance(stage="fit"))
        combined = {"models": fits, "best_model": "classic"}
        if "classic" in fits and "fractional" in fits:  # as pendtrack.fitting.cross_model.CrossModel.to_dict
            g1, g1c = FRACTIONAL["G1"], CLASSIC["C0"] / (4 * w0 ** 2)
            pf, pc = FRACTIONAL["p_f"] - FRACTIONAL["beta"], CLASSIC["p"]
            combined["cross_model"] = {"both_converged": True, "relations": {
                "G1": {"relation": "G1 ~ C0/(4 Omega0^2)", "lhs": g1, "lhs_stderr": 2e-5, "rhs": g1c,
                       "rhs_stderr": 1e-5, "ratio": g1 / g1c, "z": (g1 - g1c) / 2.2e-5},
                "p_f": {"relation": "p_f - beta ~ p", "lhs": pf, "lhs_stderr": 0.01, "rhs": pc,
                        "rhs_stderr": 0.003, "ratio": pf / pc, "z": (pf - pc) / 0.0104}}}
        write_json_artifact(combined, run_dir / "fit.json", required=(), provenance=Provenance(stage="fit"))
    if discovery:
        step = {"effect": "power_drag", "model": "standard+power_drag", "params": {"C3": {"value": 0.35,
                "stderr": 0.002, "u_paper": 0.004}, "p": {"value": 1.7, "stderr": 0.01, "u_paper": 0.02}},
                "rms_before": 0.02, "rms_after": 0.004, "xi2_before": 1e-4, "xi2_after": 4e-6,
                "heldout_rms_before": 0.022, "heldout_rms_after": 0.005, "heldout_z": 9.1, "delta_bic": -812.0}
        final = {"model": "standard+power_drag", "extra": ["power_drag"], "params": dict(step["params"]),
                 "rms": 0.004, "heldout_rms": 0.005, "converged": True, "terms_added": ["power_drag"]}
        disc = {"baseline": "standard", "effects": ["power_drag"], "steps": [step],
                "diagnosis": {"evidence": {"excess_rms": 14.2, "dephasing": 6.1, "hysteresis": 3.3},
                              "final": {"evidence": {"excess_rms": 0.4, "dephasing": 0.3, "hysteresis": 0.8}},
                              "ranking": [{"effect": "power_drag", "score": 7.2, "note": "drag <evidence>"},
                                          {"effect": "memory", "score": 2.1, "note": ""}],
                              "signature_top": "power_drag", "cause": "power_drag",
                              "cause_matches_signature": True},
                "final_model": final,
                "runners_up": [{"effect": "memory", "step": 2, "heldout_gain": -0.0001, "delta_bic": 12.0,
                                "reason": "held-out RMS did not improve"}]}
        assert set(DISCOVERY_JSON_KEYS) <= set(disc)
        write_json_artifact(disc, run_dir / "discovery.json", required=DISCOVERY_JSON_KEYS,
                            provenance=Provenance(stage="discover"))
        (run_dir / "discovery.md").write_text(
            "# Discovery\n\nStarted from **standard**; its residual oscillates (*dephasing*).\n\n"
            "- step 1: add `power_drag`: held-out RMS 22 -> 5 mrad\n", encoding="utf-8")
    return run_dir


def two_cuboid(l1_m: np.ndarray, x: float, l0: float, g: float = 9.81) -> np.ndarray:
    """Eq. consistencycheck (for making realistic batch numbers only)."""
    r = np.asarray(l1_m) / l0
    return np.sqrt(g / l0) * np.sqrt((0.5 * x + r - 0.5 * r ** 2) / (x / 3 + r - r ** 2 + r ** 3 / 3))


def write_batch(batch_dir: Path, *, run_dirs: int = 2, seed: int = 1, csv_only: bool = False) -> Path:
    """A synthetic batch folder: summary (all 4 series x 5 tiles), batch.json and a few run folders."""
    rng = np.random.default_rng(seed)
    batch_dir = Path(batch_dir)
    batch_dir.mkdir(parents=True, exist_ok=True)
    rows = []
    for kind in ("la", "ln", "na", "nn"):
        for tile in (0, 6, 12, 18, 24):
            l1 = tile / 100
            w0 = float(two_cuboid(l1, 1.48, 0.54)) * (0.995 if kind[1] == "a" else 1.0) + rng.normal(0, 0.005)
            code = f"{tile:02d}{kind}1"
            row = {"run_id": code, "file": f"{code}.mp4", "status": "ok", "reason": "", "resumed": False,
                   "code": code, "kind": kind, "tile_cm": tile, "l1_m": l1, "launched": kind[0] == "l",
                   "alley": kind[1] == "a", "trial": 1, "frames": 7200, "fps": 120.0, "duration_s": 60.0,
                   "ok_fraction": 0.998, "runtime_s": 300.0, "video_sha256": "0" * 64,
                   "classic__converged": True, "classic__rms": 0.004, "fractional__converged": True,
                   "fractional__rms": 0.003}
            vals = {"classic": {"Omega0": w0, "C0": 0.03 - 0.0008 * tile, "C3": 0.1 + 0.02 * tile,
                                "p": 1.6 + (0.02 * tile if kind[1] == "n" else 0.005 * tile),
                                "Ca": 0.01 + 0.0008 * tile},
                    "fractional": {"Omega0": w0 * 1.0005, "G1": 0.001, "G2": 0.002 + 0.0004 * tile,
                                   "beta": 0.2 + 0.03 * tile, "p_f": 2.0 + 0.01 * tile}}
            for model, params in vals.items():
                for k, v in params.items():
                    row[f"{model}__{k}__value"] = v
                    row[f"{model}__{k}__stderr"] = abs(v) * 0.003
                    row[f"{model}__{k}__u_paper"] = abs(v) * 0.008
            rows.append(row)
    df = pd.DataFrame(rows)
    if csv_only:
        df.to_csv(batch_dir / "summary.csv", index=False)
    else:
        write_artifact(df, batch_dir / "summary.parquet", "summary", provenance=Provenance(stage="batch"))
    check = {"status": "ok", "model": "fractional", "n": len(rows), "n_tiles": 5, "sigma": "stderr",
             "x": 1.48, "x_stderr": 0.05, "l0": 0.54, "l0_stderr": 0.004, "chi2": 21.0, "dof": 18, "rms": 0.004,
             "weighted": True, "g": 9.81}
    write_json_artifact({"counts": {"videos": len(rows) + 1, "runs": len(rows), "ok": len(rows), "failed": 0,
                                    "skipped": 1},
                         "groups": {}, "two_cuboid": check, "failures": [],
                         "skipped": [{"file": "notes.mp4", "reason": "name 'notes' is not a run code"}],
                         "models": ["classic", "fractional"], "runtime_s": 1234.0},
                        batch_dir / "batch.json", required=("counts", "two_cuboid"),
                        provenance=Provenance(stage="batch"))
    for row in rows[:run_dirs]:  # small run folders: the batch report only links to their reports
        write_run(batch_dir / row["run_id"], seconds=6.0, discovery=False, stages=("track", "angle"))
    return batch_dir


def test_synthetic_run_is_a_damped_oscillation(tmp_path):
    run = write_run(tmp_path / "24la1", seconds=10.0, discovery=False)
    kin = pd.read_parquet(run / "kinematics.parquet")
    assert kin["theta"].abs().max() > 2.5  # released near the top
    assert 0 < kin["energy"].iloc[-1] < kin["energy"].iloc[0]  # and losing energy
