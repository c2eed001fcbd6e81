"""The run report's tables: fit quality, parameters with both uncertainties, cross-model
relations, and the provenance of every input."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from html import escape
from typing import Any

from pendtrack.report.html import Note, Section, Table, fmt
from pendtrack.report.load import RunData

_UNCERTAINTY_NOTE = (
    "Three uncertainties are given for every parameter. <b>stderr</b> is the statistical standard error "
    "(autocorrelation-consistent) at the best fit. The <b>95 % interval</b> is the one to quote: value ± 1.96 "
    "stderr, widened for a model with memory where the cost's valley over β holds other near-equal minima (the "
    "likelihood-ratio set), so its two sides can differ; fit_&lt;model&gt;.json also gives the 68 % one. "
    "<b>u<sub>paper</sub></b> is the paper's eq. paramuncertain: half the range of the parameter over the "
    "multistart fits with Ξ² ≤ 5/4 Ξ²<sub>min</sub>, a measure of how well the cost pins the parameter down "
    "rather than a standard deviation. u<sub>r</sub> = stderr/|value|."
)


def number(x: Any) -> float | None:
    """A finite float from a number or a {"value": ...} record; None otherwise."""
    if isinstance(x, Mapping):
        x = x.get("value")
    if isinstance(x, bool):
        return None
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def unit(name: str) -> str:
    try:
        from pendtrack.models import PARAMS
    except ImportError:  # pragma: no cover - models is part of the package
        return ""
    spec = PARAMS.get(name)
    return spec.unit if spec is not None else {"theta0": "rad", "omega0": "rad/s"}.get(name, "")


def meaning(name: str) -> str:
    try:
        from pendtrack.models import PARAMS
    except ImportError:  # pragma: no cover
        return ""
    spec = PARAMS.get(name)
    if spec is not None:
        return spec.description
    return {"theta0": "fitted initial angle", "omega0": "fitted initial angular velocity"}.get(name, "")


def interval_text(value: float | None, interval: Any) -> str | None:
    """A 95 % interval ``[low, high]`` about ``value`` as its two sides, ``-b / +a``; None if unknown."""
    if value is None or not isinstance(interval, (list, tuple)) or len(interval) != 2:
        return None
    low, high = (number(v) for v in interval)
    if low is None or high is None:
        return None
    return f"−{fmt(value - low, 3)} / +{fmt(high - value, 3)}"


def _param_rows(entries: Mapping[str, Any], intervals: Any) -> list[tuple[Any, ...]]:
    rows = []
    intervals = intervals if isinstance(intervals, Mapping) else {}
    for name, entry in entries.items():
        e = entry if isinstance(entry, Mapping) else {"value": entry}
        value, stderr, u_paper = (number(e.get(k)) for k in ("value", "stderr", "u_paper"))
        u_r = f"{100 * stderr / abs(value):.3g} %" if value and stderr is not None else None
        rows.append((str(name), unit(str(name)), value, stderr, interval_text(value, intervals.get(name)), u_paper,
                     u_r, meaning(str(name))))
    return rows


def quality_table(run: RunData) -> Table:
    bics = {m: number(f.get("bic")) for m, f in run.fits.items()}
    finite = [b for b in bics.values() if b is not None]
    best = min(finite) if finite else None
    rows = []
    for name, fit in run.fits.items():
        rms = number(fit.get("rms"))
        bic = bics[name]
        accepted = fit.get("n_accepted"), fit.get("n_starts")
        rows.append((name, bool(fit.get("converged")), fit.get("n"), number(fit.get("xi2_min")),
                     None if rms is None else 1e3 * rms, number(fit.get("aic")), bic,
                     None if bic is None or best is None else bic - best,
                     f"{accepted[0]}/{accepted[1]}" if None not in accepted else None, number(fit.get("runtime_s"))))
    return Table(("model", "converged", "n", "Ξ²min", "RMS [mrad]", "AIC", "BIC", "ΔBIC", "accepted starts",
                  "runtime [s]"), tuple(rows),
                 caption="Fit quality. Ξ² is the paper's cost (eq. leastsquarescostfunction); RMS is that of "
                         "θ − θ<sub>model</sub>. ΔBIC is relative to the lowest BIC; with autocorrelated residuals "
                         "it overstates the evidence, so read it as a ranking.",
                 text_columns=(0,), key="fit-quality")


_RELATIONS_CAPTION = (
    "Cross-model relations between the classic and fractional parameters (paper: G<sub>1</sub> ≃ "
    "C<sub>0</sub>/(4Ω<sub>0</sub>²), G<sub>2</sub> ≃ C<sub>3</sub>/(2<sup>2−p</sup>Ω<sub>0</sub>²), "
    "p<sub>f</sub> − β ≈ p), as computed by the fit stage: the fractional side, the classic side, each with its "
    "standard error, their ratio and z = difference / combined standard error (the fits share the data, so z "
    "is indicative only). <b>Look for</b> ratios near 1.")


def find_relations(combined: Mapping[str, Any] | None) -> tuple[Any, Any]:
    """The cross-model relations in a combined fit.json, and its ``both_converged`` flag (or None)."""
    if not combined:
        return None, None
    for key in ("cross_model", "cross_model_relations", "relations"):
        value = combined.get(key)
        if isinstance(value, Mapping) and "relations" in value:
            return value["relations"], value.get("both_converged")
        if value:
            return value, combined.get("both_converged")
    return None, None


def _relations(data: Any, both_converged: Any) -> Table | None:
    """Cross-model relations (fit output) as a table, whatever their exact layout."""
    if isinstance(data, Mapping):
        items = list(data.items())
    elif isinstance(data, list):
        items = [(str(i), d) for i, d in enumerate(data)]
    else:
        return None
    if not items:
        return None
    caption = _RELATIONS_CAPTION
    if both_converged is False:
        caption += " <b>Not both fits converged: the relations mean little.</b>"
    known = ("lhs", "lhs_stderr", "rhs", "rhs_stderr", "ratio", "z")
    if all(isinstance(v, Mapping) and "lhs" in v and "rhs" in v for _, v in items):
        rows = tuple((str(v.get("relation") or v.get("name") or k), *(number(v.get(c)) for c in known))
                     for k, v in items)
        header = ("relation", "fractional side", "stderr", "classic side", "stderr", "ratio", "z")
        return Table(header, rows, caption=caption, text_columns=(0,), key="relations")
    keys: list[str] = []
    for _, v in items:
        if isinstance(v, Mapping):
            keys += [k for k in v if k not in keys]
    rows = tuple((k, *(_cell(v.get(c)) for c in keys)) if isinstance(v, Mapping) else (k, _cell(v))
                 for k, v in items)
    header = ("relation", *keys) if keys else ("relation", "value")
    return Table(header, rows, caption=caption, text_columns=tuple(range(len(header))), key="relations")


def _cell(v: Any) -> Any:
    if isinstance(v, (bool, int, float, str)) or v is None:
        return v
    return json.dumps(v, default=str)


def parameters_section(run: RunData) -> Section:
    """Fit quality, each model's parameters with both uncertainties, and cross-model relations."""
    title = "Fitted parameters"
    if not run.fits:
        return Section("parameters", title, (Note("No fit results: no fit_*.json or fit.json in this run folder "
                                                  "(run the fit stage).", kind="missing"),))
    blocks: list[Any] = [quality_table(run), Note(_UNCERTAINTY_NOTE, trusted=True)]
    for name, fit in run.fits.items():
        rows = _param_rows(fit.get("params") or {}, fit.get("interval95"))
        state = fit.get("initial_state")
        if isinstance(state, Mapping):
            rows += _param_rows(state, fit.get("interval95"))
        window = fit.get("window")
        wtext = ""
        if isinstance(window, list) and len(window) == 2 and None not in window:
            wtext = f" Fitted window {float(window[0]):.2f}–{float(window[1]):.2f} s."
        message = str(fit.get("message") or "").strip().rstrip(".")
        msg = f" Optimiser's last message: “{escape(message)}”." if message else ""
        fitted = fit.get("fitted_model")
        if fitted and fitted != name:
            msg = (f" Fitted as <b>{escape(str(fitted))}</b>" + (": θ's zero was not measured, so it is fitted as "
                   "θ<sub>off</sub> (θ<sub>obs</sub> = θ + θ<sub>off</sub>)." if "theta_off" in (fit.get("params") or {})
                   else ".") + msg)
        blocks.append(Table(("parameter", "unit", "value", "stderr", "95 % interval", "u_paper", "u_r", "meaning"),
                            tuple(rows),
                            caption=f"<b>{escape(str(name))}</b> model ({'converged' if fit.get('converged') else 'NOT converged'})."
                                    f"{wtext}{msg}",
                            text_columns=(0, 1, 4, 7), key=f"params-{name}"))
    relations, both = find_relations(run.combined)
    table = _relations(relations, both) if relations is not None else None
    if table is not None:
        blocks.append(table)
    elif "classic" in run.fits and "fractional" in run.fits:
        blocks.append(Note("The fit output records no cross-model relations.", kind="missing"))
    return Section("parameters", title, tuple(blocks))


def provenance_section(run: RunData, hashes: Mapping[str, str]) -> Section:
    """Every input file with the stage that wrote it, its pendtrack version, time and sha256.

    ``hashes`` maps file names to their sha256 (as recorded in the page's provenance).
    """
    rows = []
    for path in run.inputs:
        record = run.provenances.get(path.name, {})
        stage, version, created = (str(record.get(k, "")) for k in ("stage", "version", "created"))
        rows.append((path.name, stage, version, created, str(hashes.get(path.name, ""))[:16]))
    table = Table(("file", "stage", "pendtrack", "written", "sha256 (first 16)"), tuple(rows),
                  caption="The files this report was made from.", text_columns=(0, 1, 2, 3, 4), key="inputs")
    return Section("provenance", "Provenance", (table,))
