"""discovery.md: the page a physicist reads -- what was wrong, the evidence, the cause, the gain."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from pendtrack.discovery.catalogue import CATALOGUE
from pendtrack.discovery.diagnostics import NOISE_Z, off_diagnostics
from pendtrack.discovery.result import DiscoveryResult



def _f(x: Any, fmt: str = ".3g") -> str:
    if x is None:
        return "n/a"
    try:
        x = float(x)
    except (TypeError, ValueError):
        return str(x)
    return format(x, fmt) if math.isfinite(x) else "n/a"


def _mrad(x: Any) -> str:
    return "n/a" if x is None or not math.isfinite(float(x)) else f"{1e3 * float(x):.3f}"


def _pm(value: Any, err: Any) -> str:
    if err is None or not math.isfinite(float(err)) or float(err) == 0:
        return _f(value, ".4g")
    return f"{_f(value, '.4g')} ± {_f(err, '.2g')}"


def _diagnostic_rows(d: Mapping[str, Any]) -> list[tuple[str, str, str, str]]:
    ev = d["evidence"]
    w = d["whiteness"]
    sp = d["spectrum"]
    cy = d["cycles"]
    en = d["envelope"]
    fa = d["frequency_amplitude"]
    hy = d["hysteresis"]
    snr = sp.get("snr") or []
    rows = [
        ("residual RMS / noise", f"{_mrad(d['rms'])} / {_mrad(d['sigma'])} mrad = {_f(d['rms_over_noise'], '.2f')}",
         "1", "off" if ev["excess_rms"] > 0.2 else "ok"),
        ("whiteness: Ljung-Box Q (p); runs z",
         f"{_f(w['ljung_box_q'], '.0f')} (p = {_f(w['ljung_box_p'], '.2g')}); {_f(w['runs_z'], '.1f')}",
         f"Q ~ {w['ljung_box_lags']}; |z| < 3", "off" if ev["whiteness"] > NOISE_Z else "ok"),
        ("line at the oscillation frequency (orders 1, 2, 3), power / floor",
         ", ".join(_f(s, ".3g") for s in snr), "< 20", "off" if ev["harmonic_line"] > 20 else "ok"),
        ("dephasing: timing-error chi^2 per oscillation",
         f"{_f(cy['phase_chi2'], '.3g')} over {len(cy.get('t_mid') or [])} oscillations", "1",
         "off" if ev["dephasing"] > NOISE_Z else "ok"),
        ("envelope: amplitude-error chi^2 per oscillation; trend z (whole, early)",
         f"{_f(cy['amp_chi2'], '.3g')}; {_f(en['amp_trend_z'], '.1f')}, {_f(en['early_amp_trend_z'], '.1f')}",
         "1; |z| < 3", "off" if max(ev["envelope"], ev["early_envelope"]) > NOISE_Z else "ok"),
        ("residual RMS / noise, first and last third", f"{_f(en['early_over_noise'], '.2f')}, "
         f"{_f(en['late_over_noise'], '.2f')}", "1, 1", ""),
        ("period mismatch vs amplitude: slope against sin^2(A/2)",
         f"{_pm(fa['slope'], fa['slope_se'])} (z = {_f(fa['slope_z'], '.1f')})", "|z| < 3",
         "off" if ev["frequency_amplitude"] > NOISE_Z else "ok"),
        ("Delta-alpha(omega) loop area, data - model (z vs noise replicas)",
         f"{_f(hy['area_excess'], '.3g')} rad^2/s^3 (z = {_f(hy['area_z'], '.1f')})", "|z| < 3",
         "off" if ev["hysteresis"] > NOISE_Z else "ok"),
        ("residual mean level (theta's zero vs rest; no catalogue term)",
         f"{_mrad(_mean_offset(cy))} mrad (z = {_f(ev.get('offset', 0.0), '.1f')})", "|z| < 3",
         "off" if ev.get("offset", 0.0) > NOISE_Z else "ok"),
        ("negative damping near turning points: data, model + noise",
         f"{_f(hy['nd_data'], '.3f')}, {_f(hy['nd_ref_mean'], '.3f')} ± {_f(hy['nd_ref_sd'], '.2g')} "
         f"(z = {_f(hy['nd_z'], '.1f')})", "|z| < 3", "off" if ev["negative_damping"] > NOISE_Z else "ok"),
    ]
    return rows


def _mean_offset(cycles: Mapping[str, Any]) -> float:
    off = np.asarray(cycles.get("offset") or [], dtype=float)
    se = np.asarray(cycles.get("offset_se") or [], dtype=float)
    if off.size == 0:
        return float("nan")
    w = 1.0 / np.maximum(se, 1e-300) ** 2
    return float(np.sum(w * off) / np.sum(w))


def _off(evidence: Mapping[str, float]) -> list[str]:
    """Diagnostics whose evidence says the model misses something (see :data:`NOISE_Z`)."""
    return off_diagnostics(evidence)


def _measurement_verdict(r: Mapping[str, Any]) -> list[str]:
    """Sentences on the measurement terms kept: findings about the record, not causes."""
    from pendtrack.discovery.catalogue import MEASUREMENT

    out = []
    for s in r.get("measurement_steps", []):
        for name in s["terms"]:
            a = MEASUREMENT[name]
            params = "; ".join(f"{k} = {_pm(v['value'], v['stderr'])}" for k, v in s["params"].items()
                               if k in a.params)
            out.append(f"Measurement finding: **{a.title}** (`{name}`, {params}): {a.meaning}. It is a property "
                       f"of the record, not of the pendulum's physics; modelling it lowers the residual RMS from "
                       f"{_mrad(s['rms_before'])} to {_mrad(s['rms_after'])} mrad and the held-out RMS from "
                       f"{_mrad(s['heldout_rms_before'])} to {_mrad(s['heldout_rms_after'])} mrad "
                       f"(z = {_f(s['heldout_z'], '.1f')}), dBIC = {_f(s['delta_bic'], '.1f')}; it stays in the "
                       "observation of every later model and of the final one.")
    return out


def _table(header: tuple[str, ...], rows: list[tuple[str, ...]]) -> list[str]:
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    return out


def write_markdown(result: DiscoveryResult) -> str:
    """The discovery.md text for a result.

    Parameters
    ----------
    result : DiscoveryResult

    Returns
    -------
    str
        Markdown.
    """
    r = result.to_dict()
    diag = r["diagnosis"]
    base_d = diag["baseline"]
    ev = base_d["evidence"]
    src = r["data"].get("source", "")
    lines = [f"# Discovery: {src}", ""]
    an = r["data"].get("analysis", {})
    lines.append(f"Record: {r['data'].get('n')} samples over {_f(r['data'].get('duration_s'), '.1f')} s "
                 f"({_f(r['data'].get('rate_hz'), '.4g')} Hz), analysed at {_f(an.get('rate_hz'), '.4g')} Hz; "
                 f"baseline model `{r['baseline']}`; training part t <= {_f(an.get('t_split'), '.1f')} s, "
                 f"held out after.")
    lines.append("")
    lines += ["## Verdict", ""]
    off = _off(ev)
    lines.append(f"The `{r['baseline']}` model leaves a residual {_f(base_d['rms_over_noise'], '.2f')} times the "
                 f"noise (RMS {_mrad(r['baseline_fit']['rms'])} mrad), with structure in: {', '.join(off) or 'none'}.")
    lines += _measurement_verdict(r)
    if r["effects"]:
        s0 = r["steps"][0]
        named = [CATALOGUE[x] for x in s0["terms"]]
        together = len(named) > 1
        what = " together with ".join(f"**{e.title}** (`{e.name}`: {e.physics})" for e in named)
        lines.append(f"The cause{'s' if together else ''} named {'are' if together else 'is'} {what}"
                     + (" (neither alone earned its keep; together they did)" if together else "")
                     + f". Adding {'them' if together else 'it'} lowers the residual RMS from "
                     f"{_mrad(s0['rms_before'])} to {_mrad(s0['rms_after'])} mrad and the held-out RMS from "
                     f"{_mrad(s0['heldout_rms_before'])} to {_mrad(s0['heldout_rms_after'])} mrad "
                     f"(z = {_f(s0['heldout_z'], '.1f')}), dBIC = {_f(s0['delta_bic'], '.1f')}.")
        later = [x for s in r["steps"][1:] for x in s["terms"]]
        if later:
            lines.append(f"Further effects kept, in order: {', '.join(f'`{x}`' for x in later)}.")
        top = diag.get("signature_top")
        first = s0["terms"][0]
        if top and top not in s0["terms"]:
            lines.append(f"The signatures pointed first to `{top}`; the held-out test and BIC preferred `{first}`.")
        elif top:
            lines.append("The decision agrees with the signature ranking.")
    elif off:
        lines.append("No effect of the catalogue, alone or in combination, earns its parameters on held-out data "
                     "and BIC: no physical cause is named.")
    else:
        lines.append("No effect is added.")
    fm = r["final_model"]
    final_d = diag.get("final") or base_d
    chain = [f"{_mrad(r['baseline_fit']['rms'])} mrad with `{r['baseline']}`"]
    by_term = {t: st for st in [*r.get("measurement_steps", []), *r["steps"]] for t in st["terms"]}
    seen = set()
    for term in r.get("order", []):
        st = by_term.get(term)
        if st is None or id(st) in seen:
            continue
        seen.add(id(st))
        what = "measurement" if st.get("kind") == "measurement" else "effect"
        chain.append(f"{_mrad(st['rms_after'])} mrad with {' + '.join(f'`{x}`' for x in st['terms'])} ({what})")
    lines.append("Residual RMS, term by term in the order kept: " + " -> ".join(chain)
                 + f"; final `{fm['model']}`: {_mrad(fm['rms'])} mrad, {_f(final_d['rms_over_noise'], '.2f')} times "
                 f"the noise of {_mrad(final_d['sigma'])} mrad.")
    if r.get("unexplained"):
        lines.append(f"**Not explained by the catalogue:** {', '.join(r['unexplained'])} "
                     f"{'is' if len(r['unexplained']) == 1 else 'are'} still off after the final model. "
                     "No catalogue term removes this structure; the terms kept are not its cause.")
    else:
        lines.append("Nothing stays unexplained: every diagnostic of the final model is within the noise.")
    for eq in r.get("equivalents", []):
        swapped = [e for e in eq["effects"] if e not in r["effects"]]
        lost = [e for e in r["effects"] if e not in eq["effects"]]
        lines.append(f"**Not told apart:** `{eq['model']}` fits the record about as well (BIC "
                     f"{_f(eq['delta_bic'], '+.1f')}, less than the {_f(-r['thresholds']['delta_bic_max'], '.0f')} "
                     f"an effect needs to be kept): {' + '.join(f'`{e}`' for e in swapped)} in the place of "
                     f"{' + '.join(f'`{e}`' for e in lost)} is as likely a cause.")
    if ev.get("offset", 0.0) > NOISE_Z and "offset" not in r.get("measurement", []):
        lines.append(f"The baseline's residual has a persistent mean level of "
                     f"{_mrad(_mean_offset(base_d['cycles']))} mrad: theta's zero is probably not the rest position "
                     "(or a constant torque acts); the zero-offset term did not earn its keep.")
    lines.append("")

    lines += ["## What the baseline gets wrong", ""]
    lines += _table(("diagnostic", "value", "noise alone", ""), _diagnostic_rows(base_d))
    lines.append("")

    lines += ["## Which effect would explain it (signatures)", ""]
    rows = []
    for item in diag.get("ranking", []):
        e = CATALOGUE[item["effect"]]
        rows.append((f"`{e.name}`", _f(item["score"], ".2f"), ", ".join(item["explains"]) or "-", e.signature))
    lines += _table(("effect", "score", "explains", "signature"), rows)
    lines += ["", "Signatures rank the candidates; the decision is by held-out error and BIC.", ""]

    lines += ["## Extending the model", ""]
    if r["steps"] or r.get("measurement_steps"):
        rows = []
        for s in [*r.get("measurement_steps", []), *r["steps"]]:
            params = "; ".join(f"{k} = {_pm(v['value'], v['stderr'])}" for k, v in s["params"].items())
            label = f"`{s['effect']}`" + (" (measurement)" if s.get("kind") == "measurement" else "")
            rows.append((label, params, f"{_mrad(s['rms_before'])} -> {_mrad(s['rms_after'])}",
                         f"{_f(s['xi2_before'])} -> {_f(s['xi2_after'])}",
                         f"{_mrad(s['heldout_rms_before'])} -> {_mrad(s['heldout_rms_after'])} "
                         f"(z = {_f(s['heldout_z'], '.1f')})", _f(s["delta_bic"], ".1f")))
        lines += _table(("term", "new parameters (± stderr)", "RMS [mrad]", "Xi^2", "held-out RMS [mrad]", "dBIC"),
                        rows)
    else:
        lines.append("No effect was added.")
    lines.append("")
    if r["runners_up"]:
        lines += ["### Runners-up", ""]
        rows = [(("measurement " if c.get("kind") == "measurement" else "") + str(c["step"]),
                 f"`{c['effect']}`" + (" (physics held)" if c.get("kind") == "measurement"
                                       and c.get("signature_score") == 1.0 else ""),
                 _mrad(c["heldout_rms"]), _f(c["heldout_z"], ".1f"), _f(c["delta_bic"], ".1f"), c["reason"])
                for c in r["runners_up"]]
        lines += _table(("step", "term(s)", "held-out RMS [mrad]", "z", "dBIC", "why not kept"), rows)
        lines.append("")

    fm = r["final_model"]
    lines += [f"## Final model: `{fm['model']}`", ""]
    rows = [(k, _pm(v["value"], v["stderr"]), _f(v["u_paper"], ".2g")) for k, v in fm["params"].items()]
    lines += _table(("parameter", "value ± stderr", "u_paper"), rows)
    lines.append("")
    lines.append(f"Residual RMS {_mrad(fm['rms'])} mrad, Xi^2 = {_f(fm['xi2'])}, held-out RMS "
                 f"{_mrad(fm['heldout_rms'])} mrad.")
    if diag.get("final"):
        fd = diag["final"]
        still = _off(fd["evidence"])
        lines.append(f"After the extension the residual is {_f(fd['rms_over_noise'], '.2f')} times the noise; "
                     f"still off: {', '.join(still) or 'nothing'}.")
        lines.append("")
        lines += ["### Diagnostics of the final model", ""]
        lines += _table(("diagnostic", "value", "noise alone", ""), _diagnostic_rows(fd))
    lines.append("")
    th = r["thresholds"]
    lines += ["## How the decision was made", "",
              "Forward selection: the measurement terms (theta's zero, its scale) first, then the physical "
              "effects one at a time, and pairs of effects when no single one earns its keep but the residual "
              "still has structure. Each candidate is fitted by output error on the first "
              f"{_f(100 * th['train_fraction'], '.0f')} % of the record and simulated over the whole record; "
              "it is kept "
              "only if its held-out RMS gain is significant against noise "
              f"(z > {_f(th['heldout_z_min'], '.1f')}) and at "
              f"least {_f(100 * th.get('heldout_min_gain', 0.0), '.0f')} % of the held-out RMS, and "
              f"BIC drops by more than {_f(-th['delta_bic_max'], '.0f')} on the whole record. The passing candidate "
              "with the lowest BIC is added and the search repeats until nothing earns its keep.", ""]
    return "\n".join(lines)
