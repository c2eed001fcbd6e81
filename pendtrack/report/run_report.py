"""The report of one run: the paper's per-run figures, parameter tables and discovery narrative.

:func:`build_run_page` turns a :class:`~pendtrack.report.load.RunData` into a
:class:`~pendtrack.report.html.Page`. Every section checks its inputs first and says what is
missing instead of failing; a figure that raises anyway becomes an error note naming the
problem (and is logged), so one bad artifact never costs the whole report.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from html import escape
from typing import Any

import numpy as np

from pendtrack.config import Config
from pendtrack.report import derive as D
from pendtrack.report import figures as F
from pendtrack.report import joint_view as J
from pendtrack.report import tables as T
from pendtrack.report.discovery_view import discovery_section
from pendtrack.report.html import Facts, Note, Page, Section
from pendtrack.report.load import RunData
from pendtrack.report.style import draw

log = logging.getLogger(__name__)

Progress = Callable[[int], None]


def _missing(what: str, needs: str) -> Note:
    return Note(f"No {what}: {needs} is missing in this run folder.", kind="missing")


def lens_statement(run: RunData) -> tuple[str, Note | None]:
    """The lens the track was corrected with, and the lens check's verdict (one line), plus a
    note when the check found a mismatch or could not decide.

    From angle.parquet's provenance (``lens``, ``lens_check``), else track.parquet's ``[lens]``.
    """
    angle_extra = run.extra("angle")
    lens = angle_extra.get("lens") or run.stage_config("track").get("lens")
    if not isinstance(lens, dict) or "projection" not in lens:
        return "not recorded (no track.parquet)", None
    if lens["projection"] == "none":
        text = "none: no lens correction (a normal, rectilinear lens)"
    else:
        fov, fixed = D.find_number(lens, "fov_deg"), D.find_number(lens, "fixed_pixels")
        text = (f"{lens['projection']} fisheye"
                + (f", {fov:g}° diagonal field of view" if fov is not None else "")
                + (f", {100 * fixed:g} % fixed pixels" if fixed is not None else ""))
    check = angle_extra.get("lens_check")
    if not isinstance(check, dict):
        return text + " (not checked: no angle.parquet, or one made before the lens check)", None
    verdict = str(check.get("verdict", ""))
    reason = str(check.get("reason", ""))
    text += f" — check: {verdict}"
    if verdict == "mismatch":
        return text, Note(f"Lens mismatch: {reason}. θ below is computed with the configured lens and is "
                          "likely wrong by about that much; track again with the better lens.", kind="error")
    if verdict == "undecided":
        return text, Note(f"The lens could not be checked: {reason}.", kind="info")
    return text + (f" ({reason})" if reason else ""), None


def drift_statement(run: RunData) -> tuple[str | None, Note | None]:
    """The tracker's template-drift alarm (track.parquet's ``template_drift``): one line, and an
    error note when the alarm fired (an evolving template drifted beyond ``max_drift_px`` from the
    first one and was re-anchored: positions may be biased by up to that drift). (None, None) when
    the track records no drift (no track.parquet, or one made before the alarm existed)."""
    drift = run.extra("track").get("template_drift")
    if not isinstance(drift, dict):
        return None, None
    max_px, limit = D.find_number(drift, "max_px"), D.find_number(drift, "limit_px")
    reanchors = int(drift.get("reanchors") or 0)
    rate = D.find_number(run.stage_config("track"), "evolution_rate")
    if not drift.get("alarm"):
        if rate == 0:
            return "none: the template does not evolve (evolution_rate 0)", None
        text = "within the limit"
        if max_px is not None and limit is not None:
            text += f": at most {max_px:.2f} px from the first template (limit {limit:g} px)"
        return text, None
    text = (f"ALARM: up to {max_px:.2f} px from the first template (limit {limit:g} px), re-anchored "
            f"{reanchors} time{'s' if reanchors != 1 else ''}") if max_px is not None and limit is not None else "ALARM"
    return text, Note(f"Template drift alarm: the evolving template drifted up to {max_px or float('nan'):.2f} px "
                      f"from the first one (limit {limit or float('nan'):g} px) and was shifted back {reanchors} "
                      "time(s). Positions between re-anchorings may be biased by up to that drift; track again with "
                      "a lower [track] evolution_rate (0, as in the paper, keeps the first template).", kind="error")


def fit_notes(run: RunData) -> list[Note]:
    """One note per fit that is not trustworthy (not converged, parameters flagged: fit.json ``flags``),
    and one, neutral, per fit that found an effect absent (fit.json ``findings``) or leaves a residual
    that is structure, not noise (the fit stage's ``misses_structure``)."""
    notes = []
    stage = (run.extra("fit") or {}).get("models") or {}
    for name, fit in run.fits.items():
        if not isinstance(fit, dict):
            continue
        flags = fit.get("flags") or {}
        parts = []
        if fit.get("converged") is False:
            parts.append(f"did not converge ({fit.get('message', '')})")
        if flags:
            parts.append("its values are not measurements: " + "; ".join(f"{k} {v}" for k, v in flags.items()))
        if parts:
            notes.append(Note(f"The {name} fit is not trustworthy: {' '.join(parts)}.", kind="error"))
        found = sorted(set((fit.get("findings") or {}).values()))
        if found:
            notes.append(Note(f"The {name} fit: {'; '.join(found)}.", kind="info"))
        facts = stage.get(name) if isinstance(stage, dict) else None
        if isinstance(facts, dict) and facts.get("misses_structure"):
            ratio = D.finite_number(facts.get("rms_over_noise"))
            times = f"{ratio:.1f} times" if ratio is not None else "several times"
            notes.append(Note(f"The {name} fit leaves a residual {times} the noise of the record: the model misses "
                              "structure in the data (pendtrack discover looks for its cause).", kind="info"))
    return notes


def zero_offsets(run: RunData) -> str:
    """The fitted zero of theta per model, ``"classic: 1.234 ± 0.056 mrad; ..."`` ("" if no fit has ``theta_off``)."""
    parts = []
    for name, fit in run.fits.items():
        entry = ((fit or {}).get("params") or {}).get("theta_off") if isinstance(fit, dict) else None
        value = D.finite_number(entry)
        if value is None:
            continue
        se = D.finite_number((entry or {}).get("stderr")) if isinstance(entry, dict) else None
        parts.append(f"{name}: {1e3 * value:.3f}" + (f" ± {1e3 * se:.3f}" if se is not None else "") + " mrad")
    if not parts:
        return ""
    zero = (run.extra("kinematics") or {}).get("zero_reference")
    why = f" (zero reference: {zero})" if isinstance(zero, str) and zero else ""
    return "; ".join(parts) + why


def _overview(run: RunData) -> Section:
    lens_text, lens_note = lens_statement(run)
    drift_text, drift_note = drift_statement(run)
    facts: list[tuple[str, str]] = [("run", run.name), ("lens", lens_text), ("folder", str(run.run_dir))]
    if J.joint_fits(run):  # several runs' fit: no video of its own
        facts = [("joint fit", run.name), ("folder", str(run.run_dir))]
    if drift_text is not None:
        facts.append(("template drift", drift_text))
    track = run.get("track")
    if track is not None and len(track):
        t = track["t"].to_numpy(float)
        ok = track["ok"].to_numpy(bool)
        fps = (len(t) - 1) / (t[-1] - t[0]) if len(t) > 1 and t[-1] > t[0] else float("nan")
        facts += [("frames", f"{len(t)}"), ("duration", f"{t[-1] - t[0]:.2f} s"), ("frame rate", f"{fps:.2f} /s"),
                  ("tracked ok", f"{100 * ok.mean():.2f} % ({int((~ok).sum())} flagged)")]
    w0 = D.data_omega0(run)
    if w0 is not None:
        err = f" ± {w0.stderr:.4f}" if w0.stderr is not None else ""
        facts.append(("Ω0 (model-free)", f"{w0.value:.4f}{err} rad/s"))
    if run.fits:
        facts.append(("fitted models", ", ".join(run.fits)))
        facts += J.joint_facts(run)
        offsets = zero_offsets(run)
        if offsets:
            facts.append(("θ's zero (fitted θ_off)", offsets))
        selected = (run.combined or {}).get("selected")
        if selected:
            facts.append(("selected model", f"{selected} ({(run.combined or {}).get('selected_by', 'lowest BIC')})"))
    if run.discovery:
        facts.append(("discovered model", str(run.discovery.get("final_model", ""))))
    present = sorted(p.name for p in run.inputs)
    facts.append(("artifacts", ", ".join(present) or "none"))
    blocks: list[Any] = [Facts(tuple(facts))]
    if lens_note is not None:
        blocks.insert(0, lens_note)
    if drift_note is not None:
        blocks.insert(0, drift_note)
    blocks.extend(fit_notes(run))
    for p in run.problems:
        blocks.append(Note(f"Could not read: {p}", kind="error"))
    return Section("overview", "Run overview", tuple(blocks))


def _tracking(run: RunData, on_progress: Progress | None) -> Section:
    track = run.get("track")
    if track is None:
        return Section("tracking", "Tracking quality", (_missing("tracking figures", "track.parquet"),))
    min_score = D.find_number(run.stage_config("track"), "min_score")
    blocks: list[Any] = [draw(
        "track-score",
        "Template-match score of every frame. <b>Look for</b> long dips towards the dashed acceptance threshold "
        "(lighting, reflections, motion blur near the bottom of the swing); red ticks mark frames flagged not ok, "
        "which later stages bridge or drop.",
        lambda: F.track_quality_figure(track["t"], track["score"], track["ok"], min_score=min_score), on_progress)]
    extra = run.extra("angle")
    circle = extra.get("circle") if isinstance(extra.get("circle"), dict) else {}
    axle = extra.get("axle_px") or extra.get("axle")
    if axle is None and circle:
        axle = (circle.get("xc"), circle.get("yc"))
    axle_xy = (float(axle[0]), float(axle[1])) if axle is not None and None not in tuple(axle)[:2] else None
    radius = D.find_number(circle, "radius") if circle else D.find_number(extra, "radius_px", "radius")
    rms = D.find_number(extra, "circle_rms_px") or (D.find_number(circle, "rms_px") if circle else None)
    source = extra.get("axle_source", "")
    rms_text = f" The angle stage reports an RMS radial residual of {rms:.2f} px." if rms is not None else ""
    blocks.append(draw(
        "circle-fit",
        f"Left: lens-corrected marker positions with the circle fitted to them (axle: {escape(str(source)) or 'as recorded'}). "
        f"Right: each point's distance to the axle minus the radius.{rms_text} <b>Look for</b> a flat, "
        "structureless band: a trend or a swing-synchronous pattern means a misplaced axle or residual lens "
        "distortion, which would bias θ.",
        lambda: F.circle_fit_figure(track["t"], track["x"], track["y"], track["ok"], axle=axle_xy, radius=radius,
                                    rms=rms), on_progress))
    if run.get("angle") is None:
        blocks.append(Note("angle.parquet is missing: the circle above is drawn without the angle stage's fit.",
                           kind="missing"))
    return Section("tracking", "Tracking quality", tuple(blocks))


def _kinematics(run: RunData, config: Config, on_progress: Progress | None) -> tuple[Section, ...]:
    kin = run.get("kinematics")
    if kin is None:
        note = _missing("kinematic analysis", "kinematics.parquet")
        return (Section("kinematics", "Kinematic data (Fig. S1)", (note,)),
                Section("ozsin", "Acceleration at the turning points (Fig. ozsin)", (note,)),
                Section("lobes", "Hysteresis of Δα(ω) (Figs. lobolusdecaras, dissipativehysteresis)", (note,)))
    ok = kin["ok"].to_numpy(bool)
    k = kin[ok]
    s1 = draw(
        "S1",
        "Fig. S1: the kinematic data θ, ω = dθ/dt and α = d²θ/dt² (Savitzky–Golay derivatives), as a 3-D "
        "trajectory coloured by time and as time series. Figs. ozsin and lobolusdecaras below are projections "
        "of this curve. <b>Look for</b> the release near θ = π and a smooth spiral towards rest.",
        lambda: F.kinematics_figure(k["t"], k["theta"], k["omega"], k["alpha"]), on_progress)
    oz_blocks: list[Any] = []
    try:
        window_s, order = D.savgol_setup(run, config)
        tp = D.turning_points(kin, window_s=window_s, order=order, extra=run.extra("kinematics"))
    except Exception as exc:
        log.warning("report: turning points failed", exc_info=True)
        oz_blocks.append(Note(f"No turning-point analysis: {type(exc).__name__}: {exc}", kind="missing"))
    else:
        oz_blocks.append(draw(
            "ozsin",
            "Fig. ozsin: angular acceleration at the extreme angles θ<sub>ext</sub> (where ω = 0) against "
            "θ<sub>ext</sub>, with the fit α = −Ω<sub>0</sub>² sin θ<sub>ext</sub> (eq. straightline) that gives "
            "the model-free natural frequency"
            + (" (solid: with the Savitzky–Golay smoothing bias removed, as the kinematics stage does; dashed: "
               "the direct fit to the plotted points, which the residual panel refers to)" if tp.corrected else "")
            + ". <b>Look for</b> points on the sine at every amplitude; the residual panel shows what the sine "
            "leaves (friction acting at rest, the noise of α).",
            lambda: F.ozsin_figure(tp.theta_ext, tp.alpha_ext, tp.omega0, omega0_err=tp.omega0_stderr,
                                   omega0_raw=tp.omega0_raw if tp.corrected else None),
            on_progress))
    return (Section("kinematics", "Kinematic data (Fig. S1)", (s1,)),
            Section("ozsin", "Acceleration at the turning points (Fig. ozsin)", tuple(oz_blocks)),
            _lobes(run, k, config, on_progress))


def _data_delta_alpha(run: RunData, k: Any) -> tuple[np.ndarray, D.Omega0 | None]:
    w0 = D.data_omega0(run)
    if "delta_alpha" in k.columns:
        return k["delta_alpha"].to_numpy(float), w0
    if w0 is None:
        raise ValueError("no Omega0 to compute Δα (kinematics.parquet has no delta_alpha column)")
    from pendtrack.kinematics import delta_alpha

    return np.asarray(delta_alpha(k["theta"].to_numpy(float), k["alpha"].to_numpy(float), w0.value), float), w0


def _lobes(run: RunData, k: Any, config: Config, on_progress: Progress | None) -> Section:
    title = "Hysteresis of Δα(ω) (Figs. lobolusdecaras, dissipativehysteresis)"
    try:
        da, w0 = _data_delta_alpha(run, k)
    except ValueError as exc:
        return Section("lobes", title, (Note(str(exc), kind="missing"),))
    w0_text = f"Ω<sub>0</sub> = {w0.value:.4f} rad/s, {w0.source}" if w0 is not None else "the kinematics stage's Ω0"
    blocks: list[Any] = [draw(
        "lobolusdecaras",
        f"Fig. lobolusdecaras: Δα = α + Ω<sub>0</sub>² sin θ (eq. lobulosprovados, {w0_text}) against ω for the "
        "whole run, coloured by time. Δα is what gravity does not explain: dissipative plus inertial "
        "acceleration. <b>Look for</b> the lobes (hysteresis: Δα depends on more than the instantaneous ω) and "
        "for points in the shaded odd quadrants, where Δα·ω > 0: negative damping "
        "(eq. negativedampingdefinition).",
        lambda: F.delta_alpha_figure(k["t"], k["omega"], da), on_progress)]
    curves = D.model_curves(run)
    sg_window, sg_order = D.savgol_setup(run, config)
    # the paper's first ten seconds, less the filter's first half-window (its edge fit is poor at release)
    t0 = (float(k["t"].iloc[0]) if len(k) else 0.0) + 0.5 * sg_window
    window = D.time_window(k.assign(_da=da), t0, D.PAPER_HYSTERESIS_S)
    models: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    notes: list[str] = []
    for name, curve in curves.items():
        mw0 = D.model_omega0(run, name) or w0
        if mw0 is None:
            notes.append(f"{name}: no Ω0")
            continue
        c = curve.assign(_da=D.model_delta_alpha(curve, mw0.value, window_s=sg_window, order=sg_order))
        c = D.time_window(c, t0, D.PAPER_HYSTERESIS_S)
        models[name] = (c["omega_model"].to_numpy(float), c["_da"].to_numpy(float))
    power = None
    classic = D.param_values(run.fits["classic"]) if "classic" in run.fits else {}
    if {"Omega0", "C0", "C3", "p"} <= set(classic):
        wmax = float(np.nanmax(np.abs(window["omega"].to_numpy(float)))) if len(window) else 1.0
        try:
            power = D.power_law_curve(classic, wmax)
        except Exception as exc:  # bad parameters: draw without the power-law curve
            notes.append(f"power-law curve: {exc}")
    if not models:
        blocks.append(Note("No model curves for Fig. dissipativehysteresis: fit.parquet is missing (run the fit "
                           "stage). The data alone are shown above.", kind="missing"))
        return Section("lobes", title, tuple(blocks))
    blocks.append(draw(
        "dissipativehysteresis",
        f"Fig. dissipativehysteresis: a<sub>diss</sub> + a<sub>iner</sub> = Δα against ω for the first "
        f"{D.PAPER_HYSTERESIS_S:g} s, data and each fitted model (each model's Δα uses its own fitted Ω<sub>0</sub> "
        "and the data's Savitzky–Golay filter), with the classic model's dissipation at C<sub>a</sub> = 0 as "
        "“power-law”. The insets zoom on low speeds on each side of ω = 0. <b>Look for</b> which model follows "
        "the data's loops, and whether any model enters the shaded negative-damping quadrants as the data do "
        "(the classic model cannot)." + (f" Not drawn: {escape('; '.join(notes))}." if notes else ""),
        lambda: F.hysteresis_figure(window["omega"], window["_da"], models, power_law=power,
                                    seconds=D.PAPER_HYSTERESIS_S), on_progress))
    return Section("lobes", title, tuple(blocks))


def _fit_window(run: RunData, model: str) -> tuple[float, float] | None:
    window = (run.fits.get(model) or {}).get("window")
    if isinstance(window, list) and len(window) == 2:
        lo, hi = (D.find_number({"v": w}, "v") for w in window)
        if lo is not None and hi is not None:
            return lo, hi
    return None


def _fits(run: RunData, on_progress: Progress | None) -> tuple[Section, ...]:
    curves = D.model_curves(run)
    title_full = "Fits over the complete run (Figs. spuriousosc, superfit)"
    title_zoom = "The first swings (Figs. S2, S3)"
    if not curves:
        note = _missing("model curves", "fit.parquet (the fit stage's output)")
        return Section("fits", title_full, (note,)), Section("first-swings", title_zoom, (note,))
    blocks: list[Any] = []
    paper = {"classic": "Fig. spuriousosc", "fractional": "Fig. superfit"}
    for name, c in curves.items():
        label = paper.get(name, "as Figs. spuriousosc/superfit")
        blocks.append(draw(
            f"theta-{name}",
            f"{label}: θ(t) of the data and of the fitted {escape(name)} model over the complete run, and the residual "
            "θ − θ<sub>model</sub>. <b>Look for</b> structure in the residual: a persistent oscillation (dephasing, "
            "as the paper finds for the classic model) rather than white noise, and where in the run the model "
            "starts to deviate.",
            lambda c=c, name=name: F.theta_fit_figure(c["t"], c["theta"], {name: c["theta_model"]},
                                                      {name: c["residual"]}, title=f"{name} model, complete run",
                                                      window=_fit_window(run, name)),
            on_progress))
    w0 = D.best_omega0(run)
    span = D.FIRST_SWINGS * 2 * np.pi / w0.value if w0 is not None else 5.0
    t0 = min(float(c["t"].iloc[0]) for c in curves.values())
    zoom = {name: D.time_window(c, t0, span) for name, c in curves.items()}
    ref = next(iter(zoom.values()))
    zoom_block = draw(
        "first-swings",
        f"Figs. S2/S3: the first {D.FIRST_SWINGS:g} natural periods ({span:.1f} s) of θ(t) with every fitted model "
        "and their residuals. <b>Look for</b> the residual peak the paper finds near t = 1 s after a release "
        "from near the top, and which model follows the large-amplitude swings best.",
        lambda: F.theta_fit_figure(ref["t"], ref["theta"],
                                   {n: np.interp(ref["t"], z["t"], z["theta_model"]) for n, z in zoom.items()},
                                   {n: np.interp(ref["t"], z["t"], z["residual"]) for n, z in zoom.items()},
                                   title="first swings"), on_progress)
    return Section("fits", title_full, tuple(blocks)), Section("first-swings", title_zoom, (zoom_block,))


def _amplitudes(run: RunData, on_progress: Progress | None) -> tuple[Section, Section]:
    kin = run.get("kinematics")
    t1 = "Energy amplitudes and phase speed (Fig. schluck)"
    t2 = "Nyquist-like plot (Fig. nyquist)"
    if kin is None:
        note = _missing("amplitudes", "kinematics.parquet")
        return Section("schluck", t1, (note,)), Section("nyquist", t2, (note,))
    k = kin[kin["ok"].to_numpy(bool)]
    w0 = D.data_omega0(run)
    if w0 is None or not {"A_theta", "A_omega"} <= set(k.columns):
        note = Note("No amplitudes: kinematics.parquet has no A_theta/A_omega columns or no Ω0.", kind="missing")
        return Section("schluck", t1, (note,)), Section("nyquist", t2, (note,))
    curves = D.model_curves(run)
    model_name = next((m for m in ("fractional", "classic") if m in curves), next(iter(curves), None))
    model = None
    if model_name is not None:
        c = curves[model_name]
        at, aw = D.amplitudes(c["theta_model"], c["omega_model"], w0.value)
        model = (model_name, c["t"].to_numpy(float), at, aw)
    phase_speed = k["phase_speed"] if "phase_speed" in k.columns else np.full(len(k), np.nan)
    scale = f"Ω<sub>0</sub> = {w0.value:.4f} rad/s, {w0.source}"
    b1 = draw(
        "schluck",
        f"Fig. schluck: 𝒜<sub>θ</sub> = sin(θ/2) and 𝒜<sub>ω</sub> = ω/(2Ω<sub>0</sub>) (eq. amplitudes, {scale})"
        + (f", dashed: the {escape(str(model_name))} model" if model else "")
        + "; below, the phase speed Φ = dφ/dt (eq. phasespeed). <b>Look for</b> the exchange between the two "
        "amplitudes as energy decays (the OPA analogy of the paper) and the noise that the derivative propagates "
        "into Φ.",
        lambda: F.amplitudes_figure(k["t"], k["A_theta"], k["A_omega"], phase_speed, model=model), on_progress)
    b2 = draw(
        "nyquist",
        "Fig. nyquist: the state (𝒜<sub>ω</sub>, 𝒜<sub>θ</sub>) against time in natural periods tΩ<sub>0</sub>/2π, "
        f"data as points{f' and the {escape(str(model_name))} model as a line' if model else ''}: two 3-D views, the view "
        "from above, and the normalised mechanical energy 𝒜² = 𝒜<sub>θ</sub>² + 𝒜<sub>ω</sub>² "
        "(eq. amplitudesobservable). <b>Look for</b> the spiral's regularity and, in launched runs, the phase "
        "velocity changing sign when θ passes π.",
        lambda: F.nyquist_figure(k["t"], k["A_theta"], k["A_omega"], w0.value, model=model), on_progress)
    return Section("schluck", t1, (b1,)), Section("nyquist", t2, (b2,))


def count_figures(run: RunData) -> int:
    """How many figures :func:`build_run_page` will try to draw (for a progress bar)."""
    if J.joint_fits(run):
        return J.count_joint_figures(run)
    n = 0
    if run.get("track") is not None:
        n += 2
    if run.get("kinematics") is not None:
        n += 3 + (1 if run.get("fit") is not None else 0) + 2
    curves = len(D.model_curves(run))
    n += curves + (1 if curves else 0)
    return n


def build_run_page(run: RunData, *, config: Config, provenance: dict[str, Any],
                   on_progress: Progress | None = None) -> Page:
    """The whole run report as a :class:`Page`.

    Parameters
    ----------
    run : RunData
        What the run folder holds.
    config : Config
        Fallbacks for facts the artifacts do not record (Savitzky–Golay window...).
    provenance : dict
        Embedded in the page (version, inputs, time).
    on_progress : callable, optional
        Called with 1 after each figure.
    """
    if J.joint_fits(run):
        # a joint fit's folder holds no video, track or kinematics of its own: each run's folder has its report
        sections = [_overview(run), *J.joint_sections(run, on_progress), discovery_section(run),
                    T.provenance_section(run, provenance.get("inputs", {}))]
        return Page(title=f"Joint fit {run.name}", subtitle=f"pendtrack joint-fit report · {run.run_dir}",
                    sections=tuple(sections), provenance=provenance, kind="run")
    sections = [_overview(run), _tracking(run, on_progress), *_kinematics(run, config, on_progress),
                *_fits(run, on_progress), *_amplitudes(run, on_progress),
                T.parameters_section(run), discovery_section(run),
                T.provenance_section(run, provenance.get("inputs", {}))]
    subtitle = f"pendtrack run report · {run.run_dir}"
    return Page(title=f"Run {run.name}", subtitle=subtitle, sections=tuple(sections), provenance=provenance,
                kind="run")
