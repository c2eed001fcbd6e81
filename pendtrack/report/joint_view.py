"""The report of a joint fit: several runs of one pendulum fitted at once.

A folder written by a joint ``pendtrack fit A B C`` (or ``batch --joint``) holds
``fit_<model>.json`` with ``joint: true`` and ``fit_runs.parquet`` (each run's curves). Its
page shows what a joint fit is for: each parameter's value in its scope (shared by every run,
per group of runs, per run) with its standard error, how much the shared values gained over
the runs fitted alone, each run's own residual, and each run's data against the joint model.
"""

from __future__ import annotations

from collections.abc import Mapping
from html import escape
from typing import Any

import numpy as np

from pendtrack.report import figures as F
from pendtrack.report.html import Note, Section, Table
from pendtrack.report.load import RunData
from pendtrack.report.style import draw
from pendtrack.report.tables import meaning, number, quality_table, unit

CURVES_KIND = "joint_fit"  # fit_runs.parquet


def joint_fits(run: RunData) -> dict[str, dict[str, Any]]:
    """The folder's joint fits: model name -> its fit record (those with ``joint`` true)."""
    return {name: fit for name, fit in run.fits.items() if isinstance(fit, Mapping) and fit.get("joint")}


def run_ids(fit: Mapping[str, Any]) -> list[str]:
    """The runs of a joint fit, in the order the fit lists them."""
    runs = fit.get("runs")
    return [str(r) for r in runs] if isinstance(runs, Mapping) else []


def joint_facts(run: RunData) -> list[tuple[str, str]]:
    """Overview lines: the runs fitted jointly, per model."""
    out = []
    for name, fit in joint_fits(run).items():
        ids = run_ids(fit)
        out.append((f"{name}: joint fit of", f"{len(ids)} runs ({', '.join(ids)})"))
    return out


def _scope_words(scope: str) -> str:
    if scope == "shared":
        return "shared by every run"
    if scope == "run":
        return "per run"
    return f"per {scope.replace('+', ' and ')}"


def _value_rows(fit: Mapping[str, Any]) -> list[tuple[Any, ...]]:
    """parameter, unit, scope, group or run, value, stderr, u_paper, runs, meaning: one row per fitted value."""
    sharing = fit.get("sharing") if isinstance(fit.get("sharing"), Mapping) else {}
    rows: list[tuple[Any, ...]] = []
    for name, entry in (fit.get("params") or {}).items():
        e = entry if isinstance(entry, Mapping) else {"value": entry}
        rows.append((str(name), unit(str(name)), _scope_words("shared"), "all", number(e.get("value")),
                     number(e.get("stderr")), number(e.get("u_paper")), len(run_ids(fit)), meaning(str(name))))
    for name, groups in (fit.get("groups") or {}).items():
        if not isinstance(groups, Mapping):
            continue
        for label, g in groups.items():
            g = g if isinstance(g, Mapping) else {"value": g}
            members = g.get("runs") if isinstance(g.get("runs"), list) else []
            rows.append((str(name), unit(str(name)), _scope_words(str(sharing.get(name, "group"))), str(label),
                         number(g.get("value")), number(g.get("stderr")), number(g.get("u_paper")),
                         ", ".join(str(m) for m in members), meaning(str(name))))
    per_run = [p for p, s in sharing.items() if s == "run"]
    for rid, rec in (fit.get("runs") or {}).items():
        if not isinstance(rec, Mapping):
            continue
        values = {**(rec.get("params") or {}), **(rec.get("initial_state") or {})}
        for name in per_run:
            e = values.get(name)
            if e is None:
                continue
            e = e if isinstance(e, Mapping) else {"value": e}
            rows.append((str(name), unit(str(name)), _scope_words("run"), str(rid), number(e.get("value")),
                         number(e.get("stderr")), None, str(rid), meaning(str(name))))
    return rows


def _runs_rows(fit: Mapping[str, Any]) -> list[tuple[Any, ...]]:
    """run, tile, launched, alley, n, RMS [mrad] jointly and alone, Xi^2, flags: one row per run."""
    rows = []
    for rid, rec in (fit.get("runs") or {}).items():
        if not isinstance(rec, Mapping):
            continue
        labels = rec.get("labels") if isinstance(rec.get("labels"), Mapping) else {}
        single = rec.get("single") if isinstance(rec.get("single"), Mapping) else {}
        rms, alone = number(rec.get("rms")), number(single.get("rms"))
        flags = rec.get("flags") or {}
        rows.append((str(rid), *(str(labels.get(k, "")) for k in ("tile", "launched", "alley")), rec.get("n"),
                     None if rms is None else 1e3 * rms, None if alone is None else 1e3 * alone,
                     number(rec.get("xi2")),
                     "; ".join(f"{k} {v}" for k, v in flags.items()) if isinstance(flags, Mapping) else str(flags)))
    return rows


def _parameters(run: RunData, fits: Mapping[str, Mapping[str, Any]]) -> Section:
    blocks: list[Any] = [quality_table(run)]
    for name, fit in fits.items():
        state = "converged" if fit.get("converged") else "NOT converged"
        blocks.append(Table(
            ("parameter", "unit", "scope", "group / run", "value", "stderr", "u_paper", "runs", "meaning"),
            tuple(_value_rows(fit)),
            caption=f"<b>{escape(str(name))}</b> model, fitted jointly ({state}): every value in its scope. "
                    "<b>stderr</b> is the joint sandwich standard error (one autocorrelation-consistent meat per "
                    "run, the runs independent), the one to quote.",
            text_columns=(0, 1, 2, 3, 7, 8), key=f"joint-params-{name}"))
        ratio = fit.get("stderr_ratio")
        if isinstance(ratio, Mapping) and ratio:
            blocks.append(Table(
                ("parameter", "joint stderr / mean single-run stderr"),
                tuple((str(p), number(r)) for p, r in ratio.items()),
                caption="What fitting the runs together gained: each shared parameter's joint standard error over "
                        "the mean of the runs' own. <b>Look for</b> ratios well below 1 (the runs together pin what "
                        "each alone cannot); about 1/√n is what n alike runs give.",
                key=f"joint-gain-{name}"))
        blocks.append(Table(
            ("run", "tile", "launched", "alley", "n", "RMS joint [mrad]", "RMS alone [mrad]", "Ξ²", "flags"),
            tuple(_runs_rows(fit)),
            caption=f"Each run under the joint <b>{escape(str(name))}</b> fit, and fitted alone. <b>Look for</b> a "
                    "run whose joint RMS is well above its own: the shared values do not suit it (another rig, "
                    "a mislabelled run code).",
            text_columns=(0, 1, 2, 3, 8), key=f"joint-runs-{name}"))
    return Section("joint-parameters", "Parameters of the joint fit", tuple(blocks))


def _curves(run: RunData, fits: Mapping[str, Mapping[str, Any]], on_progress: Any) -> Section:
    title = "Each run under the joint fit"
    curves = run.get(CURVES_KIND)
    if curves is None:
        return Section("joint-runs", title, (Note("No model curves: fit_runs.parquet (the joint fit's curves) is "
                                                  "missing in this folder.", kind="missing"),))
    blocks: list[Any] = []
    for name, fit in fits.items():
        rows = curves[curves["model"] == name]
        per_run = {}
        for rid in run_ids(fit):
            r = rows[rows["run"] == rid]
            if len(r):
                per_run[rid] = (r["t"].to_numpy(float), r["theta"].to_numpy(float), r["theta_model"].to_numpy(float))
        if not per_run:
            blocks.append(Note(f"fit_runs.parquet holds no curves of the {name} model.", kind="missing"))
            continue
        blocks.append(draw(
            f"joint-{name}",
            f"Each run's θ(t) with the jointly fitted <b>{escape(str(name))}</b> model (from the run's own fitted "
            "initial state, with the values its scopes give it), and the residual θ − θ<sub>model</sub>. "
            "<b>Look for</b> a run whose residual grows or oscillates where the others' stay flat: one shared "
            "value does not describe it.",
            lambda per_run=per_run, name=name: F.joint_runs_figure(per_run, model=name), on_progress))
    return Section("joint-runs", title, tuple(blocks))


def joint_sections(run: RunData, on_progress: Any = None) -> tuple[Section, ...]:
    """The joint fit's sections: the values by scope, the gain, each run's residual, each run's curves."""
    fits = joint_fits(run)
    return _parameters(run, fits), _curves(run, fits, on_progress)


def count_joint_figures(run: RunData) -> int:
    """How many figures :func:`joint_sections` draws (one per joint model with curves)."""
    curves = run.get(CURVES_KIND)
    if curves is None:
        return 0
    return sum(1 for name in joint_fits(run) if bool(np.any(curves["model"] == name)))
