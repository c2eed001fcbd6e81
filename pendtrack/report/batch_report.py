"""The report of a batch: parameters against tile length by series, Omega0(l1) with the
two-cuboid fit, and a table linking every run's own report.

The summary's columns are read by pattern (``MODEL__PARAM__value|stderr|u_paper``, see the
``summary`` schema in :mod:`pendtrack.artifacts`), so any fitted model gets its panels; the
run-code fields fall back on each other (``tile_cm`` or ``l1_m``; ``kind`` or
``launched``/``alley``) so that an older or hand-made summary.csv still reports.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Mapping
from html import escape
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pendtrack.report import batch_figures as B
from pendtrack.report.derive import finite_number
from pendtrack.report.html import Facts, Markup, Note, Page, Section, Table, fmt, link
from pendtrack.report.load import BatchData
from pendtrack.report.style import draw

PARAM_COLUMN = re.compile(r"(?P<model>\w+?)__(?P<param>\w+?)__(?P<stat>value|stderr|u_paper)")
PAPER_PANELS = {  # model -> the paper's figure and its four panels (Omega0 has its own figure)
    "classic": ("Fig. fourparamsclassic", ("Ca", "C0", "p", "C3")),
    "fractional": ("Fig. paramsfractional", ("beta", "G1", "p_f", "G2")),
}
OMEGA0_PREFERENCE = ("fractional", "classic", "opa")
REPORT_NAME = "report.html"

Progress = Callable[[int], None]


def _column(df: pd.DataFrame, name: str, default: Any) -> pd.Series:
    return df[name] if name in df.columns else pd.Series(default, index=df.index)


def runs_frame(summary: pd.DataFrame) -> pd.DataFrame:
    """One row per run with normalised run-code fields: run_id, kind, l1_cm, status, ok."""
    df = summary.copy()
    run_id = _column(df, "run_id", None)
    run_id = run_id.where(run_id.notna() & (run_id.astype(str) != ""), _column(df, "code", ""))
    if "tile_cm" in df.columns:
        l1 = pd.to_numeric(df["tile_cm"], errors="coerce").astype(float)
    elif "l1_m" in df.columns:
        l1 = 100 * pd.to_numeric(df["l1_m"], errors="coerce").astype(float)
    else:
        l1 = pd.Series(np.nan, index=df.index)
    if "kind" in df.columns:
        kind = df["kind"].fillna("").astype(str)
    else:
        launched = _column(df, "launched", None)
        alley = _column(df, "alley", None)
        kind = pd.Series([("l" if bool(a) else "n") + ("a" if bool(b) else "n") if a is not None and b is not None
                          else "" for a, b in zip(launched, alley)], index=df.index)
    status = _column(df, "status", "ok").fillna("ok").astype(str)
    return pd.DataFrame({"run_id": run_id.fillna("").astype(str), "kind": kind, "l1_cm": l1, "status": status},
                        index=df.index)


def param_columns(summary: pd.DataFrame) -> dict[str, dict[str, dict[str, str]]]:
    """model -> param -> stat -> column name, in column order."""
    out: dict[str, dict[str, dict[str, str]]] = {}
    for col in summary.columns:
        m = PARAM_COLUMN.fullmatch(str(col))
        if m:
            out.setdefault(m["model"], {}).setdefault(m["param"], {})[m["stat"]] = str(col)
    return out


def usable(summary: pd.DataFrame, runs: pd.DataFrame, model: str) -> pd.Series:
    """Rows whose run ended ok and whose ``model`` fit converged (when the summary says)."""
    keep = runs["status"].eq("ok")
    conv = f"{model}__converged"
    if conv in summary.columns:
        keep &= summary[conv].astype("boolean").fillna(False).astype(bool)
    return keep


def points_for(summary: pd.DataFrame, runs: pd.DataFrame, model: str, stats: Mapping[str, str]) -> pd.DataFrame:
    """Tidy points of one parameter: kind, l1_cm, value, err (= stderr), u_paper."""
    keep = usable(summary, runs, model)
    pts = pd.DataFrame({
        "run_id": runs["run_id"], "kind": runs["kind"], "l1_cm": runs["l1_cm"],
        "value": pd.to_numeric(summary[stats["value"]], errors="coerce").astype(float),
        "err": pd.to_numeric(summary[stats["stderr"]], errors="coerce").astype(float) if "stderr" in stats
        else np.nan,
        "u_paper": pd.to_numeric(summary[stats["u_paper"]], errors="coerce").astype(float) if "u_paper" in stats
        else np.nan,
    })[keep]
    return B.finite_points(pts)


def _unit(name: str) -> str:
    from pendtrack.models import PARAMS

    spec = PARAMS.get(name)
    return spec.unit if spec is not None else ""


def _err(x: Any) -> float | None:
    return finite_number(x.get("stderr")) if isinstance(x, Mapping) else None


def _pick(record: Mapping[str, Any], *names: str) -> Any:
    for n in names:
        if n in record:
            return record[n]
    return None


def two_cuboid_curve(check: Mapping[str, Any], l1_max_cm: float) -> tuple[tuple[np.ndarray, np.ndarray], str] | None:
    """The fitted eq. consistencycheck as a curve (l1 [cm], Omega0 [rad/s]) and its legend text.

    ``check`` is batch.json's ``two_cuboid`` record: ``x``, ``x_stderr``, ``l0`` [m], ``l0_stderr`` [m]
    and ``g`` (``pendtrack.fitting.two_cuboid.TwoCuboidFit.to_dict``); None if it holds no fit.
    """
    from pendtrack.apparatus import two_cuboid_omega0

    x_entry = _pick(check, "x", "X")
    l0_entry = _pick(check, "l0", "l0_m")
    x, l0 = finite_number(x_entry), finite_number(l0_entry)
    if x is None or l0 is None:
        return None
    g = finite_number(check.get("g")) or 9.81
    l1 = np.linspace(0.0, max(l1_max_cm, 1.0), 200)
    w = np.asarray(two_cuboid_omega0(l1 / 100.0, x=x, l0=l0, g=g), float)
    xe = _err(x_entry) if _err(x_entry) is not None else finite_number(_pick(check, "x_stderr", "X_stderr"))
    le = _err(l0_entry) if _err(l0_entry) is not None else finite_number(_pick(check, "l0_stderr", "l0_m_stderr"))
    xt = f"X = {x:.3g}" + (f" ± {xe:.2g}" if xe is not None else "")
    lt = f"l₀ = {100 * l0:.1f}" + (f" ± {100 * le:.1f}" if le is not None else "") + " cm"
    return (l1, w), f"two cuboids (eq. consistencycheck): {xt}, {lt}"


def _joint_reports(batch: BatchData, out_dir: Path) -> Table | None:
    """Links to the reports of the joint fits in the batch folder (``batch --joint``: a subfolder with
    fit_runs.parquet), or None."""
    from pendtrack.artifacts import SCHEMAS

    rows = []
    for curves in sorted(batch.batch_dir.glob(f"*/{SCHEMAS['joint_fit'].filename}")):
        report = curves.parent / REPORT_NAME
        if report.is_file():
            rows.append((curves.parent.name, link(os.path.relpath(report, out_dir).replace(os.sep, "/"),
                                                  f"{curves.parent.name}/{REPORT_NAME}")))
    if not rows:
        return None
    return Table(("joint fit", "report"), tuple(rows), caption="The runs fitted jointly (shared, per-group and "
                 "per-run values, each run against the joint model).", text_columns=(0, 1), key="joint-reports")


def _overview(batch: BatchData, runs: pd.DataFrame | None, out_dir: Path) -> Section:
    facts: list[tuple[str, str]] = [("folder", str(batch.batch_dir))]
    info = batch.batch or {}
    counts = info.get("counts")
    if isinstance(counts, Mapping):
        facts.append(("runs", ", ".join(f"{k}: {v}" for k, v in counts.items())))
    elif runs is not None:
        facts.append(("runs", ", ".join(f"{k}: {v}" for k, v in runs["status"].value_counts().items())))
    if isinstance(info.get("models"), list):
        facts.append(("models", ", ".join(map(str, info["models"]))))
    if finite_number(info.get("runtime_s")) is not None:
        facts.append(("wall time", f"{finite_number(info['runtime_s']):.0f} s"))
    blocks: list[Any] = [Facts(tuple(facts))]
    joint = _joint_reports(batch, out_dir)
    if joint is not None:
        blocks.append(joint)
    for p in batch.problems:
        blocks.append(Note(f"Could not read: {p}", kind="error"))
    failures = info.get("failures") if isinstance(info.get("failures"), list) else []
    skipped = info.get("skipped") if isinstance(info.get("skipped"), list) else []
    rows = [(str(f.get("run_id", "")), str(f.get("file", "")), "failed", str(f.get("reason", ""))) for f in failures
            if isinstance(f, Mapping)]
    rows += [("", str(s.get("file", "")), "skipped", str(s.get("reason", "")))
             for s in skipped if isinstance(s, Mapping)]
    if rows:
        blocks.append(Table(("run", "file", "status", "reason"), tuple(rows), caption="Files that gave no result.",
                            text_columns=(0, 1, 2, 3), key="failures"))
    return Section("overview", "Batch overview", tuple(blocks))


def _omega0_section(batch: BatchData, summary: pd.DataFrame, runs: pd.DataFrame,
                    cols: Mapping[str, Any], on_progress: Progress | None) -> Section:
    title = "Ω0 against tile length (Fig. fittexOmegaZer)"
    check = (batch.batch or {}).get("two_cuboid") or {}
    check = check if isinstance(check, Mapping) else {}
    candidates = [str(check.get("model")), *OMEGA0_PREFERENCE, *cols]
    candidates = [m for i, m in enumerate(candidates) if m in cols and "Omega0" in cols[m] and m not in candidates[:i]]
    if not candidates:
        return Section("omega0", title, (Note("No Ω0 in the summary: no model was fitted.", kind="missing"),))
    model, pts = next(((m, p) for m in candidates if not (p := points_for(summary, runs, m, cols[m]["Omega0"])).empty),
                      (candidates[0], None))
    if pts is None:
        return Section("omega0", title, (Note(f"No usable Ω0 ({', '.join(candidates)}): no run ended ok with a "
                                              "converged fit.", kind="missing"),))
    same_model = check.get("model") in (None, model)  # never draw a fit made on another model's Omega0
    curve = two_cuboid_curve(check, float(pts["l1_cm"].max())) if same_model else None
    if curve:
        fit_text = f" The line is the two-cuboid model (eq. consistencycheck) fitted to these points: {curve[1]}."
    else:
        about = "" if same_model else f"made on the {check.get('model')} model's Ω0, "
        reason = f"; {check.get('reason')}" if check.get("reason") else ""
        fit_text = escape(f" No two-cuboid line: batch.json's fit ({about}status: {check.get('status') or 'absent'}"
                          f"{reason}).")
    block = draw(
        "fittexOmegaZer",
        f"Fig. fittexOmegaZer: Ω<sub>0</sub> of the {escape(model)} model for every run against the tile length "
        "l<sub>1</sub>, by series (error bars: statistical standard errors; series are offset sideways by "
        f"{B._JITTER_CM} cm for legibility).{fit_text} <b>Look for</b> Ω<sub>0</sub> falling as heavier tiles "
        "lower the pendulum's frequency, and the alley runs (la, na) slightly below the others (air dragged "
        "along the alley adds inertia).",
        lambda: B.omega0_figure(pts, curve=curve[0] if curve else None, curve_label=curve[1] if curve else "",
                                model=model), on_progress)
    return Section("omega0", title, (block,))


def _model_section(model: str, summary: pd.DataFrame, runs: pd.DataFrame, params: Mapping[str, Any],
                   on_progress: Progress | None) -> Section:
    paper, preferred = PAPER_PANELS.get(model, ("", ()))
    names = [p for p in B.panel_order(list(params), preferred) if not (paper and p == "Omega0")]
    points = {p: points_for(summary, runs, model, params[p]) for p in names if "value" in params[p]}
    points = {p: pts for p, pts in points.items() if not pts.empty}
    title = f"{model} model parameters" + (f" ({paper})" if paper else "")
    key = f"params-{model}"
    if not points:
        return Section(key, title, (Note(f"No usable {model} parameters in the summary.", kind="missing"),))
    labels = {p: B.axis_label(p, _unit(p)) for p in points}
    left_out = int((runs["status"].eq("ok") & ~usable(summary, runs, model)).sum())
    dropped = (f" {left_out} run(s) whose {escape(model)} fit did not converge are left out."
               if left_out else "")
    look = {
        "classic": " <b>Look for</b> C<sub>3</sub> growing almost linearly with l<sub>1</sub> whatever the alley, "
                   "p separating alley from no-alley runs for the larger tiles (the alley reduces turbulence), "
                   "and C<sub>a</sub> small enough that (τω)² = 8C<sub>a</sub>𝒜<sub>ω</sub>²/3 < 0.08.",
        "fractional": " <b>Look for</b> the two behaviours of β (small tiles: little memory for launched runs; "
                      "big tiles: the alley increases memory), and G<sub>1</sub>, p<sub>f</sub>, G<sub>2</sub> "
                      "following C<sub>0</sub>, p, C<sub>3</sub> of the classic model.",
    }.get(model, "")
    block = draw(
        key,
        f"{paper + ': ' if paper else ''}parameters of the {escape(model)} model against the tile length l<sub>1</sub>, "
        f"by series (error bars: statistical standard errors; the table below also gives u<sub>paper</sub>)."
        f"{dropped}{look}",
        lambda: B.params_figure(points, labels, title=f"{model} model"), on_progress)
    return Section(key, title, (block, _params_table(model, summary, runs, params)))


def _params_table(model: str, summary: pd.DataFrame, runs: pd.DataFrame, params: Mapping[str, Any]) -> Table:
    """Every usable run's parameters of one model: value, stderr and u_paper."""
    names = [p for p in params if "value" in params[p]]
    keep = usable(summary, runs, model)
    rows = []
    for idx in runs.index[keep]:
        row: list[Any] = [runs.at[idx, "run_id"], runs.at[idx, "kind"]]
        for p in names:
            v = finite_number(summary.at[idx, params[p]["value"]])
            se = finite_number(summary.at[idx, params[p]["stderr"]]) if "stderr" in params[p] else None
            up = finite_number(summary.at[idx, params[p]["u_paper"]]) if "u_paper" in params[p] else None
            row.append(None if v is None else f"{fmt(v)} ± {fmt(se)} [{fmt(up)}]")
        rows.append(tuple(row))
    header = ("run", "kind", *(f"{p} [{_unit(p) or '1'}]" for p in names))
    return Table(header, tuple(rows), caption=f"The {escape(model)} model's parameters of every run (ok, converged): "
                 "value ± statistical standard error [u<sub>paper</sub>, the paper's eq. paramuncertain].",
                 text_columns=(0, 1), key=f"table-{model}")


def _runs_table(batch: BatchData, summary: pd.DataFrame, runs: pd.DataFrame, cols: Mapping[str, Any],
                out_dir: Path) -> Section:
    models = list(cols)
    header = ["run", "report", "kind", "l1 [cm]", "status"]
    for m in models:
        header += [f"{m} Ω0 [rad/s]", f"{m} RMS [mrad]"]
    has_disc = "discover__final_model" in summary.columns
    if has_disc:
        header.append("discovered model")
    header.append("note")
    rows = []
    for idx, r in runs.iterrows():
        run_id = r["run_id"]
        report = batch.batch_dir / run_id / REPORT_NAME if run_id else None
        if report is not None and report.is_file():
            cell: Any = link(os.path.relpath(report, out_dir).replace(os.sep, "/"), f"{run_id}/{REPORT_NAME}")
        else:
            cell = Markup("<i>none</i>") if run_id else ""
        row: list[Any] = [run_id, cell, r["kind"], None if not np.isfinite(r["l1_cm"]) else int(r["l1_cm"]),
                          r["status"]]
        for m in models:
            w = cols[m].get("Omega0", {}).get("value")
            row.append(finite_number(summary.at[idx, w]) if w else None)
            rms = f"{m}__rms"
            v = finite_number(summary.at[idx, rms]) if rms in summary.columns else None
            row.append(None if v is None else 1e3 * v)
        if has_disc:
            v = summary.at[idx, "discover__final_model"]
            row.append("" if pd.isna(v) else str(v))
        reason = summary.at[idx, "reason"] if "reason" in summary.columns else ""
        row.append("" if pd.isna(reason) else str(reason))
        rows.append(tuple(row))
    text_cols = (0, 1, 2, 4) + ((len(header) - 2,) if has_disc else ()) + (len(header) - 1,)
    table = Table(tuple(header), tuple(rows),
                  caption="Every run of the batch with a link to its own report (relative link, works offline "
                          "next to the run folders).", text_columns=text_cols, key="runs")
    return Section("runs", "Runs", (table,))


def build_batch_page(batch: BatchData, *, out_dir: Path, provenance: dict[str, Any],
                     on_progress: Progress | None = None) -> Page:
    """The batch report as a :class:`Page`; links are relative to ``out_dir``."""
    summary = batch.summary
    sections: list[Section]
    if summary is None or summary.empty:
        note = Note("No summary.parquet or summary.csv in this batch folder (run `pendtrack batch`).",
                    kind="missing")
        sections = [_overview(batch, None, out_dir), Section("parameters", "Parameters", (note,))]
    else:
        summary = summary.reset_index(drop=True)
        runs = runs_frame(summary)
        cols = param_columns(summary)
        sections = [_overview(batch, runs, out_dir), _omega0_section(batch, summary, runs, cols, on_progress)]
        ordered = [m for m in PAPER_PANELS if m in cols] + [m for m in cols if m not in PAPER_PANELS]
        sections += [_model_section(m, summary, runs, cols[m], on_progress) for m in ordered]
        if not cols:
            sections.append(Section("parameters", "Parameters", (Note(
                "The summary has no fitted parameters (no MODEL__PARAM__value columns).", kind="missing"),)))
        sections.append(_runs_table(batch, summary, runs, cols, out_dir))
    name = batch.batch_dir.resolve().name
    return Page(title=f"Batch {name}", subtitle=f"pendtrack batch report · {batch.batch_dir}",
                sections=tuple(sections), provenance=provenance, kind="batch")


def count_figures(batch: BatchData) -> int:
    """How many figures :func:`build_batch_page` will try to draw (for a progress bar)."""
    if batch.summary is None or batch.summary.empty:
        return 0
    return 1 + len(param_columns(batch.summary))

