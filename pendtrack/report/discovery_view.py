"""The discovery narrative of a run: discovery.md, then the evidence and gains from discovery.json.

discovery.json (``pendtrack.discovery.result.DiscoveryResult.to_dict``): ``baseline`` (model
name), ``effects`` (the causes named, in order), ``partial`` (effects kept that improve the fit without
explaining the record), ``steps`` (per kept effect: ``rms_before``/
``rms_after``, ``heldout_rms_before``/``heldout_rms_after``, ``delta_bic``, the new parameters),
``diagnosis`` (the baseline's evidence scores, the ranking of candidate effects, the cause),
``final_model`` (its fit), ``runners_up`` (effects tried and not kept, with the reason).
Older or hand-made files with a text diagnosis or a bare final model name still render.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from html import escape
from typing import Any

from pendtrack.report.html import Facts, Heading, Html, Note, Preformatted, Section, Table
from pendtrack.report.load import RunData
from pendtrack.report.markdown import to_html
from pendtrack.report.tables import number




def _mrad(x: Any) -> float | None:
    v = number(x)
    return None if v is None else 1e3 * v


def _fmt(v: Any) -> str:
    n = number(v)
    return f"{n:.4g}" if n is not None else str(v)


def _params_text(params: Any) -> str:
    if isinstance(params, Mapping):
        return ", ".join(f"{k} = {_fmt(v)}" for k, v in params.items())
    return "" if params is None else str(params)


def _model_name(final: Any) -> str:
    if isinstance(final, Mapping):
        return str(final.get("model", ""))
    return "" if final is None else str(final)


def _steps_table(steps: list[Any]) -> Table:
    rows = []
    for i, step in enumerate((s for s in steps if isinstance(s, Mapping)), 1):
        hb, ha = number(step.get("heldout_rms_before")), number(step.get("heldout_rms_after"))
        gain = f"{100 * (1 - ha / hb):.1f} %" if hb and ha is not None else None
        stab = number(step.get("stability"))
        rows.append((i, str(step.get("effect", "")), _params_text(step.get("params")), _mrad(step.get("rms_before")),
                     _mrad(step.get("rms_after")), _mrad(hb), _mrad(ha), gain, number(step.get("delta_bic")),
                     None if stab is None else f"{100 * stab:.0f} %" + (" borderline" if step.get("borderline") else "")))
    return Table(("step", "term added", "its parameters", "RMS before [mrad]", "RMS after [mrad]",
                  "test before [mrad]", "test after [mrad]", "test gain", "ΔBIC", "stability"), tuple(rows),
                 caption="Each step adds one term to the model. The evidence that it is real: the RMS of "
                         "θ − θ<sub>model</sub> on the whole record and, what counts, on data it was not fitted to "
                         "(an effect: the held-out part of the record, or for an early, fading one refits on "
                         "interleaved blocks; a measurement term: interleaved blocks), "
                         "ΔBIC (negative favours the term), and the share of resampled records on which the same "
                         "decision is made (below 80 %: borderline).",
                 text_columns=(1, 2), key="discovery-steps")


def _evidence_table(diagnosis: Mapping[str, Any]) -> Table | None:
    base = diagnosis.get("evidence")
    if not isinstance(base, Mapping) or not base:
        return None
    final = diagnosis.get("final")
    final_ev = final.get("evidence") if isinstance(final, Mapping) else None
    rows = tuple((str(k), number(v), number(final_ev.get(k)) if isinstance(final_ev, Mapping) else None)
                 for k, v in base.items())
    return Table(("diagnostic", "baseline model", "final model"), rows,
                 caption="What the model gets wrong, as z-like scores (0: the residual is white noise; a few units "
                         "or more: a real defect). Compare the baseline with the final model.",
                 text_columns=(0,), key="discovery-evidence")


def _records_table(records: list[Any], key: str, caption: str) -> Table | None:
    """A list of flat-ish dicts as a table of their scalar fields."""
    records = [r for r in records if isinstance(r, Mapping)]
    if not records:
        return None
    cols: list[str] = []
    for r in records:
        cols += [k for k, v in r.items() if k not in cols and (v is None or isinstance(v, (str, int, float, bool)))]
    rows = tuple(tuple(r.get(c) for c in cols) for r in records)
    text = tuple(i for i, c in enumerate(cols) if all(isinstance(r.get(c), (str, type(None))) for r in records))
    return Table(tuple(cols), rows, caption=caption, text_columns=text, key=key)


def _final_params(final: Mapping[str, Any]) -> Table | None:
    params = final.get("params")
    if not isinstance(params, Mapping) or not params:
        return None
    rows = []
    for name, e in params.items():
        e = e if isinstance(e, Mapping) else {"value": e}
        rows.append((str(name), number(e.get("value")), number(e.get("stderr")), number(e.get("u_paper"))))
    return Table(("parameter", "value", "stderr", "u_paper"), tuple(rows),
                 caption=f"Parameters of the discovered model <b>{escape(_model_name(final))}</b> fitted to the whole record.",
                 text_columns=(0,), key="discovery-final")


def discovery_section(run: RunData) -> Section:
    """The discovery narrative with its evidence and gains, or a note that discovery did not run."""
    title = "Model discovery"
    d = run.discovery
    if d is None:
        return Section("discovery", title, (Note("Discovery did not run for this run (no discovery.json).",
                                                 kind="missing"),))
    final = d.get("final_model")
    diagnosis = d.get("diagnosis")
    effects = d.get("effects")
    partial = d.get("partial")
    facts = [("baseline model", str(d.get("baseline", ""))),
             ("causes named", ", ".join(map(str, effects)) if isinstance(effects, list) and effects else "none"),
             ("discovered model", _model_name(final))]
    if isinstance(partial, list) and partial:  # kept, improving the fit without explaining the record (#29)
        facts.append(("effects that improve the fit (not causes)", ", ".join(map(str, partial))))
    measurement = d.get("measurement")
    if isinstance(measurement, list) and measurement:  # measurement findings (issue #14): not causes
        facts.append(("measurement findings", ", ".join(map(str, measurement))))
    unexplained = d.get("unexplained")
    if isinstance(unexplained, list) and unexplained:
        facts.append(("not explained by the catalogue", ", ".join(map(str, unexplained))))
    for eq in d.get("equivalents") or []:  # a model the record does not tell apart from the final one
        if isinstance(eq, Mapping) and isinstance(eq.get("effects"), list):
            facts.append(("not told apart from", " + ".join(map(str, eq["effects"]))
                          + (f" (BIC {eq['delta_bic']:+.1f})" if isinstance(eq.get("delta_bic"), (int, float)) else "")))
    if isinstance(final, Mapping):
        if (v := _mrad(final.get("rms"))) is not None:
            facts.append(("its RMS", f"{v:.3g} mrad"))
        if (v := _mrad(final.get("heldout_rms"))) is not None:
            facts.append(("its held-out RMS", f"{v:.3g} mrad"))
    if isinstance(diagnosis, Mapping) and diagnosis.get("cause") is not None:
        match = diagnosis.get("cause_matches_signature")
        facts.append(("cause named", f"{diagnosis['cause']}" + ("" if match is None else
                                                                  f" (the diagnosis' first guess: "
                                                                  f"{diagnosis.get('signature_top')})")))
    blocks: list[Any] = [Facts(tuple(facts))]
    if run.discovery_md:
        blocks += [Heading("Narrative (discovery.md)"), Html(to_html(run.discovery_md))]
    blocks.append(Heading("Evidence and gains"))
    steps = [*(d.get("measurement_steps") if isinstance(d.get("measurement_steps"), list) else []),
             *(d.get("steps") if isinstance(d.get("steps"), list) else [])]
    blocks.append(_steps_table(steps) if steps else Note("Discovery kept no effect: the baseline model stands."))
    if isinstance(diagnosis, Mapping):
        for table in (_evidence_table(diagnosis),
                      _records_table(diagnosis.get("ranking") or [], "discovery-ranking",
                                     "The candidate effects ranked by how well their signature matches the "
                                     "baseline's diagnosis (the order they were tried in).")):
            if table is not None:
                blocks.append(table)
    elif diagnosis:
        blocks += [Heading("Diagnosis"), Preformatted(diagnosis if isinstance(diagnosis, str)
                                                      else json.dumps(diagnosis, indent=2), prose=True)]
    runners = d.get("runners_up")
    if isinstance(runners, list):
        table = _records_table(runners, "discovery-runners-up",
                               "Effects tried and not kept, with the reason (held-out gain, ΔBIC).")
        if table is not None:
            blocks.append(table)
    if isinstance(final, Mapping) and (table := _final_params(final)) is not None:
        blocks.append(table)
    return Section("discovery", title, tuple(blocks))
