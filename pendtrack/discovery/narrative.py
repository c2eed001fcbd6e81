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


def _stability(s: Mapping[str, Any]) -> str:
    """``same decision on 97 % of resampled records`` (+ ``: borderline``)."""
    st = s.get("stability")
    if st is None:
        return "stability not assessed"
    return (f"same decision on {100 * float(st):.0f} % of resampled records"
            + (" (**borderline**: below 80 %)" if s.get("borderline") else ""))


def _margins(s: Mapping[str, Any]) -> str:
    """``z = 31.8 (3 + 28.8), dBIC = -210.4 (-10 - 200.4)``: each rule's value and margin."""
    m = s.get("margins") or {}
    out = []
    z, b = m.get("z"), m.get("delta_bic")
    if z and z.get("value") is not None:
        out.append(f"z = {_f(z['value'], '.1f')} (margin {_f(z['margin'], '+.1f')} against {_f(z['threshold'], '.0f')})")
    if b and b.get("value") is not None:
        out.append(f"dBIC = {_f(b['value'], '.1f')} (margin {_f(b['margin'], '+.1f')} against "
                   f"{_f(b['threshold'], '.0f')})")
    return ", ".join(out) or "no margins"


def _margin_cells(s: Mapping[str, Any]) -> tuple[str, str, str]:
    """Table cells: z and its margin, dBIC and its margin, the stability (``borderline`` below 80 %)."""
    m = s.get("margins") or {}

    def cell(key: str, value: Any) -> str:
        mm = m.get(key) or {}
        if value is None or mm.get("margin") is None:
            return _f(value, ".1f")
        return f"{_f(value, '.1f')} ({_f(mm['margin'], '+.1f')})"

    st = s.get("stability")
    stab = "n/a" if st is None else f"{100 * float(st):.0f} %" + (" borderline" if s.get("borderline") else "")
    return cell("z", s.get("heldout_z")), cell("delta_bic", s.get("delta_bic")), stab


def _test_name(s: Mapping[str, Any]) -> str:
    return {"interleaved": "interleaved cross-validation RMS",
            "refit_folds": "RMS refitted on interleaved folds"}.get(s.get("test", ""), "held-out RMS")


def _test_tag(s: Mapping[str, Any]) -> str:
    return {"interleaved": " (interleaved)", "refit_folds": " (refit folds)"}.get(s.get("test", ""), "")


def _measurement_verdict(r: Mapping[str, Any]) -> list[str]:
    """Sentences on the measurement terms kept: findings about the record, not causes."""
    from pendtrack.discovery.catalogue import MEASUREMENT

    out = []
    for s in r.get("measurement_steps", []):
        for name in s["terms"]:
            a = MEASUREMENT[name]
            params = "; ".join(f"{k} = {_pm(v['value'], v['stderr'])}" for k, v in s["params"].items()
                               if k in a.params)
            lead = "Borderline measurement finding" if s.get("borderline") else "Measurement finding"
            out.append(f"{lead}: **{a.title}** (`{name}`, {params}): {a.meaning}. It is a property "
                       f"of the record, not of the pendulum's physics; modelling it lowers the residual RMS from "
                       f"{_mrad(s['rms_before'])} to {_mrad(s['rms_after'])} mrad and the {_test_name(s)} from "
                       f"{_mrad(s['heldout_rms_before'])} to {_mrad(s['heldout_rms_after'])} mrad; "
                       f"{_margins(s)}; {_stability(s)}. It stays in the observation of every later model and "
                       "of the final one.")
    return out


def _effects_verdict(r: Mapping[str, Any]) -> list[str]:
    """The causes named, or the terms that only improve the fit (``partial``), in words that match the numbers."""
    by_term = {t: s for s in r["steps"] for t in s["terms"]}
    if r["effects"]:
        s0 = by_term[r["effects"][0]]
        named = [CATALOGUE[x] for x in s0["terms"]]
        together = len(named) > 1
        what = " together with ".join(f"**{e.title}** (`{e.name}`: {e.physics})" for e in named)
        lead = "The borderline cause" if s0.get("borderline") else "The cause"
        lines = [f"{lead}{'s' if together else ''} named {'are' if together else 'is'} {what}"
                 + (" (neither alone earned its keep; together they did)" if together else "")
                 + f". Adding {'them' if together else 'it'} lowers the residual RMS from "
                 f"{_mrad(s0['rms_before'])} to {_mrad(s0['rms_after'])} mrad and the {_test_name(s0)} from "
                 f"{_mrad(s0['heldout_rms_before'])} to {_mrad(s0['heldout_rms_after'])} mrad; {_margins(s0)}; "
                 f"{_stability(s0)}."]
        for s in r["steps"][1:]:
            lines.append(f"Further effect kept: {' + '.join(f'`{x}`' for x in s['terms'])} "
                         + ("(borderline) " if s.get("borderline") else "")
                         + f"lowers the residual RMS from {_mrad(s['rms_before'])} to {_mrad(s['rms_after'])} mrad; "
                         f"{_margins(s)}; {_stability(s)}.")
        return lines
    if not r.get("partial"):
        return []
    why = (f"structure remains that no catalogue term removes ({', '.join(r['unexplained'])})" if r.get("unexplained")
           else "the final fit is flagged (" + "; ".join(f"{k} {v}" for k, v in r["final_model"]["flags"].items())
           + ")")
    lines = [f"**No cause is named**: {why}. The effects kept improve the fit without explaining the record:"]
    for s in r["steps"]:
        lines.append(f"- {' + '.join(f'`{x}`' for x in s['terms'])} "
                     + ("(borderline) " if s.get("borderline") else "")
                     + f"improves the fit: residual RMS {_mrad(s['rms_before'])} -> {_mrad(s['rms_after'])} mrad, "
                     f"{_test_name(s)} {_mrad(s['heldout_rms_before'])} -> {_mrad(s['heldout_rms_after'])} mrad; "
                     f"{_margins(s)}; {_stability(s)}"
                     + ("; its fit is flagged: " + "; ".join(f"{k} {v}" for k, v in s["flags"].items())
                        if s.get("flags") else "") + ".")
    return lines


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
    shift = r["data"].get("zero_shift_rad") or 0.0
    if shift:
        lines.append(f"theta's zero: the file's angle swings about {_f(shift, '.4g')} rad, not hanging straight "
                     "down (a sensor's or an axis' zero); every model is fitted about that centre, and the "
                     "`offset` term judges what remains of the zero.")
    lines.append("")
    lines += ["## Verdict", ""]
    off = _off(ev)
    lines.append(f"The `{r['baseline']}` model leaves a residual {_f(base_d['rms_over_noise'], '.2f')} times the "
                 f"noise (RMS {_mrad(r['baseline_fit']['rms'])} mrad), with structure in: {', '.join(off) or 'none'}.")
    lines += _measurement_verdict(r)
    lines += _effects_verdict(r)
    if r["effects"]:
        top = diag.get("signature_top")
        first = r["effects"][0]
        if top and top != first:
            lines.append(f"The signatures pointed first to `{top}`; the held-out test and BIC preferred `{first}`.")
        elif top:
            lines.append("The decision agrees with the signature ranking.")
    elif not r.get("partial"):
        lines.append("No effect of the catalogue, alone or in combination, earns its parameters on held-out data "
                     "and BIC: no physical cause is named." if off else "No effect is added.")
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
        what = ("measurement" if st.get("kind") == "measurement"
                else "effect" if term in r["effects"] else "improves the fit")
        chain.append(f"{_mrad(st['rms_after'])} mrad with {' + '.join(f'`{x}`' for x in st['terms'])} ({what})")
    # a term kept in between and dropped by the final check was in the models of the later steps
    dropped = [c["effect"] for c in r["runners_up"] if c["step"] == 0 and "dropped at the end" in c["reason"]]
    lines.append("Residual RMS, term by term in the order kept: " + " -> ".join(chain)
                 + (f"; without {', '.join(f'`{x}`' for x in dropped)} (kept in between, dropped by the final "
                    "check: it no longer earned its keep)" if dropped else "")
                 + f"; final `{fm['model']}`: {_mrad(fm['rms'])} mrad, {_f(final_d['rms_over_noise'], '.2f')} times "
                 f"the noise of {_mrad(final_d['sigma'])} mrad.")
    if r.get("unexplained"):
        lines.append(f"**Not explained by the catalogue:** {', '.join(r['unexplained'])} "
                     f"{'is' if len(r['unexplained']) == 1 else 'are'} still off after the final model. "
                     "No catalogue term removes this structure, so no cause is named: the effects kept improve "
                     "the fit without explaining it.")
    else:
        lines.append("Nothing stays unexplained: every diagnostic of the final model is within the noise.")
    for eq in r.get("equivalents", []):
        kept = [*r["effects"], *r.get("partial", [])]
        swapped = [e for e in eq["effects"] if e not in kept]
        lost = [e for e in kept if e not in eq["effects"]]
        lines.append(f"**Not told apart:** `{eq['model']}` fits the record about as well (BIC "
                     f"{_f(eq['delta_bic'], '+.1f')}, less than the {_f(-r['thresholds']['delta_bic_max'], '.0f')} "
                     f"an effect needs to be kept): {' + '.join(f'`{e}`' for e in swapped)} in the place of "
                     f"{' + '.join(f'`{e}`' for e in lost)} fits as well"
                     + (" and is as likely a cause." if r["effects"] else "."))
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
                         f"{_mrad(s['heldout_rms_before'])} -> {_mrad(s['heldout_rms_after'])}"
                         + _test_tag(s),
                         *_margin_cells(s)))
        lines += _table(("term", "new parameters (± stderr)", "RMS [mrad]", "Xi^2", "test RMS [mrad]",
                         "z (margin vs 3)", "dBIC (margin vs -10)", "stability"), rows)
    else:
        lines.append("No effect was added.")
    lines.append("")
    if r["runners_up"]:
        lines += ["### Runners-up", ""]
        rows = [(("measurement " if c.get("kind") == "measurement" else "") + str(c["step"]), f"`{c['effect']}`",
                 _mrad(c["heldout_rms"]) + _test_tag(c),
                 *_margin_cells(c), c["reason"])
                for c in r["runners_up"]]
        lines += _table(("step", "term(s)", "test RMS [mrad]", "z (margin vs 3)", "dBIC (margin vs -10)",
                         "stability", "why not kept"), rows)
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
              "still has structure. An effect is fitted by output error on the first "
              f"{_f(100 * th['train_fraction'], '.0f')} % of the record and simulated over the whole record "
              "(its held-out RMS); a measurement term, which shifts every sample, is judged by interleaved "
              f"cross-validation instead: the record cut into {th.get('cv_blocks', 10)} blocks, the term estimated "
              "on the even ones predicts the odd ones and back, the physics held at the current whole-record fit. "
              "An effect that acts early in the run and fades (time-varying damping) and fails the held-out "
              "test is judged again where it acts: the current model and the model with it are refitted on "
              "interleaved blocks of the whole record (the first block in both) and predict the other blocks. "
              "A term is kept only if that gain is significant against noise "
              f"(z > {_f(th['heldout_z_min'], '.1f')}) and at "
              f"least {_f(100 * th.get('heldout_min_gain', 0.0), '.0f')} % of the test RMS, "
              f"BIC drops by more than {_f(-th['delta_bic_max'], '.0f')} on the whole record, the whole-record "
              "residual RMS goes down, and its fit carries no flag (a parameter at a bound or not determined, "
              "memory at beta = 1 that is an added mass): a flagged fit's values are not measurements; and every "
              "term it adds is present in that fit (a set with one member at the limit where it vanishes is the "
              "others alone). The passing "
              "candidate with the lowest BIC is added and the search repeats until nothing earns its keep. "
              "Each decision's margins are its z minus 3 and -10 minus its dBIC (> 0: passes); its stability is "
              "the share of block-bootstrap records (the residuals of both models resampled together in blocks "
              "as long as their correlation time) on which the same decision is made; below 80 % it is called "
              "borderline. The effects kept are named as causes only when the final model leaves no structure "
              "the catalogue cannot remove and its fit carries no new flag; otherwise they are listed as "
              "improving the fit.", ""]
    return "\n".join(lines)
