"""The paper's consistency check: eq. consistencycheck fitted to Omega0(l1) over a batch.

The fit itself is :func:`pendtrack.fitting.two_cuboid.fit_two_cuboid`; this module only picks the
points from the summary: every ``ok`` run whose chosen model converged with a finite
Omega0, weighted by that Omega0's statistical standard error (``stderr``; the paper's
``u_paper`` is recorded too but is a spread of accepted starts, not a standard deviation).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

OMEGA0 = "Omega0"


def choose_model(df: pd.DataFrame, preference: Sequence[str]) -> str | None:
    """The first model of ``preference`` with an Omega0 column in the summary, else the first
    model with one (summary column order), else None."""
    fitted = [c[: -len(f"__{OMEGA0}__value")] for c in df.columns if c.endswith(f"__{OMEGA0}__value")]
    for model in list(preference) + fitted:
        if model in fitted:
            return model
    return None


def omega0_points(df: pd.DataFrame, model: str) -> pd.DataFrame:
    """``l1_m``, ``omega0``, ``stderr``, ``u_paper``, ``run_id``, ``kind`` of the usable runs."""
    ok = df["status"].eq("ok")
    conv = f"{model}__converged"
    if conv in df.columns:
        ok &= df[conv].fillna(False).astype(bool)
    pts = pd.DataFrame({
        "run_id": df["run_id"], "kind": df["kind"], "l1_m": df["l1_m"],
        "omega0": df[f"{model}__{OMEGA0}__value"],
        "stderr": df.get(f"{model}__{OMEGA0}__stderr", pd.Series(np.nan, index=df.index)),
        "u_paper": df.get(f"{model}__{OMEGA0}__u_paper", pd.Series(np.nan, index=df.index)),
    })[ok]
    return pts[np.isfinite(pts["omega0"].to_numpy(float)) & np.isfinite(pts["l1_m"].to_numpy(float))]


def two_cuboid_check(df: pd.DataFrame, *, preference: Sequence[str]) -> dict[str, Any]:
    """Fit eq. consistencycheck to the batch's Omega0(l1); a JSON-ready dict for batch.json.

    Returns
    -------
    dict
        ``status`` (``ok`` | ``too few runs`` | ``no Omega0`` | ``failed``),
        ``model``, ``n``, ``n_tiles``, ``sigma`` (what weighted the points), the fit's own
        fields (``TwoCuboidFit.to_dict()``: x, x_stderr, l0 [m], l0_stderr, covariance,
        chi2, dof, rms, weighted, g), the same as ``X`` and ``l0_m`` = {value, stderr} with
        ``corr_X_l0`` and ``chi2_red``, and ``points`` (run_id, kind, l1_m, omega0, stderr,
        u_paper).
    """
    model = choose_model(df, preference)
    if model is None:
        return {"status": "no Omega0", "model": None, "n": 0}
    pts = omega0_points(df, model)
    out: dict[str, Any] = {"model": model, "n": int(len(pts)), "n_tiles": int(pts["l1_m"].nunique()),
                           "points": [{k: _plain(v) for k, v in rec.items()} for rec in pts.to_dict(orient="records")]}
    if len(pts) < 3 or pts["l1_m"].nunique() < 2:
        reason = (f"{len(pts)} ok run(s) with a converged {model} Omega0 at {out['n_tiles']} tile length(s); "
                  "need >= 3 runs at >= 2 lengths")
        return {"status": "too few runs", "reason": reason, **out}
    sd = pts["stderr"].to_numpy(float)
    use_sigma = bool(np.all(np.isfinite(sd) & (sd > 0)))
    out["sigma"] = "stderr" if use_sigma else "none (unweighted: some stderr missing)"
    from pendtrack.fitting.two_cuboid import fit_two_cuboid

    try:
        result = fit_two_cuboid(pts["l1_m"].to_numpy(float), pts["omega0"].to_numpy(float),
                                sigma=sd if use_sigma else None)
    except Exception as exc:  # a bad fit must not lose the batch's data
        return {"status": "failed", "reason": f"{type(exc).__name__}: {exc}", **out}
    fields = result.to_dict() if hasattr(result, "to_dict") else dict(result)
    return {"status": "ok", **out, **fields, **paper_form(fields)}


def paper_form(fields: dict[str, Any]) -> dict[str, Any]:
    """``X`` and ``l0_m`` as {value, stderr}, their correlation and chi^2/dof, from the fit's dict."""
    out: dict[str, Any] = {"X": {"value": fields.get("x"), "stderr": fields.get("x_stderr")},
                           "l0_m": {"value": fields.get("l0"), "stderr": fields.get("l0_stderr")}}
    cov = np.asarray(fields.get("covariance") or np.full((2, 2), np.nan), dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov[0, 1] / np.sqrt(cov[0, 0] * cov[1, 1]) if cov.shape == (2, 2) else np.nan
        dof = fields.get("dof") or 0
        chi2_red = float(fields["chi2"]) / dof if fields.get("chi2") is not None and dof > 0 else np.nan
    out["corr_X_l0"] = float(corr) if np.isfinite(corr) else None
    out["chi2_red"] = chi2_red if np.isfinite(chi2_red) else None
    if fields.get("weighted") and np.isfinite(chi2_red):  # Birge ratio: stderr inflated when chi2/dof > 1
        birge = float(np.sqrt(max(1.0, chi2_red)))
        for key, err in (("X", "x_stderr"), ("l0_m", "l0_stderr")):
            out[key]["stderr_scaled"] = fields[err] * birge if fields.get(err) is not None else None
    return out


def _plain(v: Any) -> Any:
    """JSON-safe scalar: None for NaN/NA, Python types for numpy's."""
    if v is None or v is pd.NA or (isinstance(v, float) and not np.isfinite(v)):
        return None
    return v.item() if isinstance(v, np.generic) else v
